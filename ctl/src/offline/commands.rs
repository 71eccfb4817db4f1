//! The static offline commands: estimate, coefficients, poses, calibrate.

use std::io::Write;
use std::path::Path;

use anyhow::{Context, bail};
use dynamics::Model;
use estimator::CoefficientSet;
use estimator::correction::{Calibration, estimate_with_calibration, estimate_with_tare};
use estimator::error_model::{DriftPrior, Reference, estimate_modelled};
use estimator::estimate::{self as static_estimate, EstimateOptions, Method};
use estimator::poses::{self, Criterion, Nominal};
use estimator::samples::{StaticCheck, StaticSample};
use nalgebra::SVector;
use serde_json::json;

use super::args::{CalibrateArgs, CoefficientsArgs, EstimateArgs, MethodArg, PosesArgs};
use super::report;
use super::robot::with_robot;
use super::samples_file::read_samples;

fn options(method: MethodArg, max_velocity: f64) -> EstimateOptions {
    EstimateOptions {
        method: match method {
            MethodArg::Direct => Method::Direct,
            MethodArg::Coefficients => Method::Coefficients,
        },
        static_check: StaticCheck {
            max_velocity,
            ..StaticCheck::default()
        },
        ..EstimateOptions::default()
    }
}

fn estimate_n<const N: usize>(
    model: Model<N>,
    a: &EstimateArgs,
    out: &mut dyn Write,
) -> anyhow::Result<()> {
    let samples = read_samples::<N>(&a.samples, &model)?;
    let opts = options(a.method, a.max_velocity);
    let tare = a
        .tare
        .as_ref()
        .map(|p| read_samples::<N>(p, &model))
        .transpose()?;
    let evidence = |s: &[StaticSample<N>]| s.iter().all(|x| x.evidence.is_some());
    if matches!(a.method, MethodArg::Direct)
        && a.calibration.is_none()
        && evidence(&samples)
        && tare.as_deref().is_none_or(evidence)
    {
        return estimate_modelled_n(&model, a, &samples, tare.as_deref(), &opts, out);
    }
    let est = if let (Some(tare_path), Some(tare)) = (&a.tare, &tare) {
        estimate_with_tare(&model, &samples, tare, a.tare_tolerance, &opts).with_context(|| {
            format!(
                "tare estimate from {} and {}",
                a.samples.display(),
                tare_path.display()
            )
        })?
    } else if let Some(cal_path) = &a.calibration {
        let cal = Calibration::load(cal_path).with_context(|| "loading the calibration")?;
        estimate_with_calibration(&model, &samples, &cal, &opts)
            .with_context(|| format!("estimate from {}", a.samples.display()))?
    } else {
        static_estimate::estimate(&model, &samples, &opts)
            .with_context(|| format!("estimate from {}", a.samples.display()))?
    };
    if a.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&est)?)?;
    } else {
        write!(out, "{}", report::payload(&est, N))?;
    }
    Ok(())
}

/// The estimate under the error model, for samples with their evidence.
fn estimate_modelled_n<const N: usize>(
    model: &Model<N>,
    a: &EstimateArgs,
    samples: &[StaticSample<N>],
    tare: Option<&[StaticSample<N>]>,
    opts: &EstimateOptions,
    out: &mut dyn Write,
) -> anyhow::Result<()> {
    let reference = match tare {
        Some(t) => Reference::Tare(t),
        None => Reference::Controller {
            offset_std: UNTARED_OFFSET_STD,
        },
    };
    let drift = DriftPrior {
        rate: a.drift_rate,
        weight: 7.0,
    };
    let (est, u) = estimate_modelled(model, samples, reference, drift, opts)
        .with_context(|| format!("estimate from {}", a.samples.display()))?;
    if a.json {
        let mut v = serde_json::to_value(&est)?;
        v["uncertainty"] = serde_json::to_value(&u)?;
        writeln!(out, "{}", serde_json::to_string_pretty(&v)?)?;
    } else {
        write!(out, "{}", report::payload(&est, N))?;
        write!(out, "{}", report::uncertainty(&u))?;
    }
    Ok(())
}

/// Without a tare: 1σ of the per-joint constant error of τ_J − g_ctrl, Nm (the service's
/// `estimation.untared_offset_std` default).
const UNTARED_OFFSET_STD: f64 = 0.2;

/// `offline estimate`.
pub fn estimate(a: &EstimateArgs, out: &mut dyn Write) -> anyhow::Result<()> {
    with_robot!(&a.robot, |model| estimate_n(model, a, out))
}

fn read_vector(path: &Path) -> anyhow::Result<Vec<f64>> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    serde_json::from_str::<Vec<f64>>(&text).with_context(|| {
        format!(
            "{}: expected a JSON array of numbers in the coefficient set's order",
            path.display()
        )
    })
}

/// `offline coefficients`.
pub fn coefficients(a: &CoefficientsArgs, out: &mut dyn Write) -> anyhow::Result<()> {
    let (Some(set_name), Some(unloaded), Some(loaded)) = (&a.set, &a.unloaded, &a.loaded) else {
        return super::coefficients_log::coefficients_from_logs(a, out);
    };
    let set = match CoefficientSet::builtin(set_name) {
        Some(s) => s,
        None => {
            let text = std::fs::read_to_string(set_name).with_context(|| {
                format!(
                    "`{set_name}` is neither a built-in set (planar-2r, lwr4-gravity) nor a readable file"
                )
            })?;
            CoefficientSet::parse(&text)
                .with_context(|| format!("coefficient set file {set_name}"))?
        }
    };
    let unloaded = read_vector(unloaded)?;
    let loaded = read_vector(loaded)?;
    let est = set.estimate(&unloaded, &loaded)?;
    if a.json {
        let obj = json!({
            "mass": est.mass,
            "com": est.com,
            "p_l": est.p_l,
            "p_l_names": est.p_l_names,
            "epsilon": est.epsilon,
            "nonzero_rows": est.nonzero_rows,
            "jacobian_nonzero": est.jacobian_nonzero,
        });
        writeln!(out, "{}", serde_json::to_string_pretty(&obj)?)?;
        return Ok(());
    }
    writeln!(
        out,
        "Coefficient workflow (eps = pi_L - pi, p_L = J_eps,nz^# eps_nz), set `{set_name}`"
    )?;
    let rows: Vec<String> = est
        .nonzero_rows
        .iter()
        .map(|r| set.names()[r - 1].to_string())
        .collect();
    writeln!(
        out,
        "  coefficients changed by the payload: {}",
        rows.join(", ")
    )?;
    for (name, v) in est.p_l_names.iter().zip(&est.p_l) {
        let unit = match name.as_str() {
            "m" => "kg",
            n if n.starts_with("mc") => "kg·m",
            _ => "kg·m² (about the last frame's origin)",
        };
        writeln!(out, "  {name:<4} = {v:+.6} {unit}")?;
    }
    if let Some(m) = est.mass {
        writeln!(out, "  mass = {m:.4} kg")?;
    }
    let com: Vec<String> = est
        .com
        .iter()
        .zip(["x", "y", "z"])
        .map(|(c, ax)| match c {
            Some(v) => format!("{ax} {:+.5} m", v),
            None => format!("{ax} (not estimated)"),
        })
        .collect();
    writeln!(out, "  CoM, last link frame: {}", com.join(", "))?;
    writeln!(
        out,
        "  (no uncertainty: the coefficient vectors carry none; use `estimate` on samples for 1σ)"
    )?;
    Ok(())
}

/// Largest `--count` of `offline poses`; a static estimate needs tens of poses, not thousands.
const MAX_POSES: usize = 10_000;

fn poses_n<const N: usize>(
    model: Model<N>,
    a: &PosesArgs,
    out: &mut dyn Write,
) -> anyhow::Result<()> {
    if a.around.len() != N {
        bail!(
            "--around has {} values but the robot has {N} joints; give q1,..,q{N} in rad",
            a.around.len()
        );
    }
    if a.around.iter().any(|v| !v.is_finite()) || !(a.spread_deg.is_finite() && a.spread_deg > 0.0)
    {
        bail!(
            "--around must be finite numbers (rad) and --spread-deg a positive number of degrees"
        );
    }
    // the pose list is allocated up front: an absurd count must not abort the process
    if !(2..=MAX_POSES).contains(&a.count) {
        bail!(
            "--count {} is out of range: a pose design needs 2 to {MAX_POSES} poses",
            a.count
        );
    }
    let positive = |v: f64| v.is_finite() && v > 0.0;
    if !(positive(a.sigma) && positive(a.mass_guess)) {
        bail!("--sigma (Nm) and --mass-guess (kg) must be positive numbers");
    }
    let center = SVector::<f64, N>::from_column_slice(&a.around);
    if !model.limits().contains_position(&center) {
        bail!("the pick pose --around lies outside the joint limits of the robot");
    }
    let spread = a.spread_deg.to_radians();
    let nominal = Nominal {
        mass: a.mass_guess,
        ..Nominal::default()
    };
    let list = if a.optimize {
        poses::optimize(
            &model,
            &center,
            spread,
            a.count,
            Criterion::D,
            300,
            &nominal,
        )?
    } else {
        poses::paper_pattern(&model, &center, spread, a.count)
    };
    let pred = poses::predict(&model, &list, a.sigma, &nominal)
        .context("the pose set cannot identify the payload; increase --count or --spread-deg")?;
    if let Some(path) = &a.out {
        let mut w = csv::Writer::from_path(path)
            .with_context(|| format!("cannot write {}", path.display()))?;
        w.write_record((1..=N).map(|j| format!("q{j}")))?;
        for q in &list {
            w.write_record(q.iter().map(|v| format!("{v:.9}")))?;
        }
        w.flush()?;
    }
    if a.json {
        let obj = json!({
            "poses": list.iter().map(|q| q.iter().copied().collect::<Vec<f64>>()).collect::<Vec<_>>(),
            "pattern": if a.optimize { "d-optimal" } else { "paper" },
            "spread_deg": a.spread_deg,
            "predicted": pred,
            "sigma": a.sigma,
        });
        writeln!(out, "{}", serde_json::to_string_pretty(&obj)?)?;
        return Ok(());
    }
    writeln!(
        out,
        "{} poses ({}) within ±{}° of the pick pose, degrees:",
        list.len(),
        if a.optimize {
            "D-optimal"
        } else {
            "paper pattern"
        },
        a.spread_deg
    )?;
    for (k, q) in list.iter().enumerate() {
        let d: Vec<String> = q
            .iter()
            .map(|v| format!("{:+8.3}", v.to_degrees()))
            .collect();
        writeln!(out, "  {:>3}: {}", k + 1, d.join(" "))?;
    }
    write!(out, "{}", report::prediction(&pred, a.sigma))?;
    Ok(())
}

/// `offline poses`.
pub fn poses(a: &PosesArgs, out: &mut dyn Write) -> anyhow::Result<()> {
    with_robot!(&a.robot, |model| poses_n(model, a, out))
}

fn calibrate_n<const N: usize>(
    model: Model<N>,
    a: &CalibrateArgs,
    out: &mut dyn Write,
) -> anyhow::Result<()> {
    let samples = read_samples::<N>(&a.samples, &model)?;
    let cal = Calibration::identify(&model, &samples, &EstimateOptions::default())
        .with_context(|| format!("calibration from {}", a.samples.display()))?;
    cal.save(&a.out)?;
    if a.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&cal)?)?;
        return Ok(());
    }
    writeln!(
        out,
        "Controller gravity-model calibration written to {}",
        a.out.display()
    )?;
    writeln!(
        out,
        "  {} unloaded samples, {} gravity base parameters, condition number {:.1}",
        cal.samples,
        cal.delta.len(),
        cal.condition_number
    )?;
    let rms: Vec<String> = cal
        .residual_rms
        .iter()
        .enumerate()
        .map(|(j, r)| format!("J{} {:.3}", j + 1, r))
        .collect();
    writeln!(
        out,
        "  residual RMS per joint after correction [Nm]  {}",
        rms.join("  ")
    )?;
    writeln!(
        out,
        "  use it with: fri-ctl offline estimate --samples LOADED.csv --calibration {}",
        a.out.display()
    )?;
    Ok(())
}

/// `offline calibrate`.
pub fn calibrate(a: &CalibrateArgs, out: &mut dyn Write) -> anyhow::Result<()> {
    with_robot!(&a.robot, |model| calibrate_n(model, a, out))
}
