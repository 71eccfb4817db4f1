//! The service's per-cycle log (`record --kind log`) as the demo's evaluation reads it.

use std::path::Path;

use anyhow::{Context as _, bail};

/// One row of the service's per-cycle log.
#[derive(Debug, Clone)]
pub(super) struct LogRow {
    /// Controller time, s since the service started.
    pub(super) time_s: f64,
    /// Measured joint positions, rad.
    pub(super) q: [f64; 7],
    /// The observer's filtered joint velocities, rad/s.
    pub(super) qd: [f64; 7],
    /// Measured joint torques τ_J, Nm.
    pub(super) tau: [f64; 7],
    /// The controller's external-torque estimate, Nm.
    pub(super) tau_ext: [f64; 7],
}

/// Reads the log at `path`: the columns the evaluation needs, at least 100 rows.
pub(super) fn read_log(path: &Path) -> anyhow::Result<Vec<LogRow>> {
    let mut reader =
        csv::Reader::from_path(path).with_context(|| format!("reading {}", path.display()))?;
    let headers = reader.headers()?.clone();
    let col = |name: &str| {
        headers
            .iter()
            .position(|h| h == name)
            .with_context(|| format!("column {name} missing in the log"))
    };
    let time = col("time_s")?;
    let q1 = col("q1")?;
    let qd1 = col("qd1")?;
    let tau1 = col("tau1")?;
    let ext1 = col("tau_ext1")?;
    let mut rows = Vec::new();
    for rec in reader.records() {
        let rec = rec?;
        let num = |i: usize| -> anyhow::Result<f64> {
            Ok(rec.get(i).context("short row")?.parse::<f64>()?)
        };
        let arr = |start: usize| -> anyhow::Result<[f64; 7]> {
            let mut a = [0.0; 7];
            for (j, v) in a.iter_mut().enumerate() {
                *v = num(start + j)?;
            }
            Ok(a)
        };
        rows.push(LogRow {
            time_s: num(time)?,
            q: arr(q1)?,
            qd: arr(qd1)?,
            tau: arr(tau1)?,
            tau_ext: arr(ext1)?,
        });
    }
    if rows.len() < 100 {
        bail!("the free-motion log has only {} rows", rows.len());
    }
    Ok(rows)
}
