//! Calibration of the thresholds for a false-alarm budget: the residual envelope fitted on a
//! recording without contact, and an extreme-value fit of what is left.
//!
//! 1. **Recording** ([`EnvelopeRecorder`]): every sample's |r_j| and motion features
//!    ([`crate::envelope`]), kept per window of [`WINDOW_SAMPLES`] samples as the window's
//!    largest |r_j| with the features of that sample (what the scheduled threshold saw at the
//!    peak; a residual transient lasts a few samples, the features are held for 50 ms).
//! 2. **Contact screen** ([`screen`]): a recording with a contact-like onset (a residual held
//!    far beyond the rest of the recording for [`screen::SUSTAIN_S`]) is refused, naming the
//!    joint and the time — fitted, it would calibrate the contact away.
//! 3. **Envelope** e_j(φ) = a_j + Σ_k c_jk·φ_jk: non-negative least squares of the windows'
//!    |r_j| on (1, φ_j) — a scale model: |r_j| = e_j(φ)·z_j with z_j stationary.
//! 4. **Extreme values**: z_j = |r_j|/e_j per window, maxima per block of `block_s`, fitted with
//!    a Gumbel distribution by L-moments (a light tail by construction: a GEV shape above zero
//!    is reported as [`TailShape::Heavy`], never extrapolated — [`extreme`] says why). The
//!    budget B false alarms per hour is split over the joints (union bound), so joint j may
//!    exceed with probability p = (B/N)·block_s/3600 per block; its scale s_j is the fit's
//!    return level for p, at the upper bound of a block bootstrap at `confidence`.
//! 5. **Cap** ([`cap`]): the constant the raw block maxima of |r_j| support for the same
//!    probability, or the stated fallback (the paper's 6 Nm) where they support none that small.
//!    The scale and the cap are each fitted for half of p (union bound: their minimum is
//!    exceeded only when one of them is).
//! 6. **Thresholds** θ_j(φ) = min(s_j·e_j(φ), cap_j): θ0_j = s_j·a_j at rest and the
//!    [`ThresholdSchedule`] coefficients s_j·c_jk, its ceiling the cap, clamped into the
//!    allowed range.
//!
//! A fixed multiple of the recording's peak would not say how often it is exceeded; the
//! extreme-value fit does, with its uncertainty. It extrapolates: the recording must cover the
//! speeds and accelerations of the task (the result states the covered ranges), and the
//! thresholds should be checked on a second recording.
//!
//! Modules: [`recorder`] (the windows), [`fit`] (envelope and scale per joint), `nnls` (the
//! envelope's non-negative least squares), [`extreme`] (L-moment Gumbel fit, GEV tail test), `bootstrap`
//! (resampling and quantiles), `gamma` (Γ for the GEV), `rng` (the deterministic generator),
//! [`force`] (minimum detectable force), [`screen`] (the contact screen).

use nalgebra::SVector;
use serde::{Deserialize, Serialize};

use crate::detector::ThresholdSchedule;

mod bootstrap;
pub mod cap;
pub mod extreme;
pub mod fit;
pub mod force;
mod gamma;
mod nnls;
pub mod recorder;
mod rng;
pub mod screen;

pub use cap::{Cap, CapSource};
pub use extreme::{ExtremeFit, TailShape};
pub use force::{LinkForce, minimum_detectable_force};
pub use recorder::EnvelopeRecorder;
pub use screen::{ContactOnset, ScreenMargin};

/// Samples per recorded window (10 ms at 1 kHz): the residual's time constant is 2.5 ms at the
/// default gain, the features change over tens of ms.
pub const WINDOW_SAMPLES: usize = 10;
/// Regressors of the envelope: (1, |q̇_j|, velocity noise, payload dynamics, inertial, gravity).
pub const ENVELOPE_TERMS: usize = 6;
/// Motion features kept per window (all regressors but the constant).
const FEATURES: usize = ENVELOPE_TERMS - 1;
/// Least blocks an extreme-value fit accepts.
pub const MIN_BLOCKS: usize = 20;

/// Why a calibration could not be fitted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CalibrationError {
    /// Too few blocks for the extreme-value fit.
    #[error(
        "{blocks} blocks of {block_s} s recorded; at least {MIN_BLOCKS} are needed (record longer)"
    )]
    TooFewBlocks {
        /// Blocks recorded.
        blocks: usize,
        /// Block length \[s\].
        block_s: f64,
    },
    /// An option out of range.
    #[error("{field} = {value} is outside {min}…{max}")]
    Option {
        /// The option's name.
        field: &'static str,
        /// Its value.
        value: f64,
        /// Smallest allowed.
        min: f64,
        /// Largest allowed.
        max: f64,
    },
    /// The recording holds a contact-like onset ([`screen`]): fitted, it would calibrate the
    /// contact away.
    #[error(
        "joint {} (1-based): the residual held {:+.2} Nm for {} s from {:.3} s (peak at {:.3} s) where the envelope of the rest of the recording is {:.2} Nm — score {:.1}, beyond the limit {:.1} of a recording without contact: a contact? Nothing was fitted: record again without touching the arm",
        .0.joint + 1, .0.residual_nm, screen::SUSTAIN_S, .0.onset_s, .0.peak_s, .0.envelope_nm, .0.score, .0.limit
    )]
    ContactInRecording(ContactOnset),
    /// The residual carried no variation on a joint (e.g. a simulation without noise).
    #[error("joint {joint} (0-based): the residual never left zero; nothing to fit")]
    Degenerate {
        /// Joint index, 0-based.
        joint: usize,
    },
}

/// Options of [`EnvelopeRecorder::fit`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FitOptions<const N: usize> {
    /// False alarms per hour allowed for the whole arm (the default one per 10 h).
    pub budget_per_hour: f64,
    /// Sample period of the recording \[s\].
    pub sample_period_s: f64,
    /// Block length of the block maxima \[s\].
    pub block_s: f64,
    /// One-sided confidence of the scale's upper bound (block bootstrap), 0.5…0.99.
    pub confidence: f64,
    /// Bootstrap resamples.
    pub resamples: usize,
    /// Seed of the bootstrap.
    pub seed: u64,
    /// Smallest threshold per joint \[Nm\].
    pub floor_nm: SVector<f64, N>,
    /// Largest threshold per joint \[Nm\].
    pub ceiling_nm: SVector<f64, N>,
    /// The stated constant per joint \[Nm\]: the cap where the recording supports no smaller
    /// constant for the budget ([`cap`]; default the paper's 6 Nm).
    #[serde(default = "default_fallback")]
    pub fallback_nm: SVector<f64, N>,
}

/// The paper's constant threshold on every joint \[Nm\].
fn default_fallback<const N: usize>() -> SVector<f64, N> {
    SVector::repeat(crate::detector::DEFAULT_THRESHOLD_NM)
}

impl<const N: usize> FitOptions<N> {
    /// Defaults at sample period `sample_period_s` \[s\]: one false alarm per 10 h, 1 s blocks,
    /// 90 % upper bound from 200 bootstrap resamples, thresholds 0.1 Nm…unbounded, capped at
    /// the paper's 6 Nm where the recording supports no smaller constant.
    pub fn new(sample_period_s: f64) -> Self {
        Self {
            budget_per_hour: 0.1,
            sample_period_s,
            block_s: 1.0,
            confidence: 0.9,
            resamples: 200,
            seed: 2017,
            floor_nm: SVector::repeat(0.1),
            ceiling_nm: SVector::repeat(f64::MAX),
            fallback_nm: default_fallback(),
        }
    }

    pub(super) fn check(&self) -> Result<(), CalibrationError> {
        let bounded = |field, value: f64, min, max| {
            if value.is_finite() && (min..=max).contains(&value) {
                Ok(())
            } else {
                Err(CalibrationError::Option {
                    field,
                    value,
                    min,
                    max,
                })
            }
        };
        bounded("budget_per_hour", self.budget_per_hour, 1e-6, 100.0)?;
        bounded("sample_period_s", self.sample_period_s, 1e-4, 0.1)?;
        bounded("block_s", self.block_s, 0.1, 600.0)?;
        bounded("confidence", self.confidence, 0.5, 0.99)?;
        bounded("resamples", self.resamples as f64, 20.0, 10000.0)?;
        for j in 0..N {
            bounded("floor_nm", self.floor_nm[j], 1e-3, 1e3)?;
            bounded("fallback_nm", self.fallback_nm[j], self.floor_nm[j], 1e3)?;
            if self.ceiling_nm[j].is_nan() || self.ceiling_nm[j] < self.floor_nm[j] {
                return Err(CalibrationError::Option {
                    field: "ceiling_nm",
                    value: self.ceiling_nm[j],
                    min: self.floor_nm[j],
                    max: f64::MAX,
                });
            }
        }
        Ok(())
    }
}

/// Calibration of one joint.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct JointCalibration {
    /// Envelope coefficients: floor \[Nm\], speed \[Nm·s/rad\], velocity noise \[Nm per kg·m²\],
    /// payload dynamics \[1\], inertial \[1\], gravity \[1\].
    pub envelope: [f64; ENVELOPE_TERMS],
    /// Extreme-value fit of the normalised block maxima.
    pub extreme: ExtremeFit,
    /// What the maxima say of their tail (the return level is Gumbel's either way).
    pub tail: TailShape,
    /// 5–95 % bootstrap interval of the GEV shape ξ.
    pub shape_interval: [f64; 2],
    /// Scale s_j used: θ_j = min(s_j·e_j(φ), cap) (the upper bound at the options' confidence).
    pub scale: f64,
    /// The constant cap of the schedule ([`cap`]).
    pub cap: Cap,
    /// The return level's point estimate.
    pub scale_point: f64,
    /// Bootstrap standard deviation of the return level.
    pub scale_std: f64,
    /// 5–95 % bootstrap interval of the return level.
    pub scale_interval: [f64; 2],
    /// θ at rest \[Nm\].
    pub threshold_at_rest_nm: f64,
    /// Median of the scheduled θ over the recording \[Nm\].
    pub threshold_median_nm: f64,
    /// Largest scheduled θ over the recording \[Nm\].
    pub threshold_max_nm: f64,
    /// Largest |r_j| of the recording \[Nm\].
    pub peak_nm: f64,
    /// Windows of the recording whose |r_j| exceeds its scheduled θ (in-sample check).
    pub exceedances: usize,
    /// Largest |q̇_j| covered \[rad/s\].
    pub max_speed: f64,
    /// Largest |q̈_j| covered \[rad/s²\].
    pub max_acceleration: f64,
}

/// Result of a calibration: the thresholds and their schedule, and how they were obtained.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Calibration<const N: usize> {
    /// Per joint.
    pub joints: Vec<JointCalibration>,
    /// θ0 per joint \[Nm\] (`DetectorConfig::thresholds_nm`).
    pub thresholds_nm: SVector<f64, N>,
    /// Speed coefficients \[Nm·s/rad\] (`DetectorConfig::velocity_coefficients`).
    pub velocity_coefficients: SVector<f64, N>,
    /// The model-feature schedule (`DetectorConfig::schedule`).
    pub schedule: ThresholdSchedule<N>,
    /// Extreme-value scale s_j per joint (`MonitorConfig::threshold_to_noise`).
    pub scale: SVector<f64, N>,
    /// Median scheduled θ per joint over the recording \[Nm\].
    pub median_thresholds_nm: SVector<f64, N>,
    /// The budget \[false alarms per hour\].
    pub budget_per_hour: f64,
    /// Block length used \[s\].
    pub block_s: f64,
    /// Blocks fitted.
    pub blocks: usize,
    /// Recording length \[s\].
    pub duration_s: f64,
    /// One-sided confidence of the scales.
    pub confidence: f64,
}
