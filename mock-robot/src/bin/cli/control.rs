//! `mock-robot control …`: one request to a running simulator's control socket.

use std::path::PathBuf;

use anyhow::{Result, bail};
use serde_json::{Value, json};

/// Send one request to a running simulator (its --control-socket).
#[derive(Debug, clap::Args)]
pub struct ControlArgs {
    /// The simulator's control socket (default: $XDG_RUNTIME_DIR/mock-robot/control.sock, else
    /// /tmp/mock-robot-UID/control.sock, as mock-robot's own default).
    #[arg(long, value_name = "PATH")]
    socket: Option<PathBuf>,
    #[command(subcommand)]
    request: Request,
}

/// How a push's force evolves.
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
enum Profile {
    /// F(t) = F·sin(π t / duration): a shove.
    HalfSine,
    /// Grows along F at --rate-n-per-s up to |F|, held, released after the duration: a lean.
    Ramp,
}

#[derive(Debug, clap::Subcommand)]
enum Request {
    /// Hand the arm a payload (replaces an attached one).
    Attach {
        /// Mass, kg (more than 0, at most 14).
        #[arg(long, allow_hyphen_values = true)]
        mass_kg: f64,
        /// Centre of mass in the flange frame (DH frame 7), m: X,Y,Z.
        #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
        com_m: Vec<f64>,
    },
    /// Take the payload off.
    Detach,
    /// Push a link with a force profile, starting now.
    Push {
        /// Link, 1..=7.
        #[arg(long, allow_hyphen_values = true)]
        link: i64,
        /// Force in the base frame, N: FX,FY,FZ (peak of a half-sine, final value of a ramp).
        #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
        force_n: Vec<f64>,
        /// Point on the link in its DH frame, m: X,Y,Z.
        #[arg(
            long,
            value_delimiter = ',',
            allow_hyphen_values = true,
            default_value = "0,0,0"
        )]
        point_m: Vec<f64>,
        /// Length of the push, s.
        #[arg(long, allow_hyphen_values = true, default_value_t = 0.3)]
        duration_s: f64,
        /// Force profile.
        #[arg(long, value_enum, default_value = "half-sine")]
        profile: Profile,
        /// Ramp only: growth rate, N/s (default: |F| in 0.5 s).
        #[arg(long, allow_hyphen_values = true)]
        rate_n_per_s: Option<f64>,
    },
    /// Stop command mode from the pendant (reason 8).
    Monitor,
    /// Restart the controller.
    Restart,
    /// Send a request written as one JSON line (docs/mock-robot.md, "Control socket").
    Send {
        /// The request, e.g. '{"cmd":"detach"}'.
        json: String,
    },
}

fn triple(flag: &str, v: &[f64]) -> Result<[f64; 3]> {
    match v {
        [x, y, z] => Ok([*x, *y, *z]),
        _ => bail!(
            "{flag} needs 3 comma-separated numbers X,Y,Z, got {}",
            v.len()
        ),
    }
}

fn request_json(request: &Request) -> Result<String> {
    let value: Value = match request {
        Request::Attach { mass_kg, com_m } => {
            json!({"cmd": "attach", "mass_kg": mass_kg, "com_m": triple("--com-m", com_m)?})
        }
        Request::Detach => json!({"cmd": "detach"}),
        Request::Push {
            link,
            force_n,
            point_m,
            duration_s,
            profile,
            rate_n_per_s,
        } => {
            let force = triple("--force-n", force_n)?;
            let profile = match profile {
                Profile::HalfSine => json!({
                    "kind": "half_sine", "peak_force_n": force, "duration_s": duration_s
                }),
                Profile::Ramp => {
                    let magnitude = force.iter().map(|f| f * f).sum::<f64>().sqrt();
                    json!({
                        "kind": "ramp", "direction": force, "max_force_n": magnitude,
                        "rate_n_per_s": rate_n_per_s.unwrap_or(magnitude / 0.5),
                        "duration_s": duration_s
                    })
                }
            };
            json!({
                "cmd": "push", "link": link, "point_m": triple("--point-m", point_m)?,
                "profile": profile
            })
        }
        Request::Monitor => json!({"cmd": "monitor"}),
        Request::Restart => json!({"cmd": "restart"}),
        Request::Send { json } => return Ok(json.trim().to_owned()),
    };
    Ok(value.to_string())
}

/// Sends the request and prints the simulator's answer; an error when it refused.
pub fn run(args: &ControlArgs) -> Result<()> {
    let path = args
        .socket
        .clone()
        .unwrap_or_else(mock_robot::control::default_socket_path);
    let line = request_json(&args.request)?;
    let reply = mock_robot::control::send(&path, &line)?;
    if reply.ok {
        println!("{}", reply.message);
        Ok(())
    } else {
        bail!("{}", reply.message)
    }
}
