//! `offline estimate-motion`: full inertial estimate from trajectory logs (paper Sec. V, eq. 45).

use std::fs::File;
use std::io::{BufReader, Write};

use anyhow::{Context, bail};
use dynamics::Model;
use estimator::motion::{
    InertialEstimate, MIN_SEGMENT_ROWS, MotionOptions, Trajectory, Unloaded,
    estimate_motion as run_motion, read_log_csv, split_at_gaps,
};
use estimator::plausible::Ranges;

use super::args::MotionArgs;
use super::commands::read_samples;
use super::robot::with_robot;

/// Reads a trajectory log (CSV, or MCAP: `/joint_states`); every position and torque must be
/// plausible for `model`.
fn read_log<const N: usize>(
    path: &std::path::Path,
    model: &Model<N>,
) -> anyhow::Result<Trajectory<N>> {
    let context = || format!("reading {}", path.display());
    let trajectory = if super::mcap_log::is_mcap(path)? {
        super::mcap_log::read::<N>(path).with_context(context)?
    } else {
        let f = File::open(path)
            .with_context(|| format!("cannot open trajectory log {}", path.display()))?;
        read_log_csv::<N, _>(BufReader::new(f)).with_context(context)?
    };
    Ranges::from_limits(model.limits())
        .check_trajectory(&trajectory)
        .with_context(context)?;
    Ok(trajectory)
}

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
    out += &format!(
        "  fit  {} motion + {} static samples, {} equations, condition number {:.1} (unit-norm columns), residual σ {:.4} Nm\n",
        e.motion_samples, e.static_samples, e.equations, e.condition_number, e.residual_std
    );
    match &e.physical_warning {
        None => {
            out += "  physically consistent (m > 0, inertia positive definite, triangle inequalities hold)\n"
        }
        Some(w) => out += &format!("  WARNING: {w}\n"),
    }
    out += "  (1σ from the residual variance of filtered, correlated samples: treat as optimistic by up to ~3x)\n";
    out
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
        let log = read_log::<N>(p, &model)?;
        let s = split_at_gaps(&log).with_context(|| format!("reading {}", p.display()))?;
        if s.gaps > 0 {
            // A tare log pairs row by row with its loaded log: gaps would break the pairing.
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
        .map(|p| read_log::<N>(p, &model))
        .collect::<anyhow::Result<_>>()?;
    let statics = match &a.static_samples {
        Some(p) => read_samples::<N>(p, &model)?,
        None => Vec::new(),
    };
    let unloaded = if tare.is_empty() {
        Unloaded::Model(&model)
    } else {
        Unloaded::Tare(&tare)
    };
    let opts = MotionOptions {
        order: a.order,
        cutoff_hz: a.cutoff_hz,
        keep: a.keep,
        trim_s: a.trim_s,
        ..MotionOptions::default()
    };
    let e = run_motion(&model, &loaded, unloaded, &statics, &opts).context("motion estimate")?;
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
