//! `offline identify`: the arm identified from its own unloaded logs (paper Sec. II; the
//! method in docs/estimation.md, "Identifying the arm"), written as an identified-arm file.

use std::fmt::Write as _;
use std::io::Write;

use anyhow::Context;
use dynamics::Model;
use estimator::identify::{Identification, IdentifyOptions, identify};
use serde_json::json;

use super::args::IdentifyArgs;
use super::logs::read_recorded;
use super::robot::with_robot;
use crate::service::format::count;

fn row(label: &str, unit: &str, v: &[f64], digits: usize) -> String {
    let cells: Vec<String> = v.iter().map(|x| format!("{x:>8.digits$}")).collect();
    format!("  {label:<28} {unit:<8}{}\n", cells.join(""))
}

fn report<const N: usize>(id: &Identification<N>, out_path: &str) -> String {
    let f = id.model.file();
    let fit = &f.fit;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Arm identified from {}, written to {out_path}",
        count(fit.logs.len(), "log")
    );
    let p = &id.preparation;
    let _ = writeln!(
        s,
        "  {} over {:.1} s ({} with the log's q̇, q̈; {} derived zero-phase; {}, {} left out)",
        count(fit.samples, "sample"),
        fit.duration_s,
        count(p.recorded, "piece"),
        p.derived,
        count(p.gaps, "gap"),
        count(p.dropped_rows, "row")
    );
    let _ = writeln!(
        s,
        "  τ = Y(q,q̇,q̈)(π_nom + δπ) + offset + viscous·q̇ + coulomb·tanh(q̇/{} rad/s): {} base coefficients + {} joint terms",
        f.joint.coulomb_velocity,
        f.base.delta.len(),
        3 * N
    );
    let weight = if fit.ridge_weight.is_finite() {
        format!("{:.3e}", fit.ridge_weight)
    } else {
        "∞ (no base correction)".to_owned()
    };
    let _ = writeln!(
        s,
        "  ridge weight λ = {weight}, chosen on {} held-out groups of segments ranked by speed (each predicted by a fit that never saw its speed): the best no worse than the nominal model on any joint; condition number {:.1} (column-normalised, unpenalised)",
        fit.folds, fit.condition_number
    );
    let header: Vec<String> = (1..=N).map(|j| format!("{:>8}", format!("J{j}"))).collect();
    let _ = writeln!(s, "  {:<28} {:<8}{}", "residual RMS", "", header.join(""));
    s += &row(
        "nominal model, in sample",
        "Nm",
        &fit.residual_rms_nominal,
        3,
    );
    s += &row("identified, in sample", "Nm", &fit.residual_rms, 3);
    s += &row("identified, held out", "Nm", &fit.heldout_rms, 3);
    s += &row(
        "offsets+friction, held out",
        "Nm",
        &fit.heldout_rms_joint_terms,
        3,
    );
    s += &row("free fit (λ = 0), held out", "Nm", &fit.heldout_rms_free, 3);
    let _ = writeln!(
        s,
        "  {:<28} {:<8}{}",
        "residual peak |r|",
        "",
        header.join("")
    );
    s += &row(
        "nominal model, in sample",
        "Nm",
        &fit.residual_peak_nominal,
        3,
    );
    s += &row("identified, in sample", "Nm", &fit.residual_peak, 3);
    s += &row("identified, held out", "Nm", &fit.heldout_peak, 3);
    let _ = writeln!(
        s,
        "  joint terms (± 1σ{})",
        if id.options.non_negative_friction {
            "; friction kept ≥ 0: a coefficient held at 0 has σ 0"
        } else {
            "; friction free in sign: --non-negative-friction keeps it ≥ 0"
        }
    );
    s += &row("offset", "Nm", &f.joint.offset, 3);
    s += &row("  ± 1σ", "Nm", &f.joint.offset_std, 3);
    s += &row("viscous", "Nm·s/rad", &f.joint.viscous, 3);
    s += &row("  ± 1σ", "Nm·s/rad", &f.joint.viscous_std, 3);
    s += &row("Coulomb", "Nm", &f.joint.coulomb, 3);
    s += &row("  ± 1σ", "Nm", &f.joint.coulomb_std, 3);
    let _ = writeln!(
        s,
        "  model error (the held-out residual; payload estimates carry it)"
    );
    s += &row("RMS", "Nm", &f.model_error.residual_rms, 3);
    s += &row(
        "correlation time",
        "s",
        &f.model_error.correlation_time_s,
        3,
    );
    let largest = f
        .base
        .delta
        .iter()
        .zip(&f.base.delta_std)
        .zip(&f.base.nominal)
        .enumerate()
        .max_by(|a, b| {
            let r = |x: &(usize, ((&f64, &f64), &f64))| x.1.0.0.abs() / x.1.0.1.max(1e-300);
            r(a).total_cmp(&r(b))
        });
    if let Some((k, ((d, sd), nom))) = largest {
        let _ = writeln!(
            s,
            "  base corrections δπ ± 1σ in the file; the most significant: coefficient {} (link parameter {}), {:+.4} ± {:.4} on a nominal {:+.4}",
            k + 1,
            f.base.columns[k],
            d,
            sd,
            nom
        );
    }
    let eig: Vec<f64> = id
        .model
        .corrected_model()
        .links()
        .iter()
        .map(|l| l.smallest_pseudo_eigenvalue())
        .collect();
    let _ = writeln!(
        s,
        "  links as written (nominal + δπ on the base columns), smallest pseudo-inertia eigenvalue (> 0: a rigid body)"
    );
    s += &row("L1..L7", "kg·m²", &eig, 4);
    for w in warnings(&id.model) {
        let _ = writeln!(s, "  WARNING: {w}");
    }
    let _ = writeln!(
        s,
        "  use it with: fri-ctl offline estimate-motion --calibration {out_path} …, fri-ctl offline monitor --calibration {out_path} …"
    );
    s
}

/// What makes an identified arm suspect on motion it has not seen: a joint worse than the
/// nominal model on held-out data, negative friction (not a physical arm, and its error grows
/// with speed beyond the logs; the identification never writes it, a file may hold it), no
/// regularisation at all; and links that are no rigid body as written.
fn warnings<const N: usize>(model: &dynamics::IdentifiedModel<N>) -> Vec<String> {
    let f = model.file();
    let fit = &f.fit;
    let joints = |pick: &dyn Fn(usize) -> Option<String>| -> Vec<String> {
        (0..f.joints).filter_map(pick).collect()
    };
    let mut out = Vec::new();
    let worse = joints(&|j| {
        let (held, nominal) = (fit.heldout_rms[j], fit.residual_rms_nominal[j]);
        (held > nominal).then(|| format!("J{} ({held:.3} vs {nominal:.3} Nm)", j + 1))
    });
    if !worse.is_empty() {
        out.push(format!(
            "worse than the nominal model on held-out data on {}: use the nominal model, or identify on more varied motion",
            worse.join(", ")
        ));
    }
    for (name, unit, values) in [
        ("viscous", "Nm·s/rad", &f.joint.viscous),
        ("Coulomb", "Nm", &f.joint.coulomb),
    ] {
        let negative = joints(&|j| {
            (values[j] < 0.0).then(|| format!("J{} ({:+.3} {unit})", j + 1, values[j]))
        });
        if !negative.is_empty() {
            out.push(format!(
                "negative {name} friction on {}: not a physical arm (friction takes energy out); the fit bends model error into it, and on faster motion than the logs' its error grows with the speed",
                negative.join(", ")
            ));
        }
    }
    let bodies: Vec<String> = model
        .non_realisable_links()
        .iter()
        .map(|(l, e)| format!("L{} ({e:.3e} kg·m²)", l + 1))
        .collect();
    if !bodies.is_empty() {
        out.push(format!(
            "the links as written are no rigid body on {} (pseudo-inertia not positive definite): the base coefficients, hence the torques along motion, are the fit's; a per-link reading (one link's mass or inertia) is not physical",
            bodies.join(", ")
        ));
    }
    if fit.ridge_weight == 0.0 {
        out.push(
            "the unregularised fit was chosen (λ = 0): nothing pulls a coefficient the logs do not excite toward the nominal model"
                .to_owned(),
        );
    }
    out
}

fn identify_n<const N: usize>(
    model: Model<N>,
    a: &IdentifyArgs,
    out: &mut dyn Write,
) -> anyhow::Result<()> {
    let logs = a
        .log
        .iter()
        .map(|p| read_recorded::<N>(p, &model))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let names: Vec<String> = a.log.iter().map(|p| p.display().to_string()).collect();
    let options = IdentifyOptions {
        coulomb_velocity: a.coulomb_velocity,
        non_negative_friction: a.non_negative_friction,
        folds: a.folds,
        recorded_derivatives: !a.derive,
        order: a.order,
        cutoff_hz: a.cutoff_hz,
        trim_s: a.trim_s,
        ..IdentifyOptions::default()
    };
    let id = identify(&model, &logs, &names, &options).context("identification")?;
    let text = id.model.to_toml_string()?;
    let header = format!(
        "# Arm identified by `fri-ctl offline identify` from {}\n# (format: docs/robot-model.md, \"Identified arm models\")\n",
        names.join(", ")
    );
    std::fs::write(&a.out, header + &text)
        .with_context(|| format!("cannot write {}", a.out.display()))?;
    if a.json {
        let obj = json!({
            "file": a.out.display().to_string(),
            "identified": id.model.file(),
            "cross_validation": id.cv,
            "joint_weights": id.weights,
            "warnings": warnings(&id.model),
            "smallest_pseudo_inertia_eigenvalue": id
                .model
                .corrected_model()
                .links()
                .iter()
                .map(|l| l.smallest_pseudo_eigenvalue())
                .collect::<Vec<_>>(),
        });
        writeln!(out, "{}", serde_json::to_string_pretty(&obj)?)?;
    } else {
        write!(out, "{}", report(&id, &a.out.display().to_string()))?;
    }
    Ok(())
}

/// `offline identify`.
pub fn identify_arm(a: &IdentifyArgs, out: &mut dyn Write) -> anyhow::Result<()> {
    with_robot!(&a.robot, |model| identify_n(model, a, out))
}
