//! `fri-ctl collision show|arm|disarm|configure`: the collision monitor.

use std::io::{self, Write};

use clap::{Args, ValueEnum};

use fri_api::protocol::{CalibrationSource, CollisionAction, Command, ReactionMode};
use fri_api::results::{CollisionResult, MonitorSettings};

use super::JsonFlag;
use super::format::{fixed, joint_header, joint_row};
use super::lists;
use super::runner::Operation;

/// Long help of `collision`.
pub(super) const HELP: &str = "\
Show, arm, disarm or tune the collision monitor (the momentum observer's residual against \
per-joint thresholds). Armed, a contact stops the arm (`fri-ctl resume` releases it); \
disarmed, the residual is still computed and published but nothing reacts.

`configure` sets thresholds (Nm, one value for every joint or 7; each 0.1 Nm up to a quarter \
of the joint's torque limit: 44 Nm on joints 1–2, 25 Nm on 3–5, 9.5 Nm on 6–7), observer \
gains (1/s, one or 7; 1 up to 0.5/cycle, 500 at 1 ms), the reaction (report, stop, pause) \
and the pause of `pause` (0 to 60 s). Lower thresholds detect lighter contacts but trip on \
noise and model error; higher gains react faster but pass more noise. The service stores \
the settings with the payload applied now and restores them at its next start (arming \
follows the configuration file); `show` says when the payload has changed since. Prints the \
settings now in force.

`calibrate` fits the thresholds to a false-alarm budget (`--budget`, false alarms per hour for \
the whole arm, default 0.1 = one per 10 h; 0.0001 to 10): the service records the residual \
without contact — during its built-in excitation (`--source excitation`, the default: MOVES \
THE ARM through the paper's joint-1 sweeps around three stretched poses and the estimation \
pose pattern, at the configured motion limits), during the task the arm runs now \
(`--source current-task --duration-s S`, 20 to 3600 s; the service moves nothing), or reuses \
its last recording (`--source last-recording`) — fits how the residual grows with the motion \
and an extreme-value distribution of what remains, and reports per joint the thresholds at \
rest and in motion, the fit's uncertainty, the covered speeds and accelerations, and the \
minimum detectable force per link. `--apply` installs and stores them with the payload applied \
now; without it the result is a preview. Touching the arm during the recording aborts it when \
the monitor is armed; armed or not, the calibration refuses a recording in which the residual \
holds a contact-like level (naming the joint and the time). Every threshold is capped at the \
constant the recording supports, or at the configured `[observer] thresholds` where it supports \
none that small (a STATED CAP line says so). Thresholds (at rest, median over the recording or \
cap) above the service's `[observer] calibration_ceiling_nm` (default 6 Nm) weaken detection: \
`--apply` refuses them unless `--allow-weak` is given (the audit log then records them as \
weaker).

`configure --from FILE` installs the thresholds file of `fri-ctl offline calibrate-thresholds` \
(fitted on contact-free logs, e.g. a real arm's recordings): its schedule and the gains it was \
fitted with, stored like `calibrate --apply`. The service refuses a file fitted at another \
controller period or on another arm model (`--calibration` of the fit against its \
`robot.calibration`), and thresholds above the ceiling unless `--allow-weak` is given.";

/// Where the calibration's motion comes from, on the command line.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum SourceArg {
    /// MOVES THE ARM: the built-in excitation (the paper's joint-1 sweeps q_A, q_B, q_C and the
    /// estimation pose pattern) at the configured motion limits.
    Excitation,
    /// Record `--duration-s` of the task the arm runs now (the service moves nothing).
    CurrentTask,
    /// Fit the last recording again (e.g. for another `--budget`); nothing moves.
    LastRecording,
}

/// Collision-monitor actions on the command line.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum CollisionArg {
    /// Show settings and state.
    Show,
    /// Arm the reaction (a contact stops the arm).
    Arm,
    /// Disarm the reaction (residual still computed).
    Disarm,
    /// Change thresholds, gains and/or the reaction (stored by the service).
    Configure,
    /// Fit the thresholds to a false-alarm budget (may MOVE THE ARM, see --source).
    Calibrate,
}

/// Reaction to a detected contact on the command line.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum ReactionArg {
    /// Only report the contact; the arm keeps moving.
    Report,
    /// Hold the arm until `fri-ctl resume`.
    Stop,
    /// Hold, then resume `--pause-s` after the contact is released.
    Pause,
}

/// `fri-ctl collision`.
#[derive(Debug, Clone, Args)]
pub struct CollisionArgs {
    /// What to do.
    pub action: CollisionArg,
    /// Thresholds, Nm: one value for every joint or 7 comma-separated values, joint 1 first
    /// (with `configure`).
    #[arg(
        long,
        value_name = "NM,…",
        value_delimiter = ',',
        allow_hyphen_values = true
    )]
    pub thresholds: Option<Vec<f64>>,
    /// Observer gains, 1/s: one value for every joint or 7 comma-separated values (with
    /// `configure`).
    #[arg(
        long,
        value_name = "1/S,…",
        value_delimiter = ',',
        allow_hyphen_values = true
    )]
    pub gains: Option<Vec<f64>>,
    /// Reaction to a detected contact (with `configure`).
    #[arg(long, value_enum)]
    pub reaction: Option<ReactionArg>,
    /// Pause of the `pause` reaction before the arm resumes, s (with `configure`).
    #[arg(long, value_name = "S", allow_hyphen_values = true)]
    pub pause_s: Option<f64>,
    /// What to calibrate on (with `calibrate`; default excitation).
    #[arg(long, value_enum)]
    pub source: Option<SourceArg>,
    /// Recording length, s of robot time (with `calibrate`: required for current-task; the
    /// excitation repeats until this much is recorded, default one pass).
    #[arg(long, value_name = "S", allow_hyphen_values = true)]
    pub duration_s: Option<f64>,
    /// False alarms per hour the thresholds may cause, whole arm (with `calibrate`; default
    /// 0.1).
    #[arg(long, value_name = "PER_HOUR", allow_hyphen_values = true)]
    pub budget: Option<f64>,
    /// Install and store the calibrated thresholds (with `calibrate`; without: a preview).
    #[arg(long)]
    pub apply: bool,
    /// Install the thresholds file of `fri-ctl offline calibrate-thresholds` (with
    /// `configure`: its schedule and gains, checked by the service against its cycle, arm model
    /// and ceiling; stored).
    #[arg(long, value_name = "FILE")]
    pub from: Option<std::path::PathBuf>,
    /// With `calibrate --apply` or `configure --from`: install thresholds above the service's
    /// `[observer] calibration_ceiling_nm` too (they weaken detection; logged as weaker).
    #[arg(long)]
    pub allow_weak: bool,
    /// Output format.
    #[command(flatten)]
    pub output: JsonFlag,
}

impl Operation for CollisionArgs {
    type Output = CollisionResult;

    fn request(&self) -> Result<Command, String> {
        if let Some(path) = &self.from {
            return self.install_request(path);
        }
        let configure = matches!(self.action, CollisionArg::Configure);
        let given = self.thresholds.is_some()
            || self.gains.is_some()
            || self.reaction.is_some()
            || self.pause_s.is_some();
        if given && !configure {
            return Err(
                "--thresholds, --gains, --reaction and --pause-s go with `configure`".to_owned(),
            );
        }
        let calibrating = self.source.is_some()
            || self.duration_s.is_some()
            || self.budget.is_some()
            || self.apply
            || self.allow_weak;
        if calibrating {
            return Err(
                "--source, --duration-s, --budget, --apply and --allow-weak go with `calibrate`"
                    .to_owned(),
            );
        }
        Ok(Command::Collision {
            action: match self.action {
                CollisionArg::Show => CollisionAction::Show,
                CollisionArg::Arm => CollisionAction::Arm,
                CollisionArg::Disarm => CollisionAction::Disarm,
                CollisionArg::Configure => CollisionAction::Configure,
                // `run` sends `calibrate` as its own request (`collision_calibrate.rs`).
                CollisionArg::Calibrate => {
                    return self.calibrate_request();
                }
            },
            thresholds: lists::optional_per_joint("thresholds", &self.thresholds)?,
            gains: lists::optional_per_joint("gains", &self.gains)?,
            reaction: self.reaction.map(|r| match r {
                ReactionArg::Report => ReactionMode::Report,
                ReactionArg::Stop => ReactionMode::Stop,
                ReactionArg::Pause => ReactionMode::Pause,
            }),
            pause_s: self.pause_s,
        })
    }

    fn json(&self) -> bool {
        self.output.json
    }

    fn print(&self, r: &CollisionResult, out: &mut dyn Write) -> io::Result<()> {
        print_monitor(r, out)
    }
}

/// Writes the monitor's settings (also the end of `status`).
pub(super) fn print_monitor(m: &MonitorSettings, out: &mut dyn Write) -> io::Result<()> {
    let state = match (m.armed, m.reaction) {
        (false, _) => "disarmed (residual computed, no reaction)".to_owned(),
        (true, ReactionMode::Stop) => "ARMED (a contact stops the arm)".to_owned(),
        (true, ReactionMode::Pause) => format!(
            "ARMED (a contact stops the arm, which resumes {} s after the release)",
            fixed(m.pause_s, 1)
        ),
        (true, ReactionMode::Report) => "ARMED, report only (a contact is reported)".to_owned(),
    };
    writeln!(out, "monitor        {state}")?;
    let origin = if let Some(c) = &m.calibration {
        let payload = m
            .set_for_payload
            .as_ref()
            .map_or("without a payload".to_owned(), |p| {
                format!("for a payload of {} kg", fixed(p.mass, 3))
            });
        let by = c.installed_from.as_ref().map_or_else(
            || "calibrated by `collision calibrate`".to_owned(),
            |f| format!("calibrated offline, installed from {f}"),
        );
        format!(
            "{by} {payload}: budget {} false alarms/h, {} s recorded",
            c.budget_per_hour,
            fixed(c.duration_s, 0)
        )
    } else if m.persisted {
        match &m.set_for_payload {
            Some(p) => format!(
                "set by `collision configure` for a payload of {} kg",
                fixed(p.mass, 3)
            ),
            None => "set by `collision configure` without a payload".to_owned(),
        }
    } else {
        "from the configuration file".to_owned()
    };
    writeln!(out, "settings       {origin}")?;
    if m.payload_changed && m.calibration.is_some() {
        writeln!(
            out,
            "               the applied payload has changed since: run `collision calibrate` \
             again with the new payload"
        )?;
    } else if m.payload_changed {
        writeln!(
            out,
            "               the applied payload has changed since: check the thresholds \
             against a free motion and `collision configure` them again"
        )?;
    }
    joint_header(out)?;
    let label = if m.schedule.is_some() {
        "θ at rest"
    } else {
        "threshold"
    };
    joint_row(out, label, "Nm", &m.thresholds, 2)?;
    if let Some(s) = &m.schedule {
        joint_row(out, "+ per |q̇|", "Nm·s", &s.speed, 3)?;
        joint_row(out, "+ vel. noise", "Nm/kgm²", &s.velocity_noise, 3)?;
        joint_row(out, "+ payload dyn.", "1", &s.payload_dynamics, 3)?;
        joint_row(out, "+ inertial", "1", &s.inertial, 3)?;
        joint_row(out, "+ gravity", "1", &s.gravity, 4)?;
    }
    joint_row(out, "gain", "1/s", &m.gains, 1)
}

impl CollisionArgs {
    /// The `collision-calibrate` request of `collision calibrate`.
    pub(super) fn calibrate_request(&self) -> Result<Command, String> {
        let a = self;
        if a.allow_weak && !a.apply {
            return Err("--allow-weak goes with --apply".to_owned());
        }
        if a.thresholds.is_some()
            || a.gains.is_some()
            || a.reaction.is_some()
            || a.pause_s.is_some()
        {
            return Err(
                "--thresholds, --gains, --reaction and --pause-s go with `configure`".to_owned(),
            );
        }
        Ok(Command::CollisionCalibrate {
            source: a.source.map(|s| match s {
                SourceArg::Excitation => CalibrationSource::Excitation,
                SourceArg::CurrentTask => CalibrationSource::CurrentTask,
                SourceArg::LastRecording => CalibrationSource::LastRecording,
            }),
            duration_s: a.duration_s,
            budget_per_hour: a.budget,
            apply: Some(a.apply),
            allow_weaker: a.allow_weak.then_some(true),
        })
    }
}
