//! Zero-phase Butterworth low-pass filtering (forward–backward, like `filtfilt`) and numerical
//! differentiation of uniformly sampled signals.

use crate::error::EstimatorError;

/// One second-order (or first-order, with `b2 = a2 = 0`) section, normalised so that a0 = 1.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Biquad {
    /// Numerator coefficients b0, b1, b2.
    pub b: [f64; 3],
    /// Denominator coefficients a1, a2 (a0 = 1).
    pub a: [f64; 2],
}

impl Biquad {
    /// Complex frequency response at normalised angular frequency `omega` (rad/sample): (re, im).
    pub fn response(&self, omega: f64) -> (f64, f64) {
        // H = (b0 + b1 z⁻¹ + b2 z⁻²)/(1 + a1 z⁻¹ + a2 z⁻²), z⁻¹ = e^{-jω}
        let (c1, s1) = (omega.cos(), -omega.sin());
        let (c2, s2) = ((2.0 * omega).cos(), -(2.0 * omega).sin());
        let nr = self.b[0] + self.b[1] * c1 + self.b[2] * c2;
        let ni = self.b[1] * s1 + self.b[2] * s2;
        let dr = 1.0 + self.a[0] * c1 + self.a[1] * c2;
        let di = self.a[0] * s1 + self.a[1] * s2;
        let den = dr * dr + di * di;
        ((nr * dr + ni * di) / den, (ni * dr - nr * di) / den)
    }
}

/// A digital Butterworth low-pass filter as a cascade of sections (bilinear transform with
/// pre-warping, so the −3 dB point of one pass is exactly at the cutoff).
#[derive(Debug, Clone, PartialEq)]
pub struct Butterworth {
    /// Cascade of sections, applied in order.
    pub sections: Vec<Biquad>,
    /// Filter order.
    pub order: usize,
    /// Cutoff frequency, Hz.
    pub cutoff_hz: f64,
    /// Sample rate, Hz.
    pub sample_rate_hz: f64,
}

impl Butterworth {
    /// Designs an order-`order` low-pass with cutoff `cutoff_hz` for samples at `sample_rate_hz`.
    pub fn low_pass(
        order: usize,
        cutoff_hz: f64,
        sample_rate_hz: f64,
    ) -> Result<Self, EstimatorError> {
        if order == 0 || order > 12 {
            return Err(EstimatorError::InvalidSetting(format!(
                "filter order {order} must be in 1..=12"
            )));
        }
        if !(sample_rate_hz.is_finite() && sample_rate_hz > 0.0) {
            return Err(EstimatorError::InvalidSetting(format!(
                "sample rate {sample_rate_hz} Hz must be positive"
            )));
        }
        if !(cutoff_hz.is_finite() && cutoff_hz > 0.0 && cutoff_hz < 0.5 * sample_rate_hz) {
            return Err(EstimatorError::InvalidSetting(format!(
                "cutoff {cutoff_hz} Hz must lie between 0 and the Nyquist frequency {} Hz",
                0.5 * sample_rate_hz
            )));
        }
        let k = 2.0 * sample_rate_hz;
        let wc = k * (std::f64::consts::PI * cutoff_hz / sample_rate_hz).tan();
        let mut sections = Vec::new();
        for i in 0..order / 2 {
            // analog pole pair wc·exp(jθ), θ = π(2i + n + 1)/(2n); σ = wc cos θ < 0
            let theta = std::f64::consts::PI * (2 * i + order + 1) as f64 / (2 * order) as f64;
            let sigma = wc * theta.cos();
            let a0 = k * k - 2.0 * sigma * k + wc * wc;
            let a1 = 2.0 * (wc * wc - k * k);
            let a2 = k * k + 2.0 * sigma * k + wc * wc;
            let g = wc * wc / a0;
            sections.push(Biquad {
                b: [g, 2.0 * g, g],
                a: [a1 / a0, a2 / a0],
            });
        }
        if order % 2 == 1 {
            let a0 = k + wc;
            let g = wc / a0;
            sections.push(Biquad {
                b: [g, g, 0.0],
                a: [(wc - k) / a0, 0.0],
            });
        }
        Ok(Butterworth {
            sections,
            order,
            cutoff_hz,
            sample_rate_hz,
        })
    }

    /// Magnitude of one (forward) pass at frequency `f_hz`.
    pub fn magnitude(&self, f_hz: f64) -> f64 {
        let w = 2.0 * std::f64::consts::PI * f_hz / self.sample_rate_hz;
        self.sections
            .iter()
            .map(|s| {
                let (re, im) = s.response(w);
                (re * re + im * im).sqrt()
            })
            .product()
    }

    fn run(&self, x: &mut [f64]) {
        let Some(&x0) = x.first() else { return };
        for s in &self.sections {
            // transposed direct form II, started in the steady state of a constant input x0
            // (every section has unit DC gain)
            let mut z2 = (s.b[2] - s.a[1]) * x0;
            let mut z1 = (s.b[1] - s.a[0]) * x0 + z2;
            for v in x.iter_mut() {
                let input = *v;
                let y = s.b[0] * input + z1;
                z1 = s.b[1] * input - s.a[0] * y + z2;
                z2 = s.b[2] * input - s.a[1] * y;
                *v = y;
            }
        }
    }

    /// Zero-phase filtering: forward and backward passes over the signal extended at both ends
    /// by odd reflection, so there is neither phase lag nor an edge step. Magnitude is that of
    /// one pass squared.
    pub fn filtfilt(&self, x: &[f64]) -> Vec<f64> {
        let n = x.len();
        if n < 2 {
            return x.to_vec();
        }
        let settle = (3.0 * self.sample_rate_hz / self.cutoff_hz).ceil() as usize;
        let pad = settle.max(3 * (self.order + 1)).min(n - 1);
        let mut ext = Vec::with_capacity(n + 2 * pad);
        let (first, last) = (x[0], x[n - 1]);
        ext.extend((1..=pad).rev().map(|i| 2.0 * first - x[i]));
        ext.extend_from_slice(x);
        ext.extend((1..=pad).map(|i| 2.0 * last - x[n - 1 - i]));
        self.run(&mut ext);
        ext.reverse();
        self.run(&mut ext);
        ext.reverse();
        ext[pad..pad + n].to_vec()
    }
}

/// First derivative of a uniformly sampled signal (step `dt` s): central differences inside,
/// second-order one-sided differences at the ends (units of x per s).
pub fn derivative(x: &[f64], dt: f64) -> Vec<f64> {
    let n = x.len();
    match n {
        0 => Vec::new(),
        1 => vec![0.0],
        2 => vec![(x[1] - x[0]) / dt; 2],
        _ => {
            let mut d = Vec::with_capacity(n);
            d.push((-3.0 * x[0] + 4.0 * x[1] - x[2]) / (2.0 * dt));
            d.extend((1..n - 1).map(|k| (x[k + 1] - x[k - 1]) / (2.0 * dt)));
            d.push((3.0 * x[n - 1] - 4.0 * x[n - 2] + x[n - 3]) / (2.0 * dt));
            d
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn magnitude_is_the_warped_butterworth_response() {
        // bilinear-transformed Butterworth: |H|² = 1 / (1 + (tan(πf/fs)/tan(πfc/fs))^(2N))
        for order in [1, 2, 3, 4, 5] {
            let f = Butterworth::low_pass(order, 1.0, 200.0).unwrap();
            for freq in [0.0, 0.3, 1.0, 2.0, 7.5, 40.0] {
                let r = (PI * freq / 200.0).tan() / (PI * 1.0 / 200.0).tan();
                let expect = 1.0 / (1.0 + r.powi(2 * order as i32)).sqrt();
                let got = f.magnitude(freq);
                assert!(
                    (got - expect).abs() < 1e-9,
                    "order {order} f {freq}: {got} vs {expect}"
                );
            }
        }
    }

    #[test]
    fn filtfilt_has_no_phase_lag_and_removes_high_frequencies() {
        let fs = 200.0;
        let n = 3001; // 0..=15 s: the 25 Hz component is zero on both end samples
        let t: Vec<f64> = (0..n).map(|k| k as f64 / fs).collect();
        let slow: Vec<f64> = t.iter().map(|t| 0.7 + (2.0 * PI * 0.2 * t).sin()).collect();
        let noisy: Vec<f64> = t
            .iter()
            .zip(&slow)
            .map(|(t, s)| s + 0.3 * (2.0 * PI * 25.0 * t).sin())
            .collect();
        let f = Butterworth::low_pass(4, 1.0, fs).unwrap();
        let y = f.filtfilt(&noisy);
        // |H(0.2 Hz)|² = 1/(1 + 0.2⁸) ≈ 1 and zero phase; |H(25 Hz)|² ≈ 7e-23
        // the end samples are reflection pivots (as in `filtfilt`): noise on them would leak,
        // which is why the test signal has none there; edges included in the check
        let max_err = y
            .iter()
            .zip(&slow)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(max_err < 5e-3, "max error {max_err}");
    }

    #[test]
    fn derivative_of_polynomial() {
        let dt = 0.01;
        let x: Vec<f64> = (0..50).map(|k| (k as f64 * dt).powi(2)).collect();
        let d = derivative(&x, dt);
        for (k, v) in d.iter().enumerate() {
            assert!((v - 2.0 * k as f64 * dt).abs() < 1e-10, "k {k}: {v}");
        }
    }

    #[test]
    fn bad_settings_are_rejected() {
        assert!(Butterworth::low_pass(0, 1.0, 200.0).is_err());
        assert!(Butterworth::low_pass(2, 150.0, 200.0).is_err());
        assert!(Butterworth::low_pass(2, 1.0, -1.0).is_err());
    }
}
