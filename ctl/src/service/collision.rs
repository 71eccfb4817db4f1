//! `fri-ctl collision show|arm|disarm|configure`: the collision monitor.

use std::io::{self, Write};

use clap::{Args, ValueEnum};

use fri_api::protocol::{CollisionAction, Command, ReactionMode};
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
settings now in force.";

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
    /// Output format.
    #[command(flatten)]
    pub output: JsonFlag,
}

impl Operation for CollisionArgs {
    type Output = CollisionResult;

    fn request(&self) -> Result<Command, String> {
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
        Ok(Command::Collision {
            action: match self.action {
                CollisionArg::Show => CollisionAction::Show,
                CollisionArg::Arm => CollisionAction::Arm,
                CollisionArg::Disarm => CollisionAction::Disarm,
                CollisionArg::Configure => CollisionAction::Configure,
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
    let origin = if m.persisted {
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
    if m.payload_changed {
        writeln!(
            out,
            "               the applied payload has changed since: check the thresholds \
             against a free motion and `collision configure` them again"
        )?;
    }
    joint_header(out)?;
    joint_row(out, "threshold", "Nm", &m.thresholds, 2)?;
    joint_row(out, "gain", "1/s", &m.gains, 1)
}
