//! `fri-ctl estimate-payload`: the pose pattern driven with the payload, and its estimate.

use std::io::{self, Write};

use clap::Args;

use fri_api::protocol::Command;
use fri_api::results::{Correction, EstimateMethod, EstimateResult, UncertaintyReport};

use super::JsonFlag;
use super::format::{
    fixed, joint_header, joint_row, joint_row_deg, timing_line, xyz_mm, xyz_mm_std,
};
use super::pattern::PatternArgs;
use super::runner::Operation;

/// Long help of `estimate-payload`.
pub(super) const HELP: &str = "\
Drive the pose pattern WITH the payload, estimate its mass and centre of mass from the static \
samples (generalised least squares on the payload gravity regressor under the service's \
error model) and print them with 1σ uncertainties and the σ by source (averaging noise, the \
tare's noise, sensor drift between tare and estimate, scatter beyond the model): mass in kg, centre of mass in mm in frame 7 (the last DH frame, at the wrist \
point) and in the flange frame. With `--apply` the estimate is applied to the collision \
observer and persisted, as `apply-payload` would.

THE ARM MOVES: the service enters command mode and drives every pose of the pattern (at most \
±step per joint around the centre), settles and samples at each, then returns to the start \
pose. Keep the workspace clear; `fri-ctl stop` (from another terminal) holds the arm and \
aborts the workflow. A residual change of more than twice a joint's threshold between poses \
(a contact) stops the arm.

With a stored tare the pattern defaults to the tare's centre and pose count, and the tare is \
subtracted; a pattern elsewhere is refused before the arm moves (`--tare false` estimates \
without the tare). A tare from before a controller restart is used with a WARNING line.

An estimate that means nothing fails (exit 3) and is never applied: a mass not above 3σ, a \
centre of mass beyond the service's `[estimation] max_com_distance_m` of the flange (default \
0.3 m), or a σ beyond `max_mass_std_kg` (0.1 kg) or `max_com_std_m` (0.05 m). The error names \
each with its numbers; the usual reason is a tare taken with the payload attached.";

/// `fri-ctl estimate-payload`.
#[derive(Debug, Clone, Args)]
pub struct EstimateArgs {
    /// Pose pattern.
    #[command(flatten)]
    pub pattern: PatternArgs,
    /// Subtract the stored tare: true or false (default: true when a tare is stored; its poses
    /// are then used).
    #[arg(long, value_name = "BOOL")]
    pub tare: Option<bool>,
    /// Apply the estimate to the collision observer and persist it.
    #[arg(long)]
    pub apply: bool,
    /// Output format.
    #[command(flatten)]
    pub output: JsonFlag,
}

impl Operation for EstimateArgs {
    type Output = EstimateResult;

    fn request(&self) -> Result<Command, String> {
        Ok(Command::EstimatePayload {
            around: self.pattern.around()?,
            poses: self.pattern.poses,
            step_deg: self.pattern.step_deg,
            pattern: self.pattern.kind(),
            use_tare: self.tare,
            apply: Some(self.apply),
        })
    }

    fn json(&self) -> bool {
        self.output.json
    }

    fn shows_progress(&self) -> bool {
        true
    }

    fn print(&self, r: &EstimateResult, out: &mut dyn Write) -> io::Result<()> {
        print(r, out)
    }
}

/// Writes the human-readable estimate.
pub(super) fn print(r: &EstimateResult, out: &mut dyn Write) -> io::Result<()> {
    // Mass to 0.1 g, centre of mass to 0.01 mm, each with its 1σ.
    writeln!(
        out,
        "mass           {} kg ± {} kg (1σ)",
        fixed(r.mass, 4),
        fixed(r.mass_std, 4)
    )?;
    writeln!(out, "com frame {}    [mm] {}", r.frame, xyz_mm(&r.com, 2))?;
    writeln!(out, "         ± 1σ  [mm] {}", xyz_mm_std(&r.com_std, 2))?;
    writeln!(out, "com flange     [mm] {}", xyz_mm(&r.com_flange, 2))?;
    writeln!(
        out,
        "         ± 1σ  [mm] {}",
        xyz_mm_std(&r.com_flange_std, 2)
    )?;
    let method = match r.method {
        EstimateMethod::Direct => "direct least squares",
        EstimateMethod::Coefficients => "gravity-coefficient route",
    };
    let correction = match (r.tare_used, r.correction) {
        (true, _) | (_, Correction::Tare) => "stored tare subtracted",
        (false, Correction::Calibration) => "model-error calibration",
        (false, Correction::IdentifiedArm) => {
            "the identified arm's gravity and offsets (robot.calibration; no tare)"
        }
        (false, Correction::None) => {
            "none (no matching tare: biased by the controller's model error)"
        }
    };
    writeln!(
        out,
        "fit            {} samples, {method}, condition number {}, residual σ {} Nm",
        r.samples,
        fixed(r.condition_number, 1),
        fixed(r.residual_std, 3)
    )?;
    writeln!(out, "correction     {correction}")?;
    if let Some(u) = &r.uncertainty {
        print_uncertainty(u, out)?;
    }
    if let Some(t) = &r.timing {
        writeln!(out, "{}", timing_line(t))?;
    }
    joint_header(out)?;
    joint_row_deg(out, "around", &r.around, 2)?;
    if let Ok(rms) = <[f64; 7]>::try_from(r.residual_rms.as_slice()) {
        joint_row(out, "fit RMS", "Nm", &rms, 3)?;
    }
    let applied = if r.applied {
        "applied to the collision observer (persisted)"
    } else {
        "NOT applied (use --apply or `fri-ctl apply-payload`)"
    };
    writeln!(out, "payload        {applied}")?;
    for w in &r.warnings {
        writeln!(out, "WARNING        {}", w.message())?;
    }
    Ok(())
}

/// The σ by source: mass in g, CoM in mm (each source alone; the variances add up).
fn print_uncertainty(u: &UncertaintyReport, out: &mut dyn Write) -> io::Result<()> {
    writeln!(out, "1σ by source   mass [g]   com frame 7 [mm]")?;
    for s in &u.sources {
        writeln!(
            out,
            "  {:<20} {:>7}   {}",
            s.source.label(),
            fixed(s.mass_std * 1e3, 2),
            xyz_mm_std(&s.com_std, 2)
        )?;
    }
    let measured = u.drift_rate_measured.map_or_else(
        || "not measured (no revisit)".to_owned(),
        |m| {
            format!(
                "{} measured over {} increments",
                fixed(m * 1e3, 2),
                u.drift_increments
            )
        },
    );
    writeln!(
        out,
        "drift          {} mNm/√s used ({measured}); scatter ratio {} over {} dof",
        fixed(u.drift_rate * 1e3, 2),
        fixed(u.scatter_ratio, 2),
        u.dof
    )?;
    match u.since_tare_s {
        // The drift over this pause cannot be told from a payload: say how long it was.
        Some(pause) => writeln!(
            out,
            "since tare     {} s from the tare's last sample to the estimate's first",
            fixed(pause, 1)
        ),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mass_to_a_tenth_of_a_gram_and_com_in_mm_with_sigma() {
        let r = EstimateResult {
            method: EstimateMethod::Direct,
            correction: Correction::Tare,
            mass: 3.028_14,
            mass_std: 0.000_42,
            com: [0.000_1, -0.000_2, 0.119_04],
            com_std: [0.000_3; 3],
            com_flange: [0.0, 0.0, 0.04],
            com_flange_std: [0.000_3; 3],
            first_moment: [0.0; 3],
            first_moment_std: [0.0; 3],
            covariance: [[0.0; 4]; 4],
            residual_rms: vec![0.01; 7],
            residual_std: 0.012,
            condition_number: 12.54,
            samples: 6,
            joints_used: vec![1, 2, 3, 4, 5, 6, 7],
            tare_used: true,
            frame: "7".into(),
            around: [0.0; 7],
            applied: false,
            timing: None,
            warnings: vec![fri_api::results::EstimateWarning::TareFromBeforeRestart {
                evidence:
                    "the controller's clock went back from 3600.000 s at the tare to 12.000 s"
                        .into(),
            }],
            uncertainty: Some(UncertaintyReport {
                sources: vec![fri_api::results::SourceShare {
                    source: fri_api::results::UncertaintySource::Drift,
                    mass_std: 0.000_41,
                    com_std: [0.000_2; 3],
                }],
                scatter_ratio: 0.93,
                dof: 73,
                drift_rate: 0.002_1,
                drift_rate_measured: Some(0.002_3),
                drift_increments: 14,
                since_tare_s: Some(5.3),
            }),
        };
        let mut out = Vec::new();
        print(&r, &mut out).unwrap();
        let text = String::from_utf8(out).unwrap();
        assert!(
            text.contains("mass           3.0281 kg ± 0.0004 kg (1σ)"),
            "{text}"
        );
        assert!(text.contains("z +119.04"), "{text}");
        assert!(text.contains("drift                   0.41"), "{text}");
        assert!(text.contains("2.30 measured over 14 increments"), "{text}");
        assert!(text.contains("since tare     5.3 s"), "{text}");
        assert!(
            text.contains("WARNING        the tare was taken before a controller restart (the controller's clock went back"),
            "{text}"
        );
        assert!(
            text.contains("stored tare subtracted") && text.contains("NOT applied"),
            "{text}"
        );
    }
}
