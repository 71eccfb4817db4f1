//! Recursive Newton-Euler inverse dynamics and the gravity vector.

use nalgebra::SVector;

use crate::data::Data;
use crate::kinematics::update_link_poses;
use crate::model::Model;
use crate::spatial::Motion;

/// Forward pass of the RNEA: link velocities and accelerations (gravity included as a base
/// acceleration −g), stored in `data`.
#[inline]
pub(crate) fn forward_pass<const N: usize>(
    model: &Model<N>,
    data: &mut Data<N>,
    q: &SVector<f64, N>,
    qd: &SVector<f64, N>,
    qdd: &SVector<f64, N>,
) {
    forward_pass_with_base_acceleration(model, data, q, qd, qdd, &-model.gravity());
}

/// RNEA forward pass with an arbitrary linear base acceleration (m/s², base frame); −g models
/// gravity, zero leaves it out.
#[inline]
fn forward_pass_with_base_acceleration<const N: usize>(
    model: &Model<N>,
    data: &mut Data<N>,
    q: &SVector<f64, N>,
    qd: &SVector<f64, N>,
    qdd: &SVector<f64, N>,
    base_acceleration: &nalgebra::Vector3<f64>,
) {
    update_link_poses(model, data, q);
    let mut v_parent = Motion::ZERO;
    let mut a_parent = Motion {
        ang: nalgebra::Vector3::zeros(),
        lin: *base_acceleration,
    };
    for i in 0..N {
        let pose = &data.link_in_parent[i];
        let s = model.joints()[i].motion_subspace();
        let v_joint = s.scale(qd[i]);
        let v = pose.motion_to_child(&v_parent).add(&v_joint);
        let a = pose
            .motion_to_child(&a_parent)
            .add(&s.scale(qdd[i]))
            .add(&v.cross_motion(&v_joint));
        data.velocity[i] = v;
        data.acceleration[i] = a;
        v_parent = v;
        a_parent = a;
    }
}

/// Inverse dynamics τ = M(q)q̈ + C(q,q̇)q̇ + g(q) by the recursive Newton-Euler algorithm; q in
/// rad, q̇ in rad/s, q̈ in rad/s², τ in Nm.
pub fn rnea<const N: usize>(
    model: &Model<N>,
    data: &mut Data<N>,
    q: &SVector<f64, N>,
    qd: &SVector<f64, N>,
    qdd: &SVector<f64, N>,
) -> SVector<f64, N> {
    forward_pass(model, data, q, qd, qdd);
    link_forces_and_project(model, data)
}

/// f_i = I_i a_i + v_i ×* I_i v_i for every link, then τ = Sᵀf accumulated tip to base.
#[inline]
fn link_forces_and_project<const N: usize>(
    model: &Model<N>,
    data: &mut Data<N>,
) -> SVector<f64, N> {
    for i in 0..N {
        let inertia = &model.links()[i];
        let v = &data.velocity[i];
        data.force[i] = inertia
            .apply(&data.acceleration[i])
            .add(&v.cross_force(&inertia.apply(v)));
    }
    backward_project(model, data)
}

/// τ_i = S_iᵀ f_i with f accumulated from the tip to the base.
#[inline]
pub(crate) fn backward_project<const N: usize>(
    model: &Model<N>,
    data: &mut Data<N>,
) -> SVector<f64, N> {
    let mut tau = SVector::<f64, N>::zeros();
    for i in (0..N).rev() {
        tau[i] = model.joints()[i].motion_subspace().dot(&data.force[i]);
        if i > 0 {
            let to_parent = data.link_in_parent[i].force_to_parent(&data.force[i]);
            data.force[i - 1] = data.force[i - 1].add(&to_parent);
        }
    }
    tau
}

/// Gravity torque vector g(q), Nm: the torque that holds the arm still at `q`.
pub fn compute_generalized_gravity<const N: usize>(
    model: &Model<N>,
    data: &mut Data<N>,
    q: &SVector<f64, N>,
) -> SVector<f64, N> {
    update_link_poses(model, data, q);
    // At rest only the (linear) base acceleration −g propagates, rotated into each frame.
    let mut a = -model.gravity();
    for i in 0..N {
        a = data.link_in_parent[i].rot.tr_mul(&a);
        let inertia = &model.links()[i];
        data.force[i].ang = inertia.first_moment.cross(&a);
        data.force[i].lin = a * inertia.mass;
    }
    backward_project(model, data)
}

/// Coriolis, centrifugal and gravity torques h(q, q̇) = C(q,q̇)q̇ + g(q), Nm.
pub fn nonlinear_effects<const N: usize>(
    model: &Model<N>,
    data: &mut Data<N>,
    q: &SVector<f64, N>,
    qd: &SVector<f64, N>,
) -> SVector<f64, N> {
    rnea(model, data, q, qd, &SVector::zeros())
}

/// Coriolis and centrifugal torques C(q, q̇)q̇ alone (no gravity), Nm.
pub fn coriolis_centrifugal_torques<const N: usize>(
    model: &Model<N>,
    data: &mut Data<N>,
    q: &SVector<f64, N>,
    qd: &SVector<f64, N>,
) -> SVector<f64, N> {
    let zero = SVector::<f64, N>::zeros();
    forward_pass_with_base_acceleration(model, data, q, qd, &zero, &nalgebra::Vector3::zeros());
    link_forces_and_project(model, data)
}
