//! `fri-service demo`: the paper's pick-estimate-and-move experiment against the embedded mock
//! robot, through the real service and its operator socket.
//!
//! 1. Tare: the 10-pose centred pattern (start pose first and last, D-optimal poses within ±7°)
//!    without payload (controller run 1).
//! 2. Estimate: the same pattern with the paper's 3.028 kg payload at (0, 0, 0.119) m in frame 7
//!    (controller run 2: the payload is attached while the arm is parked), applied to the observer;
//!    then `collision-calibrate` on a contact-free run of the free motion (`current-task`).
//! 3. Free motion with three contacts at 1, 8 and 17 s (controller run 3, KRL-side motion in
//!    monitor mode), recorded by the service; the residual is evaluated with the estimate
//!    (compensated) and without it (uncompensated, the paper's problem), at the 6 Nm threshold.
//! 4. SVG plots in the style of the paper's Fig. 5 and Fig. 6.

//!
//! One file per phase ([`estimate`], [`free_motion`], [`evaluate`]; the thresholds' calibration
//! in [`calibrate`]), the scenario in [`scenario`], the log, the replayed monitor and the
//! figures in their own.

mod calibrate;
mod clock;
mod estimate;
mod evaluate;
mod figures;
mod free_motion;
mod log;
mod replay;
mod scenario;

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

use anyhow::Context as _;
use fri_api::client::Client;
use fri_service::config::Config;
use fri_service::service::RunningService;
use mock_robot::server::TimingMode;
use serde::Serialize;
use serde_json::{Value, json};
use tokio::sync::watch;

/// The paper's payload (Sec. VI, eq. 39): mass, kg.
pub const PAYLOAD_MASS: f64 = 3.028;
/// The paper's payload CoM in frame 7, m.
pub const PAYLOAD_COM: [f64; 3] = [0.0, 0.0, 0.119];
/// The paper's 10-sample estimate (eq. 47): mass, kg.
pub const PAPER_MASS: f64 = 3.059;
/// The paper's 10-sample estimate (eq. 47): CoM in frame 7, m.
pub const PAPER_COM: [f64; 3] = [-2.8e-3, 1.1e-2, 0.1283];
/// Contact onsets of the free-motion segment, s (as in Fig. 6).
pub const CONTACTS_S: [f64; 3] = [1.0, 8.0, 17.0];
/// Length of the free-motion segment, s.
pub const FREE_MOTION_S: f64 = 20.0;
/// Recorded robot time of the contact-free task the thresholds are calibrated on, s (the
/// whole motion; the fit needs 20 blocks of 1 s).
const CALIBRATION_RECORD_S: f64 = FREE_MOTION_S + 1.0;
/// Detection threshold, Nm (Fig. 6).
pub const THRESHOLD_NM: f64 = 6.0;
/// An onset within this time after a contact onset detects it, s.
const MATCH_WINDOW_S: f64 = 0.5;

/// Demo options.
#[derive(Debug, Clone)]
pub struct DemoOptions {
    /// Where plots and the free-motion log are written.
    pub out_dir: PathBuf,
    /// Seed of the simulated robot (noise, model error).
    pub seed: u64,
    /// The simulated arm: the shared nominal model or the real LWR 4+'s profile.
    pub arm: mock_robot::config::ArmProfile,
    /// Real time (the demo) or lockstep (tests).
    pub pacing: TimingMode,
    /// Print progress lines.
    pub verbose: bool,
    /// Publish over iceoryx2, write the service's configuration here for the ROS 2 bridge, and
    /// keep the service up after the demo until Ctrl-C (`demo --ros2`).
    pub ros2_config: Option<PathBuf>,
}

/// A payload with optional uncertainties (frame 7).
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct PayloadReport {
    /// Mass, kg.
    pub mass: f64,
    /// CoM in frame 7, m.
    pub com: [f64; 3],
    /// 1σ of the mass, kg.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mass_std: Option<f64>,
    /// 1σ of the CoM, m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub com_std: Option<[f64; 3]>,
}

/// The final report (`--json` prints it).
#[derive(Debug, Clone, Serialize)]
pub struct DemoReport {
    /// True payload of the simulation.
    pub payload_truth: PayloadReport,
    /// The service's estimate.
    pub payload_estimate: PayloadReport,
    /// The paper's 10-sample estimate (eq. 47), for comparison.
    pub payload_paper: PayloadReport,
    /// Onset times of detected contacts with the compensated residual, s.
    pub detections_compensated: Vec<f64>,
    /// Onset times of detected contacts with the uncompensated residual, s.
    pub detections_uncompensated: Vec<f64>,
    /// Onsets with the compensated residual not explained by a contact.
    pub false_alarms_compensated: usize,
    /// Onsets with the uncompensated residual not explained by a contact.
    pub false_alarms_uncompensated: usize,
    /// Onset times of detected contacts with the controller's estExtJntTrq, s.
    pub detections_fri: Vec<f64>,
    /// Onsets with the controller's estExtJntTrq not explained by a contact.
    pub false_alarms_fri: usize,
    /// Peak |signal| during free motion away from contacts, Nm: compensated, uncompensated, FRI.
    pub free_motion_peak_nm: [f64; 3],
    /// Contact onsets, s.
    pub contacts: Vec<f64>,
    /// The calibrated thresholds at rest, Nm (joints 1..7; `collision calibrate`, budget one
    /// false alarm per 10 h); panel (c) of Fig. 6 and its detections use the scheduled ones.
    pub calibrated_thresholds_at_rest_nm: [f64; 7],
    /// Collision events the service reported online (watch), s since the segment start.
    pub service_detections: Vec<f64>,
    /// Plot files.
    pub plots: Vec<PathBuf>,
    /// The free-motion log (CSV) recorded by the service.
    pub log: PathBuf,
    /// Robot time the simulated controllers ran, s (their cycles × the FRI cycle).
    pub robot_time_s: f64,
    /// Wall-clock time of the three phases that run the controller (the evaluation and the
    /// plots not counted), s.
    pub wall_time_s: f64,
}

fn say(opts: &DemoOptions, msg: impl AsRef<str>) {
    if opts.verbose {
        eprintln!("{}", msg.as_ref());
    }
}

/// Runs the demo.
pub async fn run(opts: &DemoOptions) -> anyhow::Result<DemoReport> {
    std::fs::create_dir_all(&opts.out_dir)
        .with_context(|| format!("creating {}", opts.out_dir.display()))?;
    let work = std::env::temp_dir().join(format!("fri-service-demo-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&work);
    std::fs::create_dir_all(&work)?;
    let result = run_in(opts, &work).await;
    let _ = std::fs::remove_dir_all(&work);
    result
}

async fn run_in(opts: &DemoOptions, work: &Path) -> anyhow::Result<DemoReport> {
    let mut config = scenario::demo_config(work);
    if let Some(path) = &opts.ros2_config {
        crate::ros2::prepare(&mut config, path)?;
    }
    let cycle_s = config.fri.cycle_s;
    let service = Arc::new(RunningService::start(config.clone())?);
    let fri = service
        .fri_addr()
        .context("the FRI endpoint has no address")?;
    let (shutdown, rx) = watch::channel(false);
    let server = {
        let s = service.clone();
        tokio::spawn(async move { s.serve_operator(rx).await })
    };
    for _ in 0..500 {
        if config.operator.socket.exists() {
            break;
        }
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    let mut outcome = phases(opts, &config, fri, cycle_s).await;
    if let (Ok(report), Some(path)) = (&outcome, &opts.ros2_config) {
        say(
            opts,
            format!(
                "demo done (payload {:.4} kg); the service stays up for the ROS 2 bridge \
                 (`cargo run --release -p fri-ros2 -- --config {}`) until Ctrl-C ...",
                report.payload_estimate.mass,
                path.display()
            ),
        );
        if let Err(e) = crate::ros2::serve_until_interrupted(fri).await {
            outcome = Err(e);
        }
    }
    if let Some(path) = &opts.ros2_config {
        let _ = std::fs::remove_file(path);
    }
    let _ = shutdown.send(true);
    let _ = server.await;
    if let Ok(s) = Arc::try_unwrap(service) {
        s.shutdown();
    }
    outcome
}

/// The four phases against the running service (see the module documentation).
async fn phases(
    opts: &DemoOptions,
    config: &Config,
    fri: std::net::SocketAddr,
    cycle_s: f64,
) -> anyhow::Result<DemoReport> {
    let started = std::time::Instant::now();
    let socket = &config.operator.socket;
    let mut client = Client::connect(socket).await?;
    let estimated = estimate::tare_and_estimate(opts, &mut client, fri).await?;
    let (schedule, calibration_cycles) =
        calibrate::calibrate_thresholds(opts, &mut client, fri).await?;
    let run = free_motion::run(opts, &mut client, socket, fri, cycle_s).await?;
    let simulated = started.elapsed().as_secs_f64();
    let e = evaluate::evaluate(opts, config, &estimated.estimate, &schedule, &run)?;
    let cycles = estimated.cycles + calibration_cycles + run.cycles;
    Ok(DemoReport {
        payload_truth: estimated.truth,
        payload_estimate: estimated.estimate,
        payload_paper: PayloadReport {
            mass: PAPER_MASS,
            com: PAPER_COM,
            mass_std: None,
            com_std: None,
        },
        detections_compensated: e.compensated.detected,
        detections_uncompensated: e.uncompensated.detected,
        false_alarms_compensated: e.compensated.false_alarms,
        false_alarms_uncompensated: e.uncompensated.false_alarms,
        detections_fri: e.fri.detected,
        false_alarms_fri: e.fri.false_alarms,
        free_motion_peak_nm: [
            e.compensated.free_motion_peak_nm,
            e.uncompensated.free_motion_peak_nm,
            e.fri.free_motion_peak_nm,
        ],
        contacts: CONTACTS_S.to_vec(),
        calibrated_thresholds_at_rest_nm: schedule.thresholds,
        service_detections: run.online.iter().map(|t| t - run.t0).collect(),
        plots: e.plots,
        log: run.log,
        robot_time_s: cycles as f64 * cycle_s,
        wall_time_s: simulated,
    })
}

/// A count of false alarms as text: "1 false alarm", "0 false alarms".
pub fn fmt_false_alarms(n: usize) -> String {
    if n == 1 {
        "1 false alarm".to_owned()
    } else {
        format!("{n} false alarms")
    }
}

/// Detection times as text: "at 1.019, 8.015 s", or "none".
pub fn fmt_times(t: &[f64]) -> String {
    if t.is_empty() {
        return "none".into();
    }
    let times = t
        .iter()
        .map(|x| format!("{x:.3}"))
        .collect::<Vec<_>>()
        .join(", ");
    format!("at {times} s")
}

/// Renders the report for people.
pub fn summary(r: &DemoReport) -> Value {
    json!(r)
}
