//! Trajectory logs: the CSV reader, optional recorded derivatives, and the cut at gaps.

use std::io::Read;
use std::ops::Range;

use nalgebra::SVector;

use crate::error::EstimatorError;

/// A recorded trajectory: time stamps (s), measured positions (rad) and joint torques (Nm).
#[derive(Debug, Clone, PartialEq)]
pub struct Trajectory<const N: usize> {
    /// Time stamps, s, strictly increasing (a real log's step jitters: the stamps are used).
    pub t: Vec<f64>,
    /// Measured joint positions, rad.
    pub q: Vec<SVector<f64, N>>,
    /// Measured joint torques τ_J, Nm.
    pub tau: Vec<SVector<f64, N>>,
}

/// Joint velocities and accelerations a recorder derived, one per row.
#[derive(Debug, Clone, PartialEq)]
pub struct Derivatives<const N: usize> {
    /// Velocities, rad/s.
    pub qd: Vec<SVector<f64, N>>,
    /// Accelerations, rad/s².
    pub qdd: Vec<SVector<f64, N>>,
}

/// A trajectory log with the velocities and accelerations its recorder derived, when it has
/// both (`qd1..n`, rad/s, and `qdd1..n`, rad/s²; e.g. an identification data set).
#[derive(Debug, Clone, PartialEq)]
pub struct RecordedLog<const N: usize> {
    /// Stamps, positions and torques.
    pub trajectory: Trajectory<N>,
    /// Recorded joint velocities and accelerations, when the log carries both groups.
    pub derivatives: Option<Derivatives<N>>,
}

/// Reads a trajectory log, CSV with header `t,q1..qn,tau1..taun` (s, rad, Nm); other columns
/// ignored. The time column may also be `time_s`, as the service's `record --kind log` writes it.
pub fn read_log_csv<const N: usize, R: Read>(reader: R) -> Result<Trajectory<N>, EstimatorError> {
    read_recorded_csv(reader).map(|l| l.trajectory)
}

/// Reads a trajectory log like [`read_log_csv`], keeping `qd1..n` and `qdd1..n` when the log has
/// both groups (a log with only one of them, like the service's, gets derivatives computed).
pub fn read_recorded_csv<const N: usize, R: Read>(
    reader: R,
) -> Result<RecordedLog<N>, EstimatorError> {
    let (mut rdr, header) = crate::samples::open_csv(reader)?;
    let col = |name: &str| -> Option<usize> { header.iter().position(|h| h == name) };
    let ct = col("time_s")
        .or_else(|| col("t"))
        .ok_or_else(|| EstimatorError::WrongColumns {
            joints: N,
            detail: format!(
                "the log has no column `t` or `time_s` (needs t, q1..q{N}, tau1..tau{N})"
            ),
        })?;
    let group = |prefix: &str, required: bool| {
        crate::samples::find_group::<N>(&header, prefix, required).map_err(|_| {
            EstimatorError::WrongColumns {
                joints: N,
                detail: format!("the log needs the columns {prefix}1..{prefix}{N}, once each"),
            }
        })
    };
    let missing = |prefix: &str| EstimatorError::WrongColumns {
        joints: N,
        detail: format!("the log has no columns {prefix}1..{prefix}{N}"),
    };
    let cq = group("q", true)?.ok_or_else(|| missing("q"))?;
    let ctau = group("tau", true)?.ok_or_else(|| missing("tau"))?;
    let derivative_columns = match (group("qd", false)?, group("qdd", false)?) {
        (Some(d), Some(dd)) => Some((d, dd)),
        _ => None,
    };
    let mut tr = Trajectory {
        t: Vec::new(),
        q: Vec::new(),
        tau: Vec::new(),
    };
    let mut derivatives = derivative_columns.map(|_| Derivatives {
        qd: Vec::new(),
        qdd: Vec::new(),
    });
    for (k, rec) in rdr.records().enumerate() {
        let rec = rec.map_err(|e| EstimatorError::Csv(format!("row {}: {e}", k + 1)))?;
        let get = |c: usize| -> Result<f64, EstimatorError> {
            rec.get(c)
                .and_then(|s| s.parse::<f64>().ok())
                .filter(|v| v.is_finite())
                .ok_or_else(|| EstimatorError::NotFinite {
                    sample: k + 1,
                    column: header[c].clone(),
                })
        };
        let vector = |cols: &[usize; N]| -> Result<SVector<f64, N>, EstimatorError> {
            let mut v = SVector::<f64, N>::zeros();
            for j in 0..N {
                v[j] = get(cols[j])?;
            }
            Ok(v)
        };
        tr.t.push(get(ct)?);
        tr.q.push(vector(&cq)?);
        tr.tau.push(vector(&ctau)?);
        if let (Some((cd, cdd)), Some(d)) = (&derivative_columns, &mut derivatives) {
            d.qd.push(vector(cd)?);
            d.qdd.push(vector(cdd)?);
        }
    }
    Ok(RecordedLog {
        trajectory: tr,
        derivatives,
    })
}

/// Rows a contiguous piece of a log needs to be used (the filter's edges are trimmed).
pub const MIN_SEGMENT_ROWS: usize = 50;

/// A log cut at its gaps: the contiguous pieces, the gaps found, and the rows left out in pieces
/// shorter than [`MIN_SEGMENT_ROWS`].
#[derive(Debug, Clone)]
pub struct Segments<const N: usize> {
    /// The contiguous pieces, in order.
    pub pieces: Vec<Trajectory<N>>,
    /// Time steps longer than 1.5 × the median step (lost or skipped cycles).
    pub gaps: usize,
    /// Rows in pieces too short to use.
    pub dropped_rows: usize,
}

/// The contiguous row ranges of stamps `t` (cut where a step exceeds 1.5 × the median step),
/// the number of gaps and the rows in ranges shorter than [`MIN_SEGMENT_ROWS`] (left out).
/// Time that does not increase is an error, not a gap.
pub fn gap_ranges(t: &[f64]) -> Result<(Vec<Range<usize>>, usize, usize), EstimatorError> {
    let n = t.len();
    let mut steps: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    if let Some(k) = steps.iter().position(|s| s.is_nan() || *s <= 0.0) {
        return Err(EstimatorError::InvalidSetting(format!(
            "row {}: time stamps must increase",
            k + 2
        )));
    }
    steps.sort_by(f64::total_cmp);
    let median = steps.get(steps.len() / 2).copied().unwrap_or(0.0);
    let (mut ranges, mut gaps, mut dropped) = (Vec::new(), 0, 0);
    let mut start = 0;
    for k in 1..=n {
        let cut = k == n || t[k] - t[k - 1] > 1.5 * median;
        if !cut {
            continue;
        }
        if k < n {
            gaps += 1;
        }
        if k - start >= MIN_SEGMENT_ROWS {
            ranges.push(start..k);
        } else {
            dropped += k - start;
        }
        start = k;
    }
    Ok((ranges, gaps, dropped))
}

impl<const N: usize> Trajectory<N> {
    /// The rows in `range`.
    pub fn slice(&self, range: Range<usize>) -> Trajectory<N> {
        Trajectory {
            t: self.t[range.clone()].to_vec(),
            q: self.q[range.clone()].to_vec(),
            tau: self.tau[range].to_vec(),
        }
    }
}

impl<const N: usize> RecordedLog<N> {
    /// The rows in `range`.
    pub fn slice(&self, range: Range<usize>) -> RecordedLog<N> {
        RecordedLog {
            trajectory: self.trajectory.slice(range.clone()),
            derivatives: self.derivatives.as_ref().map(|d| Derivatives {
                qd: d.qd[range.clone()].to_vec(),
                qdd: d.qdd[range].to_vec(),
            }),
        }
    }
}

/// Cuts `tr` wherever a time step exceeds 1.5 × the median step, so that each piece has the
/// (jittered) rate the filter and the derivatives need (a recorded log skips the cycles the
/// controller did not send). Time that does not increase is an error, not a gap.
pub fn split_at_gaps<const N: usize>(tr: &Trajectory<N>) -> Result<Segments<N>, EstimatorError> {
    let (ranges, gaps, dropped_rows) = gap_ranges(&tr.t)?;
    Ok(Segments {
        pieces: ranges.into_iter().map(|r| tr.slice(r)).collect(),
        gaps,
        dropped_rows,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn log_at(times: &[f64]) -> Trajectory<2> {
        Trajectory {
            t: times.to_vec(),
            q: vec![SVector::zeros(); times.len()],
            tau: vec![SVector::zeros(); times.len()],
        }
    }

    #[test]
    fn a_log_is_cut_at_its_gaps_and_short_pieces_are_counted() {
        // 100 rows at 1 ms, a 4 ms gap, 60 rows, a 2 ms gap, 10 rows.
        let mut t: Vec<f64> = (0..100).map(|k| k as f64 * 1e-3).collect();
        t.extend((0..60).map(|k| 0.103 + k as f64 * 1e-3));
        t.extend((0..10).map(|k| 0.164 + k as f64 * 1e-3));
        let s = split_at_gaps(&log_at(&t)).unwrap();
        assert_eq!(s.gaps, 2);
        let lens: Vec<usize> = s.pieces.iter().map(|p| p.t.len()).collect();
        assert_eq!(lens, [100, 60]);
        assert_eq!(s.dropped_rows, 10);
        let contiguous: Vec<f64> = (0..80).map(|k| k as f64 * 1e-3).collect();
        let s = split_at_gaps(&log_at(&contiguous)).unwrap();
        assert_eq!((s.gaps, s.pieces.len(), s.dropped_rows), (0, 1, 0));
        let mut backwards = contiguous;
        backwards[40] = 0.0;
        assert!(split_at_gaps(&log_at(&backwards)).is_err());
    }

    #[test]
    fn derivatives_are_kept_only_when_both_groups_exist() {
        let both = "t,q1,q2,qd1,qd2,qdd1,qdd2,tau1,tau2\n0,1,2,3,4,5,6,7,8\n0.1,1,2,3,4,5,6,7,8\n";
        let l = read_recorded_csv::<2, _>(both.as_bytes()).unwrap();
        let d = l.derivatives.unwrap();
        assert_eq!(
            (d.qd[1][1], d.qdd[0][0], l.trajectory.tau[0][1]),
            (4.0, 5.0, 8.0)
        );
        // the service's log: qd (its filtered velocity) but no qdd, and more columns
        let service =
            "cycle,time_s,flags,q1,q2,qd1,qd2,tau1,tau2,tau_ext1,tau_ext2\n1,0,0,1,2,3,4,5,6,7,8\n";
        let l = read_recorded_csv::<2, _>(service.as_bytes()).unwrap();
        assert!(l.derivatives.is_none());
        assert_eq!(l.trajectory.tau[0][1], 6.0);
        let partial = "t,q1,q2,qd1,tau1,tau2\n0,1,2,3,4,5\n";
        assert!(matches!(
            read_recorded_csv::<2, _>(partial.as_bytes()),
            Err(EstimatorError::WrongColumns { .. })
        ));
    }
}
