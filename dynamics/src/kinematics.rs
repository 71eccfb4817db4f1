//! Forward kinematics and geometric Jacobians.

use nalgebra::{Isometry3, Rotation3, SMatrix, SVector, Translation3, UnitQuaternion, Vector3};

use crate::data::Data;
use crate::model::Model;
use crate::spatial::Pose;

/// Fills `data.link_in_parent` for configuration `q`.
#[inline]
pub(crate) fn update_link_poses<const N: usize>(
    model: &Model<N>,
    data: &mut Data<N>,
    q: &SVector<f64, N>,
) {
    for (i, joint) in model.joints().iter().enumerate() {
        data.link_in_parent[i] = joint.pose(q[i]);
    }
}

/// Fills `data.link_in_parent` and `data.link_in_base` for configuration `q`.
pub(crate) fn update_world_poses<const N: usize>(
    model: &Model<N>,
    data: &mut Data<N>,
    q: &SVector<f64, N>,
) {
    update_link_poses(model, data, q);
    let mut parent = Pose::IDENTITY;
    for i in 0..N {
        parent = parent.compose(&data.link_in_parent[i]);
        data.link_in_base[i] = parent;
    }
}

fn to_isometry(pose: &Pose) -> Isometry3<f64> {
    let rotation =
        UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(pose.rot));
    Isometry3::from_parts(Translation3::from(pose.trans), rotation)
}

/// Pose of every link frame (e.g. DH frame i) in the base frame at joint positions `q` (rad / m).
pub fn forward_kinematics<const N: usize>(
    model: &Model<N>,
    data: &mut Data<N>,
    q: &SVector<f64, N>,
) -> [Isometry3<f64>; N] {
    update_world_poses(model, data, q);
    std::array::from_fn(|i| to_isometry(&data.link_in_base[i]))
}

/// Flange pose in the base frame at joint positions `q`.
pub fn flange_pose<const N: usize>(
    model: &Model<N>,
    data: &mut Data<N>,
    q: &SVector<f64, N>,
) -> Isometry3<f64> {
    update_world_poses(model, data, q);
    match data.link_in_base.last() {
        Some(last) => to_isometry(last) * model.flange(),
        None => model.flange(),
    }
}

/// Geometric Jacobian of a point fixed on link `link` (0-based; `point_in_link` in m, link frame):
/// rows 0-2 map q̇ to the point's linear velocity, rows 3-5 to the link's angular velocity, both
/// in the base frame. A `link` ≥ N gives the zero matrix.
pub fn point_jacobian<const N: usize>(
    model: &Model<N>,
    data: &mut Data<N>,
    q: &SVector<f64, N>,
    link: usize,
    point_in_link: &Vector3<f64>,
) -> SMatrix<f64, 6, N> {
    let mut jacobian = SMatrix::<f64, 6, N>::zeros();
    if link >= N {
        return jacobian;
    }
    update_world_poses(model, data, q);
    let frame = &data.link_in_base[link];
    let point = frame.rot * point_in_link + frame.trans;
    for j in 0..=link {
        // Joint j's unit twist in the base frame, at the base origin.
        let s = data.link_in_base[j].motion_to_parent(model.joints()[j].motion_subspace());
        let v = s.lin + s.ang.cross(&point);
        jacobian.fixed_view_mut::<3, 1>(0, j).copy_from(&v);
        jacobian.fixed_view_mut::<3, 1>(3, j).copy_from(&s.ang);
    }
    jacobian
}

/// Geometric Jacobian of the flange frame (rows: linear velocity of the flange origin; angular
/// velocity), base frame.
pub fn flange_jacobian<const N: usize>(
    model: &Model<N>,
    data: &mut Data<N>,
    q: &SVector<f64, N>,
) -> SMatrix<f64, 6, N> {
    let point = model.flange().translation.vector;
    point_jacobian(model, data, q, N.saturating_sub(1), &point)
}
