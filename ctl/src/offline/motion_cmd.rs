//! `offline estimate-motion`: full inertial estimate from trajectory logs (paper Sec. V, eq. 45).

use std::io::Write;

use anyhow::{Context, bail};
use dynamics::Model;
use estimator::motion::{
    InertialEstimate, MIN_SEGMENT_ROWS, MotionOptions, Trajectory, Unloaded,
    estimate_motion as run_motion, split_at_gaps,
};

use super::args::MotionArgs;
use super::logs::{read_identified, read_trajectory};
use super::robot::with_robot;
use super::samples_file::read_samples;

fn report(e: &InertialEstimate, last_frame: usize) -> String {
    let s = &e.parameters_std;
    let p = &e.parameters;
    let mut out = String::new();
    out += "Full inertial payload estimate (motion, eq. 45)\n";
    out += &format!("  mass     {:.4} kg ± {:.4} kg (1σ)\n", e.mass, s[0]);
    out += &format!(
        "  CoM, frame {last_frame} (last DH frame) [mm]  x {:+.2} ± {:.2}  y {:+.2} ± {:.2}  z {:+.2} ± {:.2}\n",
        1e3 * e.com[0],
        1e3 * e.com_std[0],
        1e3 * e.com[1],
        1e3 * e.com_std[1],
        1e3 * e.com[2],
        1e3 * e.com_std[2]
    );
    if !e.inertia_resolved {
        // Numbers that mean nothing are not shown as an estimate (they stay in --json).
        out += &inertia_unresolved(e);
        out += &fit_line(e);
        out += &model_error(e);
        return out;
    }
    out += &format!("  inertia about the frame-{last_frame} origin [kg·m²] (± 1σ)\n");
    for (name, i) in ["Jxx", "Jxy", "Jxz", "Jyy", "Jyz", "Jzz"].iter().zip(4..10) {
        out += &format!("    {name} {:+.5} ± {:.5}\n", p[i], s[i]);
    }
    out += &format!("  inertia about the CoM, frame-{last_frame} axes [kg·m²] (± 1σ)\n");
    let ic = &e.inertia_com;
    let vals = [ic[0][0], ic[0][1], ic[0][2], ic[1][1], ic[1][2], ic[2][2]];
    for ((name, v), sd) in ["Ixx", "Ixy", "Ixz", "Iyy", "Iyz", "Izz"]
        .iter()
        .zip(vals)
        .zip(e.inertia_com_std)
    {
        out += &format!("    {name} {v:+.5} ± {sd:.5}\n");
    }
    out += &format!(
        "  principal moments about the CoM [kg·m²]  {:.5} {:.5} {:.5}\n",
        e.principal_moments[0], e.principal_moments[1], e.principal_moments[2]
    );
    out += &fit_line(e);
    match &e.physical_warning {
        None => {
            out += "  physically consistent (m > 0, inertia positive definite, triangle inequalities hold)\n"
        }
        Some(w) => out += &format!("  note: {w}\n"),
    }
    out += &model_error(e);
    out
}

/// The report's lines for an estimate whose inertia the data do not resolve.
pub(crate) fn inertia_unresolved(e: &InertialEstimate) -> String {
    format!(
        "  inertia  NOT RESOLVED by these data: only mass and CoM are estimated\n  note: {}\n",
        e.physical_warning.as_deref().unwrap_or_default()
    )
}

/// The report's line on the fit's size and conditioning.
fn fit_line(e: &InertialEstimate) -> String {
    format!(
        "  fit  {} motion + {} static samples, {} equations, condition number {:.1} (unit-norm columns), residual σ {:.4} Nm\n",
        e.motion_samples, e.static_samples, e.equations, e.condition_number, e.residual_std
    )
}

/// The model-error term's lines of a report.
pub(crate) fn model_error(e: &InertialEstimate) -> String {
    let me = &e.model_error;
    let cells = |v: &[f64], digits: usize| -> String {
        v.iter()
            .map(|x| {
                if x.is_nan() {
                    "     n/a".to_owned()
                } else {
                    format!("{x:>8.digits$}")
                }
            })
            .collect::<Vec<_>>()
            .join("")
    };
    format!(
        "  1σ includes the model-error term ({}): per joint σ [Nm] {}\n                                    correlation time [s] {}\n  (rows counted as independent would give the mass ± {:.4} kg)\n",
        me.source,
        cells(&me.rms, 3),
        cells(&me.correlation_time_s, 2),
        e.parameters_std_white[0]
    )
}

fn motion_n<const N: usize>(
    model: Model<N>,
    a: &MotionArgs,
    out: &mut dyn Write,
) -> anyhow::Result<()> {
    if !a.tare_log.is_empty() && a.tare_log.len() != a.log.len() {
        bail!(
            "{} --log files but {} --tare-log files: give one tare log per loaded log, in the same order",
            a.log.len(),
            a.tare_log.len()
        );
    }
    let mut loaded: Vec<Trajectory<N>> = Vec::new();
    let mut notes = Vec::new();
    for p in &a.log {
        let log = read_trajectory::<N>(p, &model)?;
        let s = split_at_gaps(&log).with_context(|| format!("reading {}", p.display()))?;
        if s.gaps > 0 {
            // A tare log is aligned to one contiguous loaded log: its pieces would need one each.
            if !a.tare_log.is_empty() {
                bail!(
                    "{}: {} gaps in the time column (lost cycles); with --tare-log every log must be contiguous",
                    p.display(),
                    s.gaps
                );
            }
            notes.push(format!(
                "  {}: {} gaps (lost cycles): estimated from {} contiguous pieces, {} rows in pieces under {MIN_SEGMENT_ROWS} rows left out",
                p.display(),
                s.gaps,
                s.pieces.len(),
                s.dropped_rows
            ));
        }
        loaded.extend(s.pieces);
    }
    let tare: Vec<Trajectory<N>> = a
        .tare_log
        .iter()
        .map(|p| read_trajectory::<N>(p, &model))
        .collect::<anyhow::Result<_>>()?;
    let statics = match &a.static_samples {
        Some(p) => read_samples::<N>(p, &model)?,
        None => Vec::new(),
    };
    let identified = a
        .calibration
        .as_ref()
        .map(|p| read_identified(p, &model))
        .transpose()?;
    let unloaded = match (&identified, tare.is_empty()) {
        (Some(m), _) => Unloaded::Identified(m),
        (None, true) => Unloaded::Model(&model),
        (None, false) => Unloaded::Tare(&tare),
    };
    let opts = MotionOptions {
        order: a.order,
        cutoff_hz: a.cutoff_hz,
        keep: a.keep,
        trim_s: a.trim_s,
        tare_tolerance: a.tare_tolerance,
        max_com_distance_m: a.max_com_distance,
        fit_offsets: a.fit_offsets,
        ..MotionOptions::default()
    };
    let e = run_motion(&model, &loaded, unloaded, &statics, &opts).context("motion estimate")?;
    if let Some(path) = &a.calibration {
        notes.push(format!(
            "  unloaded torques: the arm identified in {} (its held-out residual is the model-error floor)",
            path.display()
        ));
    }
    if a.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&e)?)?;
    } else {
        write!(out, "{}", report(&e, N))?;
        for n in &notes {
            writeln!(out, "{n}")?;
        }
    }
    Ok(())
}

/// `offline estimate-motion`.
pub fn estimate_motion(a: &MotionArgs, out: &mut dyn Write) -> anyhow::Result<()> {
    with_robot!(&a.robot, |model| motion_n(model, a, out))
}
