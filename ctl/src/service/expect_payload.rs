//! `fri-ctl expect-payload`: declare the payload unknown before grasping it, so the collision
//! monitor stays armed through the grasp and the estimate.

use std::io::{self, Write};

use clap::Args;

use fri_api::protocol::Command;
use fri_api::results::{DeclaredBy, ExpectPayloadResult, UnknownPayload};

use super::JsonFlag;
use super::format::{count, fixed, xyz_mm};
use super::runner::Operation;
use fri_api::results::PinnedPayload;

/// Long help of `expect-payload`.
pub(super) const HELP: &str = "\
Declare the payload unknown, before grasping it (the arm does not move). The collision monitor \
stays ARMED: it detects contacts against the torque of the payload it predicts instead of \
tripping on the payload itself (the paper's point: an unknown payload looks like a contact).

During the grasp it tolerates only what a plausible static load on the flange explains: a \
downward force of at most --max-mass kg whose centre of mass lies within --max-radius m of the \
flange point; anything else (sideways or lifting forces, torques no flange load makes, a \
heavier load) is a contact. The grasp ends when the load has changed and settled (the \
service's [unknown_payload] settle_s at rest), or at the latest when the grasp window \
([unknown_payload] grasp_window_s, default 10 s) ends: the load is then PINNED, and any later \
change of it beyond the thresholds (a push down, a lift) is a contact. `estimate-payload` \
refits the payload after every static sample and pins the fit; a torque no flange load \
explains across the poses is a contact too, and so is the payload's inertia beyond an \
allowance derived from the motion limits while the arm moves. Without an estimate the mode \
expires ([unknown_payload] expire_s after the declaration or the last sample, default 120 s): \
the monitor detects against the applied payload again. The answer (and `status`) says until \
when the grasp may last, what is pinned, and when the mode expires. A declaration while the \
mode is active is refused (it would reopen the grasp window: the active one keeps its pin and \
expiry), and after 3 declarations with no payload applied since, so is the next one until a \
payload with mass is applied.

The mode ends when a payload is applied (`estimate-payload --apply`, `apply-payload`, \
`clear-payload`), without a gap, or with `--end` (the applied payload, or none, is the payload \
again: with the unknown payload still held the monitor trips at once). A grasp without this \
declaration trips the armed monitor; declaring after such a trip and then `resume` releases \
the arm. Limits of the mode: docs/collision-detection.md, \"Estimating with the monitor armed\".

--max-mass in kg, 0.01…7 (the LWR 4+'s rating; default from the service's \
[unknown_payload] max_mass_kg, 7): every kilogram above the real payload is a downward push on \
the flange that is tolerated before the first sample, so give the payload's mass bound. \
--max-radius in m, 0.01…1 (default 0.3): the sphere around the flange that holds the payload.";

/// `fri-ctl expect-payload`.
#[derive(Debug, Clone, Args)]
pub struct ExpectPayloadArgs {
    /// Largest plausible payload mass, kg: 0.01…7.
    #[arg(
        long,
        value_name = "KG",
        allow_negative_numbers = true,
        conflicts_with = "end"
    )]
    pub max_mass: Option<f64>,
    /// Radius around the flange point that holds the payload, m: 0.01…1.
    #[arg(
        long,
        value_name = "M",
        allow_negative_numbers = true,
        conflicts_with = "end"
    )]
    pub max_radius: Option<f64>,
    /// Leave the unknown-payload mode without applying a payload.
    #[arg(long)]
    pub end: bool,
    /// Output format.
    #[command(flatten)]
    pub output: JsonFlag,
}

impl Operation for ExpectPayloadArgs {
    type Output = ExpectPayloadResult;

    fn request(&self) -> Result<Command, String> {
        Ok(Command::ExpectPayload {
            max_mass: self.max_mass,
            max_radius: self.max_radius,
            end: self.end.then_some(true),
        })
    }

    fn json(&self) -> bool {
        self.output.json
    }

    fn print(&self, r: &ExpectPayloadResult, out: &mut dyn Write) -> io::Result<()> {
        match &r.unknown_payload {
            Some(u) => print_mode(u, out),
            None => writeln!(
                out,
                "payload known  the monitor detects against the applied payload (if any)"
            ),
        }
    }
}

/// Writes the unknown-payload mode (shared with `status`).
pub(super) fn print_mode(u: &UnknownPayload, out: &mut dyn Write) -> io::Result<()> {
    let by = match u.declared_by {
        DeclaredBy::Operator => "by the operator",
        DeclaredBy::EstimatePayload => {
            "by estimate-payload (the applied payload did not explain the residual)"
        }
    };
    writeln!(
        out,
        "payload UNKNOWN  declared {by}; the armed monitor tolerates a flange load of at most {} kg within {} m of the flange",
        fixed(u.max_mass, 2),
        fixed(u.max_radius, 3)
    )?;
    print_pin(u, out)?;
    match (u.mass, u.samples) {
        (_, 0) => writeln!(out, "                 no static sample yet"),
        (Some(m), n) => writeln!(
            out,
            "                 fitted to {}: {} kg, centre of mass [mm] {} in frame 7{}",
            count(n, "static sample"),
            fixed(m, 4),
            u.com.map_or_else(|| "-".to_owned(), |c| xyz_mm(&c, 1)),
            if u.consistent {
                ""
            } else {
                "; NOT explained by one flange load across the poses (a contact): declare again or apply a payload"
            }
        ),
        (None, n) => writeln!(out, "                 {}", count(n, "static sample")),
    }
}

/// Writes the grasp window, the pinned load and the expiry (controller time, as `status`'s).
fn print_pin(u: &UnknownPayload, out: &mut dyn Write) -> io::Result<()> {
    match (&u.pinned, u.grasp_window_end_s) {
        (Some(p), _) => print_pinned(p, u.max_radius, out)?,
        (None, Some(end)) => writeln!(
            out,
            "                 GRASP WINDOW open until t = {} s: any plausible load at the current pose is tolerated until the load has settled or the window ends",
            fixed(end, 3)
        )?,
        (None, None) => writeln!(
            out,
            "                 the loop has not taken the declaration yet (no controller?): any plausible load will be tolerated until it is pinned"
        )?,
    }
    match (u.expires_at_s, u.expires_in_s) {
        (Some(at), Some(left)) => writeln!(
            out,
            "                 expires at t = {} s (in {} s) unless an estimate is applied or a static sample refits the load",
            fixed(at, 3),
            fixed(left, 1)
        ),
        (Some(at), None) => writeln!(
            out,
            "                 expires at t = {} s unless an estimate is applied or a static sample refits the load",
            fixed(at, 3)
        ),
        _ => Ok(()),
    }
}

fn print_pinned(p: &PinnedPayload, max_radius: f64, out: &mut dyn Write) -> io::Result<()> {
    let by = match p.samples {
        Some(n) => format!("by the fit of {}", count(n as usize, "static sample")),
        None => format!("({})", p.by.name()),
    };
    writeln!(
        out,
        "                 load PINNED {by} at t = {} s: {} kg, centre of mass [mm] {} in frame 7; any later change is a contact",
        fixed(p.at_s, 3),
        fixed(p.mass, 4),
        p.com.map_or_else(|| "-".to_owned(), |c| xyz_mm(&c, 1)),
    )?;
    writeln!(
        out,
        "                 unseen at the pinning pose: up to {} kg more or less ({} N down or up on the flange), a {} mm shift of the centre of mass across gravity{}",
        fixed(p.mass_tolerance, 3),
        fixed(p.mass_tolerance * 9.81, 1),
        fixed(p.com_tolerance * 1e3, 1),
        if p.com_height_open {
            format!(
                "; its height along gravity follows the pose within {} m until a sample at a second orientation",
                fixed(max_radius, 3)
            )
        } else {
            String::new()
        }
    )
}
