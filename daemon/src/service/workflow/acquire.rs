//! One static sample: wait for settling, then average a contiguous window of published states
//! during which the arm stays settled; a stop, a silent controller or a residual change ends it
//! with its cause. A sample is never taken while the arm moves.

use std::collections::VecDeque;
use std::time::Duration;

use tokio::sync::broadcast::error::RecvError;
use tokio::time::Instant;

use super::motion::SilenceTimer;
use crate::ipc::RobotState;
use crate::service::core::{ServiceCore, err};
use crate::service::output::CycleEvent;
use crate::service::settle::{AveragedSample, Averager, SettleDetector};
use crate::service::stream::Update;
use fri_api::cause::Cause;
use fri_api::protocol::{ErrorCode, OperatorError};

/// Longest wait for a settled sample when the service does not move the arm itself (`sample`,
/// `record --kind samples`), s.
pub const WATCH_WAIT_S: f64 = 60.0;

/// Who moves the arm while a sample is taken.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Acquire {
    /// The service's own workflow, which has just brought the arm to rest: the quiet settle
    /// window starts the average, and not settling within `estimation.settle_timeout_s` is an
    /// error (never a sample of a moving arm).
    Workflow,
    /// Someone else (a KRL program, the operator) may start a move at any time: a cycle
    /// enters the average only after a full settled window has followed it, so that the start
    /// of a move is never in the sample; the wait for rest is bounded by `wait_s`.
    Watch {
        /// Longest wait for a settled sample, s.
        wait_s: f64,
    },
}

impl ServiceCore {
    /// Waits for settling and averages one window of `duration_s` (see [`Acquire`]).
    /// `baseline` is the residual at the workflow's start: a change larger than the thresholds
    /// aborts (contact during a workflow that may carry an uncompensated payload). A restart of
    /// the collision monitor (gap, controller restart), a lag of this reader or motion during
    /// the window starts the window over: a sample spans contiguous settled cycles only.
    /// Returns the sample and the time waited for settling, s.
    pub async fn acquire(
        &self,
        mode: Acquire,
        duration_s: f64,
        baseline: Option<[f64; 7]>,
    ) -> Result<(AveragedSample, f64), OperatorError> {
        self.latest()?;
        let e = &self.config.estimation;
        let cycle_s = self.config.fri.cycle_s;
        let window = ((e.settle_window_s / cycle_s).round() as usize).max(2);
        let average_cycles = ((duration_s / cycle_s).round() as usize).max(1);
        let (wait_limit_s, delay) = match mode {
            Acquire::Workflow => (e.settle_timeout_s, 0),
            Acquire::Watch { wait_s } => (wait_s, window),
        };
        let mut detector = SettleDetector::new(window, e.settle_velocity, e.settle_torque_std);
        let mut updates = self.shared.subscribe();
        let thresholds = self.persistent(|s| s.thresholds);
        let silence = SilenceTimer::new(self);
        let started = Instant::now();
        let wall_limit = Duration::from_secs_f64(wait_limit_s + duration_s + 10.0);
        let mut start_t: Option<f64> = None;
        // settled cycles waiting for a full settled window after them (Watch), oldest first
        let mut pending: VecDeque<RobotState> = VecDeque::with_capacity(delay + 1);
        let mut avg: Option<Averager> = None;
        let mut settle_s = 0.0;
        loop {
            tokio::select! {
                u = updates.recv() => match u {
                    Ok(Update::Snapshot(s)) => {
                        if let Some(e) = self.state_abort(&s, baseline.as_ref(), &thresholds, "while sampling: contact?") {
                            return Err(e);
                        }
                        let t0 = *start_t.get_or_insert(s.robot.time_s);
                        let settled = detector.push(&s.robot);
                        match (&mut avg, settled) {
                            (None, false) => {
                                if s.robot.time_s - t0 > wait_limit_s {
                                    return Err(not_settled(&detector, wait_limit_s));
                                }
                            }
                            (None, true) => {
                                let mut a = Averager::new(average_cycles);
                                if delay == 0 {
                                    // the quiet window is static data already: it starts the
                                    // average, and the settling time is what came before it
                                    for r in detector.window().take(average_cycles) {
                                        a.push(r);
                                    }
                                }
                                let first = detector.window().next().map_or(s.robot.time_s, |r| r.time_s);
                                settle_s = (first - t0).max(0.0);
                                avg = Some(a);
                            }
                            (Some(a), true) => {
                                if delay == 0 {
                                    if a.len() < average_cycles {
                                        a.push(&s.robot);
                                    }
                                } else {
                                    pending.push_back(s.robot);
                                    if pending.len() > delay && let Some(r) = pending.pop_front() {
                                        a.push(&r);
                                    }
                                }
                            }
                            (Some(_), false) => {
                                // moving again: this window is not a static sample
                                avg = None;
                                pending.clear();
                                if s.robot.time_s - t0 > wait_limit_s {
                                    return Err(not_settled(&detector, wait_limit_s));
                                }
                            }
                        }
                        if let Some(a) = &avg && a.len() >= average_cycles {
                            let Some(mut sample) = a.finish(cycle_s) else { continue };
                            if let Some(e) = &mut sample.sample.evidence {
                                e.settle_s = settle_s;
                            }
                            return Ok((sample, settle_s));
                        }
                    }
                    Ok(Update::Event(CycleEvent::Stopped { reason, fri, .. })) => {
                        return Err(Self::stop_error(reason, fri));
                    }
                    Ok(Update::Event(CycleEvent::Resynchronised { reason, .. })) => {
                        tracing::warn!(reason = %reason.describe(), "collision monitor restarted while sampling; restarting the window");
                        avg = None;
                        pending.clear();
                    }
                    Ok(Update::Event(_)) => {}
                    Err(RecvError::Lagged(n)) => {
                        // The sample must be contiguous: start over.
                        tracing::warn!(lost = n, "sampling fell behind; restarting the window");
                        avg = None;
                        pending.clear();
                        detector = SettleDetector::new(window, e.settle_velocity, e.settle_torque_std);
                    }
                    Err(RecvError::Closed) => return Err(err(ErrorCode::NotReady, "the FRI loop has stopped")),
                },
                silent = silence.silence() => {
                    return Err(self.silent_error(silent));
                }
                _ = tokio::time::sleep_until(started + wall_limit) => {
                    return Err(err(ErrorCode::NotReady, "no measurements while sampling"));
                }
            }
        }
    }
}

/// The error for an arm that did not come to rest, with what the detector saw.
fn not_settled(detector: &SettleDetector, limit_s: f64) -> OperatorError {
    err(
        ErrorCode::Failed,
        format!(
            "the arm did not settle within {limit_s} s (largest joint velocity over the last settle window {:.2e} rad/s; limits: estimation.settle_velocity, settle_torque_std, settle_timeout_s): no sample was taken",
            detector.speed()
        ),
    )
    .with_cause(Cause::NotSettled {
        speed_rad_s: detector.speed(),
        limit_rad_s: detector.max_velocity(),
        waited_s: limit_s,
    })
}
