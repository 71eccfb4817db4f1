//! The identification's held-out segments, by speed.
//!
//! The pieces are cut into segments of about `segment_s`, ranked by their mean joint speed
//! |q̇|₂ and dealt into folds of consecutive rank (the slowest fifth, …, the fastest fifth).
//! Every fold is predicted by a fit that never saw motion of its speed, so the weight chosen on
//! them holds on a faster (or slower) trajectory, not only on a repeat of the same one. Repeats
//! of one trajectory (runs 1 and 2 of the real arm) have about the same speed segment by
//! segment, so they mostly fall into the same fold and are seldom fitted and checked at once:
//! contiguous blocks of a repeated path measure repeatability, not generalisation.

use super::Piece;

/// Default length of a held-out segment, s: several periods of an excitation's slowest
/// harmonic at most, many segments per fold on a 25 s log.
pub const DEFAULT_SEGMENT_S: f64 = 2.5;

/// The fold of every sample (pieces in order, samples in order): segments of about
/// `segment_s` (shorter when the logs hold fewer than four per fold), ranked by mean |q̇|₂
/// (rad/s), dealt into `folds` groups of consecutive rank, slowest first.
pub(super) fn speed_folds<const N: usize>(
    pieces: &[Piece<N>],
    segment_s: f64,
    folds: usize,
) -> Vec<usize> {
    let folds = folds.max(1);
    let duration: f64 = pieces
        .iter()
        .map(|p| p.t.last().copied().unwrap_or(0.0) - p.t.first().copied().unwrap_or(0.0))
        .sum();
    let length = segment_s
        .min(duration / (4 * folds) as f64)
        .max(f64::MIN_POSITIVE);
    // (first sample, samples, mean speed) per segment; a segment never spans two pieces
    let mut segments: Vec<(usize, usize, f64)> = Vec::new();
    let mut start = 0;
    for piece in pieces {
        let t0 = piece.t.first().copied().unwrap_or(0.0);
        let mut current: Option<(usize, usize, f64, f64)> = None;
        for k in 0..piece.len() {
            let index = ((piece.t[k] - t0) / length).floor();
            let speed = piece.qd[k].norm();
            match &mut current {
                Some((_, n, sum, seg)) if *seg == index => {
                    *n += 1;
                    *sum += speed;
                }
                _ => {
                    if let Some((first, n, sum, _)) = current.take() {
                        segments.push((first, n, sum / n as f64));
                    }
                    current = Some((start + k, 1, speed, index));
                }
            }
        }
        if let Some((first, n, sum, _)) = current {
            segments.push((first, n, sum / n as f64));
        }
        start += piece.len();
    }
    let mut ranked: Vec<usize> = (0..segments.len()).collect();
    ranked.sort_by(|a, b| segments[*a].2.total_cmp(&segments[*b].2));
    let mut fold = vec![0; start];
    let count = segments.len().max(1);
    for (rank, s) in ranked.into_iter().enumerate() {
        let f = (rank * folds / count).min(folds - 1);
        let (first, n, _) = segments[s];
        fold[first..first + n].iter_mut().for_each(|v| *v = f);
    }
    fold
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::SVector;

    type V2 = SVector<f64, 2>;

    /// A piece of `seconds` at 100 Hz whose speed grows with time.
    fn ramp(seconds: f64) -> Piece<2> {
        let n = (seconds * 100.0) as usize;
        let t: Vec<f64> = (0..n).map(|k| k as f64 * 0.01).collect();
        Piece {
            qd: t.iter().map(|s| V2::repeat(*s)).collect(),
            q: vec![V2::zeros(); n],
            qdd: vec![V2::zeros(); n],
            tau: vec![V2::zeros(); n],
            t,
        }
    }

    #[test]
    fn folds_group_segments_by_speed_and_repeats_together() {
        // two repeats of one 25 s ramp: each fold holds the same stretch of both
        let pieces = [ramp(25.0), ramp(25.0)];
        let fold = speed_folds(&pieces, 2.5, 5);
        let n = pieces[0].len();
        assert_eq!(fold.len(), 2 * n);
        let same = (0..n).filter(|&k| fold[k] == fold[n + k]).count();
        assert!(same * 10 >= n * 8, "{same} of {n} samples in the same fold");
        // slowest first, fastest last, every fold used, monotone along the ramp
        assert_eq!(fold[0], 0);
        assert_eq!(fold[n - 1], 4);
        assert!(fold[..n].windows(2).all(|w| w[0] <= w[1]), "not monotone");
        for f in 0..5 {
            assert!(fold.contains(&f), "fold {f} empty");
        }
        // a short log still gets at least four segments per fold
        let short = speed_folds(&[ramp(5.0)], 2.5, 5);
        for f in 0..5 {
            assert!(short.iter().filter(|v| **v == f).count() >= 40, "fold {f}");
        }
    }
}
