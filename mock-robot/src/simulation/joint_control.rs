//! The KRC's joint controllers as emulated here, computing motor torques from the controller's
//! own gravity model (which lacks the payload):
//!
//! - position (strategy 10): PID with feed-forward, natural frequency ω, critical damping,
//!   integral rate λ (|integral| ≤ 40 Nm), gains scaled by the controller's M_ii + B_i;
//! - joint impedance (30): τ = K (q_d − q) − 2 d √(K (M_ii + B_i)) q̇ + g_ctrl(q) + τ_FRI.
//!
//! Motor torques are clamped to the joint torque limits.

use crate::config::ControlSpec;
use crate::joints::JOINTS;
use crate::joints::JointVector;
use crate::krl::{CommandView, FLAG_JNTTRQ, Strategy};
use crate::motion::SetPoint;

/// Joint torque limits of the LWR 4+, Nm (lwr4-model.md §1.2); motor torques are clamped here.
pub const TORQUE_LIMITS_NM: [f64; JOINTS] = [176.0, 176.0, 100.0, 100.0, 100.0, 38.0, 38.0];

/// Largest integral torque of the position controller, Nm (anti-windup).
const INTEGRAL_LIMIT_NM: f64 = 40.0;

/// Command flag: `jntStiffness` valid.
const FLAG_JNTSTIFF: u32 = 0x0010;
/// Command flag: `jntDamping` valid.
const FLAG_JNTDAMP: u32 = 0x0020;

/// Gains and controller state of both strategies.
#[derive(Debug, Clone)]
pub(crate) struct JointControl {
    spec: ControlSpec,
    integral: JointVector,
    stiffness: JointVector,
    damping: JointVector,
    added_torque: JointVector,
}

impl JointControl {
    /// Controllers with `spec`'s gains, the default impedance and an empty integral.
    pub(crate) fn new(spec: &ControlSpec) -> Self {
        Self {
            spec: spec.clone(),
            integral: JointVector::zeros(),
            stiffness: JointVector::from(spec.default_stiffness_nm_per_rad),
            damping: JointVector::from(spec.default_damping),
            added_torque: JointVector::zeros(),
        }
    }

    /// The position controller has been holding the pose: its integral carries what the
    /// controller's gravity model `g_ctrl` misses of the torques `held` (payload, model error),
    /// so the arm starts at rest.
    pub(crate) fn preload(&mut self, held: &JointVector, g_ctrl: &JointVector) {
        self.integral = (held - g_ctrl).map(|v| v.clamp(-INTEGRAL_LIMIT_NM, INTEGRAL_LIMIT_NM));
    }

    /// Takes stiffness, damping and added torque from a command answered in command mode
    /// (defaults where the command's flags leave them out or the values are out of range).
    pub(crate) fn take_command(&mut self, c: &CommandView) {
        let spec = &self.spec;
        for i in 0..JOINTS {
            let k = c.jnt_stiffness[i];
            self.stiffness[i] = if c.flags & FLAG_JNTSTIFF != 0 && (0.0..=5000.0).contains(&k) {
                k
            } else {
                spec.default_stiffness_nm_per_rad[i]
            };
            let d = c.jnt_damping[i];
            self.damping[i] = if c.flags & FLAG_JNTDAMP != 0 && (0.0..=1.0).contains(&d) {
                d
            } else {
                spec.default_damping[i]
            };
        }
        self.added_torque = if c.flags & FLAG_JNTTRQ != 0 {
            c.add_jnt_trq
        } else {
            JointVector::zeros()
        };
    }

    /// The added torque of the last command taken, Nm.
    pub(crate) fn added_torque(&self) -> &JointVector {
        &self.added_torque
    }

    /// Motor torques of `strategy` for one substep of `dt` (s) towards `setpoint` from the state
    /// `q`, `qd`, with the controller's gravity `g_ctrl`, the added torque `added` and the gain
    /// inertia `inertia` (M_ii + B_i); Nm, clamped to the torque limits.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn torque(
        &mut self,
        strategy: Strategy,
        setpoint: &SetPoint,
        q: &JointVector,
        qd: &JointVector,
        g_ctrl: &JointVector,
        added: &JointVector,
        inertia: &JointVector,
        dt: f64,
    ) -> JointVector {
        let (w, lambda) = (
            self.spec.position_bandwidth_rad_s,
            self.spec.position_integral_per_s,
        );
        let error = setpoint.q - q;
        let mut tau = g_ctrl + added;
        match strategy {
            Strategy::Position => {
                for i in 0..JOINTS {
                    let j = inertia[i];
                    let kp = w * w * j;
                    let kd = 2.0 * w * j;
                    self.integral[i] = (self.integral[i] + kp * lambda * error[i] * dt)
                        .clamp(-INTEGRAL_LIMIT_NM, INTEGRAL_LIMIT_NM);
                    tau[i] += kp * error[i]
                        + kd * (setpoint.qd[i] - qd[i])
                        + self.integral[i]
                        + j * setpoint.qdd[i];
                }
            }
            Strategy::JointImpedance => {
                self.integral = JointVector::zeros();
                for i in 0..JOINTS {
                    let d = 2.0 * self.damping[i] * (self.stiffness[i] * inertia[i]).sqrt();
                    tau[i] += self.stiffness[i] * error[i] - d * qd[i];
                }
            }
        }
        for (i, limit) in TORQUE_LIMITS_NM.iter().enumerate() {
            tau[i] = tau[i].clamp(-limit, *limit);
        }
        tau
    }
}
