//! The identification's design rows: per sample and joint j,
//! a = [Y_base,j | e_j | q̇_j e_j | tanh(q̇_j/v0) e_j] and y = τ_j − τ_nom,j (Nm), so that
//! y ≈ a·x with x = [δπ | offsets | viscous | Coulomb].

use dynamics::identified::base_regressor;
use dynamics::{Data, Model, rnea};

use super::Piece;

/// Joint terms per joint: offset, viscous, Coulomb.
pub(super) const JOINT_TERMS: usize = 3;

/// Calls `row(sample, piece, t, joint, a, y)` for every joint of every sample (see the module
/// docs; `columns` the base coefficients' link-parameter indices, `v0` rad/s).
pub(super) fn for_each_row<const N: usize>(
    model: &Model<N>,
    columns: &[usize],
    v0: f64,
    pieces: &[Piece<N>],
    mut row: impl FnMut(usize, usize, f64, usize, &[f64], f64),
) {
    let mut data = Data::new(model);
    let p = columns.len();
    let mut a = vec![0.0; p + JOINT_TERMS * N];
    let mut sample = 0;
    for (i, piece) in pieces.iter().enumerate() {
        for k in 0..piece.len() {
            let (q, qd, qdd) = (&piece.q[k], &piece.qd[k], &piece.qdd[k]);
            let y = base_regressor(model, &mut data, columns, q, qd, qdd);
            let nominal = rnea(model, &mut data, q, qd, qdd);
            for j in 0..N {
                a.iter_mut().for_each(|v| *v = 0.0);
                for c in 0..p {
                    a[c] = y[(j, c)];
                }
                a[p + j] = 1.0;
                a[p + N + j] = qd[j];
                a[p + 2 * N + j] = (qd[j] / v0).tanh();
                row(sample, i, piece.t[k], j, &a, piece.tau[k][j] - nominal[j]);
            }
            sample += 1;
        }
    }
}
