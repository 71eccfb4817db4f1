//! One static sample of a workflow: wait for settling, then average a contiguous window of
//! published states; a stop, a silent controller or a residual change ends it with its cause.

use std::time::Duration;

use tokio::sync::broadcast::error::RecvError;
use tokio::time::Instant;

use super::motion::SilenceTimer;
use crate::service::core::{ServiceCore, err};
use crate::service::output::CycleEvent;
use crate::service::settle::{AveragedSample, Averager, SettleDetector};
use crate::service::stream::Update;
use fri_api::protocol::{ErrorCode, OperatorError};

impl ServiceCore {
    /// Waits for settling (bounded by `estimation.settle_timeout_s`) and averages one window.
    /// `baseline` is the residual at the workflow's start: a change larger than the thresholds
    /// aborts (contact during a workflow that may carry an uncompensated payload). A restart of
    /// the collision monitor (gap, controller restart) starts the window over: a sample spans
    /// contiguous cycles only.
    pub async fn acquire(
        &self,
        settle: bool,
        duration_s: f64,
        baseline: Option<[f64; 7]>,
    ) -> Result<(AveragedSample, f64), OperatorError> {
        self.latest()?;
        let e = &self.config.estimation;
        let cycle_s = self.config.fri.cycle_s;
        let window = (e.settle_window_s / cycle_s).round() as usize;
        let average_cycles = ((duration_s / cycle_s).round() as usize).max(1);
        let mut detector = SettleDetector::new(window, e.settle_velocity, e.settle_torque_std);
        let mut updates = self.shared.subscribe();
        let thresholds = self.persistent(|s| s.thresholds);
        let silence = SilenceTimer::new(self.connection_timeout());
        let started = Instant::now();
        let mut settle_time = 0.0;
        let mut settling = settle;
        let mut settle_start_t = None;
        let mut avg = Averager::new(average_cycles);
        let wall_limit = Duration::from_secs_f64(e.settle_timeout_s + duration_s + 10.0);
        loop {
            tokio::select! {
                u = updates.recv() => match u {
                    Ok(Update::Snapshot(s)) => {
                        if let Some(e) = self.state_abort(&s, baseline.as_ref(), &thresholds, "while sampling: contact?") {
                            return Err(e);
                        }
                        if settling {
                            let t0 = *settle_start_t.get_or_insert(s.robot.time_s);
                            settle_time = s.robot.time_s - t0;
                            if detector.push(&s.robot) {
                                // The quiet window is static data already: it starts the
                                // average, and the settling time is what came before it.
                                settling = false;
                                let mut quiet = 0usize;
                                for r in detector.window().take(average_cycles) {
                                    avg.push(r);
                                    quiet += 1;
                                }
                                settle_time = (settle_time - (quiet as f64 - 1.0) * cycle_s).max(0.0);
                            } else if settle_time >= e.settle_timeout_s {
                                settling = false;
                                continue;
                            } else {
                                continue;
                            }
                        } else {
                            avg.push(&s.robot);
                        }
                        if avg.len() >= average_cycles {
                            let Some(mut sample) = avg.finish(cycle_s) else { continue };
                            if let Some(e) = &mut sample.sample.evidence {
                                e.settle_s = settle_time;
                            }
                            return Ok((sample, settle_time));
                        }
                    }
                    Ok(Update::Event(CycleEvent::Stopped { reason, fri, .. })) => {
                        return Err(Self::stop_error(reason, fri));
                    }
                    Ok(Update::Event(CycleEvent::Resynchronised { reason, .. })) => {
                        tracing::warn!(reason = %reason.describe(), "collision monitor restarted while sampling; restarting the window");
                        avg = Averager::new(average_cycles);
                    }
                    Ok(Update::Event(_)) => {}
                    Err(RecvError::Lagged(n)) => {
                        // The sample must be contiguous: start over.
                        tracing::warn!(lost = n, "sampling fell behind; restarting the window");
                        avg = Averager::new(average_cycles);
                    }
                    Err(RecvError::Closed) => return Err(err(ErrorCode::NotReady, "the FRI loop has stopped")),
                },
                silent = silence.silence() => {
                    return Err(self.silent_error(silent.as_secs_f64()));
                }
                _ = tokio::time::sleep_until(started + wall_limit) => {
                    return Err(err(ErrorCode::NotReady, "no measurements while sampling"));
                }
            }
        }
    }
}
