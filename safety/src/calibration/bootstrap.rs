//! Resampling with replacement and quantiles.

use super::rng::SplitMix64;

/// `resamples` values of `statistic` on resamples (with replacement) of `sample`; NaN results
/// are dropped.
pub(super) fn bootstrap(
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
pub(super) fn quantile(values: &[f64], q: f64) -> f64 {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    quantile_sorted(&v, q)
}

pub(super) fn quantile_sorted(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let pos = q.clamp(0.0, 1.0) * (sorted.len() - 1) as f64;
    let (lo, hi) = (pos.floor() as usize, pos.ceil() as usize);
    sorted[lo] + (sorted[hi] - sorted[lo]) * (pos - lo as f64)
}
