//! `fri-ctl record`: static samples or a per-cycle log to a new CSV file of the service, or the
//! per-cycle state and events to a new MCAP file.

use std::io::{self, Write};

use clap::{Args, ValueEnum};

use fri_api::protocol::{Command, RecordKind};
use fri_api::results::RecordResult;

use super::JsonFlag;
use super::runner::Operation;

/// Long help of `record`.
pub(super) const HELP: &str = "\
Record to a new CSV or MCAP file in the service's recording directory (`state.record_dir`) and \
print its full path. The arm does not move, except with `--excite-deg`.

`--kind log` (default) writes every cycle for `--duration` seconds (0.001…3600, default 1): \
cycle, time (s), flags, then q (rad), q̇ (rad/s), τ_J, gravity, τ_ext and residual (Nm) per \
joint. `--kind samples` takes `--count` averaged static samples at the current pose \
(1…1000, default 1) in the static-sample format q1..q7 (rad), tau1..tau7, g1..g7 (Nm) that \
`fri-ctl offline estimate` reads. `--kind tare` writes the stored tare's samples in the same \
format, for `fri-ctl offline estimate --tare` and `offline calibrate`.

`--kind mcap` writes every cycle for `--duration` seconds as ROS 2 messages in an MCAP file \
(ros2 profile, zstd chunks, indexed): /joint_states (q rad, q̇ rad/s, τ_J Nm), \
/lwr/external_torque (residual) and /lwr/controller_gravity (Nm, as effort), /lwr/payload \
(applied payload at the start and on change), /lwr/collision (onsets) and /robot_description, \
stamped with the controller's time (s since the service's first measurement). It opens in \
Foxglove and reads with `ros2 bag` and the `mcap` libraries; `fri-ctl offline estimate-motion \
--log` reads it too.

`--excite-deg DEG` (with `--kind log` only; 1…45) MOVES THE ARM: the service drives its \
identification excitation — twelve waypoints around the current pose whose joint offsets of up \
to DEG degrees are orthogonal cosine patterns (each joint at its own frequencies), clamped 5° \
inside the joint limits, at the `[motion]` limits — while it logs, repeats it until \
`--duration` (default one pass), and holds the arm where it started, in monitor mode. `fri-ctl \
identify` uses it to identify the arm.

Cycles the recorder could not keep up with are reported as lost: the log has gaps there.

The name is a file name, not a path: 1 to 255 characters of A-Z a-z 0-9 . _ -, not starting \
with `.` or `-`; an existing file is never overwritten.";

/// Record kinds on the command line.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum RecordArg {
    /// Averaged static samples (static-sample CSV).
    Samples,
    /// Every cycle.
    Log,
    /// The stored tare's samples (static-sample CSV; the arm does not move).
    Tare,
    /// Every cycle and the events as ROS 2 messages (MCAP, ros2 profile).
    Mcap,
}

/// `fri-ctl record`.
#[derive(Debug, Clone, Args)]
pub struct RecordArgs {
    /// File name in the recording directory (A-Z a-z 0-9 . _ -, no `/`; must not exist yet).
    pub name: String,
    /// What to record.
    #[arg(long, value_enum, default_value = "log")]
    pub kind: RecordArg,
    /// Log length, s: 0.001…3600 (with `--kind log` or `mcap`; default 1).
    #[arg(long, value_name = "SECONDS")]
    pub duration: Option<f64>,
    /// Number of static samples: 1…1000 (with `--kind samples`; default 1).
    #[arg(long, value_parser = super::counts::record_count)]
    pub count: Option<usize>,
    /// MOVES THE ARM (with `--kind log`): drive the identification excitation of this
    /// amplitude, deg (1…45), around the current pose while logging.
    #[arg(long, value_name = "DEG")]
    pub excite_deg: Option<f64>,
    /// Output format.
    #[command(flatten)]
    pub output: JsonFlag,
}

impl Operation for RecordArgs {
    type Output = RecordResult;

    fn request(&self) -> Result<Command, String> {
        Ok(Command::Record {
            path: self.name.clone(),
            kind: match self.kind {
                RecordArg::Samples => RecordKind::Samples,
                RecordArg::Log => RecordKind::Log,
                RecordArg::Tare => RecordKind::Tare,
                RecordArg::Mcap => RecordKind::Mcap,
            },
            duration_s: self.duration,
            count: self.count,
            excite_deg: self.excite_deg,
        })
    }

    fn json(&self) -> bool {
        self.output.json
    }

    fn shows_progress(&self) -> bool {
        true
    }

    fn print(&self, r: &RecordResult, out: &mut dyn Write) -> io::Result<()> {
        let what = match self.kind {
            RecordArg::Samples => "static-sample CSV",
            RecordArg::Log => "per-cycle CSV",
            RecordArg::Tare => "tare static-sample CSV",
            RecordArg::Mcap => "per-cycle ROS 2 MCAP",
        };
        let rows = match self.kind {
            RecordArg::Mcap => "cycles",
            _ => "rows",
        };
        writeln!(out, "recorded {} {rows} to {} ({what})", r.rows, r.path)?;
        match r.lost {
            Some(n) if n > 0 => writeln!(
                out,
                "warning: {n} cycles lost (the recorder fell behind): the log has gaps"
            ),
            _ => Ok(()),
        }
    }
}
