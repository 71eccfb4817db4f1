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

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

use anyhow::{Context as _, bail};
use dynamics::{Data, InertialParameters};
use mock_robot::SimulationConfig;
use mock_robot::contact::{ContactProfile, ContactSpec};
use mock_robot::motion::MotionSegment;
use nalgebra::{SVector, Vector3};
use safety::{CollisionDetector, CollisionMonitor, Detection, ObserverInput, PayloadCompensation};
use serde::Serialize;
use serde_json::{Value, json};
use tokio::sync::watch;

use super::plots::{self, Marker, Panel, Series, Threshold};
use fri_api::client::Client;
use fri_api::protocol::{Command, RecordKind};
use fri_service::config::{Config, ReactionMode};
use fri_service::service::RunningService;
use mock_robot::server::{ServerConfig, TimingMode};

type V7 = SVector<f64, 7>;

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
}

fn say(opts: &DemoOptions, msg: impl AsRef<str>) {
    if opts.verbose {
        eprintln!("{}", msg.as_ref());
    }
}

fn sim(seed: u64, payload: bool) -> SimulationConfig {
    let mut c = SimulationConfig {
        name: "demo".into(),
        seed,
        ..SimulationConfig::default()
    };
    c.payload.mass_kg = PAYLOAD_MASS;
    c.payload.com_m = PAYLOAD_COM;
    c.payload.attached_at_start = payload;
    c
}

fn free_motion(seed: u64) -> SimulationConfig {
    let mut c = sim(seed, true);
    let p0 = mock_robot::config::DEFAULT_INITIAL_Q_DEG;
    let ptp = |q: [f64; 7], d: f64| MotionSegment::Ptp {
        q_deg: q,
        duration_s: Some(d),
        speed_fraction: None,
    };
    c.motion = vec![
        ptp([30.0, 45.0, 15.0, -45.0, 20.0, 70.0, 15.0], 3.0),
        ptp([-30.0, 20.0, -15.0, -80.0, -20.0, 45.0, -15.0], 3.5),
        ptp([20.0, 55.0, 25.0, -35.0, 30.0, 80.0, 25.0], 3.5),
        ptp([-25.0, 30.0, -20.0, -70.0, -25.0, 50.0, -20.0], 3.5),
        ptp([25.0, 40.0, 10.0, -50.0, 15.0, 65.0, 10.0], 3.0),
        ptp(p0, 3.0),
        MotionSegment::Dwell { duration_s: 1.0 },
    ];
    let contact = |link: usize, onset_s: f64, force: [f64; 3]| ContactSpec {
        link,
        point_m: [0.0, 0.0, 0.0],
        onset_s,
        profile: ContactProfile::HalfSine {
            peak_force_n: force,
            duration_s: 0.3,
        },
    };
    c.contacts = vec![
        contact(4, CONTACTS_S[0], [0.0, 60.0, 0.0]),
        contact(6, CONTACTS_S[1], [60.0, 0.0, 0.0]),
        contact(7, CONTACTS_S[2], [0.0, -50.0, 30.0]),
    ];
    c.duration_s = Some(FREE_MOTION_S + 0.5);
    c
}

fn demo_config(dir: &Path) -> Config {
    let mut c = Config::default();
    c.fri.bind = "127.0.0.1:0".parse().unwrap_or(c.fri.bind);
    c.operator.socket = dir.join("operator.sock");
    c.state.dir = dir.join("state");
    c.iceoryx2.enabled = false;
    // Faster than the conservative defaults (still far below the LWR's limits) so the demo
    // finishes in about a minute.
    c.fri.max_joint_step = 1.0e-3;
    c.motion.max_velocity = [0.9; 7];
    // 2.5 rad/s²: faster, an undeclared 3 kg payload's inertial torque on the centred pattern's
    // moves reaches the workflow's residual check
    c.motion.max_acceleration = [2.5; 7];
    c.motion.max_jerk = [50.0; 7];
    c.estimation.settle_window_s = 0.1;
    c.estimation.average_s = 0.3;
    // the faster moves leave the arm ringing longer before it counts as settled
    c.estimation.settle_timeout_s = 2.0;
    // Each phase brings its simulated controller up on a new socket, at least 0.2 s after the
    // previous one stopped: a 0.1 s resync binds the new one at its first datagram (with the
    // default 1 s its first 0.8 s would go unanswered and the log would start late).
    c.fri.resync_after_s = 0.1;
    // Armed throughout (the default); the payload is declared unknown before it is attached.
    // Report only: the free motion is the controller's own program, which the service does not
    // hold, and every contact is to be counted.
    c.observer.thresholds = [THRESHOLD_NM; 7];
    c.reaction.policy = ReactionMode::Report;
    c
}

/// Waits until the service's cycle count passes `after_cycle + margin` (a controller heard).
async fn wait_fresh_state(
    client: &mut Client,
    after_cycle: Option<u64>,
    margin: u64,
) -> anyhow::Result<()> {
    for _ in 0..1000 {
        let s = client.call(Command::Status, |_, _| {}).await?;
        if let Ok(s) = s
            && let Some(c) = s["cycle"].as_u64()
            && after_cycle.is_none_or(|a| c > a + margin)
        {
            return Ok(());
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    bail!("the service did not see the simulated controller")
}

async fn current_cycle(client: &mut Client) -> anyhow::Result<Option<u64>> {
    let s = client.call(Command::Status, |_, _| {}).await?;
    Ok(s.ok().and_then(|s| s["cycle"].as_u64()))
}

/// The service's cycle count and clock (s) at its newest measurement, read once they stopped
/// changing: the previous controller's datagrams are all processed.
async fn service_clock(client: &mut Client) -> anyhow::Result<(u64, f64)> {
    let mut last = None;
    for _ in 0..100 {
        let s = client
            .call(Command::Status, |_, _| {})
            .await?
            .map_err(|e| anyhow::anyhow!("status failed: {}", e.message))?;
        let now = s["cycle"].as_u64().zip(s["time_s"].as_f64());
        if let Some(settled) = now
            && last == now
        {
            return Ok(settled);
        }
        last = now;
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    bail!("the service's clock did not settle after the previous controller ended")
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
    let mut config = demo_config(work);
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

async fn phases(
    opts: &DemoOptions,
    config: &Config,
    fri: std::net::SocketAddr,
    cycle_s: f64,
) -> anyhow::Result<DemoReport> {
    let socket = &config.operator.socket;
    let mut client = Client::connect(socket).await?;

    // 1. Tare.
    say(
        opts,
        "[1/4] tare: 10 poses (centred pattern, ±7°), no payload ...",
    );
    let driver = mock_robot::spawn_new(
        sim(opts.seed, false),
        ServerConfig::loopback(fri, opts.pacing),
    )?;
    wait_fresh_state(&mut client, None, 50).await?;
    let tare = client
        .call(
            Command::Tare {
                around: None,
                poses: Some(10),
                step_deg: Some(7.0),
                pattern: None,
                replace_loaded: None,
            },
            |_, d| {
                if d["phase"] == "sampled" {
                    say(opts, sampled_line(&d["step"], &d["of"]));
                }
            },
        )
        .await?
        .map_err(|e| anyhow::anyhow!("tare failed: {}", e.message))?;
    say(
        opts,
        format!(
            "      tare stored: {} poses and the first again, {} samples",
            tare["samples"],
            tare["samples"].as_u64().map_or(0, |n| n + 1)
        ),
    );

    // 2. Estimate.
    say(
        opts,
        format!("[2/4] payload attached ({PAYLOAD_MASS} kg at (0, 0, 0.119) m); estimating ..."),
    );
    let before = current_cycle(&mut client).await?;
    // Declared unknown before the grasp: the monitor stays armed and tolerates only what a
    // plausible flange load explains (docs/collision-detection.md §8).
    let declared = client
        .call(
            Command::ExpectPayload {
                max_mass: None,
                max_radius: None,
                end: None,
            },
            |_, _| {},
        )
        .await?
        .map_err(|e| anyhow::anyhow!("expect-payload failed: {}", e.message))?;
    // The same robot carries on: the tare's noise, drift and estimate are independent draws.
    let (mut robot, _) = driver
        .join()
        .context("the simulated controller of the tare phase failed")?;
    robot.set_payload_attached(true);
    let driver = mock_robot::spawn(robot, ServerConfig::loopback(fri, opts.pacing))?;
    wait_fresh_state(&mut client, before, 50).await?;
    let est = client
        .call(
            Command::EstimatePayload {
                around: None,
                poses: Some(10),
                step_deg: Some(7.0),
                pattern: None,
                use_tare: None,
                apply: Some(true),
            },
            |_, d| {
                if d["phase"] == "sampled" {
                    say(opts, sampled_line(&d["step"], &d["of"]));
                }
            },
        )
        .await?
        .map_err(|e| anyhow::anyhow!("estimation failed: {}", e.message))?;
    // A collision would have aborted the estimate; the monitor was armed from the declaration
    // on, and the applied estimate ended the unknown-payload mode.
    let after = client
        .call(Command::Status, |_, _| {})
        .await?
        .map_err(|e| anyhow::anyhow!("status failed: {}", e.message))?;
    let armed = declared["unknown_payload"].is_object()
        && after["monitor"]["armed"] == true
        && after["unknown_payload"].is_null();
    say(
        opts,
        if armed {
            "      estimated with the monitor ARMED throughout (payload declared unknown, no collision; estimate applied)"
        } else {
            "      WARNING: the monitor was not armed throughout the estimate"
        },
    );
    let (robot, _) = driver
        .join()
        .context("the simulated controller of the estimate phase failed")?;
    let truth = robot
        .true_payload()
        .copied()
        .context("the simulation ended without its truth")?;
    let schedule = calibrate_thresholds(opts, &mut client, fri).await?;
    let f = |v: &Value| v.as_f64().unwrap_or(f64::NAN);
    let v3 = |v: &Value| [f(&v[0]), f(&v[1]), f(&v[2])];
    let estimate = PayloadReport {
        mass: f(&est["mass"]),
        com: v3(&est["com"]),
        mass_std: Some(f(&est["mass_std"])),
        com_std: Some(v3(&est["com_std"])),
    };
    let truth_com = truth.com().map_or([f64::NAN; 3], |c| [c.x, c.y, c.z]);
    let payload_truth = PayloadReport {
        mass: truth.mass,
        com: truth_com,
        mass_std: None,
        com_std: None,
    };
    say(
        opts,
        "      payload (frame 7)         mass [kg]            com [m]",
    );
    say(
        opts,
        format!(
            "      truth                     {:.4}               ({:+.4}, {:+.4}, {:+.4})",
            truth.mass, truth_com[0], truth_com[1], truth_com[2]
        ),
    );
    let sd = estimate.com_std.unwrap_or([f64::NAN; 3]);
    say(
        opts,
        format!(
            "      service (tare, 10 poses)  {:.4} ± {:.4}     ({:+.4} ± {:.4}, {:+.4} ± {:.4}, {:+.4} ± {:.4})",
            estimate.mass,
            estimate.mass_std.unwrap_or(f64::NAN),
            estimate.com[0],
            sd[0],
            estimate.com[1],
            sd[1],
            estimate.com[2],
            sd[2]
        ),
    );
    say(
        opts,
        format!(
            "      paper eq. 47 (10 poses)   {PAPER_MASS:.4}               ({:+.4}, {:+.4}, {:+.4})",
            PAPER_COM[0], PAPER_COM[1], PAPER_COM[2]
        ),
    );
    // What the service's σ is made of, and where the procedure's robot time went.
    if let Some(sources) = est["uncertainty"]["sources"].as_array() {
        let parts: Vec<String> = sources
            .iter()
            .map(|p| {
                format!(
                    "{} {:.2} g",
                    p["source"].as_str().unwrap_or("?"),
                    f(&p["mass_std"]) * 1e3
                )
            })
            .collect();
        say(
            opts,
            format!("      mass 1σ by source: {}", parts.join(", ")),
        );
    }
    let t = &est["timing"];
    if t.is_object() {
        say(
            opts,
            format!(
                "      estimate robot time {:.1} s: moving {:.1}, settling {:.1}, averaging {:.1}",
                f(&t["total_s"]),
                f(&t["moving_s"]),
                f(&t["settling_s"]),
                f(&t["averaging_s"])
            ),
        );
    }

    // 3. Free motion with contacts.
    say(
        opts,
        "[3/4] free motion, contacts at 1, 8, 17 s; monitor armed with the estimate ...",
    );
    let log = opts.out_dir.join("free-motion.csv");
    let log_abs = if log.is_absolute() {
        log.clone()
    } else {
        std::env::current_dir()?.join(&log)
    };
    // The previous phase's controller has ended (joined). After the 0.2 s a rebind needs
    // (see `demo_config`), the service's clock at its last measurement fixes t = 0 of this
    // run: the new controller's first measurement is counted one cycle later. Recording and
    // watching start once the new controller is heard (a recording needs a live controller,
    // and one begun on the old controller's last breath fails when it falls silent); the few
    // cycles before that are missing from the log, never misplaced in time.
    tokio::time::sleep(Duration::from_millis(200)).await;
    let (before_cycle, before_time) = service_clock(&mut client).await?;
    let t0 = before_time + cycle_s;
    let driver = mock_robot::spawn_new(
        free_motion(opts.seed),
        ServerConfig::loopback(fri, opts.pacing),
    )?;
    wait_fresh_state(&mut client, Some(before_cycle), 0).await?;
    // The service writes only into its recording directory (in the demo's work directory); the
    // log is copied to the output directory afterwards.
    let mut recorder = Client::connect(socket).await?;
    let record_path = "free-motion.csv".to_owned();
    let record = tokio::spawn(async move {
        recorder
            .call(
                Command::Record {
                    path: record_path,
                    kind: RecordKind::Log,
                    // Ends before the controller does (FREE_MOTION_S + 0.5 s after t = 0, the
                    // first row is a little later): a recording whose controller falls silent
                    // fails (issue 20 item 9).
                    duration_s: Some(FREE_MOTION_S),
                    count: None,
                    excite_deg: None,
                },
                |_, _| {},
            )
            .await
    });
    let mut watcher = Client::connect(socket).await?;
    let online = Arc::new(std::sync::Mutex::new(Vec::<f64>::new()));
    let online_w = online.clone();
    let watch_task = tokio::spawn(async move {
        let _ = watcher
            .call(Command::Watch { state_every: None }, |ev, d| {
                if ev == "collision"
                    && let (Some(t), Ok(mut v)) = (d["time_s"].as_f64(), online_w.lock())
                {
                    v.push(t);
                }
            })
            .await;
    });
    let recorded = record
        .await
        .context("recording task")??
        .map_err(|e| anyhow::anyhow!("recording failed: {}", e.message))?;
    drop(driver.join());
    watch_task.abort();
    let written = recorded["path"]
        .as_str()
        .context("the record reply has no path")?;
    std::fs::copy(written, &log_abs)
        .with_context(|| format!("copying {written} to {}", log_abs.display()))?;
    say(
        opts,
        format!(
            "      recorded {} cycles to {}",
            recorded["rows"],
            log.display()
        ),
    );

    // 4. Evaluation and plots.
    say(opts, "[4/4] evaluating residuals and plotting ...");
    let rows = read_log(&log_abs)?;
    let online_rel: Vec<f64> = online
        .lock()
        .map(|v| v.iter().map(|t| t - t0).collect())
        .unwrap_or_default();
    let model = dynamics::lwr4();
    // Panel (c) and the compensated detections: the service's calibrated monitor (scheduled
    // thresholds, the applied estimate as the service compensates it) on the recorded log.
    let applied = fri_service::persistence::AppliedPayload {
        mass: estimate.mass,
        com: estimate.com,
    };
    let (compensated, scheduled, on_c) = scheduled_residuals(
        &model,
        config,
        &rows,
        fri_service::service::core::compensation(&applied),
        cycle_s,
        &schedule,
        t0,
    )?;
    let uncompensated = residuals(&model, config, &rows, PayloadCompensation::None, cycle_s)?;
    let fri_signal: Vec<V7> = rows.iter().map(|r| V7::from(r.tau_ext)).collect();
    let times: Vec<f64> = rows.iter().map(|r| r.time_s - t0).collect();
    let velocities: Vec<V7> = rows.iter().map(|r| V7::from(r.qd)).collect();
    // The service's thresholds, so the figure's dashed lines are the ones the evaluation used.
    let thresholds = &config.observer.thresholds;
    let on_u = onsets(&uncompensated, &velocities, &times, thresholds)?;
    let on_f = onsets(&fri_signal, &velocities, &times, thresholds)?;
    let (det_c, fa_c) = classify(&on_c);
    let (det_u, fa_u) = classify(&on_u);
    let (det_f, fa_f) = classify(&on_f);
    let peak = |sig: &[V7]| {
        sig.iter()
            .zip(&times)
            .filter(|(_, t)| CONTACTS_S.iter().all(|c| **t < *c - 0.05 || **t > *c + 1.0))
            .map(|(r, _)| r.amax())
            .fold(0.0, f64::max)
    };
    let free_motion_peak_nm = [peak(&compensated), peak(&uncompensated), peak(&fri_signal)];
    for (name, det, fa, pk) in [
        (
            "compensated residual (with estimate)",
            &det_c,
            fa_c,
            free_motion_peak_nm[0],
        ),
        (
            "uncompensated residual (no payload)",
            &det_u,
            fa_u,
            free_motion_peak_nm[1],
        ),
        (
            "controller estExtJntTrq (FRI)",
            &det_f,
            fa_f,
            free_motion_peak_nm[2],
        ),
    ] {
        say(
            opts,
            format!(
                "      {name:38} detections {}, {fa} false alarm(s), free-motion peak {pk:.1} Nm",
                fmt_times(det)
            ),
        );
    }

    let fig5 = opts.out_dir.join("fig5-torque-validation.svg");
    let fig6 = opts.out_dir.join("fig6-residuals.svg");
    plot_fig5(&fig5, &model, &rows, &times, &estimate, cycle_s)?;
    plot_fig6(
        &fig6,
        &times,
        thresholds,
        (&fri_signal, &uncompensated, &compensated),
        &scheduled,
        &Onsets {
            fri: &on_f,
            uncompensated: &on_u,
            compensated: &on_c,
        },
    )?;
    say(
        opts,
        format!(
            "      plots: {} and {} (each also as .png)",
            fig5.display(),
            fig6.display()
        ),
    );

    Ok(DemoReport {
        payload_truth,
        payload_estimate: estimate,
        payload_paper: PayloadReport {
            mass: PAPER_MASS,
            com: PAPER_COM,
            mass_std: None,
            com_std: None,
        },
        detections_compensated: det_c,
        detections_uncompensated: det_u,
        false_alarms_compensated: fa_c,
        false_alarms_uncompensated: fa_u,
        detections_fri: det_f,
        false_alarms_fri: fa_f,
        free_motion_peak_nm,
        contacts: CONTACTS_S.to_vec(),
        calibrated_thresholds_at_rest_nm: schedule.thresholds,
        service_detections: online_rel,
        plots: vec![
            fig5.with_extension("png"),
            fig6.with_extension("png"),
            fig5,
            fig6,
        ],
        log,
    })
}

/// The progress line of a sampled pose: the pattern's poses count to their number, the last
/// sample is the first pose again (the drift over the procedure).
fn sampled_line(step: &serde_json::Value, of: &serde_json::Value) -> String {
    match (step.as_u64(), of.as_u64()) {
        (Some(k), Some(n)) if k == n && n > 1 => {
            "      pose 1 sampled again (the drift over the procedure)".to_owned()
        }
        (Some(k), Some(n)) => format!("      pose {k}/{} sampled", n.saturating_sub(1).max(1)),
        _ => format!("      pose {step}/{of} sampled"),
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

/// One row of the service's per-cycle log.
#[derive(Debug, Clone)]
struct LogRow {
    time_s: f64,
    q: [f64; 7],
    qd: [f64; 7],
    tau: [f64; 7],
    tau_ext: [f64; 7],
}

fn read_log(path: &Path) -> anyhow::Result<Vec<LogRow>> {
    let mut reader =
        csv::Reader::from_path(path).with_context(|| format!("reading {}", path.display()))?;
    let headers = reader.headers()?.clone();
    let col = |name: &str| {
        headers
            .iter()
            .position(|h| h == name)
            .with_context(|| format!("column {name} missing in the log"))
    };
    let time = col("time_s")?;
    let q1 = col("q1")?;
    let qd1 = col("qd1")?;
    let tau1 = col("tau1")?;
    let ext1 = col("tau_ext1")?;
    let mut rows = Vec::new();
    for rec in reader.records() {
        let rec = rec?;
        let num = |i: usize| -> anyhow::Result<f64> {
            Ok(rec.get(i).context("short row")?.parse::<f64>()?)
        };
        let arr = |start: usize| -> anyhow::Result<[f64; 7]> {
            let mut a = [0.0; 7];
            for (j, v) in a.iter_mut().enumerate() {
                *v = num(start + j)?;
            }
            Ok(a)
        };
        rows.push(LogRow {
            time_s: num(time)?,
            q: arr(q1)?,
            qd: arr(qd1)?,
            tau: arr(tau1)?,
            tau_ext: arr(ext1)?,
        });
    }
    if rows.len() < 100 {
        bail!("the free-motion log has only {} rows", rows.len());
    }
    Ok(rows)
}

fn residuals(
    model: &dynamics::Model<7>,
    config: &Config,
    rows: &[LogRow],
    payload: PayloadCompensation,
    cycle_s: f64,
) -> anyhow::Result<Vec<V7>> {
    let mut monitor: CollisionMonitor<7> =
        fri_service::service::build_monitor(config, model.clone())
            .context("observer configuration")?;
    monitor
        .set_payload(payload)
        .map_err(|e| anyhow::anyhow!("payload rejected by the observer: {e}"))?;
    let mut last_t: Option<f64> = None;
    Ok(rows
        .iter()
        .map(|r| {
            replay_step(&mut monitor, r, &mut last_t, cycle_s)
                .observer
                .residual
        })
        .collect())
}

/// One logged cycle through a replayed monitor, as the service ran it: the gap since the
/// previous row integrated with its true length, or — longer than the service bridges
/// (`MAX_BRIDGED_CYCLES`, e.g. a host stall in real time) — a restart and a new warm-up, as the
/// service resynchronised there (integrating across it would turn the gap into a residual step
/// and a false alarm the service never raised). During a warm-up the residual is NaN, as in
/// the service's log: it is not trusted, and the detector was not updated.
fn replay_step(
    monitor: &mut CollisionMonitor<7>,
    r: &LogRow,
    last_t: &mut Option<f64>,
    cycle_s: f64,
) -> safety::MonitorOutput<7> {
    let dt = last_t.map_or(cycle_s, |t| (r.time_s - t).max(cycle_s));
    *last_t = Some(r.time_s);
    let cycles = (dt / cycle_s).round();
    if cycles > f64::from(fri_service::service::cycle::MAX_BRIDGED_CYCLES) {
        monitor.restart();
    }
    let mut out = monitor.step(&ObserverInput::new(V7::from(r.q), V7::from(r.tau), dt));
    if !out.live {
        out.observer.residual = V7::repeat(f64::NAN);
    }
    out
}

/// Calibrates the service's thresholds on the task: a contact-free run of the free motion
/// (payload attached and its estimate applied; its own noise and drift draws), recorded as
/// `current-task`, budget one false alarm per 10 h, applied. The task, not the built-in
/// excitation: the excitation moves joint 1 and the pose pattern, and a schedule fitted there
/// extrapolates to the other joints' fast moves (joint 2 reached its ceiling in the free
/// motion). Returns the schedule in force.
async fn calibrate_thresholds(
    opts: &DemoOptions,
    client: &mut Client,
    fri: std::net::SocketAddr,
) -> anyhow::Result<fri_api::results::ThresholdSchedule> {
    say(
        opts,
        "      calibrating the collision thresholds on the task (a contact-free run of the free motion) ...",
    );
    let before = current_cycle(client).await?;
    let mut task = free_motion(opts.seed.wrapping_add(1));
    task.contacts.clear();
    // The service counts recorded samples only: the feature filters' settling (0.1 s) at the
    // start and after each gap the monitor cannot bridge (a host that stalls the real-time
    // pair) is not recorded. 5 s of rest after the motion cover them.
    task.duration_s = Some(CALIBRATION_RECORD_S + 5.0);
    let driver = mock_robot::spawn_new(task, ServerConfig::loopback(fri, opts.pacing))?;
    wait_fresh_state(client, before, 50).await?;
    let reply = client
        .call(
            Command::CollisionCalibrate {
                source: Some(fri_api::protocol::CalibrationSource::CurrentTask),
                duration_s: Some(CALIBRATION_RECORD_S),
                budget_per_hour: None,
                apply: Some(true),
                allow_weaker: None,
            },
            |_, _| {},
        )
        .await?
        .map_err(|e| anyhow::anyhow!("calibration failed: {}", e.message));
    drop(driver.join());
    let result: fri_api::results::CalibrateResult = serde_json::from_value(reply?)?;
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
    Ok(result.schedule)
}

/// The residual, the scheduled thresholds and the onset times (s since `t0`) of the service's
/// calibrated monitor replayed on the log.
fn scheduled_residuals(
    model: &dynamics::Model<7>,
    config: &Config,
    rows: &[LogRow],
    payload: PayloadCompensation,
    cycle_s: f64,
    schedule: &fri_api::results::ThresholdSchedule,
    t0: f64,
) -> anyhow::Result<(Vec<V7>, Vec<V7>, Vec<f64>)> {
    let mut monitor: CollisionMonitor<7> = fri_service::service::build_scheduled_monitor(
        config,
        &fri_service::service::arm::ArmModel::nominal(model.clone()),
        Some(schedule),
    )
    .context("observer configuration")?;
    monitor
        .set_payload(payload)
        .map_err(|e| anyhow::anyhow!("payload rejected by the observer: {e}"))?;
    let mut last_t: Option<f64> = None;
    let (mut residual, mut thresholds, mut onsets) = (Vec::new(), Vec::new(), Vec::new());
    for r in rows {
        let out = replay_step(&mut monitor, r, &mut last_t, cycle_s);
        let features = monitor
            .features()
            .copied()
            .unwrap_or_else(|| safety::MotionFeatures::from_speed(&out.observer.velocity));
        residual.push(out.observer.residual);
        thresholds.push(monitor.detector().config().thresholds_for(&features));
        if let Some(Detection::Onset(_)) = out.detection {
            onsets.push(r.time_s - t0);
        }
    }
    Ok((residual, thresholds, onsets))
}

fn onsets(
    signal: &[V7],
    velocities: &[V7],
    times: &[f64],
    thresholds: &[f64; 7],
) -> anyhow::Result<Vec<f64>> {
    let mut detector = CollisionDetector::<7>::new(safety::DetectorConfig {
        thresholds_nm: V7::from(*thresholds),
        ..Default::default()
    })
    .map_err(|e| anyhow::anyhow!("{e}"))?;
    let mut out = Vec::new();
    for (k, ((r, v), t)) in signal.iter().zip(velocities).zip(times).enumerate() {
        if let Detection::Onset(_) = detector.update(r, v, k as u64, *t) {
            out.push(*t);
        }
    }
    Ok(out)
}

/// Splits onsets into detections (first onset within the window after each contact) and false
/// alarms (all other onsets).
fn classify(onsets: &[f64]) -> (Vec<f64>, usize) {
    let mut detections = Vec::new();
    let mut used = vec![false; onsets.len()];
    for c in CONTACTS_S {
        if let Some((i, t)) = onsets
            .iter()
            .enumerate()
            .find(|(i, t)| !used[*i] && **t >= c && **t <= c + MATCH_WINDOW_S)
        {
            used[i] = true;
            detections.push(*t);
        }
    }
    let false_alarms = used.iter().filter(|u| !**u).count();
    (detections, false_alarms)
}

/// Every fifth point, without the ones that have no value (a replayed monitor's warm-up).
fn decimate(times: &[f64], values: impl Iterator<Item = f64>) -> Vec<(f64, f64)> {
    times
        .iter()
        .copied()
        .zip(values)
        .step_by(5)
        .filter(|(_, y)| y.is_finite())
        .collect()
}

fn plot_fig5(
    path: &Path,
    model: &dynamics::Model<7>,
    rows: &[LogRow],
    times: &[f64],
    estimate: &PayloadReport,
    cycle_s: f64,
) -> anyhow::Result<()> {
    let loaded = model.with_payload(&InertialParameters::point_mass(
        estimate.mass,
        Vector3::from(estimate.com),
    ));
    let mut data = Data::new(&loaded);
    // q̈ from a central difference of the observer's filtered q̇ over ±10 cycles of the log's
    // own time. Across a gap in the log (a host stall) the difference is no acceleration, and
    // after one the observer's q̇ filter settles again (50 ms): no prediction there (NaN, the
    // line is cut).
    let h = 10usize;
    let gap = |k: usize| k > 0 && rows[k].time_s - rows[k - 1].time_s > 1.5 * cycle_s;
    let settle = (0.05 / cycle_s) as usize;
    let mut since_gap = usize::MAX;
    let mut fresh = vec![false; rows.len()];
    for (k, f) in fresh.iter_mut().enumerate() {
        since_gap = if gap(k) {
            0
        } else {
            since_gap.saturating_add(1)
        };
        *f = since_gap <= settle;
    }
    let computed: Vec<V7> = (0..rows.len())
        .map(|k| {
            let (a, b) = (k.saturating_sub(h), (k + h).min(rows.len() - 1));
            if (a + 1..=b).any(gap) || fresh[k] {
                return V7::repeat(f64::NAN);
            }
            let span = (rows[b].time_s - rows[a].time_s).max(cycle_s);
            let qdd = (V7::from(rows[b].qd) - V7::from(rows[a].qd)) / span;
            dynamics::rnea(
                &loaded,
                &mut data,
                &V7::from(rows[k].q),
                &V7::from(rows[k].qd),
                &qdd,
            )
        })
        .collect();
    // The observer's q̇ restarts with the free-motion run (new controller connection); its first
    // 50 ms are the velocity filter settling, not a torque prediction, so they are not plotted.
    let settled = ((0.05 / cycle_s) as usize).min(rows.len()).min(times.len());
    let (rows, times, computed) = (&rows[settled..], &times[settled..], &computed[settled..]);
    let markers = contact_markers();
    let panels: Vec<Panel> = [1usize, 3, 5]
        .iter()
        .map(|&j| Panel {
            title: format!(
                "Joint {}: measured joint torque and the torque computed with the estimated payload (RNEA)",
                j + 1
            ),
            y_label: "joint torque [Nm]".into(),
            // The computed torque first, the measured one (thinner) on top of it.
            series: vec![
                Series {
                    label: "computed (RNEA)".into(),
                    points: decimate(times, computed.iter().map(|c| c[j])),
                    color: 0,
                    width: 2,
                },
                Series {
                    label: "measured".into(),
                    points: decimate(times, rows.iter().map(|r| r.tau[j])),
                    color: 1,
                    width: 1,
                },
            ],
            thresholds: Vec::new(),
            markers: markers.clone(),
            marker_legend: Some(CONTACT_LEGEND.into()),
            detections: Vec::new(),
        })
        .collect();
    plots::draw(path, &panels).map(|_| ())
}

/// Legend entry of the contact markers.
const CONTACT_LEGEND: &str = "contact onset C1–C3";

/// The free-motion segment's contact onsets as labelled markers.
fn contact_markers() -> Vec<Marker> {
    CONTACTS_S
        .iter()
        .enumerate()
        .map(|(i, t)| Marker {
            t: *t,
            label: format!("C{}", i + 1),
        })
        .collect()
}

/// The joint number as a Unicode subscript (joints 1..9).
fn subscript(joint: usize) -> char {
    char::from_u32(0x2080 + (joint % 10) as u32).unwrap_or(' ')
}

/// The thresholds as the figure draws them: joints with the same value share one neutral
/// dashed pair ("θ = ±6 Nm", or "θ₆,₇ = ±2 Nm" when others differ), a joint alone on its value
/// gets a pair in its own colour.
fn threshold_lines(thresholds: &[f64; 7]) -> Vec<Threshold> {
    let mut groups: Vec<(f64, Vec<usize>)> = Vec::new();
    for (j, &t) in thresholds.iter().enumerate() {
        match groups.iter_mut().find(|(v, _)| (*v - t).abs() < 1e-9) {
            Some((_, joints)) => joints.push(j),
            None => groups.push((t, vec![j])),
        }
    }
    let every = groups.len() == 1;
    groups
        .into_iter()
        .map(|(value, joints)| {
            let who: String = if every {
                String::new()
            } else {
                joints
                    .iter()
                    .map(|j| subscript(j + 1).to_string())
                    .collect::<Vec<_>>()
                    .join(",")
            };
            Threshold {
                value,
                label: format!("θ{who} = ±{} Nm", fri_api::bounds::number(value)),
                color: (joints.len() == 1 && !every).then(|| joints[0]),
                curve: None,
            }
        })
        .collect()
}

/// Where each signal's monitor detected a contact (s since the run's start): the figure's
/// triangles.
struct Onsets<'a> {
    fri: &'a [f64],
    uncompensated: &'a [f64],
    compensated: &'a [f64],
}

fn plot_fig6(
    path: &Path,
    times: &[f64],
    thresholds: &[f64; 7],
    (fri, uncompensated, compensated): (&[V7], &[V7], &[V7]),
    scheduled: &[V7],
    onsets_of: &Onsets<'_>,
) -> anyhow::Result<()> {
    let markers = contact_markers();
    // Panel (c): each joint's calibrated threshold θ_j(t), dashed in the joint's colour, as its
    // largest value per 20 ms (the schedule follows the velocity noise sample by sample).
    let scheduled_lines: Vec<Threshold> = (0..7)
        .map(|j| {
            let points: Vec<(f64, f64)> = times
                .chunks(20)
                .zip(scheduled.chunks(20))
                .map(|(t, th)| (t[0], th.iter().map(|v| v[j]).fold(0.0, f64::max)))
                .collect();
            Threshold {
                value: points.last().map_or(0.0, |p| p.1),
                label: if j == 0 {
                    "θⱼ(t), max per 20 ms".to_owned()
                } else {
                    String::new()
                },
                color: Some(j),
                curve: Some(points),
            }
        })
        .collect();
    let panel = |title: &str, y_label: &str, sig: &[V7], detected: &[f64]| Panel {
        title: title.to_owned(),
        y_label: y_label.to_owned(),
        series: (0..7)
            .map(|j| Series {
                label: format!("joint {}", j + 1),
                points: decimate(times, sig.iter().map(|r| r[j])),
                color: j,
                width: 1,
            })
            .collect(),
        thresholds: threshold_lines(thresholds),
        markers: markers.clone(),
        marker_legend: Some(CONTACT_LEGEND.into()),
        detections: detected.to_vec(),
    };
    plots::draw(
        path,
        &[
            panel(
                "(a) Controller's external-torque estimate (FRI estExtJntTrq), payload not declared",
                "estExtJntTrq [Nm]",
                fri,
                onsets_of.fri,
            ),
            panel(
                "(b) Momentum-observer residual without payload compensation",
                "r [Nm]",
                uncompensated,
                onsets_of.uncompensated,
            ),
            Panel {
                thresholds: scheduled_lines,
                ..panel(
                    "(c) Residual, estimated payload compensated (eq. 48 and its inertia); calibrated θⱼ(t), 1 false alarm/10 h",
                    "r [Nm]",
                    compensated,
                    onsets_of.compensated,
                )
            },
        ],
    )
    .map(|_| ())
}

/// Renders the report for people.
pub fn summary(r: &DemoReport) -> Value {
    json!(r)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A moving arm logged at 1 ms with a 10 ms hole (a host stall in real time): the replay
    /// restarts there as the service does, its warm-up is NaN, and what it trusts stays at the
    /// model's residual (≈ 0 for torques from the same model) instead of a step.
    #[test]
    fn a_replay_restarts_after_a_gap_the_service_does_not_bridge() {
        let model = dynamics::lwr4();
        let mut data = Data::new(&model);
        let mut row = |t: f64| {
            let w = std::f64::consts::TAU * 0.5;
            let q = V7::from_fn(|j, _| 0.4 * (w * t).sin() + 0.3 * j as f64 - 0.6);
            let qd = V7::repeat(0.4 * w * (w * t).cos());
            let qdd = V7::repeat(-0.4 * w * w * (w * t).sin());
            let tau = dynamics::rnea(&model, &mut data, &q, &qd, &qdd);
            LogRow {
                time_s: t,
                q: q.into(),
                qd: qd.into(),
                tau: tau.into(),
                tau_ext: [0.0; 7],
            }
        };
        let rows: Vec<LogRow> = (0..3000)
            .filter(|k| !(1500..1510).contains(k))
            .map(|k| row(f64::from(k) * 1e-3))
            .collect();
        let replayed = residuals(
            &model,
            &Config::default(),
            &rows,
            PayloadCompensation::None,
            1e-3,
        )
        .unwrap();
        let after_gap = rows.iter().position(|r| r.time_s > 1.5).unwrap();
        assert!(replayed[after_gap].iter().all(|x| x.is_nan()));
        let trusted: Vec<&V7> = replayed.iter().filter(|r| r[0].is_finite()).collect();
        assert!(trusted.len() > 2000);
        let peak = trusted.iter().map(|r| r.amax()).fold(0.0, f64::max);
        assert!(peak < 0.5, "largest trusted residual {peak} Nm");
    }
}
