//! Example iceoryx2 subscriber: prints the robot state, collision events and payload estimates
//! published by `fri-service`.
//!
//! `cargo run --example state_subscriber -- [--service-prefix fri-service] [--global-prefix P]
//! [--every 100] [--count N]`
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::time::Duration;

use clap::Parser;
use fri_service::ipc::publisher::open_service;
use fri_service::ipc::{CollisionMessage, IpcNames, PayloadEstimate, RobotState};

/// Command-line arguments.
#[derive(Parser, Debug)]
struct Args {
    /// Service-name prefix (config `iceoryx2.service_prefix`).
    #[arg(long, default_value = "fri-service")]
    service_prefix: String,
    /// iceoryx2 global prefix (config `iceoryx2.global_prefix`).
    #[arg(long)]
    global_prefix: Option<String>,
    /// Print one state line per this many received states.
    #[arg(long, default_value_t = 100)]
    every: u64,
    /// Exit after this many printed state lines.
    #[arg(long)]
    count: Option<u64>,
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    let names = IpcNames {
        service_prefix: args.service_prefix,
        global_prefix: args.global_prefix,
    };
    let node = names.node()?;
    let state = open_service::<RobotState>(&node, &names.state(), 1)?
        .subscriber_builder()
        .create()?;
    let collision = open_service::<CollisionMessage>(&node, &names.collision(), 16)?
        .subscriber_builder()
        .create()?;
    let payload = open_service::<PayloadEstimate>(&node, &names.payload(), 4)?
        .subscriber_builder()
        .create()?;
    let (mut received, mut printed) = (0u64, 0u64);
    loop {
        while let Some(s) = state.receive()? {
            received += 1;
            if received % args.every.max(1) == 0 {
                let s = s.payload();
                println!(
                    "cycle {:>9} t {:>9.3} s  q [{}] rad  residual [{}] Nm  flags {:#04x}",
                    s.cycle,
                    s.time_s,
                    fmt(&s.q),
                    fmt(&s.residual),
                    s.flags
                );
                printed += 1;
            }
        }
        while let Some(e) = collision.receive()? {
            let e = e.payload();
            println!(
                "COLLISION at {:.3} s (cycle {}), link {}, residual [{}] Nm",
                e.time_s,
                e.cycle,
                e.link,
                fmt(&e.residual)
            );
        }
        while let Some(p) = payload.receive()? {
            let p = p.payload();
            println!(
                "PAYLOAD {} m = {:.4} ± {:.4} kg, com = ({:.4}, {:.4}, {:.4}) m (frame 7), {} samples",
                if p.applied == 1 {
                    "applied"
                } else {
                    "estimated"
                },
                p.mass,
                p.mass_std,
                p.com[0],
                p.com[1],
                p.com[2],
                p.samples
            );
        }
        if args.count.is_some_and(|c| printed >= c) {
            return Ok(());
        }
        std::thread::sleep(Duration::from_millis(1));
    }
}

fn fmt(v: &[f64]) -> String {
    v.iter()
        .map(|x| format!("{x:+.3}"))
        .collect::<Vec<_>>()
        .join(" ")
}
