//! `fri-ctl collision calibrate`: per-joint thresholds for a false-alarm budget, fitted by the
//! service on a motion without contact.

use std::io::{self, Write};

use fri_api::protocol::Command;
use fri_api::results::{CalibrateResult, LinkForce};

use super::collision::{CollisionArgs, print_monitor};
use super::format::{fixed, joint_header, joint_row};
use super::runner::Operation;

/// `collision calibrate` as an operation (built from the `collision` arguments).
#[derive(Debug, Clone)]
pub struct Calibrate<'a>(pub &'a CollisionArgs);

impl Operation for Calibrate<'_> {
    type Output = CalibrateResult;

    fn request(&self) -> Result<Command, String> {
        self.0.calibrate_request()
    }

    fn json(&self) -> bool {
        self.0.output.json
    }

    fn shows_progress(&self) -> bool {
        true
    }

    fn print(&self, r: &CalibrateResult, out: &mut dyn Write) -> io::Result<()> {
        let rec = &r.recording;
        writeln!(
            out,
            "calibration    {} s of robot time ({}), {} blocks of {} s; budget {} false alarms/h \
             (each joint a seventh), scales at the {} % bootstrap bound",
            fixed(rec.duration_s, 1),
            r.source.name(),
            rec.blocks,
            fixed(rec.block_s, 1),
            r.budget_per_hour,
            fixed(100.0 * r.confidence, 0)
        )?;
        match &r.calibrated_for_payload {
            Some(p) => writeln!(
                out,
                "payload        {} kg (the thresholds fit this payload)",
                fixed(p.mass, 3)
            )?,
            None => writeln!(out, "payload        none applied")?,
        }
        joint_header(out)?;
        let per = |f: &dyn Fn(usize) -> f64| -> [f64; 7] { std::array::from_fn(f) };
        joint_row(out, "θ at rest", "Nm", &r.schedule.thresholds, 2)?;
        joint_row(
            out,
            "θ median",
            "Nm",
            &per(&|j| r.joints[j].threshold_median),
            2,
        )?;
        joint_row(out, "θ max", "Nm", &per(&|j| r.joints[j].threshold_max), 2)?;
        joint_row(out, "θ cap", "Nm", &r.schedule.ceiling, 2)?;
        joint_row(out, "peak |r|", "Nm", &per(&|j| r.joints[j].peak), 2)?;
        joint_row(out, "scale s", "1", &per(&|j| r.joints[j].scale), 2)?;
        joint_row(out, "scale σ", "1", &per(&|j| r.joints[j].scale_std), 2)?;
        joint_row(out, "max |q̇|", "rad/s", &rec.max_speed, 2)?;
        joint_row(out, "max |q̈|", "rad/s²", &rec.max_acceleration, 2)?;
        let models: Vec<String> = r.joints.iter().map(|j| j.model.clone()).collect();
        writeln!(
            out,
            "{:<16}{}",
            "model",
            models.iter().map(|m| format!("{m:>9}")).collect::<String>()
        )?;
        let forces = |f: &[LinkForce; 7]| -> [f64; 7] { std::array::from_fn(|l| f[l].median) };
        writeln!(
            out,
            "minimum detectable force per link (median over poses, points, directions):"
        )?;
        let mut header = format!("{:<16}", "");
        for l in 1..=7 {
            header.push_str(&format!("{:>9}", format!("link{l}")));
        }
        writeln!(out, "{}", header.trim_end())?;
        let row = |label: &str, v: [f64; 7]| {
            let mut line = format!("{:<16}", format!("{label} [N]"));
            for x in v {
                line.push_str(&format!("{:>9}", fixed(x, 1)));
            }
            line
        };
        writeln!(out, "{}", row("at rest", forces(&r.min_force_at_rest)))?;
        writeln!(out, "{}", row("median θ", forces(&r.min_force_median)))?;
        for a in &r.above_ceiling {
            writeln!(
                out,
                "WEAKER         joint {}: θ {} Nm at rest, {} Nm median, above the ceiling {} Nm ([observer] calibration_ceiling_nm){}",
                a.joint,
                fixed(a.threshold_at_rest_nm, 2),
                fixed(a.threshold_median_nm, 2),
                fixed(a.ceiling_nm, 2),
                if r.applied {
                    "; installed with --allow-weak"
                } else {
                    "; --apply refuses it without --allow-weak"
                }
            )?;
        }
        for (j, fit) in r
            .joints
            .iter()
            .enumerate()
            .filter(|(_, f)| f.model == "heavy")
        {
            writeln!(
                out,
                "HEAVY TAIL     joint {}: GEV shape {}…{} > 0, the envelope misses a regime; the budget is not supported there (more false alarms than it), the threshold is the light-tail level",
                j + 1,
                fixed(fit.shape_interval[0], 2),
                fixed(fit.shape_interval[1], 2)
            )?;
        }
        for (j, why) in r
            .joints
            .iter()
            .enumerate()
            .filter_map(|(j, f)| f.cap_fallback_reason().map(|why| (j, why)))
        {
            writeln!(
                out,
                "STATED CAP     joint {}: the recording supports no constant below {} Nm for the budget ({why}); capped at that stated constant, the budget is not guaranteed where the cap binds",
                j + 1,
                fixed(r.schedule.ceiling[j], 2),
            )?;
        }
        if r.applied {
            writeln!(out, "applied and stored:")?;
            print_monitor(&r.settings, out)
        } else {
            writeln!(
                out,
                "preview only: run again with --apply (e.g. `--source last-recording --apply`) to install these thresholds"
            )
        }
    }
}
