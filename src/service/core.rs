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

use super::fanout::Shared;
use super::pattern::{PatternKind, poses as pattern_poses};
use super::rt::{RtEvent, RtRequest};
use super::settle::{AveragedSample, Averager, SettleDetector};
use crate::config::Config;
use crate::ipc::messages::flags;
use crate::ipc::{IpcSender, PayloadEstimate as IpcPayload, RobotState};
use crate::operator::protocol::{ErrorCode, OperatorError};
use crate::operator::server::EventSink;
use crate::persistence::{AppliedPayload, StateStore, StaticSample, Tare};

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

    fn latest(&self) -> Result<RobotState, OperatorError> {
        self.shared.latest().ok_or_else(|| {
            err(
                ErrorCode::NotReady,
                "no measurement from the controller yet (is the KRL program running and FRI open?)",
            )
        })
    }

    /// The controller's view (KRL status, last drop reason, quality) for error messages.
    fn fri_diagnosis(&self) -> String {
        match &self.fri_state {
            Some(f) => {
                let s = f();
                format!(
                    "; controller: state {:?}, quality {:?}, KRL {:?}, last drop {:?}",
                    s.measurement.interface.state,
                    s.measurement.interface.quality,
                    s.handshake.status,
                    s.handshake.drop_reason
                )
            }
            None => String::new(),
        }
    }

    /// `status`.
    pub fn status(&self) -> Value {
        let latest = self.shared.latest();
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
            "connected": latest.is_some(),
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
        action: crate::operator::protocol::CollisionAction,
        thresholds: Option<[f64; 7]>,
        gains: Option<[f64; 7]>,
    ) -> Result<Value, OperatorError> {
        use crate::operator::protocol::CollisionAction as A;
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
                let gain = crate::bounds::gain(self.config.fri.cycle_s);
                for j in 0..7 {
                    crate::bounds::threshold(j)
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

    /// Moves to `target` in command mode and waits for the arrival; aborts on a collision,
    /// a stop, or loss of command mode.
    /// With `baseline`, a residual change beyond the workflow threshold aborts the move.
    pub async fn move_to(
        &self,
        target: [f64; 7],
        baseline: Option<[f64; 7]>,
    ) -> Result<(), OperatorError> {
        let thresholds = self.persistent(|s| s.thresholds);
        let latest = self.latest()?;
        if latest.flags & flags::STOPPED != 0 {
            return Err(err(
                ErrorCode::NotReady,
                "the arm is stopped (operator stop or collision reaction); `resume` first",
            ));
        }
        let limits = self.model.limits();
        for (j, t) in target.iter().enumerate() {
            let inside = (limits.position_min[j]..=limits.position_max[j]).contains(t);
            if !inside {
                return Err(err(
                    ErrorCode::InvalidArguments,
                    format!("target of joint {} outside its limits", j + 1),
                ));
            }
        }
        let mut states = self.shared.subscribe_states();
        let mut events = self.shared.subscribe_events();
        self.send(RtRequest::MoveTo(target))?;
        let mut start = Instant::now();
        let mut seen_moving = false;
        let mut ended_at = None;
        let mut retries = 0;
        loop {
            let timeout = if seen_moving {
                MOVE_TIMEOUT_S
            } else {
                MOVE_START_TIMEOUT_S
            };
            let deadline = start + Duration::from_secs_f64(timeout);
            tokio::select! {
                s = states.recv() => match s {
                    Ok(s) => {
                        if s.flags & flags::STOPPED != 0 {
                            return Err(err(ErrorCode::Aborted, "stopped during the move"));
                        }
                        if let Some(b) = baseline
                            && let Some(j) = (0..7).find(|&j| (s.residual[j] - b[j]).abs() > WORKFLOW_THRESHOLD_FACTOR * thresholds[j])
                        {
                            let _ = self.send(RtRequest::Stop);
                            return Err(err(ErrorCode::Aborted, format!("residual of joint {} changed by more than twice its threshold during the move: contact? (arm stopped; `resume` to continue)", j + 1)));
                        }
                        if s.flags & flags::MOVING != 0 {
                            seen_moving = true;
                        } else if seen_moving {
                            // The set-point is at the target; wait for the arm to follow.
                            let off = (0..7).map(|j| (s.q[j] - target[j]).abs()).fold(0.0, f64::max);
                            let ended = *ended_at.get_or_insert(s.time_s);
                            if off <= ARRIVAL_TOLERANCE {
                                return Ok(());
                            }
                            if s.time_s - ended > ARRIVAL_TIMEOUT_S {
                                return Err(err(ErrorCode::Failed, format!("the arm stayed {off:.4} rad from the target")));
                            }
                        }
                    }
                    Err(RecvError::Lagged(_)) => {}
                    Err(RecvError::Closed) => return Err(err(ErrorCode::NotReady, "the FRI loop has stopped")),
                },
                e = events.recv() => match e {
                    Ok(RtEvent::Collision(c)) => {
                        await_stopped_state(&mut states).await;
                        return Err(err(ErrorCode::Aborted, format!("collision detected (link {}) at {:.3} s", c.link, c.time_s)));
                    }
                    Ok(RtEvent::Stopped { collision, .. }) => {
                        await_stopped_state(&mut states).await;
                        return Err(err(ErrorCode::Aborted, if collision { "stopped by the collision reaction" } else { "stopped by the operator" }));
                    }
                    Ok(RtEvent::MoveAborted { .. }) => {
                        let stopped = self.shared.latest().is_some_and(|s| s.flags & flags::STOPPED != 0);
                        if stopped || retries >= MOVE_RETRIES {
                            return Err(err(ErrorCode::Aborted, format!("move aborted (command mode lost or stop){}", self.fri_diagnosis())));
                        }
                        // Command mode was lost (e.g. a burst of missed answers): the loop
                        // re-requests it; drive the move again from where the arm is.
                        retries += 1;
                        tracing::warn!(retries, diagnosis = %self.fri_diagnosis(), "command mode lost during a move; retrying");
                        self.send(RtRequest::MoveTo(target))?;
                        seen_moving = false;
                        ended_at = None;
                        start = Instant::now();
                    }
                    _ => {}
                },
                _ = tokio::time::sleep_until(deadline) => {
                    return Err(err(ErrorCode::NotReady, if seen_moving {
                        "the move did not finish in time".to_owned()
                    } else {
                        "command mode was not entered (check the KRL program, quality and drives)".to_owned()
                    }));
                }
            }
        }
    }

    /// Waits for settling (bounded by `estimation.settle_timeout_s`) and averages one window.
    /// `baseline` is the residual at the workflow's start: a change larger than the thresholds
    /// aborts (contact during a workflow that may carry an uncompensated payload).
    pub async fn acquire(
        &self,
        settle: bool,
        duration_s: f64,
        baseline: Option<[f64; 7]>,
    ) -> Result<(AveragedSample, f64), OperatorError> {
        let e = &self.config.estimation;
        let cycle_s = self.config.fri.cycle_s;
        let window = (e.settle_window_s / cycle_s).round() as usize;
        let average_cycles = ((duration_s / cycle_s).round() as usize).max(1);
        let mut detector = SettleDetector::new(window, e.settle_velocity, e.settle_torque_std);
        let mut states = self.shared.subscribe_states();
        let mut events = self.shared.subscribe_events();
        let thresholds = self.persistent(|s| s.thresholds);
        let started = Instant::now();
        let mut settle_time = 0.0;
        let mut settling = settle;
        let mut settle_start_t = None;
        let mut avg = Averager::default();
        let wall_limit = Duration::from_secs_f64(e.settle_timeout_s + duration_s + 10.0);
        loop {
            tokio::select! {
                s = states.recv() => match s {
                    Ok(s) => {
                        if s.flags & flags::STOPPED != 0 {
                            return Err(err(ErrorCode::Aborted, "stopped while sampling"));
                        }
                        if let Some(b) = baseline
                            && let Some(j) = (0..7).find(|&j| (s.residual[j] - b[j]).abs() > WORKFLOW_THRESHOLD_FACTOR * thresholds[j])
                        {
                            return Err(err(ErrorCode::Aborted, format!("residual of joint {} changed by more than its threshold: contact?", j + 1)));
                        }
                        if settling {
                            let t0 = *settle_start_t.get_or_insert(s.time_s);
                            settle_time = s.time_s - t0;
                            if detector.push(&s) || settle_time >= e.settle_timeout_s {
                                settling = false;
                            }
                            continue;
                        }
                        avg.push(&s);
                        if avg.len() >= average_cycles {
                            let Some(sample) = avg.finish() else { continue };
                            return Ok((sample, settle_time));
                        }
                    }
                    Err(RecvError::Lagged(n)) => {
                        // The sample must be contiguous: start over.
                        tracing::warn!(lost = n, "sampling fell behind; restarting the window");
                        avg = Averager::default();
                    }
                    Err(RecvError::Closed) => return Err(err(ErrorCode::NotReady, "the FRI loop has stopped")),
                },
                ev = events.recv() => {
                    if let Ok(RtEvent::Stopped { .. }) = ev {
                        await_stopped_state(&mut states).await;
                        return Err(err(ErrorCode::Aborted, "stopped while sampling"));
                    }
                },
                _ = tokio::time::sleep_until(started + wall_limit) => {
                    return Err(err(ErrorCode::NotReady, "no measurements while sampling"));
                }
            }
        }
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
        crate::bounds::POSES
            .check_count("poses", count as u64)
            .and_then(|()| crate::bounds::STEP_DEG.check("step_deg", step))
            .and_then(|()| crate::bounds::check_around(&around, &start_q, step, max_distance))
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
            samples: samples.iter().map(|s| s.sample.clone()).collect(),
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
        let loaded: Vec<StaticSample> = samples.iter().map(|s| s.sample.clone()).collect();
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
    pub fn stop(&self) -> Result<Value, OperatorError> {
        self.send(RtRequest::Stop)?;
        Ok(json!({"stopped": true}))
    }

    /// `resume`.
    pub fn resume(&self) -> Result<Value, OperatorError> {
        self.send(RtRequest::Resume)?;
        Ok(json!({"stopped": false}))
    }

    /// `record`: static samples or a per-cycle log, as CSV at `path`.
    pub async fn record(
        &self,
        path: &str,
        kind: crate::operator::protocol::RecordKind,
        duration_s: Option<f64>,
        count: Option<usize>,
        events: &EventSink,
    ) -> Result<Value, OperatorError> {
        use crate::operator::protocol::RecordKind;
        let io = |e: std::io::Error| err(ErrorCode::Failed, format!("cannot write {path}: {e}"));
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
                let mut text = String::new();
                text.push_str(&static_csv_header());
                for r in &rows {
                    text.push_str(&static_csv_row(r));
                }
                std::fs::write(path, text).map_err(io)?;
                Ok(json!({"rows": rows.len(), "path": path}))
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
                let file = std::fs::File::create(path).map_err(io)?;
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
                Ok(json!({"rows": rows, "path": path, "lost": lost}))
            }
        }
    }

    /// `watch`: streams events (and optionally states) until the client goes away.
    pub async fn watch(
        &self,
        state_every: Option<u32>,
        sink: &EventSink,
    ) -> Result<Value, OperatorError> {
        let mut events = self.shared.subscribe_events();
        let mut states = self.shared.subscribe_states();
        let every = state_every.map(|e| u64::from(e.max(1)));
        loop {
            let keep = tokio::select! {
                e = events.recv() => match e {
                    Ok(RtEvent::Collision(c)) => sink.send("collision", json!({
                        "time_s": c.time_s, "cycle": c.cycle, "link": c.link,
                        "joints": (0..7).filter(|j| c.joints_mask & (1 << j) != 0).map(|j| j + 1).collect::<Vec<_>>(),
                        "residual": c.residual,
                    })).await,
                    Ok(RtEvent::Stopped { cycle, collision }) => sink.send("stopped", json!({"cycle": cycle, "reason": if collision { "collision" } else { "operator" }})).await,
                    Ok(RtEvent::Resumed { cycle }) => sink.send("resumed", json!({"cycle": cycle})).await,
                    Ok(RtEvent::MoveAborted { cycle }) => sink.send("move-aborted", json!({"cycle": cycle})).await,
                    Ok(RtEvent::State(_)) | Err(RecvError::Lagged(_)) => true,
                    Err(RecvError::Closed) => false,
                },
                s = states.recv(), if every.is_some() => match s {
                    Ok(s) if every.is_some_and(|e| s.cycle % e == 0) => sink.send("state", json!({
                        "cycle": s.cycle, "time_s": s.time_s, "q": s.q, "tau": s.tau, "residual": s.residual, "flags": s.flags,
                    })).await,
                    Ok(_) | Err(RecvError::Lagged(_)) => true,
                    Err(RecvError::Closed) => false,
                },
                // Notice a vanished client even when nothing happens.
                _ = tokio::time::sleep(Duration::from_millis(200)) => !sink.is_closed(),
            };
            if !keep {
                return Ok(json!({"watch": "ended"}));
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
    let to_est = |s: &StaticSample, reference: &[f64; 7]| {
        estimator::samples::StaticSample::new(
            SVector::from(s.q),
            SVector::from(s.tau),
            SVector::from(*reference),
        )
    };
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

/// Header of the static-sample CSV (`q1..q7,tau1..tau7,g1..g7`).
pub fn static_csv_header() -> String {
    let mut h = Vec::new();
    for name in ["q", "tau", "g"] {
        for j in 1..=7 {
            h.push(format!("{name}{j}"));
        }
    }
    h.join(",") + "\n"
}

/// One row of the static-sample CSV.
pub fn static_csv_row(s: &StaticSample) -> String {
    let v: Vec<String> =
        s.q.iter()
            .chain(&s.tau)
            .chain(&s.gravity)
            .map(|x| format!("{x}"))
            .collect();
    v.join(",") + "\n"
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
