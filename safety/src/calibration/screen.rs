//! The contact screen: a recording with a contact in it would calibrate the contact away (the
//! envelope and the extreme-value tail absorb it, and the thresholds rise until it no longer
//! trips), so the calibration itself judges every recording before it fits, whether the
//! monitor was armed during it or not.
//!
//! A contact holds a torque on the joints for as long as it lasts; motion noise and the model
//! error the envelope describes are spikes or follow the motion features. Per joint:
//!
//! 1. the **sustained level** of each window: what r_j held over the last [`SUSTAIN_S`] — the
//!    smallest |mean of r_j| of its 10 ms windows when they all have the same sign, else 0
//!    (contiguous windows only) — divided by the mean envelope e_j(φ) over the same windows:
//!    noise averages away and changes sign, a spike (a velocity-noise pulse, a torque glitch,
//!    a heavy tail) moves one or two window means, a held contact torque moves all of them;
//! 2. its **maximum per block** (the fit's blocks);
//! 3. a **Gumbel law from the blocks' quartiles** (robust: a contact in up to a quarter of the
//!    blocks does not move it), scale β = max((Q3 − Q1)/1.5725, [`MIN_SPREAD`]),
//!    location μ = median − 0.3665·β; a block's score is (b − μ)/β;
//! 4. a block **scores beyond** ln(n/[`FALSE_REFUSAL`]) (n blocks): under that law a recording
//!    without contact has at most a [`FALSE_REFUSAL`] chance of one; the floor on β means a
//!    refused block also held about 1.5 envelopes more than the median block, and it must
//!    have held at least [`MIN_CONTACT_NM`] (a score is relative to the envelope, which a
//!    well-identified arm makes tiny);
//! 5. the envelope is refitted without the windows of the blocks beyond [`SUSPECT`] of the
//!    limit (a contact inflates it and the law, and could hide below the full limit) and every
//!    block is scored again against the remaining blocks, up to [`ROUNDS`] times. A block that still scores beyond the limit refuses the recording
//!    ([`ContactOnset`]: joint, the time the sustained level first passed the limit, the held
//!    residual).
//!
//! Measured margins (limit 10.1 at 25 blocks; `safety/tests/calibration_screen.rs`): the real
//! LWR 4+ recordings (`data/real-lwr4`, through the observer at 200 Hz) score at most
//! 4.3, the mock robot's sweeps q_A, q_B, q_C at most 4.0; a 40 N push on link 4 during q_A
//! scores far above the limit on joint 1.

use nalgebra::SVector;
use serde::{Deserialize, Serialize};

use super::recorder::{EnvelopeRecorder, Window};
use super::{ENVELOPE_TERMS, FEATURES, FitOptions, MIN_BLOCKS, WINDOW_SAMPLES};

/// Length over which a residual must hold to look like a contact \[s\]: longer than the
/// residual's transients at the default gain (2.5 ms) and the motion's model-error spikes, shorter
/// than any push a person notices.
pub const SUSTAIN_S: f64 = 0.1;
/// Chance that a recording without contact is refused, under the Gumbel law of its own blocks.
pub const FALSE_REFUSAL: f64 = 1e-3;
/// Smallest Gumbel scale, in envelopes (the sustained level's unit): a recording whose blocks
/// cluster tightly (or hold nothing: zero-mean noise changes sign) does not turn a modest
/// excursion into a refusal — at the limit of 25 blocks (10.1) a refused block held at least
/// about 1.5 envelopes more than the median block.
pub const MIN_SPREAD: f64 = 0.15;
/// Envelope refits without the suspect blocks.
pub const ROUNDS: usize = 4;
/// Smallest held residual refused as a contact \[Nm\], whatever its score. The score is
/// relative to the envelope, and an arm model that explains the motion well leaves a tiny
/// envelope: the real LWR 4+ through its identified model (`fri-ctl offline identify`, 1 kHz,
/// K = 400) has an envelope of 0.06 Nm on joint 6 and holds +0.39 Nm for 0.1 s at a velocity
/// reversal (friction the model does not follow), a score of 31.5 against a limit of 10.1. A
/// push a person notices holds far more: 15 N on link 4 holds about 6 Nm on joint 1, 10 N at
/// 0.1 m from an axis 1 Nm.
pub const MIN_CONTACT_NM: f64 = 1.0;
/// Share of the limit beyond which a block is suspect: left out of the envelope and the law
/// for the next round (a contact inflates both, and could hide below the full limit).
pub const SUSPECT: f64 = 0.5;

/// A contact-like onset found in a recording (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ContactOnset {
    /// Joint, 0-based.
    pub joint: usize,
    /// When the sustained level first lay beyond the limit (start of that window, the
    /// recording's clock) \[s\].
    pub onset_s: f64,
    /// When it peaked \[s\].
    pub peak_s: f64,
    /// The residual held over the [`SUSTAIN_S`] at the peak \[Nm\] (signed: the smallest
    /// window mean).
    pub residual_nm: f64,
    /// The envelope there \[Nm\]: what the joint's residual reaches without contact.
    pub envelope_nm: f64,
    /// The block's score (b − μ)/β.
    pub score: f64,
    /// The limit ln(n/[`FALSE_REFUSAL`]).
    pub limit: f64,
}

/// How far a recording stays from the screen's refusal ([`EnvelopeRecorder::screen_margin`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScreenMargin<const N: usize> {
    /// Largest block score per joint (NaN for a joint without envelope).
    pub scores: SVector<f64, N>,
    /// The refusal limit ln(n/[`FALSE_REFUSAL`]).
    pub limit: f64,
}

/// The block maximum of the sustained level: its value and window index.
#[derive(Debug, Clone, Copy)]
struct BlockPeak {
    level: f64,
    window: usize,
}

/// One round's judgement of a joint: the envelope's coefficients, the sustained level per
/// window, the block peaks and the law of the blocks not excluded.
struct Judgement {
    coefficients: [f64; ENVELOPE_TERMS],
    levels: Vec<f64>,
    peaks: Vec<Option<BlockPeak>>,
    law: RobustGumbel,
}

impl<const N: usize> EnvelopeRecorder<N> {
    /// The screen over the first `blocks` blocks of `per_block` windows of `window_s` seconds;
    /// `Err` with the most evident onset (largest score over limit) when a block of some joint
    /// scores beyond the limit.
    pub(super) fn screen(
        &self,
        window_s: f64,
        per_block: usize,
        blocks: usize,
    ) -> Result<(), ContactOnset> {
        let sustain = ((SUSTAIN_S / window_s).round() as usize).max(1);
        let limit = (blocks as f64 / FALSE_REFUSAL).ln();
        let mut worst: Option<ContactOnset> = None;
        for j in 0..N {
            let mut excluded = vec![false; blocks];
            let mut verdict = None;
            for _ in 0..ROUNDS {
                let Some(judged) = self.judge(j, window_s, per_block, sustain, &excluded) else {
                    break;
                };
                let flagged: Vec<(usize, BlockPeak)> = judged
                    .peaks
                    .iter()
                    .enumerate()
                    .filter_map(|(b, p)| p.map(|p| (b, p)))
                    .filter(|(_, p)| judged.law.score(p.level) > limit)
                    .collect();
                verdict = flagged
                    .iter()
                    .map(|(_, p)| (p.level, self.onset(j, &judged, *p, limit, sustain)))
                    .filter(|(_, o)| o.residual_nm.abs() >= MIN_CONTACT_NM)
                    .max_by(|a, b| a.0.total_cmp(&b.0))
                    .map(|(_, o)| o);
                // Suspect blocks (beyond half the limit) leave the envelope and the law.
                let new: Vec<usize> = judged
                    .peaks
                    .iter()
                    .enumerate()
                    .filter_map(|(b, p)| p.map(|p| (b, p)))
                    .filter(|(b, p)| !excluded[*b] && judged.law.score(p.level) > SUSPECT * limit)
                    .map(|(b, _)| b)
                    .collect();
                if new.is_empty() {
                    break;
                }
                for b in new {
                    excluded[b] = true;
                }
            }
            if let Some(o) = verdict
                && worst.is_none_or(|w| o.score > w.score)
            {
                worst = Some(o);
            }
        }
        worst.map_or(Ok(()), Err)
    }

    /// Each joint's largest block score against the law of all its blocks (the first round of
    /// the screen, before any block is left out) and the limit, for reports and tests: how far
    /// a recording without contact stays from a refusal. `None` before [`super::MIN_BLOCKS`]
    /// blocks or with invalid options.
    pub fn screen_margin(&self, options: &FitOptions<N>) -> Option<ScreenMargin<N>> {
        options.check().ok()?;
        let window_s = WINDOW_SAMPLES as f64 * options.sample_period_s;
        let per_block = ((options.block_s / window_s).round() as usize).max(1);
        let blocks = self.windows.len() / per_block;
        if blocks < MIN_BLOCKS {
            return None;
        }
        let sustain = ((SUSTAIN_S / window_s).round() as usize).max(1);
        let none = vec![false; blocks];
        let scores = SVector::from_fn(|j, _| {
            self.judge(j, window_s, per_block, sustain, &none)
                .map_or(f64::NAN, |judged| {
                    judged
                        .peaks
                        .iter()
                        .flatten()
                        .map(|p| judged.law.score(p.level))
                        .fold(f64::NEG_INFINITY, f64::max)
                })
        });
        Some(ScreenMargin {
            scores,
            limit: (blocks as f64 / FALSE_REFUSAL).ln(),
        })
    }

    /// Joint `j` judged with the envelope fitted on the blocks not `excluded`, against the law
    /// of those blocks (`None`: no envelope, or too few blocks for the law).
    fn judge(
        &self,
        j: usize,
        window_s: f64,
        per_block: usize,
        sustain: usize,
        excluded: &[bool],
    ) -> Option<Judgement> {
        let blocks = excluded.len();
        let windows = &self.windows[..blocks * per_block];
        let coefficients =
            self.fit_envelope_where(j, |i| excluded.get(i / per_block).is_some_and(|x| !*x))?;
        let levels = sustained(windows, j, &coefficients, sustain, window_s);
        let peaks: Vec<Option<BlockPeak>> = (0..blocks)
            .map(|b| block_peak(&levels, b * per_block..(b + 1) * per_block))
            .collect();
        let law = RobustGumbel::of(
            peaks
                .iter()
                .zip(excluded)
                .filter(|(_, x)| !**x)
                .filter_map(|(p, _)| p.map(|p| p.level)),
        )?;
        Some(Judgement {
            coefficients,
            levels,
            peaks,
            law,
        })
    }

    /// The onset of the excursion peaking at `peak`: the first window of the recording whose
    /// sustained level lies beyond the limit, and what was held at the peak.
    fn onset(
        &self,
        j: usize,
        judged: &Judgement,
        peak: BlockPeak,
        limit: f64,
        sustain: usize,
    ) -> ContactOnset {
        let first = (0..=peak.window)
            .find(|&i| judged.levels[i].is_finite() && judged.law.score(judged.levels[i]) > limit)
            .unwrap_or(peak.window);
        let span = &self.windows[peak.window + 1 - sustain.min(peak.window + 1)..=peak.window];
        let n = span.len() as f64;
        let mean = span.iter().map(|w| f64::from(w.mean[j])).sum::<f64>();
        let residual_nm = held(span, j).copysign(mean);
        let envelope_nm = span
            .iter()
            .map(|w| envelope(w, j, &judged.coefficients))
            .sum::<f64>()
            / n;
        ContactOnset {
            joint: j,
            onset_s: self.windows[first].time_s,
            peak_s: self.windows[peak.window].time_s,
            residual_nm,
            envelope_nm,
            score: judged.law.score(peak.level),
            limit,
        }
    }
}

/// e_j(φ) of window `w` for the coefficients `c` \[Nm\].
fn envelope<const N: usize>(w: &Window<N>, j: usize, c: &[f64; ENVELOPE_TERMS]) -> f64 {
    c[0] + (0..FEATURES)
        .map(|k| c[k + 1] * f64::from(w.features[k][j]))
        .sum::<f64>()
}

/// What the residual held over `span`: the smallest |window mean of r_j| when every window's
/// mean has the same sign, else 0 \[Nm\]. A spike moves one or two window means; a contact holds
/// all of them.
fn held<const N: usize>(span: &[Window<N>], j: usize) -> f64 {
    let means = span.iter().map(|w| f64::from(w.mean[j]));
    let (low, high) = means.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), m| {
        (lo.min(m), hi.max(m))
    });
    if low > 0.0 {
        low
    } else if high < 0.0 {
        -high
    } else {
        0.0
    }
}

/// The sustained level of every window: [`held`] over the `sustain` windows ending at it
/// divided by their mean envelope e_j, NaN where those windows are not contiguous (a gap of
/// more than half a window between two, or time going back).
fn sustained<const N: usize>(
    windows: &[Window<N>],
    j: usize,
    c: &[f64; ENVELOPE_TERMS],
    sustain: usize,
    window_s: f64,
) -> Vec<f64> {
    let mut run = 0usize;
    (0..windows.len())
        .map(|i| {
            let step = i
                .checked_sub(1)
                .map(|p| windows[i].time_s - windows[p].time_s);
            run = match step {
                Some(dt) if dt > 0.0 && dt <= 1.5 * window_s => run + 1,
                _ => 1,
            };
            if run < sustain {
                return f64::NAN;
            }
            let span = &windows[i + 1 - sustain..=i];
            let e = span.iter().map(|w| envelope(w, j, c)).sum::<f64>() / sustain as f64;
            held(span, j) / e
        })
        .collect()
}

/// The largest finite level in `range` with its index.
fn block_peak(levels: &[f64], range: std::ops::Range<usize>) -> Option<BlockPeak> {
    range
        .filter(|&i| levels[i].is_finite())
        .map(|i| BlockPeak {
            level: levels[i],
            window: i,
        })
        .max_by(|a, b| a.level.total_cmp(&b.level))
}

/// A Gumbel law from the quartiles of a sample (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
struct RobustGumbel {
    location: f64,
    scale: f64,
}

/// Least blocks the quartiles are taken from.
const MIN_LAW_BLOCKS: usize = 8;

impl RobustGumbel {
    /// From the quartiles of `values` (`None` with fewer than [`MIN_LAW_BLOCKS`]).
    fn of(values: impl Iterator<Item = f64>) -> Option<Self> {
        let mut v: Vec<f64> = values.filter(|x| x.is_finite()).collect();
        if v.len() < MIN_LAW_BLOCKS {
            return None;
        }
        v.sort_by(f64::total_cmp);
        let q = |p: f64| super::bootstrap::quantile_sorted(&v, p);
        let (q1, median, q3) = (q(0.25), q(0.5), q(0.75));
        // Gumbel quantiles: Q(p) = μ − β·ln(−ln p); Q3 − Q1 = 1.5725·β, median = μ + 0.3665·β.
        let scale = ((q3 - q1) / 1.5725).max(MIN_SPREAD);
        Some(Self {
            location: median - 0.3665 * scale,
            scale,
        })
    }

    /// (x − μ)/β.
    fn score(&self, x: f64) -> f64 {
        (x - self.location) / self.scale
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_law_of_a_gumbel_sample_scores_its_own_maximum_below_the_limit() {
        let mut rng = super::super::rng::SplitMix64(11);
        let x: Vec<f64> = (0..2000)
            .map(|_| 2.0 - 0.5 * (-(rng.uniform().max(1e-300)).ln()).ln())
            .collect();
        let law = RobustGumbel::of(x.iter().copied()).unwrap();
        assert!((law.location - 2.0).abs() < 0.1, "{law:?}");
        assert!((law.scale - 0.5).abs() < 0.05, "{law:?}");
        let max = x.iter().copied().fold(f64::MIN, f64::max);
        assert!(
            law.score(max) < (2000.0 / FALSE_REFUSAL).ln(),
            "{law:?} {max}"
        );
        // A clustered sample keeps the floor on its scale.
        let tight = RobustGumbel::of((0..20).map(|i| 1.0 + 1e-6 * f64::from(i))).unwrap();
        assert_eq!(tight.scale, MIN_SPREAD, "{tight:?}");
        assert!(RobustGumbel::of([1.0; 5].into_iter()).is_none());
    }

    /// A synthetic residual of two joints at 1 kHz: noise whose scale follows a speed feature,
    /// through the observer's first-order response; joint 1's noise heavy-tailed (Pareto spikes
    /// of index 1.5 on top of the Gaussian, about one a second); from `step.0` for `step.1`
    /// seconds joint 2 holds `step.2` Nm.
    fn record(seconds: f64, step: Option<(f64, f64, f64)>, seed: u64) -> EnvelopeRecorder<2> {
        let mut rng = super::super::rng::SplitMix64(seed);
        let mut rec = EnvelopeRecorder::<2>::new();
        let mut r = SVector::<f64, 2>::zeros();
        for k in 0..(seconds * 1000.0) as usize {
            let t = k as f64 * 1e-3;
            let v = (t * 0.7).sin().abs();
            let f = crate::envelope::MotionFeatures::from_speed(&SVector::repeat(v));
            let mut gauss = || {
                let (u1, u2) = (rng.uniform().max(1e-300), rng.uniform());
                (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
            };
            let (g1, g2) = (gauss(), gauss());
            let spike = if rng.uniform() < 1e-3 {
                let sign = if rng.uniform() < 0.5 { -1.0 } else { 1.0 };
                sign * 0.5 * rng.uniform().max(1e-12).powf(-1.0 / 1.5)
            } else {
                0.0
            };
            let u = SVector::<f64, 2>::new(
                (g1 * 0.2 + spike) * (1.0 + 2.0 * v),
                g2 * 0.1 * (1.0 + v)
                    + step.map_or(
                        0.0,
                        |(at, long, nm)| {
                            if t >= at && t < at + long { nm } else { 0.0 }
                        },
                    ),
            );
            r = r * 0.6 + u * 0.4;
            rec.push(t, &r, &f);
        }
        rec
    }

    #[test]
    fn heavy_tailed_noise_passes_and_a_held_torque_is_refused_naming_joint_and_time() {
        let options = FitOptions::<2>::new(1e-3);
        let clean = record(120.0, None, 5);
        let margin = clean.screen_margin(&options).unwrap();
        assert!(
            margin.scores.iter().all(|s| *s < SUSPECT * margin.limit),
            "{margin:?}"
        );
        assert!(clean.fit(&options).is_ok());
        // 0.5 Nm held on joint 2 (five times its noise) for 3 s scores beyond the limit but
        // is below MIN_CONTACT_NM: the recording is fitted.
        let small = record(120.0, Some((40.5, 3.0, 0.5)), 5);
        let m = small.screen_margin(&options).unwrap();
        assert!(m.scores[1] > m.limit, "{m:?}");
        assert!(small.fit(&options).is_ok());
        // 2 Nm held on joint 2 (twenty times its noise) for 3 s from 40.5 s.
        let touched = record(120.0, Some((40.5, 3.0, 2.0)), 5);
        match touched.fit(&options) {
            Err(super::super::CalibrationError::ContactInRecording(o)) => {
                assert_eq!(o.joint, 1, "{o:?}");
                assert!((o.onset_s - 40.5).abs() < 0.15, "{o:?}");
                assert!(o.peak_s >= o.onset_s && o.peak_s < 43.6, "{o:?}");
                assert!((o.residual_nm - 2.0).abs() < 0.2, "{o:?}");
                assert!(o.score > o.limit, "{o:?}");
            }
            other => panic!("{other:?}"),
        }
        // A contact a quarter of the recording long is still found (the quartiles hold).
        let long = record(120.0, Some((30.0, 28.0, 2.0)), 6);
        assert!(matches!(
            long.fit(&options),
            Err(super::super::CalibrationError::ContactInRecording(o)) if o.joint == 1
        ));
    }
}
