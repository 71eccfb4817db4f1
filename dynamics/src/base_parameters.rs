//! Numerical base parameters: QR with column pivoting of a regressor stacked over random states
//! finds which parameter combinations the dynamics can see (offline; uses heap matrices).

use nalgebra::{DMatrix, SVector};

use crate::data::Data;
use crate::model::Model;
use crate::regressor::{gravity_regressor, joint_torque_regressor};

/// Result of the base-parameter analysis of a stacked regressor W (rows: samples × joints,
/// columns: parameters p).
#[derive(Debug, Clone, PartialEq)]
pub struct BaseParameters {
    /// Number of base parameters (numerical rank of W).
    pub rank: usize,
    /// Parameter (column) indices chosen as base, in pivot order.
    pub independent: Vec<usize>,
    /// The remaining parameter indices, whose effect is regrouped into the base ones.
    pub dependent: Vec<usize>,
    /// rank × P map K with π = K p, so that W p = W[:, independent] π for every p.
    pub map: DMatrix<f64>,
    /// |R_kk| of the pivoted QR, descending; shows how clear the rank decision was.
    pub pivots: Vec<f64>,
}

/// Which regressor to analyse.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RegressorKind {
    /// The full n × 10n joint torque regressor (random q, q̇, q̈).
    Full,
    /// The static n × 4n gravity regressor (random q).
    Gravity,
}

/// Deterministic generator for the random states (SplitMix64), so results are reproducible
/// without a dependency on `rand`.
struct SplitMix64(u64);

impl SplitMix64 {
    fn next_unit(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        // 53 random bits mapped to [−1, 1).
        (z >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }
}

/// Base parameters of `model`'s regressor of `kind`, stacked over `samples` random states drawn
/// with `seed` (positions uniform within ±π, clipped to the limits; velocities and accelerations
/// uniform in ±2).
pub fn base_parameters<const N: usize>(
    model: &Model<N>,
    kind: RegressorKind,
    samples: usize,
    seed: u64,
) -> BaseParameters {
    let mut rng = SplitMix64(seed);
    let limits = model.limits();
    let states: Vec<[SVector<f64, N>; 3]> = (0..samples)
        .map(|_| {
            let q = SVector::<f64, N>::from_fn(|i, _| {
                let lo = limits.position_min[i].max(-std::f64::consts::PI);
                let hi = limits.position_max[i].min(std::f64::consts::PI);
                lo + (hi - lo) * 0.5 * (rng.next_unit() + 1.0)
            });
            let qd = SVector::<f64, N>::from_fn(|_, _| 2.0 * rng.next_unit());
            let qdd = SVector::<f64, N>::from_fn(|_, _| 2.0 * rng.next_unit());
            [q, qd, qdd]
        })
        .collect();
    let stacked = match kind {
        RegressorKind::Full => {
            let mut data = Data::new(model);
            let mut stacked = DMatrix::<f64>::zeros(samples * N, 10 * N);
            for (s, [q, qd, qdd]) in states.iter().enumerate() {
                let blocks = joint_torque_regressor(model, &mut data, q, qd, qdd);
                for (b, block) in blocks.iter().enumerate() {
                    stacked.view_mut((s * N, 10 * b), (N, 10)).copy_from(block);
                }
            }
            stacked
        }
        RegressorKind::Gravity => {
            let poses: Vec<SVector<f64, N>> = states.iter().map(|[q, ..]| *q).collect();
            stacked_gravity_regressor(model, &poses)
        }
    };
    base_parameters_of_columns(&stacked, 1e-9, ColumnChoice::LargestFirst)
}

/// The gravity regressors Y_g(q) (N × 4N, Nm per kg and kg·m) of `poses` (rad) stacked into one
/// (poses·N) × 4N matrix, pose by pose.
pub fn stacked_gravity_regressor<const N: usize>(
    model: &Model<N>,
    poses: &[SVector<f64, N>],
) -> DMatrix<f64> {
    let mut data = Data::new(model);
    let mut stacked = DMatrix::<f64>::zeros(poses.len() * N, 4 * N);
    for (s, q) in poses.iter().enumerate() {
        let blocks = gravity_regressor(model, &mut data, q);
        for (b, block) in blocks.iter().enumerate() {
            stacked.view_mut((s * N, 4 * b), (N, 4)).copy_from(block);
        }
    }
    stacked
}

/// Which columns of a regressor become the base parameters.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ColumnChoice {
    /// The largest remaining column first (QR with column pivoting): the best-conditioned base;
    /// a column counts when |R_kk| > tolerance·|R_00|.
    LargestFirst,
    /// The first independent columns in their given order (Gram–Schmidt order), so that every
    /// dependent parameter is regrouped into parameters listed before it; a column counts when
    /// more than tolerance·(largest column norm) of it remains after projection.
    InOrder,
}

/// Base parameters of a stacked regressor `w` by Householder QR with columns chosen by `choice`
/// (`relative_tolerance` is dimensionless, see [`ColumnChoice`]).
pub fn base_parameters_of_columns(
    w: &DMatrix<f64>,
    relative_tolerance: f64,
    choice: ColumnChoice,
) -> BaseParameters {
    let (rows, cols) = w.shape();
    let mut a = w.clone();
    let mut perm: Vec<usize> = (0..cols).collect();
    let steps = rows.min(cols);
    let mut pivots = Vec::with_capacity(steps);
    let scale = (0..cols).map(|c| w.column(c).norm()).fold(0.0, f64::max);
    let in_order_tolerance = relative_tolerance * scale.max(f64::MIN_POSITIVE);
    let remaining = |a: &DMatrix<f64>, k: usize, j: usize| a.view((k, j), (rows - k, 1)).norm();
    for k in 0..steps {
        match choice {
            ColumnChoice::LargestFirst => {
                // Pivot: the remaining column with the largest norm below row k.
                let mut best = k;
                let mut best_norm = -1.0;
                for j in k..cols {
                    let norm = remaining(&a, k, j);
                    if norm > best_norm {
                        best_norm = norm;
                        best = j;
                    }
                }
                a.swap_columns(k, best);
                perm.swap(k, best);
            }
            ColumnChoice::InOrder => {
                // The next column (in order) with something left; the skipped, dependent ones
                // move behind it in their order.
                let Some(next) = (k..cols).find(|&j| remaining(&a, k, j) > in_order_tolerance)
                else {
                    break;
                };
                for j in (k..next).rev() {
                    a.swap_columns(j, j + 1);
                }
                perm[k..=next].rotate_right(1);
            }
        }
        let x = a.view((k, k), (rows - k, 1)).into_owned();
        let norm = x.norm();
        if norm == 0.0 {
            pivots.push(0.0);
            break;
        }
        let alpha = if x[0] > 0.0 { -norm } else { norm };
        let mut v = x;
        v[0] -= alpha;
        let v_norm = v.norm();
        if v_norm > 0.0 {
            v /= v_norm;
            let mut block = a.view_mut((k, k), (rows - k, cols - k));
            let projection = v.transpose() * &block;
            block -= &v * projection * 2.0;
        }
        pivots.push(a[(k, k)].abs());
    }
    let rank = match choice {
        ColumnChoice::LargestFirst => {
            let reference = pivots.first().copied().unwrap_or(0.0);
            pivots
                .iter()
                .take_while(|p| **p > relative_tolerance * reference && **p > 0.0)
                .count()
        }
        ColumnChoice::InOrder => pivots.iter().take_while(|p| **p > 0.0).count(),
    };
    // π = p_independent + R1⁻¹ R2 p_dependent.
    let r1 = a.view((0, 0), (rank, rank)).upper_triangle();
    let r2 = a.view((0, rank), (rank, cols - rank)).into_owned();
    let beta = r1
        .solve_upper_triangular(&r2)
        .unwrap_or_else(|| DMatrix::zeros(rank, cols - rank));
    let mut map = DMatrix::<f64>::zeros(rank, cols);
    for i in 0..rank {
        map[(i, perm[i])] = 1.0;
    }
    for j in 0..(cols - rank) {
        for i in 0..rank {
            let value = beta[(i, j)];
            // Regrouping coefficients are kinematic constants; round-off below 1e-10 is noise.
            map[(i, perm[rank + j])] = if value.abs() < 1e-10 { 0.0 } else { value };
        }
    }
    BaseParameters {
        rank,
        independent: perm[..rank].to_vec(),
        dependent: perm[rank..].to_vec(),
        map,
        pivots,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn in_order_keeps_the_first_independent_columns() {
        // Columns: c0, 2·c0 (dependent), c1, c0 + c1 (dependent).
        let w = DMatrix::from_row_slice(
            3,
            4,
            &[1.0, 2.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 1.0, 2.0, 1.0, 2.0],
        );
        let b = base_parameters_of_columns(&w, 1e-8, ColumnChoice::InOrder);
        assert_eq!(
            (b.rank, b.independent.clone(), b.dependent.clone()),
            (2, vec![0, 2], vec![1, 3])
        );
        let p = nalgebra::DVector::from_column_slice(&[1.0, 2.0, 3.0, 4.0]);
        let base = DMatrix::from_fn(3, 2, |r, c| w[(r, b.independent[c])]);
        assert!((&w * &p - base * (&b.map * &p)).amax() < 1e-12);
        let zero = base_parameters_of_columns(&DMatrix::zeros(3, 2), 1e-8, ColumnChoice::InOrder);
        assert_eq!((zero.rank, zero.dependent), (0, vec![0, 1]));
    }
}
