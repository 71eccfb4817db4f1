//! Static-sample CSV files (`q1..qn,tau1..taun,g1..gn`) as the offline tools read them.

use std::fs::File;
use std::io::BufReader;
use std::path::Path;

use anyhow::Context;
use dynamics::Model;
use estimator::plausible::Ranges;
use estimator::samples::{StaticSample, read_csv};

/// Reads static samples of an N-joint robot from a CSV file; every value must be plausible for
/// `model` (positions within its joint limits, torques within twice its torque limits).
pub(crate) fn read_samples<const N: usize>(
    path: &Path,
    model: &Model<N>,
) -> anyhow::Result<Vec<StaticSample<N>>> {
    let file =
        File::open(path).with_context(|| format!("cannot open samples file {}", path.display()))?;
    let context = || format!("reading {}", path.display());
    let samples = read_csv::<N, _>(BufReader::new(file)).with_context(context)?;
    Ranges::from_limits(model.limits())
        .check_samples(&samples)
        .with_context(context)?;
    Ok(samples)
}
