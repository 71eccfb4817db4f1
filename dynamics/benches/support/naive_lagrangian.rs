//! Yardstick for the benchmarks: the textbook Jacobian-sum ("naive Lagrangian") computation of
//! M(q) and g(q), with every Jacobian rebuilt from scratch from the chained link poses.
#![allow(clippy::needless_range_loop, dead_code)]

use dynamics::Model;
use nalgebra::{Isometry3, Point3, SMatrix, SVector, Vector3};

/// M(q) = Σ_b J_v,bᵀ m_b J_v,b + J_ω,bᵀ R_b I_c,b R_bᵀ J_ω,b and g(q) = −Σ_b J_v,bᵀ m_b g, with
/// every Jacobian built from scratch from the chained link poses.
pub fn naive_mass_and_gravity<const N: usize>(
    model: &Model<N>,
    q: &SVector<f64, N>,
) -> (SMatrix<f64, N, N>, SVector<f64, N>) {
    let mut poses = [Isometry3::identity(); N];
    let mut axes = [Vector3::zeros(); N];
    let mut points = [Vector3::zeros(); N];
    let mut parent = Isometry3::identity();
    for i in 0..N {
        let joint = &model.joints()[i];
        parent *= joint.link_pose(q[i]);
        poses[i] = parent;
        axes[i] = parent.rotation * joint.axis_in_link();
        // A point on joint i's axis: the joint frame origin, i.e. link origin minus B.
        let joint_frame = parent * joint.body_in_joint().inverse();
        points[i] = joint_frame.translation.vector;
    }
    let mut mass = SMatrix::<f64, N, N>::zeros();
    let mut gravity = SVector::<f64, N>::zeros();
    for b in 0..N {
        let link = &model.links()[b];
        let com_local = link.com().unwrap_or_else(Vector3::zeros);
        let com = (poses[b] * Point3::from(com_local)).coords;
        let mut jv = SMatrix::<f64, 3, N>::zeros();
        let mut jw = SMatrix::<f64, 3, N>::zeros();
        for j in 0..=b {
            jv.set_column(j, &axes[j].cross(&(com - points[j])));
            jw.set_column(j, &axes[j]);
        }
        let r = poses[b].rotation.to_rotation_matrix().into_inner();
        let inertia = r * link.inertia_about_com() * r.transpose();
        mass += jv.transpose() * jv * link.mass + jw.transpose() * inertia * jw;
        gravity -= jv.transpose() * model.gravity() * link.mass;
    }
    (mass, gravity)
}
