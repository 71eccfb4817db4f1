//! The cycle's snapshot for the non-real-time side: flags, measured values and the residual
//! (NaN while it is not valid).

use super::*;

impl CycleProcessor {
    pub(super) fn publish(&mut self, msr: &Measurement, velocity: &V7) {
        let mut f = 0;
        if self.in_command {
            f |= flags::COMMAND_MODE;
        }
        if self.armed {
            f |= flags::MONITOR_ARMED;
        }
        if self.collision_now {
            f |= flags::COLLISION;
        }
        if self.operator_stop || self.reaction_hold {
            f |= flags::STOPPED;
        }
        if self.payload.is_some() {
            f |= flags::PAYLOAD_APPLIED;
        }
        if self.observer_fault {
            f |= flags::OBSERVER_FAULT;
        }
        if !self.residual_valid {
            f |= flags::RESIDUAL_INVALID;
        }
        if self.motion.is_some() || self.pending_target.is_some() {
            f |= flags::MOVING;
        }
        if self.command_wanted {
            f |= flags::COMMAND_REQUESTED;
        }
        if self.resume_when_clear {
            f |= flags::RESUME_PENDING;
        }
        if self.tolerance.is_active() {
            f |= flags::PAYLOAD_UNKNOWN;
        }
        let mut qd = [0.0; 7];
        qd.copy_from_slice(velocity.as_slice());
        // An unsynchronised observer's value is not published: NaN, flagged.
        let mut residual = [f64::NAN; 7];
        if self.residual_valid {
            residual.copy_from_slice(self.last_residual.as_slice());
        }
        let state = RobotState {
            cycle: self.cycle,
            time_s: self.time_s,
            q: msr.data.msr_jnt_pos,
            qd,
            tau: msr.data.msr_jnt_trq,
            gravity: msr.data.gravity,
            tau_ext: msr.data.est_ext_jnt_trq,
            residual,
            flags: f,
            fri_state: match msr.interface.state {
                InterfaceState::Monitor => 1,
                InterfaceState::Command => 2,
                _ => 0,
            },
            quality: match msr.interface.quality {
                Quality::Perfect => 3,
                Quality::Ok => 2,
                Quality::Bad => 1,
                _ => 0,
            },
            reserved: 0,
        };
        self.emit(CycleEvent::State(state));
    }
}
