//! Normal equations of the identification, per cross-validation fold and joint, so that every
//! fold's fit and held-out error at every ridge weight come from the same sums:
//! held-out SSE_j(x) = Σy² − 2xᵀΣay + xᵀ(Σaaᵀ)x over the fold's rows of joint j.

use nalgebra::{DMatrix, DVector};

/// Sums Σaaᵀ, Σay and Σy² per (fold, joint), and samples per fold.
#[derive(Debug, Clone)]
pub(crate) struct Normal {
    cols: usize,
    joints: usize,
    gram: Vec<DMatrix<f64>>,
    rhs: Vec<DVector<f64>>,
    energy: Vec<f64>,
    samples: Vec<usize>,
}

impl Normal {
    /// Empty sums for `cols` unknowns, `folds` folds and `joints` joints.
    pub fn new(cols: usize, folds: usize, joints: usize) -> Self {
        Self {
            cols,
            joints,
            gram: vec![DMatrix::zeros(cols, cols); folds * joints],
            rhs: vec![DVector::zeros(cols); folds * joints],
            energy: vec![0.0; folds * joints],
            samples: vec![0; folds],
        }
    }

    /// Folds.
    pub fn folds(&self) -> usize {
        self.samples.len()
    }

    /// Adds joint `j`'s row `a` with target `y` to fold `f`; `first_joint` counts the sample.
    pub fn add(&mut self, f: usize, j: usize, a: &[f64], y: f64) {
        let i = f * self.joints + j;
        let g = &mut self.gram[i];
        for (r, ar) in a.iter().enumerate() {
            if *ar == 0.0 {
                continue;
            }
            for (c, ac) in a.iter().enumerate() {
                g[(r, c)] += ar * ac;
            }
            self.rhs[i][r] += ar * y;
        }
        self.energy[i] += y * y;
        if j == 0 {
            self.samples[f] += 1;
        }
    }

    /// Samples in fold `f` (`None`: all).
    pub fn samples(&self, f: Option<usize>) -> usize {
        match f {
            Some(f) => self.samples[f],
            None => self.samples.iter().sum(),
        }
    }

    /// Σ_j w_j·(Σaaᵀ, Σay) over all folds but `exclude` (`None`: all folds).
    pub fn weighted(&self, w: &[f64], exclude: Option<usize>) -> (DMatrix<f64>, DVector<f64>) {
        let mut g = DMatrix::zeros(self.cols, self.cols);
        let mut h = DVector::zeros(self.cols);
        for f in 0..self.folds() {
            if Some(f) == exclude {
                continue;
            }
            for (j, wj) in w.iter().enumerate().take(self.joints) {
                let i = f * self.joints + j;
                g += &self.gram[i] * *wj;
                h += &self.rhs[i] * *wj;
            }
        }
        (g, h)
    }

    /// Σ over folds (`None`) or one fold of joint j's squared residual at x.
    pub fn sse(&self, fold: Option<usize>, j: usize, x: &DVector<f64>) -> f64 {
        (0..self.folds())
            .filter(|f| fold.is_none_or(|g| g == *f))
            .map(|f| {
                let i = f * self.joints + j;
                self.energy[i] - 2.0 * x.dot(&self.rhs[i])
                    + (x.transpose() * &self.gram[i] * x)[(0, 0)]
            })
            .sum::<f64>()
            .max(0.0)
    }
}

/// x = (G + diag(penalty))⁻¹h restricted to the columns `free` (others zero); `None` when the
/// system is not positive definite.
pub(crate) fn solve(
    g: &DMatrix<f64>,
    h: &DVector<f64>,
    penalty: &DVector<f64>,
    free: &[usize],
) -> Option<DVector<f64>> {
    let n = free.len();
    let mut a = DMatrix::from_fn(n, n, |r, c| g[(free[r], free[c])]);
    for (r, &k) in free.iter().enumerate() {
        a[(r, r)] += penalty[k];
    }
    let b = DVector::from_fn(n, |r, _| h[free[r]]);
    let xs = a.cholesky()?.solve(&b);
    let mut x = DVector::zeros(g.nrows());
    for (r, &k) in free.iter().enumerate() {
        x[k] = xs[r];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// [`solve`] with the columns `non_negative` kept ≥ 0: a column that comes out negative is held
/// at zero and the others solved again, the most negative (by the torque it makes) first, until
/// none is. Friction takes energy out of an arm: a negative coefficient is model error fitted
/// as physics, and it grows with speed beyond the data. Returns the solution and the columns
/// left free.
pub(crate) fn solve_non_negative(
    g: &DMatrix<f64>,
    h: &DVector<f64>,
    penalty: &DVector<f64>,
    free: &[usize],
    non_negative: &[usize],
) -> Option<(DVector<f64>, Vec<usize>)> {
    let mut free = free.to_vec();
    loop {
        let x = solve(g, h, penalty, &free)?;
        let worst = free
            .iter()
            .copied()
            .filter(|c| non_negative.contains(c) && x[*c] < 0.0)
            .min_by(|a, b| {
                let torque = |c: usize| x[c] * g[(c, c)].max(0.0).sqrt();
                torque(*a).total_cmp(&torque(*b))
            });
        match worst {
            None => return Some((x, free)),
            Some(c) => free.retain(|k| *k != c),
        }
    }
}

/// (G + diag(penalty))⁻¹ on the columns `free` (others zero), for the covariance.
pub(crate) fn inverse(
    g: &DMatrix<f64>,
    penalty: &DVector<f64>,
    free: &[usize],
) -> Option<DMatrix<f64>> {
    let n = free.len();
    let mut a = DMatrix::from_fn(n, n, |r, c| g[(free[r], free[c])]);
    for (r, &k) in free.iter().enumerate() {
        a[(r, r)] += penalty[k];
    }
    let inv = a.cholesky()?.inverse();
    let mut out = DMatrix::zeros(g.nrows(), g.nrows());
    for (r, &kr) in free.iter().enumerate() {
        for (c, &kc) in free.iter().enumerate() {
            out[(kr, kc)] = inv[(r, c)];
        }
    }
    Some(out)
}

/// Condition number of the column-normalised Gram matrix's square root (that of the
/// column-normalised regressor); ∞ when a column is zero or the matrix is singular.
pub(crate) fn condition_number(g: &DMatrix<f64>) -> f64 {
    let d: Vec<f64> = (0..g.nrows()).map(|k| g[(k, k)]).collect();
    if d.iter().any(|v| v.is_nan() || *v <= 0.0) {
        return f64::INFINITY;
    }
    let n = DMatrix::from_fn(g.nrows(), g.ncols(), |r, c| {
        g[(r, c)] / (d[r] * d[c]).sqrt()
    });
    let e = n.symmetric_eigenvalues();
    let (lo, hi) = (e.min(), e.max());
    if lo > 0.0 {
        (hi / lo).sqrt()
    } else {
        f64::INFINITY
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn held_out_error_from_the_sums_equals_the_direct_one() {
        let rows = [
            ([1.0, 2.0], 3.0),
            ([0.5, -1.0], 0.2),
            ([2.0, 0.1], 1.0),
            ([-1.0, 1.0], 0.7),
        ];
        let mut n = Normal::new(2, 2, 1);
        for (k, (a, y)) in rows.iter().enumerate() {
            n.add(k % 2, 0, a, *y);
        }
        let x = DVector::from_column_slice(&[0.3, -0.4]);
        let direct: f64 = rows
            .iter()
            .enumerate()
            .filter(|(k, _)| k % 2 == 1)
            .map(|(_, (a, y))| (y - a[0] * x[0] - a[1] * x[1]).powi(2))
            .sum();
        assert!((n.sse(Some(1), 0, &x) - direct).abs() < 1e-12);
        let (g, h) = n.weighted(&[1.0], Some(1));
        let fit = solve(&g, &h, &DVector::zeros(2), &[0, 1]).unwrap();
        // fold 0 alone: rows 0 and 2, an exact 2×2 solve
        assert!((fit[0] * 1.0 + fit[1] * 2.0 - 3.0).abs() < 1e-9);
        assert!((fit[0] * 2.0 + fit[1] * 0.1 - 1.0).abs() < 1e-9);
        assert_eq!(n.samples(None), 4);
    }
}
