//! The samples an identification fits: (t, q, q̇, q̈, τ) per contiguous piece of each log, with
//! the log's own derivatives when it carries them, otherwise derived here on its own stamps.

use nalgebra::SVector;

use crate::error::EstimatorError;
use crate::motion::{RecordedLog, filtered, gap_ranges};

use super::IdentifyOptions;

/// One contiguous piece of samples.
#[derive(Debug, Clone, Default)]
pub struct Piece<const N: usize> {
    /// Time, s.
    pub t: Vec<f64>,
    /// Positions, rad.
    pub q: Vec<SVector<f64, N>>,
    /// Velocities, rad/s.
    pub qd: Vec<SVector<f64, N>>,
    /// Accelerations, rad/s².
    pub qdd: Vec<SVector<f64, N>>,
    /// Measured torques, Nm.
    pub tau: Vec<SVector<f64, N>>,
}

impl<const N: usize> Piece<N> {
    /// Samples in the piece.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// Whether the piece has no samples.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// Every `stride`-th sample.
    fn every(&self, stride: usize) -> Self {
        let pick = |v: &Vec<SVector<f64, N>>| v.iter().step_by(stride).copied().collect();
        Piece {
            t: self.t.iter().step_by(stride).copied().collect(),
            q: pick(&self.q),
            qd: pick(&self.qd),
            qdd: pick(&self.qdd),
            tau: pick(&self.tau),
        }
    }
}

/// How the samples were obtained.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Preparation {
    /// Pieces whose q̇, q̈ came from the log.
    pub recorded: usize,
    /// Pieces whose q̇, q̈ (and filtered q, τ) were derived here.
    pub derived: usize,
    /// Gaps in the logs' stamps.
    pub gaps: usize,
    /// Rows left out (pieces too short, filter edges, decimation excluded).
    pub dropped_rows: usize,
}

/// One contiguous part of a log as samples, and whether its derivatives were recorded; `None`
/// when it is too short for the filter's edges (see [`prepare`]).
pub fn piece_of<const N: usize>(
    part: &RecordedLog<N>,
    options: &IdentifyOptions,
) -> Result<Option<(Piece<N>, bool)>, EstimatorError> {
    if let (Some(d), true) = (&part.derivatives, options.recorded_derivatives) {
        return Ok(Some((
            Piece {
                t: part.trajectory.t.clone(),
                q: part.trajectory.q.clone(),
                qd: d.qd.clone(),
                qdd: d.qdd.clone(),
                tau: part.trajectory.tau.clone(),
            },
            true,
        )));
    }
    let samples = match filtered(
        &part.trajectory,
        options.order,
        options.cutoff_hz,
        options.trim_s,
    ) {
        Ok(s) => s,
        Err(EstimatorError::TooFewSamples { .. } | EstimatorError::LogTooShort { .. }) => {
            return Ok(None);
        }
        Err(e) => return Err(e),
    };
    Ok(Some((
        Piece {
            t: samples.iter().map(|s| s.t).collect(),
            q: samples.iter().map(|s| s.q).collect(),
            qd: samples.iter().map(|s| s.qd).collect(),
            qdd: samples.iter().map(|s| s.qdd).collect(),
            tau: samples.iter().map(|s| s.tau).collect(),
        },
        false,
    )))
}

/// Cuts every log at its gaps and turns each piece into samples (see the module docs):
/// recorded derivatives are used as they are; otherwise q and τ are filtered forward and
/// backward (Butterworth, `options.order` and `options.cutoff_hz`) on the piece's own stamps,
/// differentiated by central differences and trimmed by `options.trim_s` (default 3/cutoff) at
/// both ends. Pieces are then thinned to at most `options.max_rate_hz`.
pub fn prepare<const N: usize>(
    logs: &[RecordedLog<N>],
    options: &IdentifyOptions,
) -> Result<(Vec<Piece<N>>, Preparation), EstimatorError> {
    let mut pieces = Vec::new();
    let mut how = Preparation::default();
    for (i, log) in logs.iter().enumerate() {
        let (ranges, gaps, dropped) = gap_ranges(&log.trajectory.t)
            .map_err(|e| EstimatorError::InvalidSetting(format!("log {}: {e}", i + 1)))?;
        how.gaps += gaps;
        how.dropped_rows += dropped;
        for range in ranges {
            let rows = range.len();
            let Some((piece, recorded)) = piece_of(&log.slice(range), options)? else {
                how.dropped_rows += rows;
                continue;
            };
            if recorded {
                how.recorded += 1;
            } else {
                how.derived += 1;
                how.dropped_rows += rows - piece.len();
            }
            let span =
                piece.t.last().copied().unwrap_or(0.0) - piece.t.first().copied().unwrap_or(0.0);
            let rate = if span > 0.0 {
                (piece.len() - 1) as f64 / span
            } else {
                0.0
            };
            let stride = ((rate / options.max_rate_hz).floor() as usize).max(1);
            let thinned = piece.every(stride);
            how.dropped_rows += piece.len() - thinned.len();
            pieces.push(thinned);
        }
    }
    let total: usize = pieces.iter().map(Piece::len).sum();
    if total == 0 {
        return Err(EstimatorError::TooFewSamples {
            got: 0,
            need: 1,
            what: "usable samples in the logs (every piece between gaps was too short)",
        });
    }
    Ok((pieces, how))
}
