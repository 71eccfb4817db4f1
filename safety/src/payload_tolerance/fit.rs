//! Least-squares fits of the payload's gravity parameters θ = (m, h) to joint torques, inside
//! the plausible set ([`super::plausible`]): at one pose (before any static sample) and over the
//! static samples plus the current pose (after them).
//!
//! The data are load torques z = Y(q)·θ + (contact) \[Nm\], Y the payload gravity regressor
//! (`dynamics::payload_gravity_regressor`), weighted per joint by 1/θ_j² (θ_j the joint's
//! detection threshold), so the fit minimises what the detector would see.

use nalgebra::{Matrix4, Matrix4x3, SMatrix, SVector, UnitQuaternion, Vector3, Vector4};

use super::plausible::{FlangeLoadBounds, minimise_in_cone};

/// How much more a static sample weighs than one cycle of the running residual. A sample is
/// averaged at rest; its error is the static model error, about a tenth of a threshold (≤ 0.5 Nm
/// against 6 Nm on the simulated LWR, docs/collision-detection.md §4), so its weight relative to
/// a residual judged at the threshold is (θ/(0.1 θ))² = 100. The current pose can then move the
/// sampled directions of the fit by at most 1 % per sample and only the directions the samples
/// leave open (the centre of mass along gravity after one pose) are fitted to it.
pub const STATIC_SAMPLE_WEIGHT: f64 = 100.0;

/// Weighted normal equations (YᵀWY, YᵀWz) of one pose.
pub(crate) fn normal_equations<const N: usize>(
    y: &SMatrix<f64, N, 4>,
    z: &SVector<f64, N>,
    weights: &SVector<f64, N>,
) -> (Matrix4<f64>, Vector4<f64>) {
    let mut h = Matrix4::zeros();
    let mut g = Vector4::zeros();
    for j in 0..N {
        let row = y.row(j).transpose();
        h += row * row.transpose() * weights[j];
        g += row * (weights[j] * z[j]);
    }
    (h, g)
}

/// Per-joint weights 1/θ_j² \[1/Nm²\] from the thresholds \[Nm\].
pub(crate) fn weights<const N: usize>(thresholds: &SVector<f64, N>) -> SVector<f64, N> {
    thresholds.map(|t| if t > 0.0 { 1.0 / (t * t) } else { 0.0 })
}

/// Two unit vectors that span the plane normal to the unit vector `u` (with `u` a right-handed
/// frame): the directions a centre of mass can move without changing its gravity torque's
/// height along `u`.
pub(crate) fn normal_plane(u: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let helper = if u.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let e1 = u.cross(&helper).normalize();
    (e1, u.cross(&e1))
}

/// θ = T·x for the cone coordinates x = (m, w) of one pose: w = (α, β) spans the plane normal
/// to gravity (`gravity_in_last`, unit, last DH frame), and the centre of mass's height along
/// gravity, which no torque at this pose reveals, is put at the flange point's.
pub(crate) fn single_pose_frame(
    flange: &Vector3<f64>,
    gravity_in_last: &Vector3<f64>,
) -> Matrix4x3<f64> {
    let (e1, e2) = normal_plane(gravity_in_last);
    let mut t = Matrix4x3::zeros();
    t[(0, 0)] = 1.0;
    t.fixed_view_mut::<3, 1>(1, 0).copy_from(flange);
    t.fixed_view_mut::<3, 1>(1, 1).copy_from(&e1);
    t.fixed_view_mut::<3, 1>(1, 2).copy_from(&e2);
    t
}

/// θ = T·x for the full cone coordinates x = (m, h − m f).
pub(crate) fn full_frame(flange: &Vector3<f64>) -> Matrix4<f64> {
    let mut t = Matrix4::identity();
    t.fixed_view_mut::<3, 1>(1, 0).copy_from(flange);
    t
}

/// x = T⁻¹θ for [`full_frame`].
pub(crate) fn to_full_coordinates(flange: &Vector3<f64>, theta: &Vector4<f64>) -> Vector4<f64> {
    let mut x = *theta;
    let w: Vector3<f64> = theta.fixed_rows::<3>(1) - flange * theta[0];
    x.fixed_rows_mut::<3>(1).copy_from(&w);
    x
}

/// The plausible θ minimising the weighted misfit with normal equations (H, g) in θ, searched
/// in the coordinates θ = T x (T: [`single_pose_frame`] or [`full_frame`]); directions H does
/// not determine stay at `anchor` (x coordinates).
pub(crate) fn best_load<const D: usize>(
    t: &SMatrix<f64, 4, D>,
    h: &Matrix4<f64>,
    g: &Vector4<f64>,
    anchor: &SVector<f64, D>,
    bounds: &FlangeLoadBounds,
) -> Vector4<f64> {
    let hx = t.transpose() * h * t;
    let gx = t.transpose() * g;
    t * minimise_in_cone(&hx, &gx, anchor, bounds)
}

/// The plausible load that best explains the load torque `z` \[Nm\] at one pose (regressor
/// `y`, gravity direction `gravity_in_last` in the last DH frame).
pub(crate) fn fit_at_pose<const N: usize>(
    y: &SMatrix<f64, N, 4>,
    z: &SVector<f64, N>,
    weights: &SVector<f64, N>,
    flange: &Vector3<f64>,
    gravity_in_last: &Vector3<f64>,
    bounds: &FlangeLoadBounds,
) -> Vector4<f64> {
    let (h, g) = normal_equations(y, z, weights);
    let t = single_pose_frame(flange, gravity_in_last);
    best_load(&t, &h, &g, &Vector3::zeros(), bounds)
}

/// Unit direction of gravity in the last DH frame from the orientation of that frame in the
/// base (`rotation`, base ← last) and the base-frame gravity.
pub(crate) fn gravity_in_last(
    rotation: &UnitQuaternion<f64>,
    gravity: &Vector3<f64>,
) -> Vector3<f64> {
    let g = rotation.inverse_transform_vector(gravity);
    let n = g.norm();
    if n > 0.0 { g / n } else { Vector3::z() }
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynamics::{Data, forward_kinematics, payload_gravity_regressor};
    use nalgebra::SVector;

    const BOUNDS: FlangeLoadBounds = super::super::plausible::TEST_BOUNDS;

    #[test]
    fn one_pose_explains_a_plausible_load_and_not_a_lifting_or_sideways_push() {
        let model = dynamics::lwr4();
        let mut data = Data::new(&model);
        let q = SVector::<f64, 7>::from(dynamics::LWR4_PICK_POSE_RAD);
        let y = payload_gravity_regressor(&model, &mut data, &q);
        let rotation = forward_kinematics(&model, &mut data, &q)[6].rotation;
        let u = gravity_in_last(&rotation, &model.gravity());
        let flange = model.flange().translation.vector;
        let w = weights(&SVector::<f64, 7>::repeat(6.0));
        // The paper's payload: explained to the last digit.
        let theta = Vector4::new(3.028, 0.0, 0.0, 3.028 * 0.119);
        let z = y * theta;
        let fit = fit_at_pose(&y, &z, &w, &flange, &u, &BOUNDS);
        assert!((y * fit - z).amax() < 1e-6, "{}", y * fit - z);
        // A lifting force (negative mass): nothing of it is explained.
        let lift = y * Vector4::new(-2.0, 0.0, 0.0, -0.2);
        let fit = fit_at_pose(&y, &lift, &w, &flange, &u, &BOUNDS);
        assert!((y * fit - lift).amax() > 0.9 * lift.amax());
        // Heavier than the bound: only up to 7 kg is explained.
        let heavy = y * Vector4::new(12.0, 0.0, 0.0, 12.0 * 0.08);
        let fit = fit_at_pose(&y, &heavy, &w, &flange, &u, &BOUNDS);
        assert!((fit[0] - 7.0).abs() < 1e-6, "{fit}");
        assert!((y * fit - heavy).amax() > 1.0);
    }
}
