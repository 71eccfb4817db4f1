//! The demo's threshold calibration: `collision calibrate --source current-task` on a
//! contact-free run of the free motion.

use fri_api::client::Client;
use fri_api::protocol::{CalibrationSource, Command};
use fri_api::results::{CalibrateResult, ThresholdSchedule};
use mock_robot::server::ServerConfig;

use super::clock::{current_cycle, wait_fresh_state};
use super::scenario::free_motion;
use super::{CALIBRATION_RECORD_S, DemoOptions, say};

/// Calibrates the service's thresholds on the task: a contact-free run of the free motion on
/// the same simulated arm (payload attached and its estimate applied; its own noise and drift
/// draws), recorded as
/// `current-task`, budget one false alarm per 10 h, applied. The task, not the built-in
/// excitation: the excitation moves joint 1 and the pose pattern, and a schedule fitted there
/// extrapolates to the other joints' fast moves (joint 2 reached its ceiling in the free
/// motion). Returns the schedule in force and the controller cycles of the run.
pub(super) async fn calibrate_thresholds(
    opts: &DemoOptions,
    client: &mut Client,
    fri: std::net::SocketAddr,
) -> anyhow::Result<(ThresholdSchedule, u64)> {
    say(
        opts,
        "      calibrating the collision thresholds on the task (a contact-free run of the free motion) ...",
    );
    let before = current_cycle(client).await?;
    // the same arm (its sensors' offsets, its controller's model), other noise
    let mut task = free_motion(opts.seed.wrapping_add(1), opts.arm);
    task.arm_seed = Some(opts.seed);
    task.contacts.clear();
    // The service counts recorded samples only: the feature filters' settling (0.1 s) at the
    // start and after each gap the monitor cannot bridge (a host that stalls the real-time
    // pair) is not recorded. 5 s of rest after the motion cover them.
    task.duration_s = Some(CALIBRATION_RECORD_S + 5.0);
    let driver = mock_robot::spawn_new(task, ServerConfig::loopback(fri, opts.pacing))?;
    wait_fresh_state(client, before, 50).await?;
    let reply = client
        .call_typed::<CalibrateResult>(
            Command::CollisionCalibrate {
                source: Some(CalibrationSource::CurrentTask),
                duration_s: Some(CALIBRATION_RECORD_S),
                budget_per_hour: None,
                apply: Some(true),
                allow_weaker: None,
            },
            |_| {},
        )
        .await;
    let cycles = driver.join().map_or(0, |(_, run)| run.cycles);
    let result = reply?.map_err(|e| anyhow::anyhow!("calibration failed: {}", e.message))?;
    let fmt = |v: &[f64; 7]| {
        v.iter()
            .map(|x| format!("{x:.2}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let median: [f64; 7] = std::array::from_fn(|j| result.joints[j].threshold_median);
    let force: [f64; 7] = std::array::from_fn(|l| result.min_force_median[l].median);
    say(
        opts,
        format!(
            "      thresholds at rest ({}) Nm, median in motion ({}) Nm; F_min per link at the median ({}) N",
            fmt(&result.schedule.thresholds),
            fmt(&median),
            fmt(&force)
        ),
    );
    Ok((result.schedule, cycles))
}
