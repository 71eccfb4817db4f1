//! Static samples (q, τ_J, g_ctrl) and their CSV format, with input validation.
//!
//! CSV: a header row naming the columns `q1..qn` (rad), `tau1..taun` (Nm, measured joint
//! torques) and `g1..gn` (Nm, the controller's gravity vector without payload), one static pose
//! per row. Optional `qd1..qdn` (rad/s, joint velocities at sampling time) and `drift1..driftn`
//! (rad, position change over the averaging window) enable the static check. The optional
//! evidence group (`time_s`, `window_s`, `settle_s`, `max_qd`, `tau_std1..n`, `tau_sem1..n`:
//! [`SampleEvidence`]) feeds the uncertainty model. Any other column is ignored.

use std::io::Read;

use nalgebra::SVector;
use serde::{Deserialize, Serialize};

use crate::error::EstimatorError;

/// One static sample of an n-joint robot (serde: `{"q": [..], "tau": [..], "gravity": [..]}`
/// with optional `qd` and `drift`, as the service stores its tare).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StaticSample<const N: usize> {
    /// Measured joint positions, rad.
    pub q: SVector<f64, N>,
    /// Measured joint torques τ_J, Nm.
    pub tau: SVector<f64, N>,
    /// The controller's gravity torques g_ctrl(q) computed without payload, Nm.
    pub gravity: SVector<f64, N>,
    /// Joint velocities at sampling time, rad/s, when recorded.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub qd: Option<SVector<f64, N>>,
    /// Position drift over the averaging window, rad, when recorded.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub drift: Option<SVector<f64, N>>,
    /// How the sample was taken (time, window, settling, noise of the mean), when recorded.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub evidence: Option<SampleEvidence<N>>,
}

/// The settling and averaging evidence of one static sample: what the uncertainty model needs
/// beyond the means (CSV columns `time_s`, `window_s`, `settle_s`, `max_qd`, `tau_std1..n`,
/// `tau_sem1..n`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SampleEvidence<const N: usize> {
    /// Controller time at the middle of the averaging window, s.
    pub time_s: f64,
    /// Length of the averaging window, s.
    pub window_s: f64,
    /// Time waited for settling before the window, s.
    pub settle_s: f64,
    /// Largest |q̇| of any joint over the window, rad/s.
    pub max_qd: f64,
    /// Standard deviation of τ_J over the window per joint, Nm.
    pub tau_std: SVector<f64, N>,
    /// Standard error of the window mean of τ_J per joint, Nm, from batch means (so that
    /// correlated noise is not counted as independent cycles).
    pub tau_sem: SVector<f64, N>,
}

impl<const N: usize> StaticSample<N> {
    /// A sample without velocity or drift information.
    pub fn new(q: SVector<f64, N>, tau: SVector<f64, N>, gravity: SVector<f64, N>) -> Self {
        StaticSample {
            q,
            tau,
            gravity,
            qd: None,
            drift: None,
            evidence: None,
        }
    }

    /// Δτ = τ_J − g_ctrl, the torque the payload (and the model error) produce, Nm.
    pub fn delta_tau(&self) -> SVector<f64, N> {
        self.tau - self.gravity
    }
}

/// Thresholds of the static-sample check.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct StaticCheck {
    /// Largest accepted |q̇_j| at sampling time, rad/s.
    pub max_velocity: f64,
    /// Largest accepted position drift per joint during the averaging window, rad.
    pub max_drift: f64,
}

impl Default for StaticCheck {
    fn default() -> Self {
        // 0.01 rad/s moves the 3 kg payload's lever arm by < 1 cm/s: inertial torques ≪ noise
        StaticCheck {
            max_velocity: 0.01,
            max_drift: 1e-3,
        }
    }
}

/// Checks finiteness and staticness of every sample; Err names the first offending sample.
pub fn validate<const N: usize>(
    samples: &[StaticSample<N>],
    check: &StaticCheck,
) -> Result<(), EstimatorError> {
    for (k, s) in samples.iter().enumerate() {
        let groups: [(&str, Option<&SVector<f64, N>>); 5] = [
            ("q", Some(&s.q)),
            ("tau", Some(&s.tau)),
            ("g", Some(&s.gravity)),
            ("qd", s.qd.as_ref()),
            ("drift", s.drift.as_ref()),
        ];
        for (name, v) in groups {
            if let Some(v) = v
                && let Some(j) = v.iter().position(|x| !x.is_finite())
            {
                return Err(EstimatorError::NotFinite {
                    sample: k + 1,
                    column: format!("{name}{}", j + 1),
                });
            }
        }
        if let Some(qd) = &s.qd
            && let Some(j) = qd.iter().position(|v| v.abs() > check.max_velocity)
        {
            return Err(EstimatorError::NotStatic {
                sample: k + 1,
                detail: format!(
                    "joint {} moves at {:.4} rad/s (limit {} rad/s)",
                    j + 1,
                    qd[j],
                    check.max_velocity
                ),
            });
        }
        if let Some(dr) = &s.drift
            && let Some(j) = dr.iter().position(|v| v.abs() > check.max_drift)
        {
            return Err(EstimatorError::NotStatic {
                sample: k + 1,
                detail: format!(
                    "joint {} drifted {:.5} rad while sampling (limit {} rad)",
                    j + 1,
                    dr[j],
                    check.max_drift
                ),
            });
        }
    }
    Ok(())
}

/// Column indices of `prefix1..prefixN` in a header, or a [`EstimatorError::WrongColumns`].
pub(crate) fn find_group<const N: usize>(
    header: &[String],
    prefix: &str,
    required: bool,
) -> Result<Option<[usize; N]>, EstimatorError> {
    let mut found: Vec<(usize, usize)> = Vec::new(); // (joint index 1-based, column)
    for (col, name) in header.iter().enumerate() {
        if let Some(rest) = name.trim().strip_prefix(prefix)
            && let Ok(j) = rest.parse::<usize>()
        {
            found.push((j, col));
        }
    }
    if found.is_empty() && !required {
        return Ok(None);
    }
    let max_j = found.iter().map(|(j, _)| *j).max().unwrap_or(0);
    let mut cols = [usize::MAX; N];
    for (j, col) in &found {
        if *j >= 1 && *j <= N {
            if cols[j - 1] != usize::MAX {
                return Err(EstimatorError::WrongColumns {
                    joints: N,
                    detail: format!("column `{prefix}{j}` appears twice"),
                });
            }
            cols[j - 1] = *col;
        }
    }
    if max_j != N || cols.contains(&usize::MAX) || found.iter().any(|(j, _)| *j == 0) {
        return Err(EstimatorError::WrongColumns {
            joints: N,
            detail: format!(
                "found {} `{prefix}*` columns (highest {prefix}{max_j})",
                found.len()
            ),
        });
    }
    Ok(Some(cols))
}

/// A CSV reader with the conventions of every estimator input file (cells trimmed, `#`
/// comment lines) and its header row.
pub(crate) fn open_csv<R: Read>(
    reader: R,
) -> Result<(csv::Reader<R>, Vec<String>), EstimatorError> {
    let mut rdr = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .comment(Some(b'#'))
        .from_reader(reader);
    let header: Vec<String> = rdr
        .headers()
        .map_err(|e| EstimatorError::Csv(e.to_string()))?
        .iter()
        .map(str::to_string)
        .collect();
    Ok((rdr, header))
}

/// Column indices of the evidence group.
struct EvidenceColumns<const N: usize> {
    scalars: [usize; 4],
    tau_std: [usize; N],
    tau_sem: [usize; N],
}

/// The evidence group's columns: all of them, or none (a partial group is an error naming the
/// first missing column).
fn evidence_columns<const N: usize>(
    header: &[String],
) -> Result<Option<EvidenceColumns<N>>, EstimatorError> {
    let find = |name: &str| header.iter().position(|h| h.trim() == name);
    let scalars = EVIDENCE_SCALARS.map(find);
    let tau_std = find_group::<N>(header, "tau_std", false)?;
    let tau_sem = find_group::<N>(header, "tau_sem", false)?;
    if scalars.iter().all(Option::is_none) && tau_std.is_none() && tau_sem.is_none() {
        return Ok(None);
    }
    let missing = |what: &str| EstimatorError::WrongColumns {
        joints: N,
        detail: format!("the evidence columns are incomplete: no `{what}`"),
    };
    let mut found = [0; 4];
    for (i, c) in scalars.iter().enumerate() {
        found[i] = c.ok_or_else(|| missing(EVIDENCE_SCALARS[i]))?;
    }
    Ok(Some(EvidenceColumns {
        scalars: found,
        tau_std: tau_std.ok_or_else(|| missing("tau_std1"))?,
        tau_sem: tau_sem.ok_or_else(|| missing("tau_sem1"))?,
    }))
}

/// Reads static samples of an `N`-joint robot from CSV (format in the module docs).
pub fn read_csv<const N: usize, R: Read>(
    reader: R,
) -> Result<Vec<StaticSample<N>>, EstimatorError> {
    let (mut rdr, header) = open_csv(reader)?;
    let cq = find_group::<N>(&header, "q", true)?;
    let ct = find_group::<N>(&header, "tau", true)?;
    let cg = find_group::<N>(&header, "g", true)?;
    let cqd = find_group::<N>(&header, "qd", false)?;
    let cdr = find_group::<N>(&header, "drift", false)?;
    let evidence = evidence_columns::<N>(&header)?;
    let (Some(cq), Some(ct), Some(cg)) = (cq, ct, cg) else {
        return Err(EstimatorError::WrongColumns {
            joints: N,
            detail: "missing q/tau/g columns".into(),
        });
    };
    let mut out = Vec::new();
    for (k, rec) in rdr.records().enumerate() {
        let rec = rec.map_err(|e| EstimatorError::Csv(format!("row {}: {e}", k + 1)))?;
        let cell = |c: usize| -> Result<f64, EstimatorError> {
            let text = rec.get(c).ok_or_else(|| EstimatorError::WrongColumns {
                joints: N,
                detail: format!("row {} has only {} fields", k + 1, rec.len()),
            })?;
            match text.parse::<f64>() {
                Ok(x) if x.is_finite() => Ok(x),
                _ => Err(EstimatorError::NotFinite {
                    sample: k + 1,
                    column: header[c].clone(),
                }),
            }
        };
        let get = |cols: &[usize; N]| -> Result<SVector<f64, N>, EstimatorError> {
            let mut v = SVector::<f64, N>::zeros();
            for (j, &c) in cols.iter().enumerate() {
                v[j] = cell(c)?;
            }
            Ok(v)
        };
        let evidence = match &evidence {
            Some(e) => Some(SampleEvidence {
                time_s: cell(e.scalars[0])?,
                window_s: cell(e.scalars[1])?,
                settle_s: cell(e.scalars[2])?,
                max_qd: cell(e.scalars[3])?,
                tau_std: get(&e.tau_std)?,
                tau_sem: get(&e.tau_sem)?,
            }),
            None => None,
        };
        out.push(StaticSample {
            q: get(&cq)?,
            tau: get(&ct)?,
            gravity: get(&cg)?,
            qd: cqd.as_ref().map(&get).transpose()?,
            drift: cdr.as_ref().map(&get).transpose()?,
            evidence,
        });
    }
    Ok(out)
}

/// Which optional column groups a static-sample CSV carries.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CsvColumns {
    /// `qd1..qdn` (rad/s).
    pub qd: bool,
    /// `drift1..driftn` (rad, position change over the averaging window).
    pub drift: bool,
    /// `time_s, window_s, settle_s, max_qd, tau_std1..n, tau_sem1..n` ([`SampleEvidence`]).
    pub evidence: bool,
}

impl CsvColumns {
    /// The groups every one of `samples` has (none for an empty slice).
    pub fn common_to<const N: usize>(samples: &[StaticSample<N>]) -> Self {
        let all = |f: fn(&StaticSample<N>) -> bool| !samples.is_empty() && samples.iter().all(f);
        CsvColumns {
            qd: all(|s| s.qd.is_some()),
            drift: all(|s| s.drift.is_some()),
            evidence: all(|s| s.evidence.is_some()),
        }
    }
}

/// Names of the evidence's scalar columns, in file order.
const EVIDENCE_SCALARS: [&str; 4] = ["time_s", "window_s", "settle_s", "max_qd"];

/// Header of the static-sample CSV: `q1..qn,tau1..taun,g1..gn`, then the optional groups.
pub fn csv_header<const N: usize>(columns: CsvColumns) -> Vec<String> {
    let vector = |p: &'static str| (1..=N).map(move |j| format!("{p}{j}"));
    let mut h: Vec<String> = ["q", "tau", "g"].into_iter().flat_map(vector).collect();
    if columns.qd {
        h.extend(vector("qd"));
    }
    if columns.drift {
        h.extend(vector("drift"));
    }
    if columns.evidence {
        h.extend(EVIDENCE_SCALARS.map(str::to_owned));
        h.extend(vector("tau_std").chain(vector("tau_sem")));
    }
    h
}

/// One static-sample CSV row in the column order of [`csv_header`] (rad, Nm, Nm, rad/s, rad,
/// s, s, s, rad/s, Nm, Nm), each value written in the shortest form that reads back exactly; a
/// group the sample lacks is left out.
pub fn csv_row<const N: usize>(sample: &StaticSample<N>, columns: CsvColumns) -> Vec<String> {
    let cells = |v: &SVector<f64, N>| v.iter().map(|x| format!("{x}")).collect::<Vec<_>>();
    let mut row: Vec<String> = [&sample.q, &sample.tau, &sample.gravity]
        .into_iter()
        .flat_map(cells)
        .collect();
    if let Some(qd) = sample.qd.as_ref().filter(|_| columns.qd) {
        row.extend(cells(qd));
    }
    if let Some(d) = sample.drift.as_ref().filter(|_| columns.drift) {
        row.extend(cells(d));
    }
    if let Some(e) = sample.evidence.as_ref().filter(|_| columns.evidence) {
        row.extend([e.time_s, e.window_s, e.settle_s, e.max_qd].map(|x| format!("{x}")));
        row.extend(cells(&e.tau_std).into_iter().chain(cells(&e.tau_sem)));
    }
    row
}

/// Writes static samples as CSV ([`csv_header`], then one [`csv_row`] per sample); an optional
/// group is written when every sample has it.
pub fn write_csv<const N: usize, W: std::io::Write>(
    writer: W,
    samples: &[StaticSample<N>],
) -> Result<(), EstimatorError> {
    let err = |e: csv::Error| EstimatorError::Csv(e.to_string());
    let mut w = csv::Writer::from_writer(writer);
    let columns = CsvColumns::common_to(samples);
    w.write_record(csv_header::<N>(columns)).map_err(err)?;
    for s in samples {
        w.write_record(csv_row(s, columns)).map_err(err)?;
    }
    w.flush().map_err(|e| EstimatorError::Csv(e.to_string()))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_extra_columns() {
        let s = StaticSample::<2>::new(
            SVector::from([0.1, -0.2]),
            SVector::from([1.0, 2.0]),
            SVector::from([0.5, 1.5]),
        );
        let mut buf = Vec::new();
        write_csv(&mut buf, &[s, s]).unwrap();
        let back: Vec<StaticSample<2>> = read_csv(buf.as_slice()).unwrap();
        assert_eq!(back.len(), 2);
        assert!((back[0].q - s.q).norm() < 1e-12 && (back[1].gravity - s.gravity).norm() < 1e-12);
        let text = "time,g2,g1,q1,q2,tau1,tau2,note\n0.5,1,2,0.1,0.2,3,4,x\n";
        let r: Vec<StaticSample<2>> = read_csv(text.as_bytes()).unwrap();
        assert_eq!(r[0].gravity, SVector::from([2.0, 1.0]));
        assert_eq!(r[0].delta_tau(), SVector::from([1.0, 3.0]));
    }

    #[test]
    fn csv_is_exact_and_json_keeps_the_stored_shape() {
        let mut s = StaticSample::<2>::new(
            SVector::from([0.1, -1.0 / 3.0]),
            SVector::from([1.0, 2.0]),
            SVector::from([0.5, 1.5]),
        );
        let mut buf = Vec::new();
        write_csv(&mut buf, &[s]).unwrap();
        let text = String::from_utf8(buf).unwrap();
        assert!(text.starts_with("q1,q2,tau1,tau2,g1,g2\n0.1,"), "{text}");
        let back: Vec<StaticSample<2>> = read_csv(text.as_bytes()).unwrap();
        assert_eq!(back, vec![s]);
        let json = r#"{"q":[0.1,0.2],"tau":[1.0,2.0],"gravity":[0.5,1.5]}"#;
        let parsed: StaticSample<2> = serde_json::from_str(json).unwrap();
        assert_eq!(parsed.q, SVector::from([0.1, 0.2]));
        assert_eq!(parsed.qd, None);
        s.q = parsed.q;
        assert_eq!(serde_json::to_string(&s).unwrap(), json);
        assert!(serde_json::from_str::<StaticSample<2>>(r#"{"q":[0,0],"tau":[0,0]}"#).is_err());
    }

    #[test]
    fn evidence_round_trips_and_a_partial_group_is_named() {
        let mut s = StaticSample::<2>::new(
            SVector::from([0.1, -0.2]),
            SVector::from([1.0, 2.0]),
            SVector::from([0.5, 1.5]),
        );
        s.evidence = Some(SampleEvidence {
            time_s: 12.25,
            window_s: 0.5,
            settle_s: 0.1,
            max_qd: 1e-4,
            tau_std: SVector::from([0.05, 0.04]),
            tau_sem: SVector::from([0.0016, 0.0013]),
        });
        let mut buf = Vec::new();
        write_csv(&mut buf, &[s]).unwrap();
        let text = String::from_utf8(buf).unwrap();
        assert!(
            text.contains("time_s,window_s,settle_s,max_qd,tau_std1"),
            "{text}"
        );
        let back: Vec<StaticSample<2>> = read_csv(text.as_bytes()).unwrap();
        assert_eq!(back, vec![s]);
        let json = serde_json::to_string(&s).unwrap();
        assert_eq!(serde_json::from_str::<StaticSample<2>>(&json).unwrap(), s);
        let partial = "q1,q2,tau1,tau2,g1,g2,time_s\n0,0,0,0,0,0,1\n";
        let e = read_csv::<2, _>(partial.as_bytes())
            .unwrap_err()
            .to_string();
        assert!(e.contains("window_s"), "{e}");
    }

    #[test]
    fn wrong_columns_and_nan_are_errors() {
        let text = "q1,q2,q3,tau1,tau2,tau3,g1,g2,g3\n0,0,0,0,0,0,0,0,0\n";
        let e = read_csv::<2, _>(text.as_bytes()).unwrap_err().to_string();
        assert!(e.contains("wrong column count") && e.contains("q3"), "{e}");
        let text = "q1,q2,tau1,tau2,g1,g2\n0,0,NaN,0,0,0\n";
        let e = read_csv::<2, _>(text.as_bytes()).unwrap_err().to_string();
        assert!(e.contains("tau1") && e.contains("sample 1"), "{e}");
        let text = "q1,q2,tau1,tau2,g1,g2\n0,0,abc,0,0,0\n";
        assert!(read_csv::<2, _>(text.as_bytes()).is_err());
        let text = "q1,q2,tau1,tau2,g1\n0,0,0,0,0\n";
        assert!(
            read_csv::<2, _>(text.as_bytes())
                .unwrap_err()
                .to_string()
                .contains("`g*`")
        );
    }

    #[test]
    fn moving_samples_are_rejected() {
        let text = "q1,q2,tau1,tau2,g1,g2,qd1,qd2\n0,0,0,0,0,0,0,0\n0,0,0,0,0,0,0,0.2\n";
        let s = read_csv::<2, _>(text.as_bytes()).unwrap();
        let e = validate(&s, &StaticCheck::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains("sample 2") && e.contains("joint 2"), "{e}");
        let text = "q1,q2,tau1,tau2,g1,g2,drift1,drift2\n0,0,0,0,0,0,0.01,0\n";
        let s = read_csv::<2, _>(text.as_bytes()).unwrap();
        assert!(
            validate(&s, &StaticCheck::default())
                .unwrap_err()
                .to_string()
                .contains("drifted")
        );
    }
}
