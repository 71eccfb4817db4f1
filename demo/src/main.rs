//! `fri-demo demo`: the paper's pick-estimate-and-move experiment, the FRI service against an
//! embedded simulated LWR 4+ (`cargo run --release -- demo` from the repository root).

use std::io::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context as _;
use clap::{Parser, Subcommand};
use fri_api::stdio::{Stdout, clap_exit, exit_status};
use fri_demo::run::{DemoOptions, fmt_false_alarms, fmt_times, run as run_demo};
use mock_robot::TimingMode;
use mock_robot::config::ArmProfile;

/// The FRI service's demonstration against a simulated KUKA LWR 4+: payload estimation from
/// static poses and payload-compensated collision detection, with plots.
#[derive(Debug, Parser)]
#[command(name = "fri-demo", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Cmd,
}

#[derive(Debug, Subcommand)]
enum Cmd {
    /// The paper's pick-estimate-and-move experiment against an embedded simulated robot.
    Demo {
        /// Print one JSON object with the results at the end (progress goes to stderr).
        #[arg(long)]
        json: bool,
        /// Directory for the plots and the free-motion log.
        #[arg(long, default_value = "target/demo")]
        out: PathBuf,
        /// Seed of the simulated robot (noise, controller-model error).
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Run the simulated controller in lockstep (faster than real time) instead of real time.
        #[arg(long)]
        lockstep: bool,
        /// Next to the ROS 2 bridge: publish over iceoryx2, write the service's configuration
        /// to FILE (default target/demo/fri-service.toml) for `cargo run --release -p fri-ros2
        /// -- --config FILE`, and keep the service up after the demo until Ctrl-C.
        #[arg(long, value_name = "FILE", num_args = 0..=1, default_missing_value = "target/demo/fri-service.toml")]
        ros2: Option<PathBuf>,
        /// The simulated arm: `nominal` (the shared LWR 4+ model) or `real-lwr4` (the real arm
        /// of data/real-lwr4 as its recordings describe it; docs/mock-robot.md).
        #[arg(long, value_name = "PROFILE", default_value = "nominal")]
        arm: ArmProfile,
    },
}

/// Exit status of every failure (start, demo, stdout).
const EXIT_FAILED: u8 = 1;

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => return ExitCode::from(clap_exit(&e, EXIT_FAILED)),
    };
    fri_service::init_logging("warn");
    let mut stdout = Stdout::new();
    let result = match cli.command {
        Cmd::Demo {
            json,
            out,
            seed,
            lockstep,
            ros2,
            arm,
        } => demo(json, out, seed, lockstep, ros2, arm, &mut stdout),
    };
    ExitCode::from(exit_status(result, &mut stdout, EXIT_FAILED))
}

fn runtime() -> anyhow::Result<tokio::runtime::Runtime> {
    fri_service::runtime().context("starting the tokio runtime")
}

fn demo(
    json: bool,
    out: PathBuf,
    seed: u64,
    lockstep: bool,
    ros2: Option<PathBuf>,
    arm: ArmProfile,
    stdout: &mut Stdout,
) -> anyhow::Result<()> {
    let opts = DemoOptions {
        out_dir: out,
        seed,
        arm,
        pacing: if lockstep {
            TimingMode::Lockstep {
                answer_timeout: std::time::Duration::from_millis(200),
            }
        } else {
            TimingMode::RealTime
        },
        verbose: true,
        ros2_config: ros2,
    };
    let rt = runtime()?;
    let report = rt.block_on(run_demo(&opts))?;
    if json {
        writeln!(stdout, "{}", serde_json::to_string(&report)?)?;
    } else {
        writeln!(
            stdout,
            "done: payload {:.4} kg (truth {:.4} kg, paper {:.3} kg); compensated: detections {}, \
             {}; uncompensated: detections {}, {}; plots in {}\n\
             robot time {:.1} s in {:.1} s of wall time ({:.1}× real time)",
            report.payload_estimate.mass,
            report.payload_truth.mass,
            report.payload_paper.mass,
            fmt_times(&report.detections_compensated),
            fmt_false_alarms(report.false_alarms_compensated),
            fmt_times(&report.detections_uncompensated),
            fmt_false_alarms(report.false_alarms_uncompensated),
            opts.out_dir.display(),
            report.robot_time_s,
            report.wall_time_s,
            report.robot_time_s / report.wall_time_s.max(f64::EPSILON),
        )?;
    }
    Ok(())
}
