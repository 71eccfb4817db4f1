//! Test-only reference for the Coriolis matrix: the Christoffel symbols of the first kind of M(q),
//! C_ij = Σ_k ½ (∂M_ij/∂q_k + ∂M_ik/∂q_j − ∂M_jk/∂q_i) q̇_k, built from the crate's independent
//! O(n⁴) route to ∂M/∂q (M = Σ_b J_bᵀ I_b J_b). This was `coriolis_matrix` before the O(n²)
//! recursion replaced it.

use dynamics::{Data, Model, mass_matrix_partial_derivatives};
use nalgebra::{SMatrix, SVector};

/// C(q, q̇) from the Christoffel symbols of M, N·m·s/rad.
pub fn christoffel_coriolis_matrix<const N: usize>(
    model: &Model<N>,
    data: &mut Data<N>,
    q: &SVector<f64, N>,
    qd: &SVector<f64, N>,
) -> SMatrix<f64, N, N> {
    let dm = mass_matrix_partial_derivatives(model, data, q);
    SMatrix::from_fn(|i, j| {
        (0..N)
            .map(|k| 0.5 * (dm[k][(i, j)] + dm[j][(i, k)] - dm[i][(j, k)]) * qd[k])
            .sum()
    })
}
