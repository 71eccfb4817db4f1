//! `offline coefficients --loaded-log …`: the paper's coefficient route end to end from logs
//! (`estimator::coefficient_route`): the unloaded arm identified (from `--unloaded-log`, or read
//! from `--calibration`), the coefficients the payload changes identified again on the loaded
//! logs, the payload from their difference (eqs. 22–28).

use std::io::Write;

use anyhow::{Context, bail};
use dynamics::Model;
use estimator::coefficient_route::estimate_from_logs;
use estimator::identify::{IdentifyOptions, identify};
use estimator::motion::MotionOptions;
use serde_json::json;

use super::args::CoefficientsArgs;
use super::logs::{read_identified, read_recorded, read_trajectory};
use super::motion_cmd::{inertia_unresolved, model_error};
use super::robot::with_robot;

fn route_n<const N: usize>(
    model: Model<N>,
    a: &CoefficientsArgs,
    out: &mut dyn Write,
) -> anyhow::Result<()> {
    let arm = match (&a.calibration, a.unloaded_log.is_empty()) {
        (Some(path), _) => read_identified(path, &model)?,
        (None, false) => {
            let logs = a
                .unloaded_log
                .iter()
                .map(|p| read_recorded::<N>(p, &model))
                .collect::<anyhow::Result<Vec<_>>>()?;
            let names: Vec<String> = a
                .unloaded_log
                .iter()
                .map(|p| p.display().to_string())
                .collect();
            identify(&model, &logs, &names, &IdentifyOptions::default())
                .context("identifying the unloaded arm")?
                .model
        }
        (None, true) => bail!(
            "the coefficient route from logs needs the unloaded arm: --unloaded-log FILE (identified here) or --calibration arm.toml (`offline identify`)"
        ),
    };
    let loaded = a
        .loaded_log
        .iter()
        .map(|p| read_trajectory::<N>(p, &model))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let options = MotionOptions {
        fit_offsets: a.fit_offsets,
        ..MotionOptions::default()
    };
    let route = estimate_from_logs(&arm, &loaded, &options).context("coefficient route")?;
    if a.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&json!(route))?)?;
        return Ok(());
    }
    let e = &route.estimate;
    let s = &e.parameters_std;
    writeln!(
        out,
        "Coefficient route from logs (eqs. 22–28): π̂ of the identified unloaded arm, π̂_L = π̂ + ε̂ on the {} coefficients the payload changes, p̂_L = J_ε,nz^# ε̂ (condition of J_ε,nz {:.1})",
        route.coefficients.len(),
        route.jacobian_condition
    )?;
    for (k, c) in route.coefficients.iter().enumerate() {
        writeln!(
            out,
            "  coefficient of link parameter {:>3}: π̂ {:+.5}  π̂_L {:+.5}  ε̂ {:+.5} ± {:.5}",
            c, route.unloaded[k], route.loaded[k], route.epsilon[k], route.epsilon_std[k]
        )?;
    }
    writeln!(out, "  mass     {:.4} kg ± {:.4} kg (1σ)", e.mass, s[0])?;
    writeln!(
        out,
        "  CoM, frame {N} [mm]  x {:+.2} ± {:.2}  y {:+.2} ± {:.2}  z {:+.2} ± {:.2}",
        1e3 * e.com[0],
        1e3 * e.com_std[0],
        1e3 * e.com[1],
        1e3 * e.com_std[1],
        1e3 * e.com[2],
        1e3 * e.com_std[2]
    )?;
    if e.inertia_resolved {
        for (name, i) in ["Jxx", "Jxy", "Jxz", "Jyy", "Jyz", "Jzz"].iter().zip(4..10) {
            writeln!(
                out,
                "  {name} {:+.5} ± {:.5} kg·m² (about the frame-{N} origin)",
                e.parameters[i], s[i]
            )?;
        }
    } else {
        write!(out, "{}", inertia_unresolved(e))?;
    }
    write!(out, "{}", model_error(e))?;
    Ok(())
}

/// `offline coefficients` with logs.
pub fn coefficients_from_logs(a: &CoefficientsArgs, out: &mut dyn Write) -> anyhow::Result<()> {
    with_robot!(&a.robot, |model| route_n(model, a, out))
}
