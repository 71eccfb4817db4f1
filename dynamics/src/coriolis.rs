//! Coriolis/centrifugal terms: the Christoffel-consistent matrix C(q, q̇) by an O(n²) recursion,
//! ∂M/∂q and Ṁ (an independent O(n⁴) route, for analysis and tests), and an O(n) recursion for
//! Cᵀ(q, q̇)q̇ = ∂(½ q̇ᵀM(q)q̇)/∂q used by momentum observers.

use nalgebra::{Matrix3, Matrix6, SMatrix, SVector, Vector6};

use crate::data::Data;
use crate::inertia::skew;
use crate::joint_frames::unit_motion_in;
use crate::kinematics::{update_link_poses, update_world_poses};
use crate::model::Model;
use crate::spatial::{Motion, Pose};

fn to_vector6(m: &Motion) -> Vector6<f64> {
    Vector6::new(m.ang.x, m.ang.y, m.ang.z, m.lin.x, m.lin.y, m.lin.z)
}

/// 6×6 motion cross-product matrix of `m` (angular first).
fn cross_motion_matrix(m: &Vector6<f64>) -> Matrix6<f64> {
    let w = skew(&m.fixed_rows::<3>(0).into_owned());
    let v = skew(&m.fixed_rows::<3>(3).into_owned());
    let mut out = Matrix6::zeros();
    out.fixed_view_mut::<3, 3>(0, 0).copy_from(&w);
    out.fixed_view_mut::<3, 3>(3, 0).copy_from(&v);
    out.fixed_view_mut::<3, 3>(3, 3).copy_from(&w);
    out
}

/// 6×6 spatial inertia of a link in the base frame, given the link pose in the base.
fn spatial_inertia_in_base(params: &crate::InertialParameters, pose: &Pose) -> Matrix6<f64> {
    let sh = skew(&params.first_moment);
    let mut body = Matrix6::zeros();
    body.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&params.inertia_origin);
    body.fixed_view_mut::<3, 3>(0, 3).copy_from(&sh);
    body.fixed_view_mut::<3, 3>(3, 0).copy_from(&sh.transpose());
    body.fixed_view_mut::<3, 3>(3, 3)
        .copy_from(&(Matrix3::identity() * params.mass));
    // Motion transform base → link: ω_b = Rᵀω, v_b = Rᵀ(v − p × ω).
    let rt = pose.rot.transpose();
    let mut x = Matrix6::zeros();
    x.fixed_view_mut::<3, 3>(0, 0).copy_from(&rt);
    x.fixed_view_mut::<3, 3>(3, 3).copy_from(&rt);
    x.fixed_view_mut::<3, 3>(3, 0)
        .copy_from(&(-rt * skew(&pose.trans)));
    x.transpose() * body * x
}

/// Partial derivatives ∂M/∂q_k (k = 0..N), each N×N in kg·m²/rad, from M = Σ_b J_bᵀ I_b J_b in
/// the base frame (an independent route from the CRBA; O(n⁴), meant for analysis and tests).
pub fn mass_matrix_partial_derivatives<const N: usize>(
    model: &Model<N>,
    data: &mut Data<N>,
    q: &SVector<f64, N>,
) -> [SMatrix<f64, N, N>; N] {
    update_world_poses(model, data, q);
    let twists: [Vector6<f64>; N] = std::array::from_fn(|j| {
        to_vector6(&data.link_in_base[j].motion_to_parent(model.joints()[j].motion_subspace()))
    });
    let crosses: [Matrix6<f64>; N] = std::array::from_fn(|k| cross_motion_matrix(&twists[k]));
    let mut derivatives = [SMatrix::<f64, N, N>::zeros(); N];
    for b in 0..N {
        let inertia = spatial_inertia_in_base(&model.links()[b], &data.link_in_base[b]);
        let mut jac = SMatrix::<f64, 6, N>::zeros();
        for (j, twist) in twists.iter().enumerate().take(b + 1) {
            jac.set_column(j, twist);
        }
        let inertia_jac = inertia * jac;
        for k in 0..=b {
            // ∂J_b/∂q_k: column j (k < j ≤ b) is S_k ×m S_j.
            let mut djac = SMatrix::<f64, 6, N>::zeros();
            for (j, twist) in twists.iter().enumerate().take(b + 1).skip(k + 1) {
                djac.set_column(j, &(crosses[k] * twist));
            }
            // ∂I_b/∂q_k = S_k×* I − I S_k×m, with S×* = −(S×m)ᵀ.
            let dinertia = -crosses[k].transpose() * inertia - inertia * crosses[k];
            let term = djac.transpose() * inertia_jac;
            derivatives[k] += term + term.transpose() + jac.transpose() * dinertia * jac;
        }
    }
    derivatives
}

/// Time derivative Ṁ(q, q̇) = Σ_k ∂M/∂q_k q̇_k, kg·m²/s.
pub fn mass_matrix_time_derivative<const N: usize>(
    model: &Model<N>,
    data: &mut Data<N>,
    q: &SVector<f64, N>,
    qd: &SVector<f64, N>,
) -> SMatrix<f64, N, N> {
    let derivatives = mass_matrix_partial_derivatives(model, data, q);
    let mut mdot = SMatrix::<f64, N, N>::zeros();
    for (k, d) in derivatives.iter().enumerate() {
        mdot += d * qd[k];
    }
    mdot
}

/// Coriolis/centrifugal matrix C(q, q̇), N·m·s/rad: the Christoffel-consistent one
/// (C_ij = Σ_k Γ_ijk q̇_k with the Christoffel symbols of M, so Ṁ − 2C is skew), and C(q,q̇)q̇ is
/// the Coriolis/centrifugal torque. Computed by an O(n²) recursion in the base frame (Echeandia &
/// Wensing 2021; Pinocchio's `computeCoriolisMatrix`), not from ∂M/∂q. Allocation-free.
///
/// With S_j, Ṡ_j = v_j ×m S_j, and per subtree k the composite inertia I_k, its rate İ_k and
/// momentum h_k, let B_k m = ½ İ_k m + ½ m ×* h_k. Then for a ≤ k (a on the path to k):
/// C_ak = S_a · (I_k Ṡ_k + B_k S_k) and, for a < k, C_ka = (I_k S_k) · Ṡ_a + (B_kᵀ S_k) · S_a.
pub fn coriolis_matrix<const N: usize>(
    model: &Model<N>,
    data: &mut Data<N>,
    q: &SVector<f64, N>,
    qd: &SVector<f64, N>,
) -> SMatrix<f64, N, N> {
    let frames = model.joint_frames();
    // Forward: axes, axis rates, and each link's inertia, inertia rate and momentum, base frame.
    let mut v = Motion::ZERO;
    for i in 0..N {
        let local = frames.pose(i, q[i]);
        data.joint_in_base[i] = match i.checked_sub(1) {
            None => local,
            Some(parent) => data.joint_in_base[parent].compose(&local),
        };
        let pose = &data.joint_in_base[i];
        let s = unit_motion_in(frames.kind(i), pose);
        v = v.add(&s.scale(qd[i]));
        data.axes_in_base[i] = s;
        data.axes_rate_in_base[i] = v.cross_motion(&s);
        let inertia = frames.links()[i].transformed(&pose.rot, &pose.trans);
        data.composite_momentum_in_base[i] = inertia.apply(&v);
        data.composite_rate_in_base[i] = inertia.rate(&v);
        data.composite_in_base[i] = inertia;
    }
    // Backward: subtree sums need no transforms in the base frame.
    for i in (0..N.saturating_sub(1)).rev() {
        data.composite_in_base[i] = data.composite_in_base[i].plus(&data.composite_in_base[i + 1]);
        data.composite_rate_in_base[i] =
            data.composite_rate_in_base[i].plus(&data.composite_rate_in_base[i + 1]);
        data.composite_momentum_in_base[i] =
            data.composite_momentum_in_base[i].add(&data.composite_momentum_in_base[i + 1]);
    }
    let mut c = SMatrix::<f64, N, N>::zeros();
    for k in 0..N {
        let s = &data.axes_in_base[k];
        let inertia = &data.composite_in_base[k];
        // B_k S_k = p + r and B_kᵀ S_k = p − r (İ is symmetric, m ↦ m ×* h is skew).
        let p = data.composite_rate_in_base[k].apply(s).scale(0.5);
        let r = s
            .cross_force(&data.composite_momentum_in_base[k])
            .scale(0.5);
        let column = inertia.apply(&data.axes_rate_in_base[k]).add(&p).add(&r);
        let momentum = inertia.apply(s);
        let row = p.sub(&r);
        c[(k, k)] = s.dot(&column);
        for a in 0..k {
            c[(a, k)] = data.axes_in_base[a].dot(&column);
            c[(k, a)] = data.axes_rate_in_base[a].dot(&momentum) + data.axes_in_base[a].dot(&row);
        }
    }
    c
}

/// Cᵀ(q, q̇)q̇ = ∂(½ q̇ᵀM(q)q̇)/∂q, Nm, by an O(n) recursion: with link momenta h_b = I_b v_b,
/// (Cᵀq̇)_i = −S_iᵀ (v_i ×* Σ_{b ≥ i} h_b). Allocation-free.
pub fn coriolis_transpose_times_velocity<const N: usize>(
    model: &Model<N>,
    data: &mut Data<N>,
    q: &SVector<f64, N>,
    qd: &SVector<f64, N>,
) -> SVector<f64, N> {
    // Velocity-only forward pass; link momenta h_i = I_i v_i.
    update_link_poses(model, data, q);
    let mut v_parent = Motion::ZERO;
    for i in 0..N {
        let v = data.link_in_parent[i]
            .motion_to_child(&v_parent)
            .add(&model.joints()[i].motion_subspace().scale(qd[i]));
        data.velocity[i] = v;
        data.force[i] = model.links()[i].apply(&v);
        v_parent = v;
    }
    let mut out = SVector::<f64, N>::zeros();
    for i in (0..N).rev() {
        let s = model.joints()[i].motion_subspace();
        out[i] = -s.dot(&data.velocity[i].cross_force(&data.force[i]));
        if i > 0 {
            let to_parent = data.link_in_parent[i].force_to_parent(&data.force[i]);
            data.force[i - 1] = data.force[i - 1].add(&to_parent);
        }
    }
    out
}
