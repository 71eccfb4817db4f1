//! Static samples (q, τ_J, g_ctrl) and their CSV format, with input validation.
//!
//! CSV: a header row naming the columns `q1..qn` (rad), `tau1..taun` (Nm, measured joint
//! torques) and `g1..gn` (Nm, the controller's gravity vector without payload), one static pose
//! per row. Optional `qd1..qdn` (rad/s, joint velocities at sampling time) and `drift1..driftn`
//! (rad, position change over the averaging window) enable the static check. Any other column
//! is ignored.

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
fn find_group<const N: usize>(
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
    let (Some(cq), Some(ct), Some(cg)) = (cq, ct, cg) else {
        return Err(EstimatorError::WrongColumns {
            joints: N,
            detail: "missing q/tau/g columns".into(),
        });
    };
    let mut out = Vec::new();
    for (k, rec) in rdr.records().enumerate() {
        let rec = rec.map_err(|e| EstimatorError::Csv(format!("row {}: {e}", k + 1)))?;
        let get = |cols: &[usize; N]| -> Result<SVector<f64, N>, EstimatorError> {
            let mut v = SVector::<f64, N>::zeros();
            for (j, &c) in cols.iter().enumerate() {
                let cell = rec.get(c).ok_or_else(|| EstimatorError::WrongColumns {
                    joints: N,
                    detail: format!("row {} has only {} fields", k + 1, rec.len()),
                })?;
                let x: f64 = cell.parse().map_err(|_| EstimatorError::NotFinite {
                    sample: k + 1,
                    column: header[c].clone(),
                })?;
                if !x.is_finite() {
                    return Err(EstimatorError::NotFinite {
                        sample: k + 1,
                        column: header[c].clone(),
                    });
                }
                v[j] = x;
            }
            Ok(v)
        };
        out.push(StaticSample {
            q: get(&cq)?,
            tau: get(&ct)?,
            gravity: get(&cg)?,
            qd: cqd.as_ref().map(&get).transpose()?,
            drift: cdr.as_ref().map(&get).transpose()?,
        });
    }
    Ok(out)
}

/// Header of the static-sample CSV: `q1..qn,tau1..taun,g1..gn`, plus `qd1..qdn` when `with_qd`.
pub fn csv_header<const N: usize>(with_qd: bool) -> Vec<String> {
    let groups: &[&str] = if with_qd {
        &["q", "tau", "g", "qd"]
    } else {
        &["q", "tau", "g"]
    };
    groups
        .iter()
        .flat_map(|p| (1..=N).map(move |j| format!("{p}{j}")))
        .collect()
}

/// One static-sample CSV row in the column order of [`csv_header`] (rad, Nm, Nm, rad/s), each
/// value written in the shortest form that reads back exactly.
pub fn csv_row<const N: usize>(sample: &StaticSample<N>, with_qd: bool) -> Vec<String> {
    let qd = sample.qd.filter(|_| with_qd);
    [&sample.q, &sample.tau, &sample.gravity]
        .into_iter()
        .chain(qd.as_ref())
        .flat_map(|v| v.iter().map(|x| format!("{x}")))
        .collect()
}

/// Writes static samples as CSV ([`csv_header`], then one [`csv_row`] per sample); the `qd*`
/// columns are written when every sample has velocities.
pub fn write_csv<const N: usize, W: std::io::Write>(
    writer: W,
    samples: &[StaticSample<N>],
) -> Result<(), EstimatorError> {
    let err = |e: csv::Error| EstimatorError::Csv(e.to_string());
    let mut w = csv::Writer::from_writer(writer);
    let with_qd = samples.iter().all(|s| s.qd.is_some()) && !samples.is_empty();
    w.write_record(csv_header::<N>(with_qd)).map_err(err)?;
    for s in samples {
        w.write_record(csv_row(s, with_qd)).map_err(err)?;
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
