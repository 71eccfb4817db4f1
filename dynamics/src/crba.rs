//! Composite rigid body algorithm for the joint-space mass matrix.

use nalgebra::{SMatrix, SVector};

use crate::data::Data;
use crate::joint_frames::{inertia_times_unit_motion, project, project_in_parent};
use crate::model::Model;

/// Joint-space mass (inertia) matrix M(q), kg·m² (symmetric, both triangles filled), by the
/// composite rigid body algorithm.
///
/// Everything is expressed in the moving joint frames, where each S_j is a unit vector along z:
/// I_k S_k is a column of the composite inertia and M_jk = S_jᵀ f one component of f, so the only
/// arithmetic left is one inertia transform per joint and one force transform per pair 0 < j < k
/// (into joint frame 0 only the one component that joint reads).
pub fn crba<const N: usize>(
    model: &Model<N>,
    data: &mut Data<N>,
    q: &SVector<f64, N>,
) -> SMatrix<f64, N, N> {
    let frames = model.joint_frames();
    for i in 0..N {
        data.joint_in_previous[i] = frames.pose(i, q[i]);
    }
    data.composite = *frames.links();
    for i in (1..N).rev() {
        let pose = &data.joint_in_previous[i];
        let moved = data.composite[i].transformed(&pose.rot, &pose.trans);
        data.composite[i - 1] = data.composite[i - 1].plus(&moved);
    }
    let mut mass = SMatrix::<f64, N, N>::zeros();
    for k in 0..N {
        let mut f = inertia_times_unit_motion(frames.kind(k), &data.composite[k]);
        mass[(k, k)] = project(frames.kind(k), &f);
        for j in (1..k).rev() {
            f = data.joint_in_previous[j + 1].force_to_parent(&f);
            let m_jk = project(frames.kind(j), &f);
            mass[(j, k)] = m_jk;
            mass[(k, j)] = m_jk;
        }
        // f is in joint frame 1 now; joint 0 needs one component of it in frame 0.
        if k > 0 {
            let m_0k = project_in_parent(frames.kind(0), &data.joint_in_previous[1], &f);
            mass[(0, k)] = m_0k;
            mass[(k, 0)] = m_0k;
        }
    }
    mass
}
