//! Command-line arguments.

use std::path::PathBuf;

/// Options of a run (see the crate docs for the flags and defaults).
pub struct Args {
    pub out: PathBuf,
    pub hours: f64,
    pub contacts: usize,
    pub seed: u64,
    /// Run only the tuning sweep (free motion, delay campaigns, Fig. 6 detection per candidate).
    pub sweep: bool,
    /// Run only the evaluation at calibrated settings (`calibrated.md`).
    pub calibrated: bool,
    /// Cut-off of the observers' first-order velocity filter [Hz]; `None` keeps
    /// `safety::VelocityFilter::default()` (what the service runs).
    pub velocity_cutoff_hz: Option<f64>,
}

/// Parses `std::env::args`; panics on an unknown flag or a malformed value.
pub fn parse_args() -> Args {
    let mut args = Args {
        out: PathBuf::from("target/collision-eval"),
        hours: 1.0,
        contacts: 200,
        seed: 2017,
        sweep: false,
        calibrated: false,
        velocity_cutoff_hz: None,
    };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        if flag == "--sweep" {
            args.sweep = true;
            continue;
        }
        if flag == "--calibrated" {
            args.calibrated = true;
            continue;
        }
        let value = it
            .next()
            .unwrap_or_else(|| panic!("missing value for {flag}"));
        match flag.as_str() {
            "--out" => args.out = PathBuf::from(value),
            "--hours" => args.hours = value.parse().expect("--hours"),
            "--contacts" => args.contacts = value.parse().expect("--contacts"),
            "--seed" => args.seed = value.parse().expect("--seed"),
            "--velocity-cutoff-hz" => {
                args.velocity_cutoff_hz = Some(value.parse().expect("--velocity-cutoff-hz"))
            }
            other => panic!("unknown flag {other}"),
        }
    }
    args
}
