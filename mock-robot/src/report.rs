//! What the controller reports about the arm in a measurement: the measured joint positions and
//! torques it is given, and everything the KRC computes from its own dynamic model at the
//! measured pose (gravity, mass matrix, Jacobian, frames, estimated external torques and wrench).

use dynamics::{Data, Model};
use fri::wire::{
    ControlStrategy, InterfaceInfo, InterfaceState, InterfaceStatistics, Measurement,
    Quality as WireQuality, RobotData, RobotStatus,
};
use nalgebra::{Isometry3, SMatrix};

use crate::joints::{JOINTS, JointVector};

/// Drive temperature reported in `robot.temperature`, °C.
pub const REPORTED_TEMPERATURE_C: f64 = 35.0;

/// The measurement a controller starts from (a simulation's or a replay's): monitor mode,
/// quality UNACCEPTABLE until answers arrive, no answers yet (miss rate 1), drives powered in
/// joint position control; `cycle_s` the FRI period, s.
pub(crate) fn initial_measurement(cycle_s: f64) -> Measurement {
    Measurement {
        interface: InterfaceInfo {
            timestamp: 0.0,
            state: InterfaceState::Monitor,
            quality: WireQuality::Unacceptable,
            desired_msr_sample_time: cycle_s,
            desired_cmd_sample_time: cycle_s,
            safety_limits: 1.0,
            statistics: InterfaceStatistics {
                answer_rate: 0.0,
                latency: 0.0,
                jitter: 0.0,
                miss_rate: 1.0,
                miss_counter: 0,
            },
        },
        robot: RobotStatus {
            power: 0x7F,
            control: ControlStrategy::Position,
            error: 0,
            warning: 0,
            temperature: [REPORTED_TEMPERATURE_C; JOINTS],
        },
        ..Measurement::default()
    }
}

/// The joint state a measurement reports, and the set-point the controller holds.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Reading<'a> {
    /// Measured joint angles (encoders), rad.
    pub q_msr: &'a JointVector,
    /// Joint velocities the controller's model uses, rad/s.
    pub qd: &'a JointVector,
    /// Joint accelerations the controller's model uses, rad/s².
    pub qdd: &'a JointVector,
    /// Measured joint torques (τ_J sensors), Nm.
    pub tau_msr: &'a JointVector,
    /// The KRL program's commanded joint angles (`cmdJntPos`), rad.
    pub cmd_pos: &'a JointVector,
    /// The FRI set-point applied in command mode (None in monitor mode), rad.
    pub fri_setpoint: Option<&'a JointVector>,
}

/// A pose as the wire's 3×4 row-major frame.
fn frame(iso: &Isometry3<f64>) -> [[f64; 4]; 3] {
    let m = iso.to_homogeneous();
    std::array::from_fn(|r| std::array::from_fn(|c| m[(r, c)]))
}

/// Writes the measured and model-derived fields of `r` into `d` with the controller's `model`;
/// returns the set-point the measurement reports (`cmdJntPos + cmdJntPosFriOffset`, rad): the
/// one a remote must mirror.
pub(crate) fn write_robot_data(
    model: &Model<7>,
    data: &mut Data<7>,
    r: &Reading<'_>,
    d: &mut RobotData,
) -> JointVector {
    let q_msr = r.q_msr;
    let gravity = dynamics::compute_generalized_gravity(model, data, q_msr);
    let mass = dynamics::crba(model, data, q_msr);
    let inverse_dynamics = dynamics::rnea(model, data, q_msr, r.qd, r.qdd);
    let est_ext = inverse_dynamics - r.tau_msr;
    let jac = dynamics::flange_jacobian(model, data, q_msr);
    let flange = dynamics::flange_pose(model, data, q_msr);
    // estExtTcpFT = (J Jᵀ + λ²I)⁻¹ J τ_ext (damped pseudo-inverse of Jᵀ).
    let jjt = jac * jac.transpose() + SMatrix::<f64, 6, 6>::identity() * 1e-6;
    let wrench = jjt
        .cholesky()
        .map_or_else(nalgebra::Vector6::zeros, |ch| ch.solve(&(jac * est_ext)));
    let cmd_pos = *r.cmd_pos;
    let offset = match r.fri_setpoint {
        Some(setpoint) => setpoint - cmd_pos,
        None => JointVector::zeros(),
    };
    let mirrored = cmd_pos + offset;
    let cmd_pose = dynamics::flange_pose(model, data, &cmd_pos);
    let offset_pose = if r.fri_setpoint.is_some() {
        cmd_pose.inverse() * dynamics::flange_pose(model, data, &mirrored)
    } else {
        Isometry3::identity()
    };
    d.msr_jnt_pos = (*q_msr).into();
    d.msr_cart_pos = frame(&flange);
    d.cmd_jnt_pos = cmd_pos.into();
    d.cmd_jnt_pos_fri_offset = offset.into();
    d.cmd_cart_pos = frame(&cmd_pose);
    d.cmd_cart_pos_fri_offset = frame(&offset_pose);
    d.msr_jnt_trq = (*r.tau_msr).into();
    d.est_ext_jnt_trq = est_ext.into();
    // Wire order: Fx Fy Fz Tz Ty Tx; Jacobian rows X Y Z RZ RY RX.
    d.est_ext_tcp_ft = [
        wrench[0], wrench[1], wrench[2], wrench[5], wrench[4], wrench[3],
    ];
    let rows = [0usize, 1, 2, 5, 4, 3];
    d.jacobian = std::array::from_fn(|r| std::array::from_fn(|c| jac[(rows[r], c)]));
    d.mass_matrix = std::array::from_fn(|r| std::array::from_fn(|c| mass[(r, c)]));
    d.gravity = gravity.into();
    mirrored
}

/// The diagonal of the mass matrix `d` reports, plus `rotor`: the inertia the joint controllers
/// scale their gains with, kg·m².
pub(crate) fn gain_inertia(d: &RobotData, rotor: &JointVector) -> JointVector {
    JointVector::from_fn(|i, _| d.mass_matrix[i][i] + rotor[i])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::joints::JOINTS;

    #[test]
    fn monitor_mode_reports_no_offset_and_mirrors_the_commanded_pose() {
        let model = dynamics::lwr4();
        let mut data = Data::new(&model);
        let q = JointVector::from([0.1, 0.5, 0.0, -1.0, 0.2, 0.6, 0.0]);
        let zero = JointVector::zeros();
        let g = dynamics::compute_generalized_gravity(&model, &mut Data::new(&model), &q);
        let mut d = fri::wire::Measurement::default().data;
        let reading = Reading {
            q_msr: &q,
            qd: &zero,
            qdd: &zero,
            tau_msr: &g,
            cmd_pos: &q,
            fri_setpoint: None,
        };
        let mirrored = write_robot_data(&model, &mut data, &reading, &mut d);
        assert_eq!(mirrored, q);
        assert_eq!(d.cmd_jnt_pos_fri_offset, [0.0; JOINTS]);
        // At rest the sensors read gravity: no external torque.
        assert!(d.est_ext_jnt_trq.iter().all(|t| t.abs() < 1e-9));
        assert_eq!(d.gravity, <[f64; JOINTS]>::from(g));
    }
}
