//! Isolation and identification: which link was hit, and with what wrench.
//!
//! A contact on link i produces τ_ext = J_iᵀF, which has no component on joints distal to i
//! (they do not move link i), so the hit link is the most distal joint whose residual exceeds
//! its threshold. Isolation degenerates when the force line passes through the axis of that
//! joint (its torque is then zero and a more proximal link is reported).
//!
//! Identification: F̂ = (J Jᵀ + λ²I)⁻¹ J r (damped least-squares inverse of τ = JᵀF) at an assumed
//! contact point; meaningful on the last link (contact on the tool), where J has full row rank
//! away from singularities.

use dynamics::{Data, Model, point_jacobian};
use nalgebra::{Matrix3, Matrix6, SVector, Vector3, Vector6};

use crate::detector::JointSet;

/// The isolated link (0-based; link i is moved by joint i): most distal joint in `over`.
pub fn isolate_link(over: JointSet) -> Option<usize> {
    over.most_distal()
}

/// Damped least-squares estimate of the contact wrench (F \[N\]; moment about the point \[Nm\]),
/// base frame, from residual `residual` \[Nm\] for a contact at `point_in_link` \[m\] in the DH
/// frame of link `link` (0-based), damping `damping` λ (same units as J entries; 0 = plain
/// pseudo-inverse). `None` when the damped system is singular.
pub fn estimate_contact_wrench<const N: usize>(
    model: &Model<N>,
    data: &mut Data<N>,
    q: &SVector<f64, N>,
    residual: &SVector<f64, N>,
    link: usize,
    point_in_link: &Vector3<f64>,
    damping: f64,
) -> Option<Vector6<f64>> {
    let jacobian = point_jacobian(model, data, q, link, point_in_link);
    let normal: Matrix6<f64> =
        jacobian * jacobian.transpose() + Matrix6::identity() * (damping * damping);
    let rhs: Vector6<f64> = jacobian * residual;
    normal.cholesky().map(|c| c.solve(&rhs))
}

/// Damped least-squares estimate of a pure contact force F \[N\] (base frame) at `point_in_link`
/// \[m\] on link `link` (0-based) from residual `residual` \[Nm\]: F̂ = (J_v J_vᵀ + λ²I)⁻¹ J_v r.
pub fn estimate_contact_force<const N: usize>(
    model: &Model<N>,
    data: &mut Data<N>,
    q: &SVector<f64, N>,
    residual: &SVector<f64, N>,
    link: usize,
    point_in_link: &Vector3<f64>,
    damping: f64,
) -> Option<Vector3<f64>> {
    let jacobian = point_jacobian(model, data, q, link, point_in_link);
    let linear = jacobian.fixed_rows::<3>(0);
    let normal: Matrix3<f64> =
        linear * linear.transpose() + Matrix3::identity() * (damping * damping);
    let rhs: Vector3<f64> = linear * residual;
    normal.cholesky().map(|c| c.solve(&rhs))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn most_distal_joint_is_the_isolated_link() {
        let mut s = JointSet::default();
        assert_eq!(isolate_link(s), None);
        s.insert(1);
        s.insert(4);
        s.insert(2);
        assert_eq!(isolate_link(s), Some(4));
        assert_eq!(s.len(), 3);
    }
}
