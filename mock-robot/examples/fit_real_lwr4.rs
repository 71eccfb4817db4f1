//! Fits the real arm's unexplained torque (`profiles/real-lwr4-error.toml`) to two runs of the
//! same trajectory and prints it as TOML:
//!
//! `cargo run -p mock-robot --example fit_real_lwr4 -- RUN1.csv RUN2.csv > mock-robot/profiles/real-lwr4-error.toml`

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use mock_robot::arm_profile::{RealArm, fit};
use mock_robot::replay::{LogLimits, read_log};

fn main() -> Result<()> {
    let args: Vec<PathBuf> = std::env::args_os().skip(1).map(PathBuf::from).collect();
    let [run1, run2] = args.as_slice() else {
        bail!("usage: fit_real_lwr4 RUN1.csv RUN2.csv");
    };
    let limits = LogLimits::default();
    let log1 = read_log(run1, &limits).with_context(|| format!("reading {}", run1.display()))?;
    let log2 = read_log(run2, &limits).with_context(|| format!("reading {}", run2.display()))?;
    let arm = RealArm::real_lwr4().context("the embedded identified arm")?;
    let spec = fit::fit_unexplained(&arm, &log1, &log2);
    println!(
        "# The real LWR 4+'s unexplained torque beyond the identified arm (real-lwr4.toml), per joint.\n\
         # Fitted to data/real-lwr4 run 1 and run 2 by\n\
         # `cargo run -p mock-robot --example fit_real_lwr4 -- flobaroid-run1.csv flobaroid-run2.csv`\n\
         # (mock-robot/src/arm_profile/fit.rs); checked against the recordings by mock-robot/tests/real_profile.rs.\n"
    );
    print!("{}", toml::to_string(&spec).context("TOML")?);
    Ok(())
}
