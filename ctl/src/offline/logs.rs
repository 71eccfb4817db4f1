//! Trajectory logs for the offline tools: CSV (`t` or `time_s`, `q1..n`, `tau1..n`, optional
//! `qd1..n` with `qdd1..n`; the service's `record --kind log` as it is) or MCAP
//! (`/joint_states`), every position and torque checked against the robot model.

use std::fs::File;
use std::io::BufReader;
use std::path::Path;

use anyhow::Context;
use dynamics::{IdentifiedModel, Model};
use estimator::motion::{RecordedLog, Trajectory, read_recorded_csv};
use estimator::plausible::Ranges;

/// Reads a log (CSV, or MCAP: `/joint_states`); every position and torque must be plausible for
/// `model`. MCAP logs carry no accelerations: their derivatives are derived where needed.
pub(crate) fn read_recorded<const N: usize>(
    path: &Path,
    model: &Model<N>,
) -> anyhow::Result<RecordedLog<N>> {
    let context = || format!("reading {}", path.display());
    let log = if super::mcap_log::is_mcap(path)? {
        RecordedLog {
            trajectory: super::mcap_log::read::<N>(path).with_context(context)?,
            derivatives: None,
        }
    } else {
        let f = File::open(path)
            .with_context(|| format!("cannot open trajectory log {}", path.display()))?;
        read_recorded_csv::<N, _>(BufReader::new(f)).with_context(context)?
    };
    Ranges::from_limits(model.limits())
        .check_trajectory(&log.trajectory)
        .with_context(context)?;
    Ok(log)
}

/// The stamps, positions and torques of a log (see [`read_recorded`]).
pub(crate) fn read_trajectory<const N: usize>(
    path: &Path,
    model: &Model<N>,
) -> anyhow::Result<Trajectory<N>> {
    read_recorded(path, model).map(|l| l.trajectory)
}

/// Reads an identified-arm file (`offline identify --out`) and checks it against `model`.
pub(crate) fn read_identified<const N: usize>(
    path: &Path,
    model: &Model<N>,
) -> anyhow::Result<IdentifiedModel<N>> {
    IdentifiedModel::from_toml_file(model, path).with_context(|| {
        format!(
            "identified arm file {} (written by `fri-ctl offline identify` for this robot model)",
            path.display()
        )
    })
}
