//! Composite rigid body algorithm for the joint-space mass matrix.

use nalgebra::{SMatrix, SVector};

use crate::data::Data;
use crate::kinematics::update_link_poses;
use crate::model::Model;

/// Joint-space mass (inertia) matrix M(q), kg·m² (symmetric, both triangles filled), by the
/// composite rigid body algorithm.
pub fn crba<const N: usize>(
    model: &Model<N>,
    data: &mut Data<N>,
    q: &SVector<f64, N>,
) -> SMatrix<f64, N, N> {
    update_link_poses(model, data, q);
    data.composite = *model.links();
    for i in (1..N).rev() {
        let pose = &data.link_in_parent[i];
        let moved = data.composite[i].transformed(&pose.rot, &pose.trans);
        data.composite[i - 1] = data.composite[i - 1].plus(&moved);
    }
    let mut mass = SMatrix::<f64, N, N>::zeros();
    for i in 0..N {
        let s_i = model.joints()[i].motion_subspace();
        let mut f = data.composite[i].apply(s_i);
        mass[(i, i)] = s_i.dot(&f);
        for j in (0..i).rev() {
            f = data.link_in_parent[j + 1].force_to_parent(&f);
            let m_ij = model.joints()[j].motion_subspace().dot(&f);
            mass[(i, j)] = m_ij;
            mass[(j, i)] = m_ij;
        }
    }
    mass
}
