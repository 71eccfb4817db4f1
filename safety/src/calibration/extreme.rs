//! Extreme-value fit of block maxima by L-moments (Hosking): Gumbel and GEV, return levels.

use serde::{Deserialize, Serialize};

use super::FitOptions;
use super::bootstrap::{bootstrap, quantile};
use super::gamma::gamma;

/// Extreme-value model of the block maxima.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ExtremeModel {
    /// Gumbel (shape 0).
    Gumbel,
    /// Generalised extreme value with a heavy (Fréchet-type) tail.
    Gev,
}

/// L-moment fit of block maxima: location μ, scale σ (> 0), GEV shape ξ (Hosking's k = −ξ;
/// ξ > 0 a heavy tail, ξ < 0 a bounded one), and the Gumbel fit of the same sample.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ExtremeFit {
    /// GEV location.
    pub location: f64,
    /// GEV scale.
    pub scale: f64,
    /// GEV shape ξ.
    pub shape: f64,
    /// Gumbel location.
    pub gumbel_location: f64,
    /// Gumbel scale.
    pub gumbel_scale: f64,
}

impl ExtremeFit {
    /// Fits `maxima` (at least three, not all equal).
    pub fn fit(maxima: &[f64]) -> Option<Self> {
        let n = maxima.len();
        if n < 3 {
            return None;
        }
        let mut x = maxima.to_vec();
        x.sort_by(f64::total_cmp);
        let nf = n as f64;
        let (mut b0, mut b1, mut b2) = (0.0, 0.0, 0.0);
        for (i, v) in x.iter().enumerate() {
            let i = i as f64;
            b0 += v;
            b1 += v * i / (nf - 1.0);
            b2 += v * i * (i - 1.0) / ((nf - 1.0) * (nf - 2.0));
        }
        b0 /= nf;
        b1 /= nf;
        b2 /= nf;
        let l1 = b0;
        let l2 = 2.0 * b1 - b0;
        let l3 = 6.0 * b2 - 6.0 * b1 + b0;
        if !(l2 > 0.0 && l2.is_finite()) {
            return None;
        }
        let t3 = l3 / l2;
        let c = 2.0 / (3.0 + t3) - 2f64.ln() / 3f64.ln();
        let k = (7.8590 * c + 2.9554 * c * c).clamp(-0.9, 0.9);
        let gumbel_scale = l2 / 2f64.ln();
        let gumbel_location = l1 - 0.577_215_664_901_532_9 * gumbel_scale;
        let (location, scale) = if k.abs() < 1e-6 {
            (gumbel_location, gumbel_scale)
        } else {
            let g = gamma(1.0 + k);
            let scale = l2 * k / ((1.0 - 2f64.powf(-k)) * g);
            (l1 - scale * (1.0 - g) / k, scale)
        };
        Some(Self {
            location,
            scale,
            shape: -k,
            gumbel_location,
            gumbel_scale,
        })
    }

    /// The level exceeded with probability `p` per block under `model`.
    pub fn return_level(&self, p: f64, model: ExtremeModel) -> f64 {
        // −ln(1 − p), accurate for tiny p.
        let y = -(-p).ln_1p();
        match model {
            ExtremeModel::Gumbel => self.gumbel_location - self.gumbel_scale * y.ln(),
            ExtremeModel::Gev => {
                let xi = self.shape;
                if xi.abs() < 1e-9 {
                    self.location - self.scale * y.ln()
                } else {
                    self.location + self.scale / xi * (y.powf(-xi) - 1.0)
                }
            }
        }
    }
}

/// The model for `maxima`: GEV when the bootstrap interval of the shape lies above zero (a
/// heavy tail: Gumbel would be too low), Gumbel otherwise (also for a bounded tail, where it is
/// conservative). Returns the model and the shape's 5–95 % interval.
pub(super) fn extreme_model<const N: usize>(
    maxima: &[f64],
    options: &FitOptions<N>,
) -> (ExtremeModel, [f64; 2]) {
    let shapes = bootstrap(maxima, options.resamples, options.seed ^ 0x5a, |s| {
        ExtremeFit::fit(s).map_or(f64::NAN, |f| f.shape)
    });
    let interval = [quantile(&shapes, 0.05), quantile(&shapes, 0.95)];
    let model = if interval[0] > 0.0 {
        ExtremeModel::Gev
    } else {
        ExtremeModel::Gumbel
    };
    (model, interval)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibration::rng::SplitMix64;

    /// Gumbel(μ, β) by inversion.
    fn gumbel(rng: &mut SplitMix64, mu: f64, beta: f64) -> f64 {
        mu - beta * (-(rng.uniform().max(1e-300)).ln()).ln()
    }

    #[test]
    fn l_moments_recover_a_gumbel_and_its_return_level() {
        let mut rng = SplitMix64(7);
        let x: Vec<f64> = (0..5000).map(|_| gumbel(&mut rng, 2.0, 0.5)).collect();
        let f = ExtremeFit::fit(&x).unwrap();
        assert!((f.gumbel_location - 2.0).abs() < 0.03, "{f:?}");
        assert!((f.gumbel_scale - 0.5).abs() < 0.03, "{f:?}");
        assert!(f.shape.abs() < 0.05, "{f:?}");
        // p = 1e-4: μ − β ln(−ln(1 − p)) = 2 + 0.5·9.21.
        let level = f.return_level(1e-4, ExtremeModel::Gumbel);
        assert!((level - (2.0 + 0.5 * 9.2103)).abs() < 0.25, "{level}");
        // The GEV with shape 0 agrees.
        let g = ExtremeFit {
            shape: 0.0,
            location: 2.0,
            scale: 0.5,
            gumbel_location: 2.0,
            gumbel_scale: 0.5,
        };
        assert!((g.return_level(1e-4, ExtremeModel::Gev) - (2.0 + 0.5 * 9.2103)).abs() < 1e-3);
    }
}
