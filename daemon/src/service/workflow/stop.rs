//! `stop` and `resume`: the operator's hold of the arm and its release.

use fri_api::results::{ControllerLink, ResumeResult, StopResult};

use fri_api::ipc::flags;
use tokio::sync::broadcast::error::RecvError;

use super::motion::SilenceTimer;
use crate::service::core::{ServiceCore, err};
use crate::service::cycle::CycleRequest;
use crate::service::state::Snapshot;
use crate::service::stream::Update;
use fri_api::protocol::{ErrorCode, OperatorError};

impl ServiceCore {
    /// Hands a request to the loop (`send`) and returns the first state published after the
    /// loop handled it, or how long the controller has been silent (requests are handled in
    /// the controller's cycles: nothing is handled while it is silent, the request waits).
    async fn after_handled(
        &self,
        send: impl FnOnce() -> Result<(), OperatorError>,
    ) -> Result<Handled, OperatorError> {
        let mut updates = self.shared.subscribe();
        let seen = self.latest().map(|s| s.robot.cycle);
        send()?;
        let seen = match seen {
            Ok(cycle) => cycle,
            Err(e) => return Ok(Handled::Silent(e.message)),
        };
        // The loop drains requests at the start of a cycle: the second cycle after the last one
        // it completed when the request was sent has handled it. The loop can be ahead of the
        // state delivered here (the stream thread lags on a stalled host), so count from the
        // endpoint thread's own cycle count, read after sending: it counts the loop's cycles
        // as the snapshots number them.
        let completed = self
            .fri_state
            .as_ref()
            .map_or(seen, |f| f().cycle.max(seen));
        let handled = completed + 2;
        let silence = SilenceTimer::new(self);
        loop {
            tokio::select! {
                u = updates.recv() => match u {
                    Ok(Update::Snapshot(s)) if s.robot.cycle >= handled => return Ok(Handled::In(Box::new(s))),
                    Ok(_) | Err(RecvError::Lagged(_)) => {}
                    Err(RecvError::Closed) => {
                        return Err(err(ErrorCode::NotReady, "the FRI loop has stopped"));
                    }
                },
                silent = silence.silence() => {
                    return Ok(Handled::Silent(self.silent_error(silent).message));
                }
            }
        }
    }

    /// `stop`.
    ///
    /// The stop is latched in the loop at once, through the [`crate::service::cycle::StopLatch`]
    /// (a full request queue cannot refuse or delay it); the reply comes from the first state
    /// after the loop handled it (the arm is held then). When the controller is silent nothing
    /// is being commanded (the controller stops the arm itself when our answers are missing) and
    /// the reply says so: the latched stop holds the arm when the controller returns.
    pub async fn stop(&self) -> Result<StopResult, OperatorError> {
        let latch = || {
            self.stop_latch.request();
            Ok(())
        };
        Ok(match self.after_handled(latch).await? {
            Handled::In(_) => StopResult {
                stopped: true,
                controller: ControllerLink::Connected,
                note: None,
            },
            Handled::Silent(why) => StopResult {
                stopped: true,
                controller: ControllerLink::Silent,
                note: Some(format!(
                    "{why}; nothing is commanded while the controller is silent, and the stop holds the arm when it returns"
                )),
            },
        })
    }

    /// `resume`.
    ///
    /// The reply is read from the first state published after the loop handled the request,
    /// so it says what happened: released, or still held because the contact that caused the
    /// hold is still detected (the resume is then latched and releases the arm when the contact
    /// ends), or held again by a new stop.
    pub async fn resume(&self) -> Result<ResumeResult, OperatorError> {
        // Stamped with the stops requested so far: a stop requested after it is never released
        // by it, even when the queue delivers the resume after the stop.
        let resume = || {
            self.send(CycleRequest::Resume {
                after_stops: self.stop_latch.requested(),
            })
        };
        Ok(match self.after_handled(resume).await? {
            Handled::In(s) => outcome(&s),
            Handled::Silent(why) => ResumeResult {
                stopped: true,
                waiting_for_release: false,
                note: Some(format!(
                    "{why}; the resume is queued and takes effect on the controller's next cycle"
                )),
            },
        })
    }
}

/// What became of a request sent to the loop.
enum Handled {
    /// The first state after the loop handled it.
    In(Box<Snapshot>),
    /// The controller is silent (why, for the operator): the request waits in the queue.
    Silent(String),
}

/// What a state after a resume says to the operator.
fn outcome(s: &Snapshot) -> ResumeResult {
    if !s.state.is_held() {
        return ResumeResult {
            stopped: false,
            waiting_for_release: false,
            note: None,
        };
    }
    let pending = s.robot.flags & flags::RESUME_PENDING != 0;
    let note = if pending {
        let over: Vec<String> = s
            .robot
            .residual
            .iter()
            .enumerate()
            .filter(|(_, r)| r.is_finite())
            .map(|(j, r)| format!("J{} {r:+.1}", j + 1))
            .collect();
        format!(
            "the contact is still detected (residual {} Nm): the arm stays held and is released when the contact ends",
            over.join(", ")
        )
    } else {
        match s.state.stop() {
            Some((reason, fri)) => {
                format!("held again: {} ({})", reason.describe(), fri.describe())
            }
            None => "the arm is still held (cause not seen: check `status`)".to_owned(),
        }
    };
    ResumeResult {
        stopped: true,
        waiting_for_release: pending,
        note: Some(note),
    }
}
