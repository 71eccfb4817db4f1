//! Command mode: following the controller (entered, lost, restarted), watching its brake until
//! the arm rests, planning and sampling the commanded move, and the handshake.

use super::*;

impl CycleProcessor {
    /// Restarts the collision monitor and says why.
    pub(super) fn resynchronise(&mut self, reason: ResyncReason, fri: FriContext) {
        self.restart_monitor();
        self.emit(CycleEvent::Resynchronised {
            cycle: self.cycle,
            reason,
            fri,
        });
    }
    /// While the controller brakes the arm after a loss of command mode the monitor stays live
    /// with the braking allowance; the window ends once the arm was at rest for
    /// [`REST_CYCLES`] (or after [`MAX_REST_WAIT_CYCLES`]).
    pub(super) fn follow_braking(&mut self, q: &V7, dt: f64) {
        let speed = self
            .previous_q
            .map_or(0.0, |p| (q - p).amax() / dt.max(f64::EPSILON));
        self.previous_q = Some(*q);
        let Some(w) = &mut self.braking else {
            return;
        };
        w.waited += 1;
        w.quiet = if speed < REST_SPEED { w.quiet + 1 } else { 0 };
        if w.quiet >= REST_CYCLES || w.waited >= MAX_REST_WAIT_CYCLES {
            self.braking = None;
        }
    }
    /// Opens [`REJOIN_FILTER_CYCLES`] of matched filtering when the controller counted a
    /// missed answer since the last measurement (its `intf.stat.missCounter` changed: a restart
    /// resets it) or `cycles` > 1 measurements passed since the last one we saw.
    pub(super) fn follow_missed_answers(&mut self, msr: &Measurement, cycles: u32) {
        let misses = msr.interface.statistics.miss_counter;
        let missed = self.previous_miss_counter.is_some_and(|m| m != misses) || cycles > 1;
        self.previous_miss_counter = Some(misses);
        self.rejoin_cycles_left = if missed {
            REJOIN_FILTER_CYCLES
        } else {
            self.rejoin_cycles_left.saturating_sub(1)
        };
    }
    /// Restarts the monitor; the unknown-payload view learns that it saw nothing meanwhile.
    fn restart_monitor(&mut self) {
        self.monitor.restart();
        self.tolerance.interrupt();
    }
    /// Follows the controller's command mode; runs before the monitor steps, so that the
    /// cycle in which the controller starts braking is already treated as such.
    /// `in_command` is the session's verdict (state CMD and a drive powered).
    pub(super) fn follow_command_mode(
        &mut self,
        msr: &Measurement,
        in_command: bool,
        restarted: bool,
        fri: FriContext,
    ) {
        if in_command && !self.in_command {
            // Entry: the session's step limits start from the mirrored set-point.
            self.setpoint = Some(V7::from(msr.mirrored_joint_position()));
            self.motion = None;
        }
        if !in_command && self.in_command {
            // Command mode lost (controller dropped it, or we released it).
            let moving = self.motion.is_some() || self.pending_target.is_some();
            if moving {
                let reason = if restarted {
                    AbortReason::ControllerRestarted
                } else {
                    AbortReason::CommandModeLost
                };
                self.abort_move(reason, fri);
                // The controller brakes the arm itself: its deceleration is no contact, but a
                // contact during it is. The monitor stays live (matched filtering keeps the
                // braking's residual small) and sees the residual less an allowance for the
                // momentum the stop removes.
                let q = V7::from(msr.data.msr_jnt_pos);
                let allowance =
                    self.monitor.momentum_bound(&q, &self.last_velocity) * BRAKING_ALLOWANCE_PER_S;
                // The unknown-payload view treats the stop like a restart: no fit meanwhile.
                self.tolerance.interrupt();
                self.braking = Some(BrakingWindow {
                    quiet: 0,
                    waited: 0,
                    allowance,
                });
                let mut allowance_nm = [0.0; 7];
                allowance_nm.copy_from_slice(allowance.as_slice());
                self.emit(CycleEvent::Braking {
                    cycle: self.cycle,
                    allowance_nm,
                    fri,
                });
            }
            self.motion = None;
            self.pending_target = None;
            self.command_wanted = self.command_wanted && !self.operator_stop;
        }
        self.in_command = in_command;
    }
    pub(super) fn command(
        &mut self,
        msr: &Measurement,
        handshake: HandshakeStatus,
        request: HandshakeRequest,
        fri: FriContext,
    ) -> (DesiredCommand, Option<(RequestKind, KrlStrategy)>) {
        let in_command = self.in_command;
        let new_request = self.handshake(msr, handshake, request);

        let mut desired = DesiredCommand::default();
        if !in_command {
            return (desired, new_request);
        }
        if self.motion.is_none()
            && let (Some(target), Some(start)) = (self.pending_target, self.setpoint)
            && !self.is_holding()
        {
            self.pending_target = None;
            match JointMove::new(start, target, self.settings.limits) {
                Ok(m) => {
                    // The service's own move: the grasp of a payload declared unknown is over.
                    self.tolerance.end_grasp();
                    self.motion = Some((m, self.time_s, target));
                    self.abort_reported = false;
                }
                Err(_) => self.abort_move(AbortReason::Unplannable, fri),
            }
        }
        if let Some((m, t0, _)) = &self.motion {
            let t = self.time_s - *t0;
            self.setpoint = Some(m.sample(t).position);
            if m.is_finished(t) {
                let braked = m.is_braking();
                self.motion = None;
                if braked && !self.abort_reported {
                    self.abort_move(AbortReason::Braked, fri);
                }
            }
        }
        desired.joint_position = self.setpoint.map(|s| {
            let mut a = [0.0; 7];
            a.copy_from_slice(s.as_slice());
            a
        });
        (desired, new_request)
    }
    pub(super) fn handshake(
        &mut self,
        msr: &Measurement,
        status: HandshakeStatus,
        current: HandshakeRequest,
    ) -> Option<(RequestKind, KrlStrategy)> {
        let busy = self.motion.is_some() || self.pending_target.is_some();
        let wanted = if self.command_wanted && !self.in_command {
            status
                .accepts_start(msr.interface.quality)
                .then_some((RequestKind::StartCommandMode, KrlStrategy::JointPosition))
        } else if !self.command_wanted && self.in_command && !busy {
            Some((RequestKind::StopCommandMode, KrlStrategy::None))
        } else {
            None
        };
        // Called every cycle: the retry counts cycles between requests of the same kind.
        self.retry.poll(wanted, &current)
    }
}
