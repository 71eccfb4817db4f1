//! One commanded move of a workflow: ask the loop, follow the published states and events, and
//! end with arrival or with the true cause (stop, collision, command mode lost, controller
//! restarted or silent).

use std::time::Duration;

use tokio::sync::broadcast::error::RecvError;
use tokio::time::Instant;

use crate::service::core::{
    ARRIVAL_TIMEOUT_S, ARRIVAL_TOLERANCE, FriStateSource, Heard, MOVE_RETRIES,
    MOVE_START_TIMEOUT_S, MOVE_TIMEOUT_S, ServiceCore, WORKFLOW_THRESHOLD_FACTOR, endpoint_heard,
    err,
};
use crate::service::cycle::CycleRequest;
use crate::service::output::{AbortReason, CycleEvent};
use crate::service::state::{LoopState, Snapshot};
use crate::service::stream::Update;
use fri_api::cause::Cause;
use fri_api::protocol::{ErrorCode, OperatorError};

/// What one published state means for a residual check against `baseline`: the joint whose
/// residual changed by more than `factor` × its threshold, with the change. States whose
/// residual is invalid (monitor warming up) say nothing, and neither do states of an armed
/// monitor.
///
/// Why only disarmed: the check was the workflows' own contact guard while grasping and
/// estimating needed a disarm. Armed, the monitor itself watches every cycle, at 1 × θ against
/// the applied payload or, while the payload is declared unknown, against what a plausible
/// flange load explains with a derived allowance for its inertia (`expect-payload`); this check
/// is coarser (2 × θ against the residual of the previous static sample) and blind to the
/// payload's inertia, which tripped it on the e2e tests' fast moves (12.5 Nm on joint 2 against
/// 12). It stays for an operator who disarms on purpose: the service's own moves are then still
/// stopped by a change no payload of the pattern makes.
pub(super) fn residual_change(
    snapshot: &Snapshot,
    baseline: &[f64; 7],
    thresholds: &[f64; 7],
) -> Option<Cause> {
    if !snapshot.residual_valid() || snapshot.monitor_armed() {
        return None;
    }
    (0..7).find_map(|j| {
        let change = snapshot.robot.residual[j] - baseline[j];
        let limit = WORKFLOW_THRESHOLD_FACTOR * thresholds[j];
        (change.abs() > limit).then_some(Cause::ResidualChange {
            joint: j + 1,
            change_nm: change,
            limit_nm: limit,
        })
    })
}

/// A timer for "the controller is silent": it fires only when the endpoint thread itself went
/// a whole connection timeout without an accepted measurement. A stall of this side (SIGSTOP,
/// a host that starves the stream thread or the tokio workers) delays the state, but the
/// controller was heard meanwhile: the timer starts over instead of blaming the controller.
pub(super) struct SilenceTimer {
    timeout: Duration,
    heard: Option<FriStateSource>,
}

impl SilenceTimer {
    /// A timer for the connection timeout of `core`.
    pub(super) fn new(core: &ServiceCore) -> Self {
        Self {
            timeout: core.connection_timeout(),
            heard: core.fri_state.clone(),
        }
    }

    /// Waits until no state arrived for a timeout and the controller was silent all along;
    /// returns the silence, s.
    pub(super) async fn silence(&self) -> f64 {
        loop {
            let armed = Instant::now();
            tokio::time::sleep(self.timeout).await;
            let slept = armed.elapsed();
            match endpoint_heard(self.heard.as_ref(), self.timeout) {
                Heard::SilentFor(silent_s) => return silent_s,
                Heard::Recently => {}
                // Without the endpoint's view, a wake far later than asked was our own pause.
                Heard::Unknown if self.heard.is_none() && slept < self.timeout * 2 => {
                    return slept.as_secs_f64();
                }
                Heard::Unknown => {}
            }
        }
    }
}

impl ServiceCore {
    /// Why a published state ends a workflow step: the arm is held, or (with `baseline`) the
    /// residual changed beyond the workflow threshold; `context` says where ("while sampling").
    pub(super) fn state_abort(
        &self,
        snapshot: &Snapshot,
        baseline: Option<&[f64; 7]>,
        thresholds: &[f64; 7],
        context: &str,
    ) -> Option<OperatorError> {
        if let Some(e) = Self::held_error(&snapshot.state) {
            return Some(e);
        }
        let cause = residual_change(snapshot, baseline?, thresholds)?;
        let message = format!("{} {context}", describe_change(&cause));
        Some(err(ErrorCode::Aborted, message).with_cause(cause))
    }

    /// Moves to `target` in command mode and waits for the arrival; aborts on a collision,
    /// a stop, or loss of command mode (after [`MOVE_RETRIES`] re-drives), each with its cause.
    /// With `baseline`, a residual change beyond the workflow threshold aborts the move.
    pub async fn move_to(
        &self,
        target: [f64; 7],
        baseline: Option<[f64; 7]>,
    ) -> Result<(), OperatorError> {
        let thresholds = self.persistent(|s| s.thresholds);
        let latest = self.latest()?;
        if latest.state.is_held() {
            return Err(err(
                ErrorCode::NotReady,
                "the arm is stopped (operator stop or collision reaction); `resume` first",
            )
            .with_cause(Cause::Held));
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
        let mut updates = self.shared.subscribe();
        self.send(CycleRequest::MoveTo(target))?;
        let silence = SilenceTimer::new(self);
        let mut start = Instant::now();
        let mut seen_moving = false;
        let mut ended_at = None;
        let mut retries = 0;
        let mut collision: Option<crate::ipc::CollisionMessage> = None;
        loop {
            let timeout = if seen_moving {
                MOVE_TIMEOUT_S
            } else {
                MOVE_START_TIMEOUT_S
            };
            let deadline = start + Duration::from_secs_f64(timeout);
            tokio::select! {
                u = updates.recv() => match u {
                    Ok(Update::Snapshot(s)) => {
                        if let Some(c) = collision.take() {
                            // Held by the reaction (its stop carries the collision as its cause),
                            // or reported only: either way the move ends here.
                            return Err(Self::held_error(&s.state).unwrap_or_else(|| {
                                err(ErrorCode::Aborted, format!("collision detected (link {}) at {:.3} s (report only: the arm is not held)", c.link, c.time_s))
                                    .with_cause(Cause::Collision { link: c.link, time_s: c.time_s, residual: c.residual })
                            }));
                        }
                        if let Some(e) = self.state_abort(&s, baseline.as_ref(), &thresholds, "during the move: contact? (arm stopped; `resume` to continue)") {
                            // A residual change: hold the arm, as a reaction would.
                            if !s.state.is_held() {
                                let _ = self.send(CycleRequest::Stop);
                            }
                            return Err(e);
                        }
                        if s.state == LoopState::Moving || s.state == LoopState::EnteringCommand {
                            seen_moving |= s.state == LoopState::Moving;
                        } else if seen_moving {
                            // The set-point is at the target; wait for the arm to follow.
                            let off = (0..7).map(|j| (s.robot.q[j] - target[j]).abs()).fold(0.0, f64::max);
                            let ended = *ended_at.get_or_insert(s.robot.time_s);
                            if off <= ARRIVAL_TOLERANCE {
                                return Ok(());
                            }
                            if s.robot.time_s - ended > ARRIVAL_TIMEOUT_S {
                                return Err(err(ErrorCode::Failed, format!("the arm stayed {off:.4} rad from the target")));
                            }
                        }
                    }
                    Ok(Update::Event(CycleEvent::Collision(c))) => {
                        // The reaction's stop, if any, follows in the same cycle, before the
                        // cycle's snapshot: end there, with the arm's state settled.
                        collision = Some(c);
                    }
                    Ok(Update::Event(CycleEvent::Stopped { reason, fri, .. })) => {
                        return Err(Self::stop_error(reason, fri));
                    }
                    Ok(Update::Event(CycleEvent::MoveAborted { reason, fri, .. })) => match reason {
                        AbortReason::Held | AbortReason::Braked => {
                            let held = self.shared.latest().and_then(|s| Self::held_error(&s.state));
                            return Err(held.unwrap_or_else(|| err(ErrorCode::Aborted, "the move was braked").with_cause(Cause::Held)));
                        }
                        AbortReason::Unplannable => return Err(err(ErrorCode::Failed, "the move could not be planned from the current set-point")),
                        AbortReason::ShuttingDown => return Err(err(ErrorCode::Aborted, "the service is shutting down: the move was braked")),
                        AbortReason::CommandModeLost | AbortReason::ControllerRestarted => {
                            if retries >= MOVE_RETRIES {
                                let cause = if reason == AbortReason::ControllerRestarted {
                                    Cause::ControllerRestarted { fri }
                                } else {
                                    Cause::CommandModeLost { retries, fri }
                                };
                                return Err(err(ErrorCode::Aborted, format!("move aborted: {} ({}) after {retries} retries", reason.describe(), fri.describe())).with_cause(cause));
                            }
                            // The loop re-requests command mode; drive the move again from where
                            // the arm is.
                            retries += 1;
                            tracing::warn!(retries, reason = reason.describe(), fri = %fri.describe(), "move interrupted; retrying");
                            self.send(CycleRequest::MoveTo(target))?;
                            seen_moving = false;
                            ended_at = None;
                            start = Instant::now();
                        }
                    },
                    // A reader that fell behind lost updates: the next snapshot carries the state.
                    Ok(Update::Event(_)) | Err(RecvError::Lagged(_)) => {}
                    Err(RecvError::Closed) => return Err(err(ErrorCode::NotReady, "the FRI loop has stopped")),
                },
                silent = silence.silence() => {
                    return Err(self.silent_error(silent));
                }
                _ = tokio::time::sleep_until(deadline) => {
                    return Err(if seen_moving {
                        err(ErrorCode::NotReady, "the move did not finish in time")
                    } else {
                        err(ErrorCode::NotReady, "command mode was not entered (check the KRL program, quality and drives)")
                            .with_cause(Cause::CommandModeNotEntered { fri: self.fri_context() })
                    });
                }
            }
        }
    }
}

/// Operator text of a [`Cause::ResidualChange`].
pub(super) fn describe_change(cause: &Cause) -> String {
    match cause {
        Cause::ResidualChange {
            joint,
            change_nm,
            limit_nm,
        } => format!(
            "residual of joint {joint} changed by {change_nm:+.1} Nm (limit ±{limit_nm:.1} Nm)"
        ),
        other => format!("{other:?}"),
    }
}
