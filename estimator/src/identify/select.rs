//! The prior's weight λ chosen on held-out segments: every candidate fitted on all folds but
//! one and scored on that one, friction kept ≥ 0 in every fit; the lowest weighted held-out
//! error among the candidates that are no worse than the nominal model on any joint.

use nalgebra::{DMatrix, DVector};

use super::CvPoint;
use super::normal::{Normal, solve_non_negative};

/// Relative ridge on the offsets and friction (numerical only: they are not pulled anywhere).
pub(super) const JOINT_TERM_RIDGE: f64 = 1e-9;

/// λ candidates, ascending: 0 (free fit), 10^(−8 + k/2) for k = 0..=20, and ∞ (`None`: the
/// nominal coefficients, offsets and friction only).
pub(super) fn candidates() -> Vec<Option<f64>> {
    let mut c = vec![Some(0.0)];
    c.extend((0..=20).map(|k| Some(10f64.powf(-8.0 + 0.5 * f64::from(k)))));
    c.push(None);
    c
}

/// The weighted ridge problem of one identification: `p` base coefficients first, then the
/// joint terms (offsets, then the non-negative friction columns `friction`).
pub(super) struct Ridge<'a> {
    /// Sums per fold and joint.
    pub sums: &'a Normal,
    /// Joint weights, 1/Nm².
    pub weights: &'a [f64],
    /// Base coefficients.
    pub p: usize,
    /// Columns that may not be negative.
    pub friction: Vec<usize>,
    /// Per column, the mean weighted square of its regressor (the prior's metric).
    pub scale: Vec<f64>,
}

impl Ridge<'_> {
    fn columns(&self) -> usize {
        self.scale.len()
    }

    /// The prior's diagonal for `rows` samples at `lambda`.
    pub fn penalty(&self, lambda: Option<f64>, rows: usize) -> DVector<f64> {
        let floor = self.scale.iter().copied().fold(0.0, f64::max) * 1e-12;
        DVector::from_fn(self.columns(), |c, _| {
            let w = if c < self.p {
                lambda.unwrap_or(0.0).max(JOINT_TERM_RIDGE)
            } else {
                JOINT_TERM_RIDGE
            };
            w * self.scale[c].max(floor) * rows as f64
        })
    }

    /// The columns fitted at `lambda` (at ∞ the base coefficients stay nominal).
    pub fn free(&self, lambda: Option<f64>) -> Vec<usize> {
        let from = if lambda.is_some() { 0 } else { self.p };
        (from..self.columns()).collect()
    }

    /// The fit of sums (g, h) over `rows` samples at `lambda`, and the columns left free.
    pub fn fit(
        &self,
        g: &DMatrix<f64>,
        h: &DVector<f64>,
        lambda: Option<f64>,
        rows: usize,
    ) -> Option<(DVector<f64>, Vec<usize>)> {
        solve_non_negative(
            g,
            h,
            &self.penalty(lambda, rows),
            &self.free(lambda),
            &self.friction,
        )
    }

    /// Every fold's fit at `lambda` (fitted on the other folds); `None` if one is singular.
    pub fn fold_fits(&self, lambda: Option<f64>) -> Option<Vec<DVector<f64>>> {
        let total = self.sums.samples(None);
        (0..self.sums.folds())
            .map(|f| {
                let (g, h) = self.sums.weighted(self.weights, Some(f));
                self.fit(&g, &h, lambda, total - self.sums.samples(Some(f)))
                    .map(|(x, _)| x)
            })
            .collect()
    }

    /// The held-out curve over [`candidates`], λ ascending.
    pub fn curve(&self) -> Vec<CvPoint> {
        let sums = self.sums;
        let total = sums.samples(None);
        let joints = self.weights.len();
        let complements: Vec<(DMatrix<f64>, DVector<f64>, usize)> = (0..sums.folds())
            .map(|f| {
                let (g, h) = sums.weighted(self.weights, Some(f));
                (g, h, total - sums.samples(Some(f)))
            })
            .collect();
        candidates()
            .into_iter()
            .map(|lambda| {
                let mut sse = vec![0.0; joints];
                let mut ok = true;
                for (f, (g, h, rows)) in complements.iter().enumerate() {
                    match self.fit(g, h, lambda, *rows) {
                        Some((x, _)) => {
                            for (j, s) in sse.iter_mut().enumerate() {
                                *s += sums.sse(Some(f), j, &x);
                            }
                        }
                        None => ok = false,
                    }
                }
                let rms = |s: &f64| {
                    if ok {
                        (s / total as f64).sqrt()
                    } else {
                        f64::NAN
                    }
                };
                CvPoint {
                    weight: lambda,
                    heldout_rms: sse.iter().map(rms).collect(),
                    score: if ok {
                        sse.iter().zip(self.weights).map(|(s, w)| s * w).sum()
                    } else {
                        f64::NAN
                    },
                }
            })
            .collect()
    }
}

/// The weight chosen: the lowest held-out score among the candidates no worse than `nominal`
/// (the nominal model's RMS on the same samples, Nm) on any joint; when none is, the lowest
/// score. `None` when every candidate was singular.
pub(super) fn choose(cv: &[CvPoint], nominal: &[f64]) -> Option<Option<f64>> {
    let no_worse = |c: &CvPoint| {
        c.heldout_rms
            .iter()
            .zip(nominal)
            .all(|(r, n)| r.is_finite() && r <= n)
    };
    let best = |admissible: &dyn Fn(&CvPoint) -> bool| {
        cv.iter()
            .filter(|c| c.score.is_finite() && admissible(c))
            .min_by(|a, b| a.score.total_cmp(&b.score))
            .map(|c| c.weight)
    };
    best(&no_worse).or_else(|| best(&|_| true))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(weight: Option<f64>, rms: [f64; 2], score: f64) -> CvPoint {
        CvPoint {
            weight,
            heldout_rms: rms.to_vec(),
            score,
        }
    }

    #[test]
    fn the_best_score_no_worse_than_nominal_on_any_joint_is_chosen() {
        let cv = [
            point(Some(0.0), [0.1, 0.9], 1.0),
            point(Some(1.0), [0.3, 0.4], 2.0),
            point(None, [0.5, 0.5], 3.0),
        ];
        // the free fit scores best but is worse than nominal on joint 2
        assert_eq!(choose(&cv, &[0.6, 0.5]), Some(Some(1.0)));
        // nothing is no worse than nominal: the best score
        assert_eq!(choose(&cv, &[0.05, 0.05]), Some(Some(0.0)));
        // a singular candidate never counts
        let nan = [point(Some(0.0), [f64::NAN; 2], f64::NAN)];
        assert_eq!(choose(&nan, &[1.0, 1.0]), None);
    }
}
