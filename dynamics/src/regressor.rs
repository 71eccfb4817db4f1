//! Inertial-parameter regressors: τ = Σ_b Y_b(q, q̇, q̈) p_b with p_b the ten parameters of link b
//! in the order of [`crate::InertialParameters::to_vector`].

use nalgebra::{SMatrix, SVector, Vector3};

use crate::data::Data;
use crate::kinematics::update_link_poses;
use crate::model::Model;
use crate::rnea::forward_pass;
use crate::spatial::{Force, Motion};

/// Spatial force on a link (own frame) per unit of each of its ten parameters, given its spatial
/// velocity `v` and acceleration `a` (gravity included): f = I a + v ×* I v is linear in p.
#[inline]
fn body_regressor(v: &Motion, a: &Motion) -> [Force; 10] {
    let w = &v.ang;
    let vl = &v.lin;
    let al = &a.lin;
    let alpha = &a.ang;
    let zero = Vector3::zeros();
    let first_moment = |e: Vector3<f64>| Force {
        // n = h×a + ω×(h×v) − v×(h×ω);  f = −h×α − ω×(h×ω)
        ang: e.cross(al) + w.cross(&e.cross(vl)) - vl.cross(&e.cross(w)),
        lin: -e.cross(alpha) - w.cross(&e.cross(w)),
    };
    // n = E α + ω × (E ω) for each symmetric basis tensor E.
    let inertia = |ea: Vector3<f64>, ew: Vector3<f64>| Force {
        ang: ea + w.cross(&ew),
        lin: zero,
    };
    [
        Force {
            ang: zero,
            lin: al + w.cross(vl),
        },
        first_moment(Vector3::x()),
        first_moment(Vector3::y()),
        first_moment(Vector3::z()),
        inertia(Vector3::new(alpha.x, 0.0, 0.0), Vector3::new(w.x, 0.0, 0.0)),
        inertia(
            Vector3::new(alpha.y, alpha.x, 0.0),
            Vector3::new(w.y, w.x, 0.0),
        ),
        inertia(
            Vector3::new(alpha.z, 0.0, alpha.x),
            Vector3::new(w.z, 0.0, w.x),
        ),
        inertia(Vector3::new(0.0, alpha.y, 0.0), Vector3::new(0.0, w.y, 0.0)),
        inertia(
            Vector3::new(0.0, alpha.z, alpha.y),
            Vector3::new(0.0, w.z, w.y),
        ),
        inertia(Vector3::new(0.0, 0.0, alpha.z), Vector3::new(0.0, 0.0, w.z)),
    ]
}

/// Static (gravity-only) version of [`body_regressor`] for (m, mcx, mcy, mcz): `a` is the base
/// acceleration −g in the link frame.
#[inline]
fn body_gravity_regressor(a: &Vector3<f64>) -> [Force; 4] {
    let zero = Vector3::zeros();
    [
        Force { ang: zero, lin: *a },
        Force {
            ang: Vector3::x().cross(a),
            lin: zero,
        },
        Force {
            ang: Vector3::y().cross(a),
            lin: zero,
        },
        Force {
            ang: Vector3::z().cross(a),
            lin: zero,
        },
    ]
}

/// Moves the joint axes S_0..S_{b−1} (held in `data.axes`, expressed in link frame b−1) into link
/// frame b and appends S_b, so that `data.axes[j]` is S_j in link frame b for all j ≤ b.
#[inline]
fn advance_axes<const N: usize>(model: &Model<N>, data: &mut Data<N>, b: usize) {
    let pose = data.link_in_parent[b];
    for axis in data.axes.iter_mut().take(b) {
        *axis = pose.motion_to_child(axis);
    }
    data.axes[b] = *model.joints()[b].motion_subspace();
}

/// Row j of `out` = torque of joint j per unit of each parameter of link b: τ_j = S_jᵀ X f
/// evaluated as (S_j in frame b) · f, which needs one motion transform per joint instead of one
/// force transform per parameter and joint.
#[inline]
fn project_to_joints<const N: usize, const P: usize>(
    data: &Data<N>,
    body: usize,
    forces: &[Force; P],
    out: &mut SMatrix<f64, N, P>,
) {
    for (j, axis) in data.axes.iter().enumerate().take(body + 1) {
        for (c, f) in forces.iter().enumerate() {
            out[(j, c)] = axis.dot(f);
        }
    }
}

/// Rotates the base acceleration −g into every link frame (the static forward pass).
#[inline]
fn static_accelerations<const N: usize>(model: &Model<N>, data: &mut Data<N>, q: &SVector<f64, N>) {
    update_link_poses(model, data, q);
    let mut a = -model.gravity();
    for i in 0..N {
        a = data.link_in_parent[i].rot.tr_mul(&a);
        data.acceleration[i] = Motion {
            ang: Vector3::zeros(),
            lin: a,
        };
    }
}

/// Full joint-torque regressor: block b (N×10, Nm per parameter unit) multiplies the parameters
/// of link b, so τ = Σ_b Y_b p_b; the n × 10n matrix of the paper is [Y_0 … Y_{N−1}].
pub fn joint_torque_regressor<const N: usize>(
    model: &Model<N>,
    data: &mut Data<N>,
    q: &SVector<f64, N>,
    qd: &SVector<f64, N>,
    qdd: &SVector<f64, N>,
) -> [SMatrix<f64, N, 10>; N] {
    forward_pass(model, data, q, qd, qdd);
    let mut blocks = [SMatrix::<f64, N, 10>::zeros(); N];
    for (b, block) in blocks.iter_mut().enumerate() {
        advance_axes(model, data, b);
        let forces = body_regressor(&data.velocity[b], &data.acceleration[b]);
        project_to_joints(data, b, &forces, block);
    }
    blocks
}

/// Regressor of a payload fixed to the last link (N×10, columns as `to_vector()`, parameters in
/// the last link frame): the torque the payload adds is `payload_regressor · p_L`.
pub fn payload_regressor<const N: usize>(
    model: &Model<N>,
    data: &mut Data<N>,
    q: &SVector<f64, N>,
    qd: &SVector<f64, N>,
    qdd: &SVector<f64, N>,
) -> SMatrix<f64, N, 10> {
    let mut out = SMatrix::<f64, N, 10>::zeros();
    if N == 0 {
        return out;
    }
    forward_pass(model, data, q, qd, qdd);
    for b in 0..N {
        advance_axes(model, data, b);
    }
    let last = N - 1;
    let forces = body_regressor(&data.velocity[last], &data.acceleration[last]);
    project_to_joints(data, last, &forces, &mut out);
    out
}

/// Static gravity regressor of all links: block b (N×4; columns m, mcx, mcy, mcz of link b in its
/// frame) gives g(q) = Σ_b Y_b p_b; the paper's n × 4n gravity regressor is [Y_0 … Y_{N−1}].
pub fn gravity_regressor<const N: usize>(
    model: &Model<N>,
    data: &mut Data<N>,
    q: &SVector<f64, N>,
) -> [SMatrix<f64, N, 4>; N] {
    static_accelerations(model, data, q);
    let mut blocks = [SMatrix::<f64, N, 4>::zeros(); N];
    for (b, block) in blocks.iter_mut().enumerate() {
        advance_axes(model, data, b);
        let forces = body_gravity_regressor(&data.acceleration[b].lin);
        project_to_joints(data, b, &forces, block);
    }
    blocks
}

/// Payload gravity regressor of eq. 40 (N×4; columns m, m·cx, m·cy, m·cz of the payload in the
/// last link frame, units Nm per kg and per kg·m): g_payload(q) = Y · p_L,g.
pub fn payload_gravity_regressor<const N: usize>(
    model: &Model<N>,
    data: &mut Data<N>,
    q: &SVector<f64, N>,
) -> SMatrix<f64, N, 4> {
    let mut out = SMatrix::<f64, N, 4>::zeros();
    if N == 0 {
        return out;
    }
    update_link_poses(model, data, q);
    let mut a = -model.gravity();
    for b in 0..N {
        a = data.link_in_parent[b].rot.tr_mul(&a);
        advance_axes(model, data, b);
    }
    let forces = body_gravity_regressor(&a);
    project_to_joints(data, N - 1, &forces, &mut out);
    out
}
