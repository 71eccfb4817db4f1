//! `collision-calibrate` through the operator socket of the whole daemon in-process against the
//! mock robot in lockstep: the built-in excitation is driven and recorded, the thresholds come out
//! per joint, a tighter budget raises them, `apply` installs and stores them with the payload, the
//! next start restores them, and bad arguments are refused naming the field and its range.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod common;

use common::collision_show as show;
use common::*;
use fri_api::cause::Cause;
use fri_api::protocol::{CalibrationSource, CollisionAction, Command, ErrorCode, OperatorError};
use fri_api::results::{CalibrateResult, CollisionResult};
use mock_robot::ServerConfig;

fn calibrate(
    source: Option<CalibrationSource>,
    duration_s: Option<f64>,
    budget_per_hour: Option<f64>,
    apply: bool,
) -> Command {
    Command::CollisionCalibrate {
        source,
        duration_s,
        budget_per_hour,
        apply: Some(apply),
        allow_weaker: None,
    }
}

async fn typed<T: serde::de::DeserializeOwned>(
    c: &mut fri_api::client::Client,
    cmd: Command,
) -> Result<T, OperatorError> {
    call(c, cmd)
        .await
        .map(|v| serde_json::from_value(v).unwrap())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn calibrated_thresholds_are_per_joint_follow_the_budget_and_survive_a_restart() {
    let dir = tempfile::tempdir().unwrap();
    let mut config = test_config(dir.path());
    // The unloaded arm at 5 rad/s² (twice the e2e limit, which is set for an undeclared 3 kg
    // payload): the sweeps' coupling shows on the shoulder above the noise floor, so the
    // per-joint structure is measurable.
    config.motion.max_acceleration = [5.0; 7];
    config.motion.max_jerk = [100.0; 7];
    let h = Harness::start(config.clone(), dir).await;
    let driver =
        mock_robot::spawn_new(sim(false, 21), ServerConfig::loopback(h.fri, lockstep())).unwrap();
    let mut c = h.client().await;
    wait_connected(&mut c).await;

    // Bad arguments first: nothing moves.
    let cases = [
        (
            calibrate(None, None, Some(100.0), false),
            "budget_per_hour = 100 1/h is outside 0.0001…10 1/h",
        ),
        (
            calibrate(Some(CalibrationSource::CurrentTask), Some(5.0), None, false),
            "duration_s = 5 s is outside 20…3600 s",
        ),
    ];
    for (command, message) in cases {
        let e = typed::<CalibrateResult>(&mut c, command).await.unwrap_err();
        assert_eq!(e.code, ErrorCode::InvalidArguments, "{e:?}");
        assert_eq!(e.message, message);
        assert!(matches!(e.cause.as_deref(), Some(Cause::OutOfRange { .. })));
    }
    let e = typed::<CalibrateResult>(
        &mut c,
        calibrate(Some(CalibrationSource::CurrentTask), None, None, false),
    )
    .await
    .unwrap_err();
    assert_eq!(e.code, ErrorCode::InvalidArguments);
    assert!(e.message.contains("`duration_s` is required"), "{e:?}");
    let e = typed::<CalibrateResult>(
        &mut c,
        calibrate(Some(CalibrationSource::LastRecording), None, None, false),
    )
    .await
    .unwrap_err();
    assert_eq!(e.code, ErrorCode::NotReady, "{e:?}");
    let line = br#"{"id": 3, "cmd": "collision-calibrate", "source": "somewhere"}"#;
    let e = fri_api::protocol::parse_request(line).unwrap_err().1;
    assert_eq!(e.code, ErrorCode::InvalidArguments, "{e:?}");

    // The excitation, previewed: progress while it moves, records and fits.
    let mut phases = std::collections::BTreeSet::new();
    let v = c
        .call(calibrate(None, None, None, false), |ev, data| {
            assert_eq!(ev, "progress");
            phases.insert(data["phase"].as_str().unwrap_or("").to_owned());
        })
        .await
        .unwrap()
        .unwrap();
    let first: CalibrateResult = serde_json::from_value(v).unwrap();
    for phase in ["moving", "recording", "fitting"] {
        assert!(phases.contains(phase), "{phases:?}");
    }
    assert!(!first.applied);
    assert_eq!(first.joints.len(), 7);
    assert!(first.recording.blocks >= 20, "{:?}", first.recording);
    // The excitation moved joint 1 at the configured speed limit.
    assert!(first.recording.max_speed[0] > 0.5, "{:?}", first.recording);
    // Per joint: the wrist's thresholds (short levers, small inertia, little velocity noise)
    // sit below the shoulder's.
    let median: Vec<f64> = first.joints.iter().map(|j| j.threshold_median).collect();
    assert!(
        median[5].max(median[6]) < median[0].min(median[1]),
        "{median:?}"
    );
    for j in &first.joints {
        assert!(j.scale.is_finite() && j.scale >= j.scale_point, "{j:?}");
        assert!(j.scale_std >= 0.0 && j.scale_interval[0] <= j.scale_interval[1]);
    }
    for l in 0..7 {
        assert!(first.min_force_at_rest[l].median <= first.min_force_median[l].median);
    }
    let before: CollisionResult = typed(&mut c, show()).await.unwrap();
    assert!(before.schedule.is_none() && before.calibration.is_none());

    // A tighter budget on the same recording raises every threshold.
    let tight: CalibrateResult = typed(
        &mut c,
        calibrate(
            Some(CalibrationSource::LastRecording),
            None,
            Some(0.001),
            false,
        ),
    )
    .await
    .unwrap();
    for (a, b) in first.joints.iter().zip(&tight.joints) {
        assert!(b.scale > a.scale, "{a:?} {b:?}");
        assert!(b.threshold_median > a.threshold_median, "{a:?} {b:?}");
        assert!(b.threshold_at_rest >= a.threshold_at_rest, "{a:?} {b:?}");
    }

    // Applied: in force, stored with the payload (none here).
    let applied: CalibrateResult = typed(
        &mut c,
        calibrate(Some(CalibrationSource::LastRecording), None, None, true),
    )
    .await
    .unwrap();
    assert!(applied.applied);
    let m = &applied.settings;
    assert!(m.persisted && !m.payload_changed);
    assert_eq!(m.thresholds, first.schedule.thresholds);
    assert_eq!(m.schedule.as_ref(), Some(&first.schedule));
    assert_eq!(m.calibration.as_ref().unwrap().budget_per_hour, 0.1);
    drop(c);
    drop(driver.join());
    let dir = h.stop().await;

    // The next start restores the calibrated settings; another payload asks for a new
    // calibration.
    let h = Harness::start(config, dir).await;
    let mut c = h.client().await;
    let m: CollisionResult = typed(&mut c, show()).await.unwrap();
    assert_eq!(m.thresholds, first.schedule.thresholds);
    assert_eq!(m.schedule.as_ref(), Some(&first.schedule));
    assert!(m.calibration.is_some() && m.persisted && !m.payload_changed);
    call(
        &mut c,
        Command::ApplyPayload {
            mass: 2.0,
            com: [0.0, 0.0, 0.1],
            // Another payload than the calibration's is what is under test, not the check.
            force: Some(true),
        },
    )
    .await
    .unwrap();
    let m: CollisionResult = typed(&mut c, show()).await.unwrap();
    assert!(m.payload_changed, "{m:?}");
    // New thresholds by hand end the calibration's schedule.
    let m: CollisionResult = typed(
        &mut c,
        Command::Collision {
            action: CollisionAction::Configure,
            thresholds: Some([6.0; 7]),
            gains: None,
            reaction: None,
            pause_s: None,
        },
    )
    .await
    .unwrap();
    assert!(m.schedule.is_none() && m.calibration.is_none(), "{m:?}");
    drop(c);
    h.stop().await;
}

/// The sweep q_A (joint 1 through ±66.7° with the arm stretched out) played by the controller
/// itself, without payload: the task `current-task` records.
fn sweeping_task(seed: u64) -> mock_robot::SimulationConfig {
    let scenario = include_str!("../../mock-robot/scenarios/sweep-qa.toml");
    let mut c = mock_robot::SimulationConfig::from_toml_str(scenario).unwrap();
    c.seed = seed;
    c.payload.attached_at_start = false;
    // The script lasts ≈ 19 s; the controller keeps answering at rest after it.
    c.duration_s = Some(600.0);
    c
}

/// The issue's attack: 40 N pushed on link 4 from 8 s (200 N/s, held 4 s): joint 1 holds
/// ≈ 16 Nm.
fn push_40_n_on_link_4() -> mock_robot::contact::ContactSpec {
    mock_robot::contact::ContactSpec {
        link: 4,
        point_m: [0.0, 0.0, 0.0],
        onset_s: 8.0,
        profile: mock_robot::contact::ContactProfile::Ramp {
            direction: [0.0, 1.0, 0.0],
            rate_n_per_s: 200.0,
            max_force_n: 40.0,
            duration_s: 4.0,
        },
    }
}

/// `current-task` for the documented minimum of 20 s (it once recorded 19 blocks of 1 s and
/// failed: the filters' settling was counted as recorded time).
fn current_task(apply: bool, allow_weaker: Option<bool>) -> Command {
    Command::CollisionCalibrate {
        source: Some(CalibrationSource::CurrentTask),
        duration_s: Some(20.0),
        budget_per_hour: None,
        apply: Some(apply),
        allow_weaker,
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_push_during_a_disarmed_current_task_calibration_is_refused_and_nothing_installed() {
    let dir = tempfile::tempdir().unwrap();
    let mut config = test_config(dir.path());
    // As the issue: the monitor disarmed, so no collision aborts the recording.
    config.observer.armed = false;
    let h = Harness::start(config, dir).await;
    let mut sim = sweeping_task(31);
    sim.contacts.push(push_40_n_on_link_4());
    let driver = mock_robot::spawn_new(sim, ServerConfig::loopback(h.fri, lockstep())).unwrap();
    let mut c = h.client().await;
    wait_connected(&mut c).await;
    let before: CollisionResult = typed(&mut c, show()).await.unwrap();

    let e = typed::<CalibrateResult>(&mut c, current_task(true, None))
        .await
        .unwrap_err();
    assert_eq!(e.code, ErrorCode::Failed, "{e:?}");
    assert!(e.message.contains("nothing installed"), "{e:?}");
    match e.cause.as_deref() {
        Some(Cause::ContactInRecording {
            joint,
            onset_s,
            residual_nm,
            score,
            limit,
            ..
        }) => {
            assert_eq!(*joint, 1, "{e:?}");
            // The service's clock starts with the controller's first measurement.
            assert!((*onset_s - 8.0).abs() < 0.5, "{e:?}");
            assert!(residual_nm.abs() > 10.0 && score > limit, "{e:?}");
        }
        other => panic!("{other:?}"),
    }
    // Nothing changed, and the contaminated recording is refused again on a refit.
    let after: CollisionResult = typed(&mut c, show()).await.unwrap();
    assert_eq!(after, before);
    assert!(!after.persisted && after.schedule.is_none());
    let e = typed::<CalibrateResult>(
        &mut c,
        calibrate(Some(CalibrationSource::LastRecording), None, None, true),
    )
    .await
    .unwrap_err();
    assert!(
        matches!(
            e.cause.as_deref(),
            Some(Cause::ContactInRecording { joint: 1, .. })
        ),
        "{e:?}"
    );
    drop(c);
    drop(driver.join());
    h.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn thresholds_above_the_ceiling_need_allow_weaker_and_are_audited_as_weaker() {
    let dir = tempfile::tempdir().unwrap();
    let mut config = test_config(dir.path());
    config.observer.armed = false;
    // Below what the sweep calibrates on joint 1 (≈ 8 Nm median over the recording), above
    // the other joints' (< 1 Nm).
    config.observer.calibration_ceiling_nm = [4.0, 4.0, 4.0, 4.0, 4.0, 4.0, 4.0];
    let h = Harness::start(config, dir).await;
    let driver =
        mock_robot::spawn_new(sweeping_task(32), ServerConfig::loopback(h.fri, lockstep()))
            .unwrap();
    let mut c = h.client().await;
    wait_connected(&mut c).await;
    let events = collect_watch(h.client().await, None).await;

    // The preview names the joint above the ceiling.
    let preview: CalibrateResult = typed(&mut c, current_task(false, None)).await.unwrap();
    assert!(preview.recording.blocks >= 20, "{:?}", preview.recording);
    assert_eq!(
        preview.above_ceiling.len(),
        1,
        "{:?}",
        preview.above_ceiling
    );
    let above = preview.above_ceiling[0];
    assert_eq!(above.joint, 1);
    assert_eq!(above.ceiling_nm, 4.0);
    assert_eq!(above.threshold_at_rest_nm, preview.schedule.thresholds[0]);
    assert_eq!(
        above.threshold_median_nm,
        preview.joints[0].threshold_median
    );
    assert!(above.threshold_median_nm > 4.0, "{above:?}");
    // `apply` alone refuses it; nothing is installed.
    let e = typed::<CalibrateResult>(
        &mut c,
        calibrate(Some(CalibrationSource::LastRecording), None, None, true),
    )
    .await
    .unwrap_err();
    assert_eq!(e.code, ErrorCode::Failed, "{e:?}");
    assert!(e.message.contains("allow_weaker"), "{e:?}");
    assert_eq!(
        e.cause.as_deref(),
        Some(&Cause::CalibrationAboveCeiling {
            joints: vec![above]
        })
    );
    let m: CollisionResult = typed(&mut c, show()).await.unwrap();
    assert!(m.schedule.is_none() && !m.persisted, "{m:?}");
    // `allow_weaker` without `apply` is a mistake, not a silent no-op.
    let e = typed::<CalibrateResult>(
        &mut c,
        Command::CollisionCalibrate {
            source: Some(CalibrationSource::LastRecording),
            duration_s: None,
            budget_per_hour: None,
            apply: Some(false),
            allow_weaker: Some(true),
        },
    )
    .await
    .unwrap_err();
    assert_eq!(e.code, ErrorCode::InvalidArguments, "{e:?}");
    // With `allow_weaker` it is installed, and the audit trail says what is weaker.
    let applied: CalibrateResult = typed(
        &mut c,
        Command::CollisionCalibrate {
            source: Some(CalibrationSource::LastRecording),
            duration_s: None,
            budget_per_hour: None,
            apply: Some(true),
            allow_weaker: Some(true),
        },
    )
    .await
    .unwrap();
    assert!(applied.applied && applied.settings.persisted);
    assert_eq!(applied.above_ceiling, vec![above]);
    wait_event(&events, "calibration audit", |e, d| {
        e == "audit" && d["change"]["what"] == "calibration-installed"
    })
    .await;
    let record = events
        .lock()
        .unwrap()
        .iter()
        .find(|(e, d)| e == "audit" && d["change"]["what"] == "calibration-installed")
        .map(|(_, d)| d.clone())
        .unwrap();
    let weaker = record["change"]["weaker_than_configuration"]
        .as_array()
        .unwrap();
    assert_eq!(weaker.len(), 1, "{record}");
    let text = weaker[0].as_str().unwrap();
    assert!(
        text.contains("joint 1") && text.contains("ceiling") && text.contains("allow_weaker"),
        "{text}"
    );
    drop(c);
    drop(driver.join());
    h.stop().await;
}
