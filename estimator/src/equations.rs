//! Stacking of per-sample joint-torque equations Δτ_k = Y(q_k) x into one least-squares system,
//! and the per-joint residual RMS of the fit; shared by the static estimators and the
//! model-error calibration.

use nalgebra::{DMatrix, DVector, Dim, Matrix, RawStorage, SVector};

/// Rows (joints) that are non-zero (above 1e-9 of the largest entry) in at least one of the
/// regressors: a joint whose axis stays parallel to gravity (joint 1 of the LWR) carries no
/// information and would only add zero equations.
pub(crate) fn used_joints<R: Dim, C: Dim, S: RawStorage<f64, R, C>>(
    regs: &[Matrix<f64, R, C, S>],
) -> Vec<usize> {
    let scale = regs.iter().map(|y| y.amax()).fold(0.0, f64::max);
    let tol = 1e-9 * scale.max(f64::MIN_POSITIVE);
    let rows = regs.first().map_or(0, |y| y.nrows());
    (0..rows)
        .filter(|&j| regs.iter().any(|y| y.row(j).amax() > tol))
        .collect()
}

/// The stacked system (A, b) with `cols` unknowns: row k·|joints| + i is joint `joints[i]` of
/// sample k (its regressor row and its Δτ, Nm).
pub(crate) fn stack<R: Dim, C: Dim, S: RawStorage<f64, R, C>, const N: usize>(
    regs: &[Matrix<f64, R, C, S>],
    deltas: &[SVector<f64, N>],
    joints: &[usize],
    cols: usize,
) -> (DMatrix<f64>, DVector<f64>) {
    let rows = joints.len() * regs.len();
    let mut a = DMatrix::zeros(rows, cols);
    let mut b = DVector::zeros(rows);
    for (k, (y, d)) in regs.iter().zip(deltas).enumerate() {
        for (i, &j) in joints.iter().enumerate() {
            let r = k * joints.len() + i;
            for c in 0..cols {
                a[(r, c)] = y[(j, c)];
            }
            b[r] = d[j];
        }
    }
    (a, b)
}

/// RMS over the samples of each joint's residual, joint 1 first (Nm); empty input gives NaN.
pub(crate) fn per_joint_rms<const N: usize>(
    residuals: impl IntoIterator<Item = SVector<f64, N>>,
) -> Vec<f64> {
    let mut sq = [0.0; N];
    let mut samples = 0usize;
    for r in residuals {
        for (acc, v) in sq.iter_mut().zip(r.iter()) {
            *acc += v * v;
        }
        samples += 1;
    }
    sq.iter().map(|s| (s / samples as f64).sqrt()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix2, Vector2};

    #[test]
    fn stacks_used_joints_sample_by_sample() {
        // joint 1 row is zero in both samples: dropped
        let regs = [
            Matrix2::new(0.0, 0.0, 1.0, 2.0),
            Matrix2::new(0.0, 0.0, 3.0, 4.0),
        ];
        let deltas = [Vector2::new(9.0, 5.0), Vector2::new(9.0, 6.0)];
        let joints = used_joints(&regs);
        assert_eq!(joints, vec![1]);
        let (a, b) = stack(&regs, &deltas, &joints, 2);
        assert_eq!(a, DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 3.0, 4.0]));
        assert_eq!(b, DVector::from_row_slice(&[5.0, 6.0]));
    }

    #[test]
    fn rms_per_joint() {
        let rms = per_joint_rms([Vector2::new(3.0, 1.0), Vector2::new(-4.0, 1.0)]);
        assert_eq!(rms, vec![(12.5f64).sqrt(), 1.0]);
    }
}
