//! Calibration of the thresholds for a false-alarm budget: the residual envelope fitted on a
//! recording without contact, and an extreme-value fit of what is left.
//!
//! 1. **Recording** ([`EnvelopeRecorder`]): every sample's |r_j| and motion features
//!    ([`crate::envelope`]), kept per window of [`WINDOW_SAMPLES`] samples as the window's
//!    largest |r_j| with the features of that sample (what the scheduled threshold saw at the
//!    peak; a residual transient lasts a few samples, the features are held for 50 ms).
//! 2. **Envelope** e_j(φ) = a_j + Σ_k c_jk·φ_jk: non-negative least squares of the windows'
//!    |r_j| on (1, φ_j) — a scale model: |r_j| = e_j(φ)·z_j with z_j stationary.
//! 3. **Extreme values**: z_j = |r_j|/e_j per window, maxima per block of `block_s`, fitted with
//!    a Gumbel distribution (a generalised extreme-value one when its shape is significantly
//!    heavy-tailed; a significantly bounded tail keeps the Gumbel, which is then conservative)
//!    by L-moments. The budget B false alarms per hour is split over the joints (union bound),
//!    so joint j may exceed with probability p = (B/N)·block_s/3600 per block; its scale s_j is
//!    the fit's return level for p, at the upper bound of a block bootstrap at `confidence`.
//! 4. **Thresholds** θ_j(φ) = s_j·e_j(φ): θ0_j = s_j·a_j at rest and the
//!    [`ThresholdSchedule`] coefficients s_j·c_jk, clamped into the allowed range.
//!
//! A fixed multiple of the recording's peak would not say how often it is exceeded; the
//! extreme-value fit does, with its uncertainty. It extrapolates: the recording must cover the
//! speeds and accelerations of the task (the result states the covered ranges), and the
//! thresholds should be checked on a second recording.

use dynamics::{Data, Model, point_jacobian};
use nalgebra::{SMatrix, SVector, Vector3};
use serde::{Deserialize, Serialize};

use crate::detector::ThresholdSchedule;
use crate::envelope::MotionFeatures;
use crate::isolation::LinkSurface;

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
}

impl<const N: usize> FitOptions<N> {
    /// Defaults at sample period `sample_period_s` \[s\]: one false alarm per 10 h, 1 s blocks,
    /// 90 % upper bound from 200 bootstrap resamples, thresholds 0.1 Nm…unbounded.
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
        }
    }

    fn check(&self) -> Result<(), CalibrationError> {
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

/// One recorded window.
#[derive(Debug, Clone, Copy)]
struct Window<const N: usize> {
    peak: [f32; N],
    features: [[f32; N]; FEATURES],
}

/// Records a residual without contact with its motion features (not real-time: it grows by
/// ≈ 30 bytes per joint and window, 75 MB for an hour of 7 joints at 1 kHz).
#[derive(Debug, Clone)]
pub struct EnvelopeRecorder<const N: usize> {
    windows: Vec<Window<N>>,
    current: Option<Window<N>>,
    in_window: usize,
    samples: u64,
    peak: SVector<f64, N>,
    max_speed: SVector<f64, N>,
    max_acceleration: SVector<f64, N>,
}

impl<const N: usize> Default for EnvelopeRecorder<N> {
    fn default() -> Self {
        Self::new()
    }
}

fn features_of<const N: usize>(f: &MotionFeatures<N>) -> [[f32; N]; FEATURES] {
    std::array::from_fn(|k| std::array::from_fn(|j| f.regressors(j)[k + 1] as f32))
}

impl<const N: usize> EnvelopeRecorder<N> {
    /// An empty recording.
    pub fn new() -> Self {
        Self {
            windows: Vec::new(),
            current: None,
            in_window: 0,
            samples: 0,
            peak: SVector::zeros(),
            max_speed: SVector::zeros(),
            max_acceleration: SVector::zeros(),
        }
    }

    /// Adds one sample: residual `residual` \[Nm\] and the motion features the detector used
    /// with it. Non-finite samples are skipped.
    pub fn push(&mut self, residual: &SVector<f64, N>, features: &MotionFeatures<N>) {
        let finite = residual.iter().all(|x| x.is_finite())
            && features_of(features)
                .iter()
                .all(|f| f.iter().all(|x| x.is_finite()));
        if !finite {
            return;
        }
        self.samples += 1;
        self.peak = self.peak.sup(&residual.abs());
        self.max_speed = self.max_speed.sup(&features.speed);
        self.max_acceleration = self.max_acceleration.sup(&features.acceleration.abs());
        let now = Window {
            peak: std::array::from_fn(|j| residual[j].abs() as f32),
            features: features_of(features),
        };
        match &mut self.current {
            None => self.current = Some(now),
            Some(w) => {
                // Per joint, the sample of the window's largest |r_j| with its own features:
                // what the scheduled threshold saw at that peak.
                for j in 0..N {
                    if now.peak[j] > w.peak[j] {
                        w.peak[j] = now.peak[j];
                        for k in 0..FEATURES {
                            w.features[k][j] = now.features[k][j];
                        }
                    }
                }
            }
        }
        self.in_window += 1;
        if self.in_window == WINDOW_SAMPLES {
            if let Some(w) = self.current.take() {
                self.windows.push(w);
            }
            self.in_window = 0;
        }
    }

    /// Samples recorded.
    pub fn samples(&self) -> u64 {
        self.samples
    }

    /// Largest |r_j| recorded \[Nm\].
    pub fn peak(&self) -> &SVector<f64, N> {
        &self.peak
    }

    /// Fits the envelope and the extreme-value scale per joint for the budget in `options`.
    pub fn fit(&self, options: &FitOptions<N>) -> Result<Calibration<N>, CalibrationError> {
        options.check()?;
        let window_s = WINDOW_SAMPLES as f64 * options.sample_period_s;
        let per_block = ((options.block_s / window_s).round() as usize).max(1);
        let blocks = self.windows.len() / per_block;
        if blocks < MIN_BLOCKS {
            return Err(CalibrationError::TooFewBlocks {
                blocks,
                block_s: options.block_s,
            });
        }
        let block_s = per_block as f64 * window_s;
        let per_joint_budget = options.budget_per_hour / N as f64;
        let p_block = per_joint_budget * block_s / 3600.0;
        let mut joints = Vec::with_capacity(N);
        let mut schedule = ThresholdSchedule::<N>::default();
        let mut thresholds = SVector::<f64, N>::zeros();
        let mut speed = SVector::<f64, N>::zeros();
        let mut scale = SVector::<f64, N>::zeros();
        let mut median_threshold = SVector::<f64, N>::zeros();
        for j in 0..N {
            let coefficients = self
                .fit_envelope(j)
                .ok_or(CalibrationError::Degenerate { joint: j })?;
            let envelope = |w: &Window<N>| {
                coefficients[0]
                    + (0..FEATURES)
                        .map(|k| coefficients[k + 1] * f64::from(w.features[k][j]))
                        .sum::<f64>()
            };
            let maxima: Vec<f64> = self.windows[..blocks * per_block]
                .chunks(per_block)
                .map(|b| {
                    b.iter()
                        .map(|w| f64::from(w.peak[j]) / envelope(w))
                        .fold(0.0, f64::max)
                })
                .collect();
            let extreme =
                ExtremeFit::fit(&maxima).ok_or(CalibrationError::Degenerate { joint: j })?;
            let (model, shape_interval) = extreme_model(&maxima, options);
            let level = |sample: &[f64]| {
                ExtremeFit::fit(sample).map_or(f64::NAN, |f| f.return_level(p_block, model))
            };
            let point = level(&maxima);
            let boot = bootstrap(&maxima, options.resamples, options.seed ^ j as u64, level);
            let upper = quantile(&boot, options.confidence);
            let s = upper.max(point);
            let mean = boot.iter().sum::<f64>() / boot.len() as f64;
            let std = (boot.iter().map(|x| (x - mean).powi(2)).sum::<f64>()
                / (boot.len().max(2) - 1) as f64)
                .sqrt();
            let theta0 = (s * coefficients[0]).clamp(options.floor_nm[j], options.ceiling_nm[j]);
            thresholds[j] = theta0;
            speed[j] = s * coefficients[1];
            schedule.velocity_noise[j] = s * coefficients[2];
            schedule.payload_dynamics[j] = s * coefficients[3];
            schedule.inertial[j] = s * coefficients[4];
            schedule.gravity[j] = s * coefficients[5];
            schedule.ceiling_nm[j] = options.ceiling_nm[j];
            scale[j] = s;
            let mut scheduled: Vec<f64> = self
                .windows
                .iter()
                .map(|w| (s * envelope(w)).clamp(options.floor_nm[j], options.ceiling_nm[j]))
                .collect();
            scheduled.sort_by(f64::total_cmp);
            median_threshold[j] = quantile_sorted(&scheduled, 0.5);
            let exceedances = self
                .windows
                .iter()
                .filter(|w| f64::from(w.peak[j]) > s * envelope(w))
                .count();
            joints.push(JointCalibration {
                envelope: coefficients,
                extreme,
                model,
                shape_interval,
                scale: s,
                scale_point: point,
                scale_std: std,
                scale_interval: [quantile(&boot, 0.05), quantile(&boot, 0.95)],
                threshold_at_rest_nm: theta0,
                threshold_median_nm: median_threshold[j],
                threshold_max_nm: *scheduled.last().unwrap_or(&theta0),
                peak_nm: self.peak[j],
                exceedances,
                max_speed: self.max_speed[j],
                max_acceleration: self.max_acceleration[j],
            });
        }
        Ok(Calibration {
            joints,
            thresholds_nm: thresholds,
            velocity_coefficients: speed,
            schedule,
            scale,
            median_thresholds_nm: median_threshold,
            budget_per_hour: options.budget_per_hour,
            block_s,
            blocks,
            duration_s: self.samples as f64 * options.sample_period_s,
            confidence: options.confidence,
        })
    }

    /// Non-negative least squares of the windows' |r_j| on (1, φ_j), columns scaled to unit
    /// RMS; the intercept is kept ≥ 5 % of the mean |r_j| so that z stays finite at rest.
    fn fit_envelope(&self, j: usize) -> Option<[f64; ENVELOPE_TERMS]> {
        let mut gram = SMatrix::<f64, ENVELOPE_TERMS, ENVELOPE_TERMS>::zeros();
        let mut rhs = SVector::<f64, ENVELOPE_TERMS>::zeros();
        let mut mean = 0.0;
        for w in &self.windows {
            let x = SVector::<f64, ENVELOPE_TERMS>::from_fn(|k, _| {
                if k == 0 {
                    1.0
                } else {
                    f64::from(w.features[k - 1][j])
                }
            });
            let y = f64::from(w.peak[j]);
            gram += x * x.transpose();
            rhs += x * y;
            mean += y;
        }
        let n = self.windows.len() as f64;
        mean /= n;
        if mean.is_nan() || mean <= 0.0 {
            return None;
        }
        // A feature that never left (numerical) zero on this joint (e.g. gravity on a vertical
        // axis) is not a regressor.
        let scale = SVector::<f64, ENVELOPE_TERMS>::from_fn(|k, _| {
            let rms = (gram[(k, k)] / n).sqrt();
            if rms > 1e-9 { 1.0 / rms } else { 0.0 }
        });
        let scaled_gram = SMatrix::<f64, ENVELOPE_TERMS, ENVELOPE_TERMS>::from_fn(|a, b| {
            gram[(a, b)] * scale[a] * scale[b] / n
        });
        let scaled_rhs = rhs.component_mul(&scale) / n;
        let x = nnls(&scaled_gram, &scaled_rhs);
        let mut c: [f64; ENVELOPE_TERMS] = std::array::from_fn(|k| x[k] * scale[k]);
        c[0] = c[0].max(0.05 * mean);
        Some(c)
    }
}

/// Non-negative least squares min ‖Ax − b‖², x ≥ 0, from the normal equations G = AᵀA,
/// h = Aᵀb (Lawson–Hanson active set; columns with zero scale stay at zero).
const K: usize = ENVELOPE_TERMS;

fn nnls(g: &SMatrix<f64, K, K>, h: &SVector<f64, K>) -> SVector<f64, K> {
    let mut x = SVector::<f64, K>::zeros();
    let mut passive = [false; K];
    let usable: [bool; K] = std::array::from_fn(|k| g[(k, k)] > 0.0);
    for _ in 0..(3 * K + 10) {
        let gradient = h - g * x;
        let candidate = (0..K)
            .filter(|&k| usable[k] && !passive[k] && gradient[k] > 1e-12)
            .max_by(|&a, &b| gradient[a].total_cmp(&gradient[b]));
        let Some(k) = candidate else {
            break;
        };
        passive[k] = true;
        loop {
            let z = solve_passive(g, h, &passive);
            if (0..K).all(|i| !passive[i] || z[i] > 0.0) {
                x = z;
                break;
            }
            // Step back to the boundary and drop the variables that hit zero.
            let mut alpha = 1.0_f64;
            for i in 0..K {
                if passive[i] && z[i] <= 0.0 {
                    alpha = alpha.min(x[i] / (x[i] - z[i]));
                }
            }
            x += (z - x) * alpha;
            for i in 0..K {
                if passive[i] && x[i] <= 1e-15 {
                    passive[i] = false;
                    x[i] = 0.0;
                }
            }
        }
    }
    x
}

/// The unconstrained solution on the passive set (others zero).
fn solve_passive(
    g: &SMatrix<f64, K, K>,
    h: &SVector<f64, K>,
    passive: &[bool; K],
) -> SVector<f64, K> {
    let mut reduced = SMatrix::<f64, K, K>::identity();
    let mut rhs = SVector::<f64, K>::zeros();
    for a in 0..K {
        if !passive[a] {
            continue;
        }
        rhs[a] = h[a];
        for b in 0..K {
            reduced[(a, b)] = if passive[b] { g[(a, b)] } else { 0.0 };
        }
        reduced[(a, a)] += 1e-12;
    }
    reduced.lu().solve(&rhs).unwrap_or_else(SVector::zeros)
}

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
fn extreme_model<const N: usize>(
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

/// `resamples` values of `statistic` on resamples (with replacement) of `sample`; NaN results
/// are dropped.
fn bootstrap(
    sample: &[f64],
    resamples: usize,
    seed: u64,
    statistic: impl Fn(&[f64]) -> f64,
) -> Vec<f64> {
    let mut rng = SplitMix64(seed);
    let mut resample = vec![0.0; sample.len()];
    let mut out = Vec::with_capacity(resamples);
    for _ in 0..resamples {
        for r in resample.iter_mut() {
            *r = sample[rng.below(sample.len())];
        }
        let v = statistic(&resample);
        if v.is_finite() {
            out.push(v);
        }
    }
    out.sort_by(f64::total_cmp);
    out
}

/// The `q`-quantile of `values` (sorted or not; NaN for an empty slice).
fn quantile(values: &[f64], q: f64) -> f64 {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    quantile_sorted(&v, q)
}

fn quantile_sorted(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let pos = q.clamp(0.0, 1.0) * (sorted.len() - 1) as f64;
    let (lo, hi) = (pos.floor() as usize, pos.ceil() as usize);
    sorted[lo] + (sorted[hi] - sorted[lo]) * (pos - lo as f64)
}

/// Γ(x) for x > 0 (Lanczos, g = 7; relative error < 1e-13 in the range used, 0.1…2).
fn gamma(x: f64) -> f64 {
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        return std::f64::consts::PI / ((std::f64::consts::PI * x).sin() * gamma(1.0 - x));
    }
    let x = x - 1.0;
    let t = x + 7.5;
    let mut a = C[0];
    for (i, c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    (2.0 * std::f64::consts::PI).sqrt() * t.powf(x + 0.5) * (-t).exp() * a
}

/// Deterministic pseudo-random numbers (SplitMix64) for the bootstrap and the force sampling:
/// a calibration gives the same result on the same data.
struct SplitMix64(u64);

impl SplitMix64 {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in \[0, 1).
    fn uniform(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
    fn below(&mut self, n: usize) -> usize {
        ((self.uniform() * n as f64) as usize).min(n.saturating_sub(1))
    }
    fn unit_vector(&mut self) -> Vector3<f64> {
        loop {
            let v = Vector3::new(
                2.0 * self.uniform() - 1.0,
                2.0 * self.uniform() - 1.0,
                2.0 * self.uniform() - 1.0,
            );
            let n = v.norm();
            if n > 0.1 && n <= 1.0 {
                return v / n;
            }
        }
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
    /// The model used for the return level.
    pub model: ExtremeModel,
    /// 5–95 % bootstrap interval of the GEV shape ξ.
    pub shape_interval: [f64; 2],
    /// Scale s_j used: θ_j = s_j·e_j(φ) (the upper bound at the options' confidence).
    pub scale: f64,
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

/// Minimum detectable force on one link at given thresholds \[N\].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LinkForce {
    /// Median over configurations, surface points and force directions.
    pub median_n: f64,
    /// 10th percentile.
    pub p10_n: f64,
    /// 90th percentile.
    pub p90_n: f64,
}

/// Static minimum detectable force per link at thresholds `thresholds` \[Nm\]: for `samples`
/// random configurations (within `fraction` of the joint ranges), points on the link's surface
/// and force directions, the smallest |F| whose J_vᵀF reaches θ on some joint,
/// F_min = min_j θ_j/|(J_vᵀn)_j|; median and percentiles per link (deterministic for `seed`).
pub fn minimum_detectable_force<const N: usize>(
    model: &Model<N>,
    surfaces: &[LinkSurface; N],
    thresholds: &SVector<f64, N>,
    samples: usize,
    fraction: f64,
    seed: u64,
) -> Vec<LinkForce> {
    let mut data = Data::new(model);
    let mut rng = SplitMix64(seed);
    let limits = model.limits();
    (0..N)
        .map(|link| {
            let mut values: Vec<f64> = (0..samples.max(1))
                .map(|_| {
                    let q = SVector::<f64, N>::from_fn(|j, _| {
                        let (lo, hi) = (limits.position_min[j], limits.position_max[j]);
                        let mid = 0.5 * (lo + hi);
                        mid + (rng.uniform() - 0.5) * (hi - lo) * fraction
                    });
                    let (point, _) =
                        surfaces[link].point(rng.uniform(), std::f64::consts::TAU * rng.uniform());
                    let jv = point_jacobian(model, &mut data, &q, link, &point)
                        .fixed_rows::<3>(0)
                        .into_owned();
                    let torque = jv.transpose() * rng.unit_vector();
                    (0..N)
                        .map(|j| thresholds[j] / torque[j].abs())
                        .fold(f64::INFINITY, f64::min)
                })
                .collect();
            values.sort_by(f64::total_cmp);
            LinkForce {
                median_n: quantile_sorted(&values, 0.5),
                p10_n: quantile_sorted(&values, 0.1),
                p90_n: quantile_sorted(&values, 0.9),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    type V2 = SVector<f64, 2>;

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

    #[test]
    fn gamma_matches_known_values() {
        assert!((gamma(1.0) - 1.0).abs() < 1e-12);
        assert!((gamma(0.5) - std::f64::consts::PI.sqrt()).abs() < 1e-12);
        assert!((gamma(1.5) - 0.5 * std::f64::consts::PI.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn nnls_keeps_coefficients_non_negative() {
        // y = 1 + 2 x1 − 3 x2 would need a negative coefficient: NNLS sets it to zero.
        // (The two last columns are unused: zero scale, kept at zero.)
        let mut g = SMatrix::<f64, K, K>::zeros();
        let mut h = SVector::<f64, K>::zeros();
        let mut rng = SplitMix64(1);
        for _ in 0..500 {
            let x = SVector::<f64, K>::new(1.0, rng.uniform(), rng.uniform(), 0.0, 0.0, 0.0);
            let y = 1.0 + 2.0 * x[1] - 3.0 * x[2];
            g += x * x.transpose();
            h += x * y;
        }
        let c = nnls(&g, &h);
        assert!(c.iter().all(|v| *v >= 0.0), "{c}");
        assert_eq!(c[2], 0.0);
        // Without the constraint binding, the exact solution comes back.
        let mut h = SVector::<f64, K>::zeros();
        let mut g = SMatrix::<f64, K, K>::zeros();
        for _ in 0..500 {
            let x = SVector::<f64, K>::new(1.0, rng.uniform(), rng.uniform(), 0.0, 0.0, 0.0);
            g += x * x.transpose();
            h += x * (0.5 + 2.0 * x[1] + 3.0 * x[2]);
        }
        let c = nnls(&g, &h);
        assert!(
            (c - SVector::<f64, K>::new(0.5, 2.0, 3.0, 0.0, 0.0, 0.0)).norm() < 1e-8,
            "{c}"
        );
    }

    /// A synthetic residual: noise whose scale grows with the speed feature.
    fn record(
        speed_gain: [f64; 2],
        noise: [f64; 2],
        seconds: f64,
        seed: u64,
    ) -> EnvelopeRecorder<2> {
        let mut rng = SplitMix64(seed);
        let mut rec = EnvelopeRecorder::<2>::new();
        let n = (seconds * 1000.0) as usize;
        for k in 0..n {
            let v = (k as f64 * 1e-3 * 0.7).sin().abs();
            let f = MotionFeatures::from_speed(&V2::repeat(v));
            // Gaussian by Box–Muller.
            let (u1, u2) = (rng.uniform().max(1e-300), rng.uniform());
            let g = (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
            let r = V2::from_fn(|j, _| g * noise[j] * (1.0 + speed_gain[j] * v));
            rec.push(&r, &f);
        }
        rec
    }

    #[test]
    fn thresholds_follow_the_envelope_and_the_budget() {
        let rec = record([2.0, 0.0], [0.5, 0.1], 300.0, 3);
        let options = FitOptions::<2>::new(1e-3);
        let c = rec.fit(&options).unwrap();
        // The noisier joint gets the higher threshold, the speed term only where it exists.
        assert!(c.thresholds_nm[0] > 2.0 * c.thresholds_nm[1], "{c:?}");
        assert!(
            c.velocity_coefficients[0] > 0.5 * c.thresholds_nm[0],
            "{c:?}"
        );
        assert!(
            c.velocity_coefficients[1] < 0.2 * c.thresholds_nm[1],
            "{c:?}"
        );
        // Gaussian noise: 1e-5 per block is about 4.4 σ above the mean local peak scale.
        assert!(c.joints.iter().all(|j| j.exceedances == 0), "{c:?}");
        // A tighter budget raises every threshold.
        let tight = rec
            .fit(&FitOptions {
                budget_per_hour: 0.001,
                ..options
            })
            .unwrap();
        for j in 0..2 {
            assert!(
                tight.thresholds_nm[j] > c.thresholds_nm[j],
                "{tight:?} {c:?}"
            );
        }
        // Too short a recording is refused.
        assert!(matches!(
            record([0.0; 2], [0.1; 2], 10.0, 4).fit(&options),
            Err(CalibrationError::TooFewBlocks { .. })
        ));
        assert!(matches!(
            rec.fit(&FitOptions {
                budget_per_hour: -1.0,
                ..options
            }),
            Err(CalibrationError::Option {
                field: "budget_per_hour",
                ..
            })
        ));
    }

    #[test]
    fn minimum_detectable_force_scales_with_the_thresholds() {
        let model = dynamics::lwr4();
        let surfaces = crate::isolation::lwr4_link_surfaces();
        let six = minimum_detectable_force(&model, &surfaces, &SVector::repeat(6.0), 300, 0.8, 1);
        let three = minimum_detectable_force(&model, &surfaces, &SVector::repeat(3.0), 300, 0.8, 1);
        for link in 0..7 {
            assert!((six[link].median_n / three[link].median_n - 2.0).abs() < 1e-9);
            assert!(six[link].p10_n <= six[link].median_n && six[link].median_n <= six[link].p90_n);
        }
        // Distal links (short levers to many joints) need less force than the shoulder links.
        assert!(six[6].median_n < six[1].median_n);
    }
}
