//! Operator requests and the collision reaction on the loop: move, release, stop, resume,
//! payload, arming, monitor replacement, shutdown; every hold and brake starts here.

use super::*;

impl CycleProcessor {
    pub(super) fn handle_requests(&mut self, fri: FriContext) {
        // A bounded number per cycle keeps the cycle time bounded.
        for _ in 0..8 {
            let Ok(request) = self.requests.try_recv() else {
                return;
            };
            match request {
                CycleRequest::MoveTo(target) => {
                    let target = V7::from(target);
                    if !self.is_holding() {
                        self.pending_target = Some(target);
                        self.command_wanted = true;
                    } else {
                        self.abort_move(AbortReason::Held, fri);
                    }
                }
                CycleRequest::ReleaseCommandMode => {
                    self.command_wanted = false;
                }
                CycleRequest::Shutdown => {
                    if self.is_moving() {
                        self.abort_move(AbortReason::ShuttingDown, fri);
                        self.abort_reported = self.motion.is_some();
                    }
                    self.brake();
                    self.command_wanted = false;
                }
                CycleRequest::Stop => self.operator_stop(fri),
                CycleRequest::Resume { after_stops } => {
                    // A stop requested after this resume was sent holds, even when the queue
                    // delivers the resume later.
                    self.take_latched_stop(fri);
                    if after_stops < self.stops_handled {
                        continue;
                    }
                    // Into a contact that is still present, the resume waits for its release
                    // (the old reaction would otherwise be replaced by a new one at once).
                    if self.armed && self.monitor.detector().in_contact() {
                        self.resume_when_clear = true;
                    } else {
                        self.resume(None);
                    }
                }
                CycleRequest::SetPayload(p) => {
                    let compensation = p.clone().unwrap_or(PayloadCompensation::None);
                    // A rejected estimate leaves the previous payload in use (the safety crate
                    // reports it as a fault); the operator side validated it already.
                    if self.monitor.set_payload(compensation).is_ok() {
                        self.payload = p;
                        // The payload is known again: from the next step on the monitor
                        // detects against it (the observer moves its residual at once).
                        self.tolerance.end(safety::ModeEnd::Applied);
                    }
                }
                CycleRequest::ExpectPayload {
                    declaration,
                    bounds,
                    timing,
                } => {
                    // The operator side validated the bounds; invalid ones change nothing.
                    let _ = self
                        .tolerance
                        .declare(declaration, bounds, timing, self.time_s);
                }
                CycleRequest::PayloadHypothesis(h) => {
                    self.tolerance.set_hypothesis(h);
                }
                CycleRequest::EndExpectPayload => self.tolerance.end(safety::ModeEnd::Ended),
                CycleRequest::Arm(on) => {
                    // Arming starts from a live reaction whatever happened while disarmed.
                    self.monitor.set_armed(on);
                    self.armed = on;
                }
                CycleRequest::ReplaceMonitor {
                    monitor: mut m,
                    react,
                } => {
                    let _ =
                        m.set_payload(self.payload.clone().unwrap_or(PayloadCompensation::None));
                    m.set_armed(self.armed);
                    self.monitor = m;
                    self.settings.react = react;
                }
            }
        }
    }
    /// Latches the stops requested through the [`StopLatch`] since the last look.
    pub(super) fn take_latched_stop(&mut self, fri: FriContext) {
        let requested = self.stop_latch.requested();
        if requested != self.stops_handled {
            self.stops_handled = requested;
            self.operator_stop(fri);
        }
    }

    /// The operator's stop: brake any move and hold until a resume.
    fn operator_stop(&mut self, fri: FriContext) {
        self.operator_stop = true;
        self.resume_when_clear = false;
        self.brake();
        self.emit(CycleEvent::Stopped {
            cycle: self.cycle,
            reason: StopReason::Operator,
            fri,
        });
    }

    /// Ends every hold (operator stop, reaction) and readies the reaction for the next onset;
    /// `by_service` says why when no operator request does it now.
    pub(super) fn resume(&mut self, by_service: Option<ReleaseReason>) {
        let was = self.is_holding();
        self.resume_when_clear = false;
        self.operator_stop = false;
        self.reaction_hold = false;
        self.interrupted_target = None;
        // The hold ended here: the supervisor must be ready for the next onset.
        self.monitor.release_reaction();
        if was {
            self.emit(CycleEvent::Resumed {
                cycle: self.cycle,
                by_service,
            });
        }
    }
    pub(super) fn abort_move(&mut self, reason: AbortReason, fri: FriContext) {
        self.emit(CycleEvent::MoveAborted {
            cycle: self.cycle,
            reason,
            fri,
        });
    }
    /// Brakes the current move (if any) and forgets pending ones.
    pub(super) fn brake(&mut self) {
        self.pending_target = None;
        let t = self.time_s;
        if let Some((m, t0, target)) = &mut self.motion {
            m.stop_at(t - *t0);
            self.interrupted_target = Some(*target);
        }
    }
    pub(super) fn apply_reaction(&mut self, request: ReactionRequest<7>, fri: FriContext) {
        match request {
            ReactionRequest::Stop(cause)
            | ReactionRequest::Pause { cause, .. }
            | ReactionRequest::HoldForOperator(cause) => {
                let reason = match cause {
                    StopCause::Collision(e) => {
                        let mut residual = [0.0; 7];
                        residual.copy_from_slice(self.reported_residual(&e.residual).as_slice());
                        StopReason::Collision {
                            link: (e.isolated_link + 1) as u32,
                            time_s: self.time_s,
                            residual,
                        }
                    }
                    StopCause::Fault(fault) => StopReason::ObserverFault { fault },
                };
                if matches!(reason, StopReason::Collision { .. }) && !self.settings.react {
                    // Report only: nothing is held, so the supervisor must not wait for a
                    // release that never comes; the detector keeps the contact until it ends
                    // (re-arming it here reported one contact on every cycle it lasted).
                    self.monitor.pass_reaction();
                    return;
                }
                self.reaction_hold = true;
                self.brake();
                self.emit(CycleEvent::Stopped {
                    cycle: self.cycle,
                    reason,
                    fri,
                });
            }
            ReactionRequest::Resume => {
                if self.reaction_hold {
                    self.reaction_hold = false;
                    // The paper's pause-then-resume: continue the interrupted move.
                    if !self.operator_stop
                        && let Some(t) = self.interrupted_target.take()
                    {
                        self.pending_target = Some(t);
                    }
                    self.emit(CycleEvent::Resumed {
                        cycle: self.cycle,
                        by_service: Some(ReleaseReason::PauseElapsed),
                    });
                }
            }
        }
    }
}
