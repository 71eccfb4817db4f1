//! A tare run of the same trajectory, aligned to the loaded run: a real arm never repeats a
//! trajectory to the sample (run 2 of the shared LWR recordings lags run 1 by a few ms and
//! differs by up to 6 mrad at the same index), so the tare is shifted in time to match the
//! loaded run's positions (least squares over every joint, sub-sample by a parabola through the
//! best shift), interpolated at the loaded run's times, and the small remaining difference in
//! path is carried by the model: τ_tare(q_loaded) ≈ τ_tare + τ_model(q_loaded, q̇, q̈) −
//! τ_model(q_tare, q̇, q̈). Only a path that still differs by more than the tolerance after the
//! alignment is refused (docs/estimation.md, "Tare runs of a trajectory").

use nalgebra::SVector;
use serde::{Deserialize, Serialize};

use crate::error::EstimatorError;
use crate::motion::ProcessedSample;

/// Default largest joint-position difference between the loaded run and the aligned tare, rad
/// (≈ 1.1°). The model carries the torque of the difference; its own error on that difference
/// is the model error's change over 0.02 rad — ≤ 0.05 Nm on the LWR, whose identified residual
/// changes by less than 2.5 Nm/rad along the recordings.
pub const DEFAULT_PATH_TOLERANCE: f64 = 0.02;
/// Largest time shift searched, s.
pub const MAX_SHIFT_S: f64 = 2.0;
/// Smallest share of the loaded run the shifted tare must cover.
pub const MIN_OVERLAP: f64 = 0.5;

/// How a tare was aligned.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Alignment {
    /// The tare's time shift: tare time = loaded time + shift, s.
    pub shift_s: f64,
    /// Largest joint-position difference after the alignment, rad.
    pub max_difference: f64,
    /// The joint (1-based) and loaded time (s) of that difference.
    pub at_joint: usize,
    /// Loaded time of the largest difference, s.
    pub at_time_s: f64,
    /// Loaded samples outside the shifted tare (left out).
    pub dropped: usize,
}

fn q_at<const N: usize>(tare: &[ProcessedSample<N>], t: f64, hint: &mut usize) -> SVector<f64, N> {
    interpolate_sample(tare, t, hint).q
}

fn interpolate_sample<const N: usize>(
    s: &[ProcessedSample<N>],
    t: f64,
    hint: &mut usize,
) -> ProcessedSample<N> {
    let n = s.len();
    if t <= s[0].t {
        return s[0].clone();
    }
    if t >= s[n - 1].t {
        return s[n - 1].clone();
    }
    let mut k = (*hint).min(n - 2);
    while k > 0 && s[k].t > t {
        k -= 1;
    }
    while k + 2 < n && s[k + 1].t < t {
        k += 1;
    }
    *hint = k;
    let w = (t - s[k].t) / (s[k + 1].t - s[k].t);
    let mix = |a: &SVector<f64, N>, b: &SVector<f64, N>| a * (1.0 - w) + b * w;
    ProcessedSample {
        t,
        q: mix(&s[k].q, &s[k + 1].q),
        qd: mix(&s[k].qd, &s[k + 1].qd),
        qdd: mix(&s[k].qdd, &s[k + 1].qdd),
        tau: mix(&s[k].tau, &s[k + 1].tau),
    }
}

/// Mean squared position difference at `shift` over the loaded samples the shifted tare covers;
/// `None` when it covers less than [`MIN_OVERLAP`].
fn mismatch<const N: usize>(
    loaded: &[ProcessedSample<N>],
    tare: &[ProcessedSample<N>],
    shift: f64,
    stride: usize,
) -> Option<f64> {
    let (first, last) = (tare[0].t, tare[tare.len() - 1].t);
    let mut hint = 0;
    let (mut sum, mut count, mut total) = (0.0, 0usize, 0usize);
    for s in loaded.iter().step_by(stride.max(1)) {
        total += 1;
        let at = s.t + shift;
        if at < first || at > last {
            continue;
        }
        sum += (s.q - q_at(tare, at, &mut hint)).norm_squared();
        count += 1;
    }
    (count as f64 >= MIN_OVERLAP * total as f64 && count > 0).then(|| sum / count as f64)
}

/// The tare at the loaded samples' times (shifted), `None` where it does not cover them, and the
/// alignment; Err when the best-aligned paths differ by more than `tolerance` (rad) on a joint.
pub fn align_tare<const N: usize>(
    loaded: &[ProcessedSample<N>],
    tare: &[ProcessedSample<N>],
    tolerance: f64,
) -> Result<(Vec<Option<ProcessedSample<N>>>, Alignment), EstimatorError> {
    if !(tolerance.is_finite() && tolerance > 0.0) {
        return Err(EstimatorError::InvalidSetting(format!(
            "tare tolerance {tolerance} rad must be a positive number"
        )));
    }
    if loaded.len() < 3 || tare.len() < 3 {
        return Err(EstimatorError::TooFewSamples {
            got: loaded.len().min(tare.len()),
            need: 3,
            what: "samples of a loaded run and its tare",
        });
    }
    let dt = (loaded[loaded.len() - 1].t - loaded[0].t) / (loaded.len() - 1) as f64;
    // the two clocks may start anywhere: search around the offset of the two starts
    let base = tare[0].t - loaded[0].t;
    let reach = MAX_SHIFT_S.min(0.5 * (loaded[loaded.len() - 1].t - loaded[0].t));
    let coarse_step = (10.0 * dt).max(1e-6);
    let coarse = (reach / coarse_step).ceil() as i64;
    let best = |range: std::ops::RangeInclusive<i64>, step: f64, centre: f64, stride: usize| {
        range
            .filter_map(|i| {
                let s = centre + i as f64 * step;
                mismatch(loaded, tare, s, stride).map(|m| (s, m))
            })
            .min_by(|a, b| a.1.total_cmp(&b.1))
    };
    let Some((c, _)) = best(-coarse..=coarse, coarse_step, base, 10) else {
        return Err(EstimatorError::TarePoseMismatch {
            detail: format!(
                "the tare covers less than {:.0} % of the loaded run at every shift within ±{reach:.1} s",
                100.0 * MIN_OVERLAP
            ),
        });
    };
    let fine = best(-12..=12, dt, c, 1);
    let Some((f, m0)) = fine else {
        return Err(EstimatorError::TarePoseMismatch {
            detail: "the tare does not overlap the loaded run".into(),
        });
    };
    // sub-sample: the parabola through the best shift and its neighbours
    let shift = match (
        mismatch(loaded, tare, f - dt, 1),
        mismatch(loaded, tare, f + dt, 1),
    ) {
        (Some(lo), Some(hi)) if lo + hi - 2.0 * m0 > 0.0 => {
            f + 0.5 * dt * (lo - hi) / (lo + hi - 2.0 * m0)
        }
        _ => f,
    };
    let (first, last) = (tare[0].t, tare[tare.len() - 1].t);
    let mut hint = 0;
    let mut out = Vec::with_capacity(loaded.len());
    let mut worst = (0.0f64, 0usize, f64::NAN);
    let mut dropped = 0;
    for s in loaded {
        let at = s.t + shift;
        if at < first || at > last {
            out.push(None);
            dropped += 1;
            continue;
        }
        let u = interpolate_sample(tare, at, &mut hint);
        for j in 0..N {
            let d = (s.q[j] - u.q[j]).abs();
            if d.is_nan() || d > worst.0 {
                worst = (d, j, s.t);
            }
        }
        out.push(Some(u));
    }
    let alignment = Alignment {
        shift_s: shift,
        max_difference: worst.0,
        at_joint: worst.1 + 1,
        at_time_s: worst.2,
        dropped,
    };
    if worst.0.is_nan() || worst.0 > tolerance {
        return Err(EstimatorError::TarePoseMismatch {
            detail: format!(
                "after aligning the tare by {:.4} s, joint {} still differs by {:.5} rad at \
                 t = {:.3} s, more than the tolerance of {tolerance} rad: the tare is not a \
                 repeat of this trajectory",
                alignment.shift_s,
                alignment.at_joint,
                alignment.max_difference,
                alignment.at_time_s
            ),
        });
    }
    Ok((out, alignment))
}
