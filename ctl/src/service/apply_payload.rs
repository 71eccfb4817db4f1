//! `fri-ctl apply-payload`: a payload for the collision observer's gravity compensation.

use std::io::{self, Write};

use clap::Args;

use fri_api::protocol::Command;
use fri_api::results::{PayloadComparison, PayloadResult};

use super::JsonFlag;
use super::format::{fixed, xyz_mm};
use super::lists;
use super::runner::Operation;

/// Long help of `apply-payload`.
pub(super) const HELP: &str = "\
Apply a payload (point mass in frame 7) to the collision observer and persist it: the observer \
then expects the payload's gravity torques and does not read them as a contact. The arm does \
not move, but a wrong payload makes the monitor either trip on the real payload or miss \
contacts of the difference: use the values of `estimate-payload` or of a datasheet.

Mass in kg (0…20), centre of mass in m in frame 7 (the last DH frame, at the wrist point), \
each coordinate −1…1, e.g. `--mass 3.028 --com -0.0005,0,0.119`.

The service checks the payload first: with the arm at rest it compares the payload's gravity \
torques at the current pose with the measured torques beyond the unloaded arm (the tare's \
sample at this pose, the identified arm, or the controller's gravity vector, each with its \
stated σ). A joint that disagrees beyond 4σ refuses the payload, naming the joint, both torques \
and the σ; so does a moving arm. `--force` applies it anyway: the audit trail records the \
refusal it overrode as a weakening (WARN).";

/// `fri-ctl apply-payload`.
#[derive(Debug, Clone, Args)]
pub struct ApplyPayloadArgs {
    /// Mass, kg: 0…20.
    #[arg(long, value_name = "KG", allow_negative_numbers = true)]
    pub mass: f64,
    /// Centre of mass in frame 7, m: X,Y,Z, each −1…1 (e.g. `-0.0005,0,0.12`).
    // allow_hyphen_values: "-0.1,0,0" is a value list, not a number, so allow_negative_numbers
    // would take it for a flag.
    #[arg(
        long,
        required = true,
        value_name = "X,Y,Z",
        value_delimiter = ',',
        allow_hyphen_values = true
    )]
    pub com: Vec<f64>,
    /// Apply it even when its torques disagree with the measured ones (audited as weakening).
    #[arg(long)]
    pub force: bool,
    /// Output format.
    #[command(flatten)]
    pub output: JsonFlag,
}

impl Operation for ApplyPayloadArgs {
    type Output = PayloadResult;

    fn request(&self) -> Result<Command, String> {
        Ok(Command::ApplyPayload {
            mass: self.mass,
            com: lists::exactly("com", &self.com)?,
            force: self.force.then_some(true),
        })
    }

    fn json(&self) -> bool {
        self.output.json
    }

    fn print(&self, r: &PayloadResult, out: &mut dyn Write) -> io::Result<()> {
        print(r, out)
    }
}

/// The per-joint figures of a payload check, one line each.
pub(super) fn comparison_lines(c: &PayloadComparison) -> Vec<String> {
    let mut v = vec![format!(
        "against {} (k = {}): joint, payload's torque, measured beyond the baseline, σ [Nm]",
        c.baseline.describe(),
        c.sigmas
    )];
    for j in 0..7 {
        v.push(format!(
            "  j{}  {:>9}  {:>9}  {:>7}{}",
            j + 1,
            fixed(c.predicted_nm[j], 3),
            fixed(c.measured_nm[j], 3),
            fixed(c.sigma_nm[j], 3),
            if j + 1 == c.joint { "  <- worst" } else { "" }
        ));
    }
    if c.mass_implied_kg.is_finite() {
        v.push(format!(
            "the measured torques imply {} ± {} kg at the declared centre of mass",
            fixed(c.mass_implied_kg, 3),
            fixed(c.mass_implied_std_kg, 3)
        ));
    }
    v
}

/// Writes the payload now applied (shared with `clear-payload`).
pub(super) fn print(r: &PayloadResult, out: &mut dyn Write) -> io::Result<()> {
    if let Some(refusal) = &r.forced_past {
        writeln!(
            out,
            "FORCED past the payload check (audited as weakening): {refusal}"
        )?;
    }
    if let Some(c) = &r.check {
        for l in comparison_lines(c) {
            writeln!(out, "{l}")?;
        }
    }
    match &r.payload {
        Some(p) => writeln!(
            out,
            "payload applied  {} kg, centre of mass [mm] {} in frame {} (persisted)",
            fixed(p.mass, 4),
            xyz_mm(&p.com, 2),
            p.frame
        ),
        None => writeln!(
            out,
            "payload cleared  the observer compensates no payload (persisted)"
        ),
    }
}
