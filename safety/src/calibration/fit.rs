//! The fit of a recording: per joint the envelope (non-negative least squares on the motion
//! features) and the extreme-value scale of what it leaves, for the false-alarm budget.

use nalgebra::{SMatrix, SVector};

use super::bootstrap::{bootstrap, quantile, quantile_sorted};
use super::cap::constant_cap;
use super::extreme::{ExtremeFit, TailShape, tail_shape};
use super::nnls::nnls;
use super::recorder::{EnvelopeRecorder, Window};
use super::{
    Calibration, CalibrationError, ENVELOPE_TERMS, FEATURES, FitOptions, JointCalibration,
    MIN_BLOCKS, WINDOW_SAMPLES,
};
use crate::detector::ThresholdSchedule;

impl<const N: usize> EnvelopeRecorder<N> {
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
        self.screen(window_s, per_block, blocks)
            .map_err(CalibrationError::ContactInRecording)?;
        let block_s = per_block as f64 * window_s;
        let per_joint_budget = options.budget_per_hour / N as f64;
        // half for the scheduled level, half for the cap: the minimum of the two is exceeded
        // only when one of them is (union bound)
        let p_block = per_joint_budget * block_s / 3600.0 / 2.0;
        let mut joints = Vec::with_capacity(N);
        let mut schedule = ThresholdSchedule::<N>::default();
        let mut thresholds = SVector::<f64, N>::zeros();
        let mut speed = SVector::<f64, N>::zeros();
        let mut scale = SVector::<f64, N>::zeros();
        let mut median_threshold = SVector::<f64, N>::zeros();
        for j in 0..N {
            let coefficients = self
                .fit_envelope_where(j, |_| true)
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
            let raw_maxima: Vec<f64> = self.windows[..blocks * per_block]
                .chunks(per_block)
                .map(|b| b.iter().map(|w| f64::from(w.peak[j])).fold(0.0, f64::max))
                .collect();
            let cap = constant_cap(&raw_maxima, self.peak[j], p_block, j, options);
            let (tail, shape_interval) = tail_shape(&maxima, options);
            let level = |sample: &[f64]| {
                ExtremeFit::fit(sample).map_or(f64::NAN, |f| f.return_level(p_block))
            };
            let point = level(&maxima);
            let boot = bootstrap(&maxima, options.resamples, options.seed ^ j as u64, level);
            let upper = quantile(&boot, options.confidence);
            // A heavy tail's Gumbel level follows the bulk of the maxima and may fall below the
            // few largest (the regime the envelope misses): floored at the largest, the
            // threshold never alarms on the recording it was fitted to, and it never exceeds
            // what the recording itself showed (an extrapolation through those few — a GEV, or
            // a light tail anchored on them — multiplied it by tens to thousands).
            let floor = match tail {
                TailShape::Heavy => maxima.iter().copied().fold(0.0, f64::max),
                TailShape::Gumbel => 0.0,
            };
            let s = upper.max(point).max(floor);
            let mean = boot.iter().sum::<f64>() / boot.len() as f64;
            let std = (boot.iter().map(|x| (x - mean).powi(2)).sum::<f64>()
                / (boot.len().max(2) - 1) as f64)
                .sqrt();
            let theta0 = (s * coefficients[0]).clamp(options.floor_nm[j], cap.nm);
            thresholds[j] = theta0;
            speed[j] = s * coefficients[1];
            schedule.velocity_noise[j] = s * coefficients[2];
            schedule.payload_dynamics[j] = s * coefficients[3];
            schedule.inertial[j] = s * coefficients[4];
            schedule.gravity[j] = s * coefficients[5];
            schedule.ceiling_nm[j] = cap.nm;
            scale[j] = s;
            let mut scheduled: Vec<f64> = self
                .windows
                .iter()
                .map(|w| (s * envelope(w)).clamp(options.floor_nm[j], cap.nm))
                .collect();
            scheduled.sort_by(f64::total_cmp);
            median_threshold[j] = quantile_sorted(&scheduled, 0.5);
            let exceedances = self
                .windows
                .iter()
                .filter(|w| f64::from(w.peak[j]) > (s * envelope(w)).min(cap.nm))
                .count();
            joints.push(JointCalibration {
                envelope: coefficients,
                extreme,
                tail,
                shape_interval,
                scale: s,
                cap,
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
    /// RMS; the intercept is kept ≥ 5 % of the mean |r_j| so that z stays finite at rest. Only
    /// the windows whose index `include` accepts enter (the contact screen leaves out blocks).
    pub(super) fn fit_envelope_where(
        &self,
        j: usize,
        include: impl Fn(usize) -> bool,
    ) -> Option<[f64; ENVELOPE_TERMS]> {
        let mut gram = SMatrix::<f64, ENVELOPE_TERMS, ENVELOPE_TERMS>::zeros();
        let mut rhs = SVector::<f64, ENVELOPE_TERMS>::zeros();
        let mut mean = 0.0;
        let mut n = 0usize;
        for (_, w) in self.windows.iter().enumerate().filter(|(i, _)| include(*i)) {
            n += 1;
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
        let n = n as f64;
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibration::CapSource;
    use crate::calibration::rng::SplitMix64;
    use crate::envelope::MotionFeatures;

    type V2 = SVector<f64, 2>;

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
            rec.push(k as f64 * 1e-3, &r, &f);
        }
        rec
    }

    #[test]
    fn a_regime_the_envelope_misses_is_reported_as_a_heavy_tail_and_never_explodes() {
        // Joint 1: the noise of `record`, and every 7th second a 30 ms burst four times as
        // loud (a regime no feature represents, e.g. a friction reversal); joint 2 stays plain.
        let mut rng = SplitMix64(11);
        let mut rec = EnvelopeRecorder::<2>::new();
        for k in 0..60_000usize {
            let v = (k as f64 * 1e-3 * 0.7).sin().abs();
            let f = MotionFeatures::from_speed(&V2::repeat(v));
            let (u1, u2) = (rng.uniform().max(1e-300), rng.uniform());
            let g = (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
            let burst = if k % 7000 < 30 { 4.0 } else { 1.0 };
            let r = V2::new(0.1 * g * burst, 0.1 * g);
            rec.push(k as f64 * 1e-3, &r, &f);
        }
        let c = rec.fit(&FitOptions::<2>::new(1e-3)).unwrap();
        let (burst, plain) = (&c.joints[0], &c.joints[1]);
        assert_eq!(burst.tail, TailShape::Heavy, "{burst:?}");
        assert_eq!(plain.tail, TailShape::Gumbel, "{plain:?}");
        // The heavy tail's own extrapolation would be many times the Gumbel level used.
        let p = 0.1 / 2.0 / 3600.0;
        assert!(
            burst.extreme.gev_return_level(p) > 3.0 * burst.scale,
            "{burst:?}"
        );
        // Never an alarm on its own recording, and of the order of the bursts, not beyond.
        assert_eq!(burst.exceedances, 0, "{burst:?}");
        assert!(burst.threshold_median_nm < 3.0 * burst.peak_nm, "{burst:?}");
    }

    #[test]
    fn thresholds_follow_the_envelope_and_the_budget() {
        let rec = record([2.0, 0.0], [0.5, 0.1], 300.0, 3);
        // Joint 1's residual reaches 6.7 Nm: at the default stated constant (6 Nm) its cap is
        // the fallback, reported, and its own recording crosses it.
        let stated = rec.fit(&FitOptions::<2>::new(1e-3)).unwrap();
        let loud = &stated.joints[0];
        assert_eq!(loud.cap.source, CapSource::Fallback, "{loud:?}");
        assert!(loud.cap.fitted_nm > 6.0 && loud.exceedances > 0, "{loud:?}");
        assert_eq!(stated.schedule.ceiling_nm[0], 6.0);
        // The envelope's own test: a stated constant far above this residual.
        let options = FitOptions::<2> {
            fallback_nm: V2::repeat(1e3),
            ..FitOptions::new(1e-3)
        };
        let c = rec.fit(&options).unwrap();
        for j in &c.joints {
            // Never above the constant the recording supports, which is above its peak.
            assert_eq!(j.cap.source, CapSource::Fitted, "{j:?}");
            assert!(j.threshold_max_nm <= j.cap.nm, "{j:?}");
            assert!(j.cap.nm > j.peak_nm, "{j:?}");
        }
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
}
