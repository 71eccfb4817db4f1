//! The service object shared by the operator handler and the workflows: configuration, the
//! channels to the loop, persistent state, and the workflows themselves (move, settle, sample,
//! pose pattern, tare, estimate).

use std::sync::mpsc::{SyncSender, TrySendError};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use dynamics::Model;
use nalgebra::{SVector, Vector3};
use safety::PayloadCompensation;
use serde_json::{Value, json};
use tokio::sync::broadcast::error::RecvError;
use tokio::time::Instant;

mod acquire;
mod move_to;
mod watch;

use super::events::{FriContext, StopReason};
use super::fanout::Shared;
use super::pattern::{PatternKind, poses as pattern_poses};
use super::rt::RtRequest;
use super::settle::AveragedSample;
use crate::config::Config;
use crate::ipc::{IpcSender, PayloadEstimate as IpcPayload, RobotState};
use crate::operator::server::EventSink;
use crate::persistence::{AppliedPayload, StateStore, StaticSample, Tare};
use fri_api::cause::Cause;
use fri_api::ipc::flags;
use fri_api::protocol::{ErrorCode, OperatorError};

/// Longest wait for the controller to enter command mode and start a move, s.
const MOVE_START_TIMEOUT_S: f64 = 10.0;
/// Moves re-driven after a loss of command mode before giving up.
const MOVE_RETRIES: u32 = 3;
/// Longest accepted move, s.
const MOVE_TIMEOUT_S: f64 = 120.0;
/// Largest distance of the measured position from the target after a move, rad.
const ARRIVAL_TOLERANCE: f64 = 0.005;
/// During workflows that may carry an unknown (uncompensated) payload, a contact is a change of
/// the residual since the previous static sample larger than this multiple of the threshold: the
/// payload's own gravity torque changes by a few Nm between neighbouring ±7° poses.
const WORKFLOW_THRESHOLD_FACTOR: f64 = 2.0;
/// Longest wait for the arm to reach the target after the set-point did, s (controller time).
const ARRIVAL_TIMEOUT_S: f64 = 2.0;

/// Where the service reads FRI statistics for `status` (the endpoint's snapshot).
pub type FriStateSource = Arc<dyn Fn() -> fri::state::RobotState + Send + Sync>;

/// Persistent, operator-visible state.
#[derive(Debug, Default)]
struct Persistent {
    payload: Option<AppliedPayload>,
    tare: Option<Tare>,
    armed: bool,
    thresholds: [f64; 7],
    gains: [f64; 7],
}

/// The service (see the module documentation).
pub struct ServiceCore {
    config: Config,
    model: Model<7>,
    shared: Arc<Shared>,
    rt: SyncSender<RtRequest>,
    store: StateStore,
    state: Mutex<Persistent>,
    workflow: tokio::sync::Mutex<()>,
    ipc: Option<IpcSender>,
    fri_state: Option<FriStateSource>,
}

impl std::fmt::Debug for ServiceCore {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ServiceCore").finish_non_exhaustive()
    }
}

fn err(code: ErrorCode, msg: impl Into<String>) -> OperatorError {
    OperatorError::new(code, msg)
}

/// Converts an applied payload into the observer's gravity compensation (paper eq. 48).
pub fn compensation(p: &AppliedPayload) -> PayloadCompensation {
    PayloadCompensation::gravity_from_com(p.mass, Vector3::from(p.com))
}

impl ServiceCore {
    /// Assembles the service; `payload`/`tare` are what was reloaded from the state directory.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        config: Config,
        model: Model<7>,
        shared: Arc<Shared>,
        rt: SyncSender<RtRequest>,
        store: StateStore,
        payload: Option<AppliedPayload>,
        tare: Option<Tare>,
        ipc: Option<IpcSender>,
        fri_state: Option<FriStateSource>,
    ) -> Self {
        let state = Persistent {
            payload,
            tare,
            armed: config.observer.armed,
            thresholds: config.observer.thresholds,
            gains: config.observer.gains,
        };
        Self {
            config,
            model,
            shared,
            rt,
            store,
            state: Mutex::new(state),
            workflow: tokio::sync::Mutex::new(()),
            ipc,
            fri_state,
        }
    }

    /// The configuration.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// The loop's shared output.
    pub fn shared(&self) -> &Arc<Shared> {
        &self.shared
    }

    fn persistent<R>(&self, f: impl FnOnce(&mut Persistent) -> R) -> R {
        match self.state.lock() {
            Ok(mut g) => f(&mut g),
            Err(p) => f(&mut p.into_inner()),
        }
    }

    /// Sends a request to the loop without blocking.
    pub fn send(&self, r: RtRequest) -> Result<(), OperatorError> {
        self.rt.try_send(r).map_err(|e| match e {
            TrySendError::Full(_) => err(ErrorCode::Busy, "the loop's request queue is full"),
            TrySendError::Disconnected(_) => err(ErrorCode::NotReady, "the FRI loop has stopped"),
        })
    }

    /// Longest silence of the controller that still counts as connected: 100 ms, or ten
    /// controller cycles when `friOpen` runs slower than 10 ms.
    pub fn connection_timeout(&self) -> Duration {
        Duration::from_secs_f64((10.0 * self.config.fri.cycle_s).max(0.1))
    }

    /// The newest state, if the controller is connected (a measurement within
    /// [`Self::connection_timeout`]).
    fn latest(&self) -> Result<RobotState, OperatorError> {
        match self.shared.latest_with_age() {
            Some((s, age)) if age <= self.connection_timeout() => Ok(s),
            Some((_, age)) => Err(self.silent_error(age.as_secs_f64())),
            None => Err(err(
                ErrorCode::NotReady,
                "no measurement from the controller yet (is the KRL program running and FRI open?)",
            )
            .with_cause(Cause::ControllerSilent {
                silent_s: f64::INFINITY,
                fri: None,
            })),
        }
    }

    /// The controller's view in its newest measurement (endpoint snapshot), if any.
    fn fri_context(&self) -> Option<FriContext> {
        let s = self.fri_state.as_ref().map(|f| f())?;
        s.valid.then(|| FriContext::of(&s.measurement))
    }

    /// The error for a controller silent for `silent_s` seconds.
    fn silent_error(&self, silent_s: f64) -> OperatorError {
        let fri = self.fri_context();
        let last = fri.map_or(String::new(), |f| {
            format!("; last measurement: {}", f.describe())
        });
        err(
            ErrorCode::NotReady,
            format!(
                "the controller is silent: no measurement for {silent_s:.3} s (connection timeout {:.3} s){last}",
                self.connection_timeout().as_secs_f64()
            ),
        )
        .with_cause(Cause::ControllerSilent { silent_s, fri })
    }

    /// The error for a stop by the loop.
    fn stop_error(reason: StopReason, fri: FriContext) -> OperatorError {
        let cause = match reason {
            StopReason::Operator => Cause::OperatorStop,
            StopReason::Collision {
                link,
                time_s,
                residual,
            } => Cause::Collision {
                link,
                time_s,
                residual,
            },
            StopReason::ObserverFault { fault } => Cause::ObserverFault {
                fault: fault.to_string(),
                fri,
            },
        };
        err(ErrorCode::Aborted, reason.describe()).with_cause(cause)
    }

    /// The error for a stopped state seen before (or without) its event.
    fn stopped_error(&self) -> OperatorError {
        match self.shared.last_stop() {
            Some((reason, fri)) => Self::stop_error(reason, fri),
            None => err(ErrorCode::Aborted, "the arm is held").with_cause(Cause::Held),
        }
    }

    /// `status`.
    pub fn status(&self) -> Value {
        // One read: `connected` and the values shown must describe the same state.
        let newest = self.shared.latest_with_age();
        let connected = newest.is_some_and(|(_, age)| age <= self.connection_timeout());
        let latest = newest.map(|(s, _)| s);
        let (payload, armed, thresholds, gains, tare) = self.persistent(|p| {
            (
                p.payload,
                p.armed,
                p.thresholds,
                p.gains,
                p.tare.as_ref().map(|t| t.samples.len()),
            )
        });
        let fri = self.fri_state.as_ref().map(|f| {
            let s = f();
            json!({
                "valid": s.valid,
                "state": format!("{:?}", s.measurement.interface.state),
                "quality": format!("{:?}", s.measurement.interface.quality),
                "krl_status": format!("{:?}", s.handshake.status),
                "drop_reason": format!("{:?}", s.handshake.drop_reason),
                "cycles": s.cycle,
                "statistics": serde_json::to_value(s.statistics).unwrap_or(Value::Null),
                "controller_statistics": serde_json::to_value(s.measurement.interface.statistics).unwrap_or(Value::Null),
            })
        });
        json!({
            "connected": connected,
            "residual_valid": latest.is_some_and(|s| s.flags & flags::RESIDUAL_INVALID == 0),
            "fri": fri,
            "cycle": latest.map(|s| s.cycle),
            "time_s": latest.map(|s| s.time_s),
            "q": latest.map(|s| s.q),
            "qd": latest.map(|s| s.qd),
            "tau": latest.map(|s| s.tau),
            "gravity": latest.map(|s| s.gravity),
            "tau_ext": latest.map(|s| s.tau_ext),
            "residual": latest.map(|s| s.residual),
            "command_mode": latest.is_some_and(|s| s.flags & flags::COMMAND_MODE != 0),
            "stopped": latest.is_some_and(|s| s.flags & flags::STOPPED != 0),
            "collision": latest.is_some_and(|s| s.flags & flags::COLLISION != 0),
            "observer_fault": latest.is_some_and(|s| s.flags & flags::OBSERVER_FAULT != 0),
            "moving": latest.is_some_and(|s| s.flags & flags::MOVING != 0),
            "payload": payload.map(|p| json!({"mass": p.mass, "com": p.com, "frame": "7"})),
            "tare_samples": tare,
            "monitor": {"armed": armed, "thresholds": thresholds, "gains": gains},
        })
    }

    /// `apply-payload`: to the observer and persisted.
    pub fn apply_payload(&self, p: Option<AppliedPayload>) -> Result<Value, OperatorError> {
        if let Some(p) = &p {
            let ok = p.mass.is_finite()
                && p.mass >= 0.0
                && p.mass <= 20.0
                && p.com.iter().all(|c| c.is_finite() && c.abs() <= 1.0);
            if !ok {
                return Err(err(
                    ErrorCode::InvalidArguments,
                    "mass must be in [0, 20] kg and each com coordinate in [-1, 1] m",
                ));
            }
        }
        self.send(RtRequest::SetPayload(p.as_ref().map(compensation)))?;
        self.store.save_payload(p.as_ref()).map_err(|e| {
            err(
                ErrorCode::Internal,
                format!("payload applied but not persisted: {e}"),
            )
        })?;
        self.persistent(|s| s.payload = p);
        if let Some(ipc) = &self.ipc {
            let latest = self.shared.latest();
            ipc.payload(&IpcPayload {
                time_s: latest.map_or(0.0, |s| s.time_s),
                mass: p.map_or(0.0, |p| p.mass),
                com: p.map_or([0.0; 3], |p| p.com),
                applied: u32::from(p.is_some()),
                ..IpcPayload::default()
            });
        }
        Ok(json!({"payload": p.map(|p| json!({"mass": p.mass, "com": p.com, "frame": "7"}))}))
    }

    /// `collision` arm/disarm/configure/show.
    pub fn collision(
        &self,
        action: fri_api::protocol::CollisionAction,
        thresholds: Option<[f64; 7]>,
        gains: Option<[f64; 7]>,
    ) -> Result<Value, OperatorError> {
        use fri_api::protocol::CollisionAction as A;
        match action {
            A::Show => {}
            A::Arm | A::Disarm => {
                let on = action == A::Arm;
                self.send(RtRequest::Arm(on))?;
                self.persistent(|s| s.armed = on);
            }
            A::Configure => {
                if thresholds.is_none() && gains.is_none() {
                    return Err(err(
                        ErrorCode::InvalidArguments,
                        "configure needs `thresholds` and/or `gains`",
                    ));
                }
                let (mut t, mut g) = self.persistent(|s| (s.thresholds, s.gains));
                if let Some(x) = thresholds {
                    t = x;
                }
                if let Some(x) = gains {
                    g = x;
                }
                // Named like the arguments; the gain bound follows the configured cycle.
                let gain = fri_api::bounds::gain(self.config.fri.cycle_s);
                for j in 0..7 {
                    fri_api::bounds::threshold(j)
                        .check(&format!("thresholds[{j}]"), t[j])
                        .and_then(|()| gain.check(&format!("gains[{j}]"), g[j]))
                        .map_err(|e| err(ErrorCode::InvalidArguments, e))?;
                }
                let mut config = self.config.clone();
                config.observer.thresholds = t;
                config.observer.gains = g;
                config
                    .validate()
                    .map_err(|e| err(ErrorCode::InvalidArguments, e.to_string()))?;
                let monitor = super::build_monitor(&config, self.model.clone())
                    .map_err(|e| err(ErrorCode::InvalidArguments, e.to_string()))?;
                self.send(RtRequest::ReplaceMonitor(Box::new(monitor)))?;
                self.persistent(|s| {
                    s.thresholds = t;
                    s.gains = g;
                });
            }
        }
        let (armed, t, g) = self.persistent(|s| (s.armed, s.thresholds, s.gains));
        Ok(json!({"armed": armed, "thresholds": t, "gains": g}))
    }

    /// Drives the pattern, one averaged sample per pose, then returns to the start pose.
    async fn run_pattern(
        &self,
        around: Option<[f64; 7]>,
        poses: Option<usize>,
        step_deg: Option<f64>,
        kind: PatternKind,
        phase: &str,
        events: &EventSink,
    ) -> Result<(Vec<AveragedSample>, [f64; 7]), OperatorError> {
        let latest = self.latest()?;
        let start_q = latest.q;
        let around = around.unwrap_or(start_q);
        let count = poses.unwrap_or(self.config.estimation.pattern_poses);
        let step = step_deg.unwrap_or(self.config.estimation.pattern_step_deg);
        // The centre must keep the pattern inside the joint limits with a margin and lie near
        // the measured pose (the protocol layer only knows the limits, not the pose).
        let max_distance = self.config.motion.max_around_distance_rad;
        fri_api::bounds::POSES
            .check_count("poses", count as u64)
            .and_then(|()| fri_api::bounds::STEP_DEG.check("step_deg", step))
            .and_then(|()| fri_api::bounds::check_around(&around, &start_q, step, max_distance))
            .map_err(|e| err(ErrorCode::InvalidArguments, e))?;
        let pattern = pattern_poses(kind, &self.model, &around, count, step).map_err(|e| {
            err(
                ErrorCode::InvalidArguments,
                format!("pose design failed: {e}"),
            )
        })?;
        let mut baseline = Some(latest.residual);
        let mut samples = Vec::with_capacity(count);
        for (k, pose) in pattern.iter().enumerate() {
            let progress = |p: &str| json!({"phase": p, "step": k + 1, "of": count, "workflow": phase, "pose": pose});
            events.send("progress", progress("moving")).await;
            let r = self.move_to(*pose, baseline).await;
            if let Err(e) = r {
                self.release().await;
                return Err(e);
            }
            events.send("progress", progress("settling")).await;
            let acquired = self
                .acquire(true, self.config.estimation.average_s, baseline)
                .await;
            let (sample, settle_s) = match acquired {
                Ok(x) => {
                    baseline = self.shared.latest().map(|s| s.residual).or(baseline);
                    x
                }
                Err(e) => {
                    self.release().await;
                    return Err(e);
                }
            };
            let mut done = progress("sampled");
            done["settle_s"] = json!(settle_s);
            done["max_speed"] = json!(sample.max_speed);
            events.send("progress", done).await;
            samples.push(sample);
        }
        events
            .send(
                "progress",
                json!({"phase": "returning", "workflow": phase, "step": count, "of": count}),
            )
            .await;
        let back = self.move_to(start_q, baseline).await;
        self.release().await;
        back?;
        Ok((samples, around))
    }

    /// Leaves command mode (best effort).
    async fn release(&self) {
        let _ = self.send(RtRequest::ReleaseCommandMode);
    }

    fn busy(&self) -> Result<tokio::sync::MutexGuard<'_, ()>, OperatorError> {
        self.workflow
            .try_lock()
            .map_err(|_| err(ErrorCode::Busy, "another workflow is running"))
    }

    /// `sample`: one averaged static sample at the current pose.
    pub async fn sample(&self, duration_s: Option<f64>) -> Result<Value, OperatorError> {
        let _guard = self.busy()?;
        let d = duration_s.unwrap_or(self.config.estimation.average_s);
        if !(d.is_finite() && d > 0.0 && d <= 60.0) {
            return Err(err(
                ErrorCode::InvalidArguments,
                "duration_s must be in (0, 60]",
            ));
        }
        let (s, settle_s) = self.acquire(true, d, None).await?;
        Ok(sample_json(&s, settle_s))
    }

    /// `tare`: the pattern without payload, stored and persisted.
    pub async fn tare(
        &self,
        around: Option<[f64; 7]>,
        poses: Option<usize>,
        step_deg: Option<f64>,
        kind: PatternKind,
        events: &EventSink,
    ) -> Result<Value, OperatorError> {
        let _guard = self.busy()?;
        let (samples, around) = self
            .run_pattern(around, poses, step_deg, kind, "tare", events)
            .await?;
        let tare = Tare {
            around,
            samples: samples.iter().map(|s| s.sample).collect(),
        };
        self.store
            .save_tare(Some(&tare))
            .map_err(|e| err(ErrorCode::Internal, format!("tare not persisted: {e}")))?;
        let n = tare.samples.len();
        self.persistent(|s| s.tare = Some(tare));
        Ok(json!({"samples": n, "around": around}))
    }

    /// `estimate-payload`.
    #[allow(clippy::too_many_arguments)]
    pub async fn estimate_payload(
        &self,
        around: Option<[f64; 7]>,
        poses: Option<usize>,
        step_deg: Option<f64>,
        kind: PatternKind,
        use_tare: Option<bool>,
        apply: bool,
        events: &EventSink,
    ) -> Result<Value, OperatorError> {
        let _guard = self.busy()?;
        let tare = self.persistent(|s| s.tare.clone());
        let (samples, around) = self
            .run_pattern(around, poses, step_deg, kind, "estimate", events)
            .await?;
        events
            .send(
                "progress",
                json!({"phase": "estimating", "workflow": "estimate"}),
            )
            .await;
        let loaded: Vec<StaticSample> = samples.iter().map(|s| s.sample).collect();
        let tare_matches = tare.as_ref().is_some_and(|t| {
            t.samples.len() == loaded.len()
                && t.samples
                    .iter()
                    .zip(&loaded)
                    .all(|(a, b)| (0..7).all(|j| (a.q[j] - b.q[j]).abs() < 0.01))
        });
        let use_tare = match use_tare {
            Some(true) if !tare_matches => {
                return Err(err(
                    ErrorCode::Failed,
                    "no stored tare for these poses: run `tare` with the same pattern first",
                ));
            }
            Some(u) => u,
            None => tare_matches,
        };
        let estimate = estimate(
            &self.model,
            &loaded,
            if use_tare { tare.as_ref() } else { None },
        )?;
        let mut result = serde_json::to_value(&estimate).unwrap_or(Value::Null);
        result["tare_used"] = json!(use_tare);
        if use_tare {
            // The tare was applied here (Δτ = τ_loaded − τ_unloaded), not inside the estimator.
            result["correction"] = json!("tare");
        }
        result["frame"] = json!("7");
        result["around"] = json!(around);
        result["applied"] = json!(apply);
        if let Some(ipc) = &self.ipc {
            ipc.payload(&IpcPayload {
                time_s: self.shared.latest().map_or(0.0, |s| s.time_s),
                mass: estimate.mass,
                com: estimate.com,
                mass_std: estimate.mass_std,
                com_std: estimate.com_std,
                samples: estimate.samples as u32,
                applied: 0,
            });
        }
        if apply {
            self.apply_payload(Some(AppliedPayload {
                mass: estimate.mass,
                com: estimate.com,
            }))?;
        }
        Ok(result)
    }

    /// `stop`.
    ///
    /// The stop is latched in the loop at once. When the controller is silent nothing is being
    /// commanded (the controller stops the arm itself when our answers are missing) and the
    /// reply says so: the latched stop holds the arm when the controller returns.
    pub fn stop(&self) -> Result<Value, OperatorError> {
        self.send(RtRequest::Stop)?;
        Ok(match self.latest() {
            Ok(_) => json!({"stopped": true, "controller": "connected"}),
            Err(e) => json!({
                "stopped": true,
                "controller": "silent",
                "note": format!("{}; nothing is commanded while the controller is silent, and the stop holds the arm when it returns", e.message),
            }),
        })
    }

    /// `resume`.
    pub fn resume(&self) -> Result<Value, OperatorError> {
        self.send(RtRequest::Resume)?;
        Ok(json!({"stopped": false}))
    }

    /// `record`: static samples or a per-cycle log, as CSV in a new file `path` of the
    /// recording directory (`state.record_dir`, see [`crate::recordings`]).
    pub async fn record(
        &self,
        path: &str,
        kind: fri_api::protocol::RecordKind,
        duration_s: Option<f64>,
        count: Option<usize>,
        events: &EventSink,
    ) -> Result<Value, OperatorError> {
        use crate::recordings::{RecordDir, RecordError};
        use fri_api::protocol::RecordKind;
        let refuse = |e: RecordError| {
            let code = if e.is_request_error() {
                ErrorCode::InvalidArguments
            } else {
                ErrorCode::Failed
            };
            err(code, e.to_string())
        };
        let dir = RecordDir::open(&self.config.state.record_dir()).map_err(refuse)?;
        let full = dir.check_free(path).map_err(refuse)?;
        let shown = full.to_string_lossy().into_owned();
        let io = |e: std::io::Error| err(ErrorCode::Failed, format!("cannot write {shown}: {e}"));
        match kind {
            RecordKind::Samples => {
                let n = count.unwrap_or(1);
                if !(1..=1000).contains(&n) {
                    return Err(err(ErrorCode::InvalidArguments, "count must be 1..1000"));
                }
                let _guard = self.busy()?;
                let mut rows = Vec::with_capacity(n);
                for k in 0..n {
                    let (s, _) = self
                        .acquire(true, self.config.estimation.average_s, None)
                        .await?;
                    rows.push(s.sample);
                    events
                        .send(
                            "progress",
                            json!({"phase": "sampled", "step": k + 1, "of": n}),
                        )
                        .await;
                }
                let mut text = Vec::new();
                estimator::samples::write_csv(&mut text, &rows)
                    .map_err(|e| err(ErrorCode::Failed, e.to_string()))?;
                // Created only now, exclusively: the name may have been taken while sampling.
                let (mut file, _) = dir.create(path).map_err(refuse)?;
                use std::io::Write;
                file.write_all(&text).map_err(io)?;
                Ok(json!({"rows": rows.len(), "path": shown}))
            }
            RecordKind::Log => {
                let d = duration_s.unwrap_or(1.0);
                if !(d.is_finite() && d > 0.0 && d <= 3600.0) {
                    return Err(err(
                        ErrorCode::InvalidArguments,
                        "duration_s must be in (0, 3600]",
                    ));
                }
                let mut states = self.shared.subscribe_states();
                let (file, _) = dir.create(path).map_err(refuse)?;
                let mut w = std::io::BufWriter::new(file);
                use std::io::Write;
                let mut header = String::from("cycle,time_s,flags");
                for name in ["q", "qd", "tau", "g", "tau_ext", "r"] {
                    for j in 1..=7 {
                        header.push_str(&format!(",{name}{j}"));
                    }
                }
                writeln!(w, "{header}").map_err(io)?;
                let mut t0 = None;
                let mut rows = 0usize;
                let mut lost = 0u64;
                let wall = Instant::now() + Duration::from_secs_f64(d * 2.0 + 10.0);
                loop {
                    let s = tokio::select! {
                        s = states.recv() => s,
                        _ = tokio::time::sleep_until(wall) => break,
                    };
                    let s = match s {
                        Ok(s) => s,
                        Err(RecvError::Lagged(n)) => {
                            lost += n;
                            continue;
                        }
                        Err(RecvError::Closed) => break,
                    };
                    let start = *t0.get_or_insert(s.time_s);
                    if s.time_s - start > d {
                        break;
                    }
                    let mut line = format!("{},{:.6},{}", s.cycle, s.time_s, s.flags);
                    for a in [&s.q, &s.qd, &s.tau, &s.gravity, &s.tau_ext, &s.residual] {
                        for v in a {
                            line.push_str(&format!(",{v}"));
                        }
                    }
                    writeln!(w, "{line}").map_err(io)?;
                    rows += 1;
                }
                w.flush().map_err(io)?;
                Ok(json!({"rows": rows, "path": shown, "lost": lost}))
            }
        }
    }
}

/// Runs the estimator on the loaded samples, with the tare subtracted sample by sample when
/// given (Δτ = τ_loaded − τ_unloaded, eq. 25 in data space).
pub fn estimate(
    model: &Model<7>,
    loaded: &[StaticSample],
    tare: Option<&Tare>,
) -> Result<estimator::estimate::PayloadEstimate, OperatorError> {
    let to_est =
        |s: &StaticSample, reference: &SVector<f64, 7>| StaticSample::new(s.q, s.tau, *reference);
    let samples: Vec<_> = match tare {
        Some(t) => loaded
            .iter()
            .zip(&t.samples)
            .map(|(l, u)| to_est(l, &u.tau))
            .collect(),
        None => loaded.iter().map(|l| to_est(l, &l.gravity)).collect(),
    };
    let options = estimator::estimate::EstimateOptions {
        // Averaged samples: the velocity check is done by the settle detector.
        static_check: estimator::samples::StaticCheck {
            max_velocity: f64::INFINITY,
            max_drift: f64::INFINITY,
        },
        ..Default::default()
    };
    estimator::estimate::estimate_direct(model, &samples, &options)
        .map_err(|e| err(ErrorCode::Failed, format!("estimation failed: {e}")))
}

fn sample_json(s: &AveragedSample, settle_s: f64) -> Value {
    json!({
        "q": s.sample.q, "tau": s.sample.tau, "gravity": s.sample.gravity,
        "velocity_max": s.max_speed, "torque_std": s.torque_std, "drift": s.drift,
        "cycles": s.cycles, "settle_s": settle_s,
    })
}

/// Waits (at most 0.2 s) until a published state shows the arm stopped.
///
/// Events and state snapshots reach the workflows on separate channels, so a collision event can
/// overtake the snapshot of its own cycle; an operator who receives "aborted" must then already
/// read `stopped` in `status`.
async fn await_stopped_state(states: &mut tokio::sync::broadcast::Receiver<RobotState>) {
    let deadline = Instant::now() + Duration::from_millis(200);
    loop {
        tokio::select! {
            s = states.recv() => match s {
                Ok(s) if s.flags & flags::STOPPED != 0 => return,
                Ok(_) | Err(RecvError::Lagged(_)) => {}
                Err(RecvError::Closed) => return,
            },
            _ = tokio::time::sleep_until(deadline) => return,
        }
    }
}
