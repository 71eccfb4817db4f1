//! Ground truth: what really happened to the arm (payload, models, state, torques, sensor bias,
//! contacts), for scoring estimators and detectors; none of it reaches the remote.

use dynamics::{InertialParameters, Model};

use super::{ContactState, Simulation};
use crate::joints::JointVector;
use crate::krl::FriState;

impl Simulation {
    /// True payload (frame 7) when attached.
    pub fn true_payload(&self) -> Option<&InertialParameters> {
        self.arm.payload()
    }

    /// The true arm model (with the payload when attached).
    pub fn true_model(&self) -> &Model<7> {
        self.arm.model()
    }

    /// The controller's own model (perturbed, without payload).
    pub fn controller_model(&self) -> &Model<7> {
        &self.controller_model
    }

    /// True joint angles, rad.
    pub fn q(&self) -> &JointVector {
        &self.arm.q
    }

    /// True joint velocities, rad/s.
    pub fn qd(&self) -> &JointVector {
        &self.arm.qd
    }

    /// True joint accelerations, rad/s².
    pub fn qdd(&self) -> &JointVector {
        &self.arm.qdd
    }

    /// True link-side joint torques τ_J (what an ideal sensor reads), Nm.
    pub fn true_joint_torques(&self) -> &JointVector {
        &self.arm.tau_j
    }

    /// True external joint torques Σ J_pᵀ F of all contacts, Nm.
    pub fn external_torques(&self) -> &JointVector {
        &self.arm.tau_ext
    }

    /// Motor torques commanded by the joint controller, Nm.
    pub fn motor_torques(&self) -> &JointVector {
        &self.arm.tau_motor
    }

    /// The controller's current joint set-point (what its joint controllers follow), rad: in
    /// command mode the last accepted command, extrapolated through bridged misses; otherwise
    /// the KRL program's (its motion script, or the pose it holds, also after a restart).
    pub fn commanded_setpoint(&self) -> JointVector {
        if self.krl.state() == FriState::Command {
            *self.krl.fri_setpoint()
        } else {
            self.krl_cmd_pos
        }
    }

    /// Current τ_J sensor bias (offset + drift) per joint, Nm.
    pub fn sensor_bias(&self) -> JointVector {
        self.sensors.bias()
    }

    /// Ground truth of every contact of the scenario.
    pub fn contacts(&self) -> &[ContactState] {
        self.arm.contacts()
    }
}
