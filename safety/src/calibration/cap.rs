//! The constant cap of a scheduled threshold: θ_j(φ) = min(s_j·e_j(φ), cap_j).
//!
//! The envelope is a scale model fitted where the recording moved; at the recording's largest
//! accelerations it extrapolates (the real LWR 4+'s joint 2: 20.6 Nm scheduled where its
//! residual peaked at 2.6 Nm). The same recording also supports a constant threshold: the Gumbel
//! return level of the raw block maxima of |r_j|. The minimum of the two is exceeded only when
//! one of them is, so with each fitted for half of the joint's probability (union bound) the
//! minimum meets the budget too, and it is never above the constant the data support.
//!
//! Where the raw maxima are heavy-tailed, their level lies below the largest of them (an edge
//! transient, a regime the recording holds once), or above the stated constant
//! ([`super::FitOptions::fallback_nm`], by default the paper's 6 Nm), the data cannot support
//! the budget with a constant at most that size: the cap is the stated constant and the result
//! says so ([`CapSource::Fallback`]) — never the service's ceiling, where nothing is detected.

use serde::{Deserialize, Serialize};

use super::FitOptions;
use super::bootstrap::{bootstrap, quantile};
use super::extreme::{ExtremeFit, TailShape, tail_shape};

/// Where a joint's cap came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum CapSource {
    /// The return level of the recording's raw block maxima, at most the stated constant.
    Fitted,
    /// The stated constant: the data support no constant at most that size for the budget
    /// (expect more false alarms than the budget where the cap binds).
    Fallback,
}

impl CapSource {
    /// The name in reports and on the wire: `fitted` or `fallback`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Fitted => "fitted",
            Self::Fallback => "fallback",
        }
    }
}

/// A joint's cap and how it was obtained.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Cap {
    /// The cap in force \[Nm\] (within the options' floor and ceiling).
    pub nm: f64,
    /// The constant the recording supports for the budget \[Nm\] (the bootstrap's upper bound at
    /// the options' confidence; infinite when the raw maxima are heavy-tailed).
    pub fitted_nm: f64,
    /// Fitted or the stated fallback.
    pub source: CapSource,
}

/// The cap of joint `j` from its raw block maxima `maxima` \[Nm\], each block exceeding it with
/// probability `p_block` at most; `largest` \[Nm\] is the recording's largest |r_j| (with the
/// windows after the last whole block, where a filter's edge transient sits).
pub(super) fn constant_cap<const N: usize>(
    maxima: &[f64],
    largest: f64,
    p_block: f64,
    j: usize,
    options: &FitOptions<N>,
) -> Cap {
    let level =
        |sample: &[f64]| ExtremeFit::fit(sample).map_or(f64::NAN, |f| f.return_level(p_block));
    let point = level(maxima);
    let boot = bootstrap(
        maxima,
        options.resamples,
        options.seed ^ 0xca9 ^ j as u64,
        level,
    );
    let upper = quantile(&boot, options.confidence);
    let (tail, _) = tail_shape(maxima, options);
    let fitted_nm = match tail {
        TailShape::Heavy => f64::INFINITY,
        TailShape::Gumbel => upper.max(point),
    };
    // A level below a residual the recording holds is one that recording already contradicts
    // (it should be exceeded once in 1/p blocks): not supported either.
    let fallback = options.fallback_nm[j];
    let (nm, source) = if fitted_nm.is_finite() && fitted_nm <= fallback && fitted_nm > largest {
        (fitted_nm, CapSource::Fitted)
    } else {
        (fallback, CapSource::Fallback)
    };
    Cap {
        nm: nm.clamp(options.floor_nm[j], options.ceiling_nm[j]),
        fitted_nm,
        source,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibration::rng::SplitMix64;

    #[test]
    fn gaussian_maxima_give_a_fitted_cap_and_a_loud_joint_the_stated_constant() {
        let options = FitOptions::<2>::new(1e-3);
        let p = 0.1 / 2.0 / 3600.0 / 2.0;
        let mut rng = SplitMix64(5);
        // Block maxima of |N(0, σ²)| over 1000 samples: ≈ σ·3.2 with a Gumbel spread.
        let maxima = |rng: &mut SplitMix64, sigma: f64| -> Vec<f64> {
            (0..40)
                .map(|_| {
                    (0..1000)
                        .map(|_| {
                            let (u1, u2) = (rng.uniform().max(1e-300), rng.uniform());
                            let g = (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
                            (sigma * g).abs()
                        })
                        .fold(0.0, f64::max)
                })
                .collect()
        };
        let quiet = maxima(&mut rng, 0.3);
        let peak = quiet.iter().copied().fold(0.0, f64::max);
        let cap = constant_cap(&quiet, peak, p, 0, &options);
        let quiet_level = cap.fitted_nm;
        assert_eq!(cap.source, CapSource::Fitted, "{cap:?}");
        // Above everything recorded, and within a small multiple of it (a light tail).
        assert!(cap.nm > peak && cap.nm < 3.0 * peak, "{cap:?} vs {peak}");
        assert_eq!(cap.nm, cap.fitted_nm);
        // A joint whose recording would need more than 6 Nm gets the stated 6 Nm, and says so.
        let loud = maxima(&mut rng, 2.0);
        let cap = constant_cap(&loud, 6.5, p, 1, &options);
        assert_eq!(cap.source, CapSource::Fallback, "{cap:?}");
        assert_eq!(cap.nm, 6.0);
        assert!(cap.fitted_nm > 6.0, "{cap:?}");
        // The stated constant is the user's: raised, the same recording fits under it.
        let mut wide = options;
        wide.fallback_nm[1] = 20.0;
        let cap = constant_cap(&loud, 6.5, p, 1, &wide);
        assert_eq!(cap.source, CapSource::Fitted, "{cap:?}");
        assert!(cap.nm > 6.0 && cap.nm < 20.0, "{cap:?}");
        // The recording holds a residual above the blocks' level (a filter's edge transient
        // after the last whole block): it contradicts that constant, so the stated one is used.
        let cap = constant_cap(&quiet, 1.1 * quiet_level, p, 0, &options);
        assert_eq!(cap.source, CapSource::Fallback, "{cap:?}");
        assert_eq!(cap.nm, 6.0);
        assert_eq!(cap.fitted_nm, quiet_level, "{cap:?}");
    }
}
