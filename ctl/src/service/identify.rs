//! `fri-ctl identify`: the unloaded arm identified from its own motion, recorded by the running
//! service (its identification excitation, or the current task) and fitted here with the same
//! code as `fri-ctl offline identify`; the result is the identified-arm file the service loads
//! as `[robot] calibration`.

use std::path::PathBuf;

use clap::{Args, ValueEnum};

use fri_api::bounds::{EXCITE_DEG, LOG_DURATION_S};
use fri_api::stdio::{Stdout, stderr_line};

use super::record::{RecordArg, RecordArgs};
use super::status::StatusArgs;
use super::{EXIT_FAILED, EXIT_NOT_READY, JsonFlag, runner};
use crate::offline::RobotChoice;

/// Long help of `identify`.
pub(super) const HELP: &str = "\
Identify the arm the service drives (paper Sec. II, eqs. 11–14; docs/estimation.md, \
\"Identifying the arm\"): per-joint torque offsets, viscous and Coulomb friction and corrections \
of the base dynamic coefficients regularised toward the nominal model, with their 1σ, the \
residual before and after and the held-out check. The file written to `--out` is what \
`[robot] calibration` loads (restart the service to use it) and what `fri-ctl offline \
estimate-motion --calibration` and `offline monitor --calibration` read.

The arm must be unloaded: nothing on the flange, no payload applied and none declared unknown \
(refused otherwise: the payload would be identified as the arm).

`--source excitation` (default) MOVES THE ARM: the service drives its identification \
excitation around the current pose — twelve waypoints whose joint offsets of up to \
`--amplitude-deg` (1…45, default 20) are orthogonal cosine patterns, clamped 5° inside the \
joint limits, at the `[motion]` limits — repeated until `--duration-s` of robot time (default \
one pass), then returns to the start pose and holds it in monitor mode. The collision monitor \
stays as it is (armed: a contact stops the excitation, and the recording is not used).
`--source current-task` moves nothing: it records `--duration-s` seconds (required) of whatever \
the robot program does now; the motion should cover the joints' speeds in both directions.

The recording stays in the service's recording directory as a per-cycle CSV log (`--log-name`, \
default identify-<unix time>.csv): fit it again with `fri-ctl offline identify --log PATH`.";

/// Where `identify` gets its motion.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum IdentifySource {
    /// MOVES THE ARM: the service's identification excitation around the current pose.
    Excitation,
    /// Record `--duration-s` of the task the arm runs now (the service moves nothing).
    CurrentTask,
}

/// `fri-ctl identify`.
#[derive(Debug, Clone, Args)]
pub struct IdentifyArgs {
    /// Identified-arm file to write (TOML), on this machine; an existing file is replaced.
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
    /// What motion to identify from.
    #[arg(long, value_enum, default_value = "excitation")]
    pub source: IdentifySource,
    /// Amplitude of the excitation's joint offsets, deg: 1…45 (with `excitation`).
    #[arg(long, value_name = "DEG", default_value_t = 20.0, value_parser = amplitude_deg)]
    pub amplitude_deg: f64,
    /// Recording length, s of robot time: required with `current-task`; with `excitation` the
    /// excitation repeats until at least this much (default one pass). 0.001…3600.
    #[arg(long, value_name = "SECONDS", value_parser = duration_s)]
    pub duration_s: Option<f64>,
    /// Name of the log in the service's recording directory (default identify-<unix time>.csv).
    #[arg(long, value_name = "NAME")]
    pub log_name: Option<String>,
    /// Output format (`--json`: the fit as one JSON object, as `offline identify --json`).
    #[command(flatten)]
    pub output: JsonFlag,
    /// Keep the viscous and Coulomb friction coefficients ≥ 0 (as `offline identify`).
    #[arg(long)]
    pub non_negative_friction: bool,
}

/// `--amplitude-deg`: the service's `excite_deg` range, named as the flag.
fn amplitude_deg(s: &str) -> Result<f64, String> {
    number(s, "amplitude_deg", &EXCITE_DEG)
}

/// `--duration-s`: the service's log length range.
fn duration_s(s: &str) -> Result<f64, String> {
    number(s, "duration_s", &LOG_DURATION_S)
}

fn number(s: &str, name: &str, range: &fri_api::bounds::Range) -> Result<f64, String> {
    let v: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("{name} = {s:?} is not a number (allowed: {range})"))?;
    range.check(name, v).map_err(String::from)?;
    Ok(v)
}

/// Why the service's state forbids identifying, or `None`.
fn not_unloaded(status: &fri_api::results::StatusResult) -> Option<String> {
    if !status.connected {
        return Some("the service has no controller: identify needs the arm's measurements".into());
    }
    if let Some(p) = &status.payload {
        return Some(format!(
            "a payload of {:.3} kg is applied: identify the unloaded arm (the payload would be identified as the arm); take it off the flange and run `fri-ctl clear-payload` first",
            p.mass
        ));
    }
    if status.unknown_payload.is_some() {
        return Some("a payload is declared unknown (`expect-payload`): identify the unloaded arm; take it off the flange and run `fri-ctl clear-payload` first".into());
    }
    None
}

/// Runs `identify` against the service at `socket`; returns the exit status.
pub(super) fn run(a: &IdentifyArgs, socket: &std::path::Path, out: &mut Stdout) -> u8 {
    if a.source == IdentifySource::CurrentTask && a.duration_s.is_none() {
        stderr_line(format_args!(
            "error: --duration-s is required with --source current-task (0.001…3600 s; a minute or more of varied motion identifies well)"
        ));
        return super::EXIT_USAGE;
    }
    let quiet = JsonFlag { json: false };
    let status = match runner::call(&StatusArgs { output: quiet }, socket, a.output.json, out) {
        Ok(s) => s,
        Err(code) => return code,
    };
    if let Some(why) = not_unloaded(&status) {
        stderr_line(format_args!("error: {why}; nothing was done"));
        return EXIT_NOT_READY;
    }
    let name = a.log_name.clone().unwrap_or_else(|| {
        let now = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_secs());
        format!("identify-{now}.csv")
    });
    let record = RecordArgs {
        name,
        kind: RecordArg::Log,
        duration: a.duration_s,
        count: None,
        excite_deg: (a.source == IdentifySource::Excitation).then_some(a.amplitude_deg),
        output: quiet,
    };
    let recorded = match runner::call(&record, socket, a.output.json, out) {
        Ok(r) => r,
        Err(code) => return code,
    };
    if recorded.lost.is_some_and(|n| n > 0) {
        stderr_line(format_args!(
            "warning: {} cycles lost while recording (the log has gaps; the fit splits it there)",
            recorded.lost.unwrap_or(0)
        ));
    }
    let fit = crate::offline::IdentifyArgs {
        log: vec![PathBuf::from(&recorded.path)],
        out: a.out.clone(),
        robot: RobotChoice::Lwr4,
        coulomb_velocity: estimator::identify::DEFAULT_COULOMB_VELOCITY,
        folds: estimator::identify::DEFAULT_FOLDS,
        non_negative_friction: a.non_negative_friction,
        derive: false,
        cutoff_hz: estimator::identify::DEFAULT_DERIVATIVE_CUTOFF_HZ,
        order: 4,
        trim_s: None,
        json: a.output.json,
    };
    if !a.output.json {
        use std::io::Write;
        if writeln!(
            out,
            "recorded {} cycles to {} (unloaded arm)",
            recorded.rows, recorded.path
        )
        .is_err()
        {
            return EXIT_FAILED;
        }
    }
    match crate::offline::identify_arm(&fit, out) {
        Ok(()) => super::EXIT_OK,
        Err(e) => {
            stderr_line(format_args!(
                "error: {e:#} (the recording is kept: {}; `fri-ctl offline identify --log` fits it again)",
                recorded.path
            ));
            EXIT_FAILED
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn out_of_range_amplitudes_name_the_flag_and_the_range() {
        for bad in ["0", "46", "-5", "NaN", "x"] {
            let e = amplitude_deg(bad).unwrap_err();
            assert!(e.starts_with("amplitude_deg = "), "{e}");
            assert!(e.contains("1…45"), "{e}");
        }
        assert_eq!(amplitude_deg("20"), Ok(20.0));
    }
}
