//! `offline calibrate-thresholds`: the service's threshold calibration (`safety::calibration`,
//! as `collision calibrate` fits it) on the residual of the service's monitor over contact-free
//! logs ([`super::monitor_run`]), written as a thresholds file ([`super::thresholds`]).

use std::fmt::Write as _;
use std::io::Write;
use std::path::Path;

use anyhow::bail;
use dynamics::lwr4;
use fri_api::bounds;
use fri_api::results::CalibrationInfo;
use nalgebra::SVector;
use safety::calibration::{EnvelopeRecorder, FitOptions};

use super::args::CalibrateThresholdsArgs;
use super::monitor_run::{Setup, arm_model, build, forces, identified, per_joint, played, run};
use super::report::{force_rows, table_row};
use super::thresholds::{THRESHOLDS_FORMAT, THRESHOLDS_KIND, ThresholdsFile};

type V7 = SVector<f64, 7>;

/// `offline calibrate-thresholds`.
pub fn calibrate_thresholds(
    a: &CalibrateThresholdsArgs,
    out: &mut dyn Write,
) -> anyhow::Result<()> {
    bounds::FALSE_ALARM_BUDGET.check("budget", a.budget)?;
    let nominal = lwr4();
    let arm = identified(&a.calibration, &nominal)?;
    let gains = match &a.gains {
        Some(g) => per_joint("gains", g, |_| bounds::gain(a.period_s))?,
        None => V7::repeat(safety::DEFAULT_GAIN),
    };
    let in_force = match &a.thresholds {
        Some(t) => per_joint("thresholds", t, bounds::threshold)?,
        None => V7::repeat(safety::DEFAULT_THRESHOLD_NM),
    };
    let fallback = match &a.fallback {
        Some(f) => per_joint("fallback", f, bounds::threshold)?,
        None => V7::repeat(safety::DEFAULT_THRESHOLD_NM),
    };
    let setup = Setup {
        period_s: a.period_s,
        gains,
        thresholds: in_force,
        schedule: None,
    };
    let model = arm_model(&nominal, arm.as_ref());
    let logs = played(&a.log, &nominal, a.period_s, a.edge_s)?;
    let mut recorder = EnvelopeRecorder::<7>::new();
    for (name, pieces) in &logs {
        let mut m = build(&model, &setup)?;
        let r = run(&mut m, pieces, a.period_s, Some(&mut recorder));
        if let Some(c) = r.crossings.first() {
            bail!(
                "{name}: the monitor detected a contact at t = {:.3} s at the thresholds in force ({:?} Nm): a recording with a contact in it would calibrate the contact away. If nothing touched the arm, raise --thresholds (or use --calibration) and calibrate again",
                c.time_s,
                in_force.as_slice()
            );
        }
    }
    let mut options = FitOptions::<7>::new(a.period_s);
    options.budget_per_hour = a.budget;
    options.floor_nm = V7::repeat(bounds::MIN_THRESHOLD_NM);
    options.ceiling_nm = V7::from_fn(|j, _| bounds::threshold(j).max);
    options.fallback_nm = fallback;
    let fit = recorder
        .fit(&options)
        .map_err(|e| anyhow::anyhow!("calibration failed: {e}"))?;
    let file = ThresholdsFile {
        format: THRESHOLDS_FORMAT,
        kind: THRESHOLDS_KIND.into(),
        robot: nominal.name().into(),
        period_s: a.period_s,
        gains: std::array::from_fn(|j| gains[j]),
        calibration: a.calibration.as_ref().map(|p| p.display().to_string()),
        arm_offset: arm_offset(arm.as_ref())?,
        logs: logs.iter().map(|(n, _)| n.clone()).collect(),
        schedule: fri_api::monitor::schedule_of(&fit),
        recording: CalibrationInfo {
            budget_per_hour: fit.budget_per_hour,
            duration_s: fit.duration_s,
            blocks: fit.blocks,
            block_s: fit.block_s,
            max_speed: std::array::from_fn(|j| fit.joints[j].max_speed),
            max_acceleration: std::array::from_fn(|j| fit.joints[j].max_acceleration),
            installed_from: None,
        },
        joints: fri_api::monitor::joint_fits(&fit),
        min_force_at_rest: forces(&nominal, &fit.thresholds_nm),
        min_force_median: forces(&nominal, &fit.median_thresholds_nm),
        fallback: Some(std::array::from_fn(|j| fallback[j])),
        min_force_fallback: Some(forces(&nominal, &fallback)),
    };
    file.write(&a.out)?;
    if a.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&file)?)?;
        return Ok(());
    }
    write!(out, "{}", thresholds_report(&file, &a.out, a.edge_s))?;
    Ok(())
}

/// The identified arm's per-joint offsets, Nm (`None`: the nominal model).
fn arm_offset(arm: Option<&dynamics::IdentifiedModel<7>>) -> anyhow::Result<Option<[f64; 7]>> {
    arm.map(|a| {
        <[f64; 7]>::try_from(a.file().joint.offset.as_slice())
            .map_err(|_| anyhow::anyhow!("the identified arm's offsets are not one per joint"))
    })
    .transpose()
}

/// Whether θ0, the median and the cap stay under the default `[observer]
/// calibration_ceiling_nm` (the paper's 6 Nm) on every joint: then a service with the default
/// ceiling installs the file without `--allow-weak`.
fn below_configured_ceiling(f: &ThresholdsFile) -> bool {
    f.joints.iter().zip(&f.schedule.ceiling).all(|(x, cap)| {
        let ceiling = safety::DEFAULT_THRESHOLD_NM;
        x.threshold_at_rest <= ceiling && x.threshold_median <= ceiling && *cap <= ceiling
    })
}

/// Joints ("J1"…) whose largest scheduled threshold over the recording is the service's
/// ceiling: the extreme-value fit could not bound the residual there with this recording.
fn at_ceiling(f: &ThresholdsFile) -> Vec<String> {
    f.joints
        .iter()
        .enumerate()
        .filter(|(j, x)| x.threshold_max >= bounds::threshold(*j).max * (1.0 - 1e-9))
        .map(|(j, _)| format!("J{}", j + 1))
        .collect()
}

fn thresholds_report(f: &ThresholdsFile, path: &Path, edge_s: f64) -> String {
    let mut s = String::new();
    let r = &f.recording;
    let _ = writeln!(
        s,
        "Thresholds for {} false alarms/h (whole arm), fitted on {:.1} s ({} blocks of {} s) of {} at {} ms, gains {:?} 1/s; observer model: {}",
        r.budget_per_hour,
        r.duration_s,
        r.blocks,
        r.block_s,
        f.logs.join(", "),
        f.period_s * 1e3,
        f.gains,
        f.calibration
            .as_deref()
            .map_or("nominal".to_owned(), |c| format!("identified arm {c}"))
    );
    let header: Vec<String> = (1..=7).map(|j| format!("{:>8}", format!("J{j}"))).collect();
    let _ = writeln!(s, "  {:<22} {:<5}{}", "", "", header.join(""));
    let j = &f.joints;
    table_row(
        &mut s,
        "θ at rest",
        "Nm",
        j.iter().map(|x| x.threshold_at_rest),
        3,
    );
    table_row(
        &mut s,
        "θ median",
        "Nm",
        j.iter().map(|x| x.threshold_median),
        3,
    );
    table_row(&mut s, "θ max", "Nm", j.iter().map(|x| x.threshold_max), 3);
    table_row(
        &mut s,
        "θ cap",
        "Nm",
        j.iter().map(|x| x.cap.unwrap_or(f64::NAN)),
        3,
    );
    table_row(
        &mut s,
        "constant fitted",
        "Nm",
        j.iter().map(|x| x.cap_fitted.unwrap_or(f64::INFINITY)),
        3,
    );
    table_row(&mut s, "peak |r|", "Nm", j.iter().map(|x| x.peak), 3);
    table_row(
        &mut s,
        "scale s (θ/envelope)",
        "",
        j.iter().map(|x| x.scale),
        2,
    );
    table_row(
        &mut s,
        "windows over θ",
        "",
        j.iter().map(|x| x.exceedances as f64),
        0,
    );
    table_row(
        &mut s,
        "covered |q̇| max",
        "rad/s",
        r.max_speed.iter().copied(),
        2,
    );
    table_row(
        &mut s,
        "covered |q̈| max",
        "rad/s²",
        r.max_acceleration.iter().copied(),
        2,
    );
    let links: Vec<String> = (1..=7).map(|l| format!("{:>8}", format!("L{l}"))).collect();
    let _ = writeln!(
        s,
        "  minimum detectable force (median over configurations, points, directions)"
    );
    let _ = writeln!(s, "  {:<22} {:<5}{}", "", "", links.join(""));
    force_rows(&mut s, "at θ at rest", &f.min_force_at_rest);
    force_rows(&mut s, "at the median θ", &f.min_force_median);
    if let (Some(c), Some(k)) = (&f.min_force_fallback, &f.fallback) {
        force_rows(
            &mut s,
            &format!("at a constant {} Nm", constant_label(k)),
            c,
        );
    }
    let capped = at_ceiling(f);
    if !capped.is_empty() {
        let _ = writeln!(
            s,
            "  WARNING: the fit reaches the service's ceiling (a quarter of the torque limit) on {} in the recorded motion: there the budget is met only by not detecting; record longer or more of the task and calibrate again",
            capped.join(", ")
        );
    }
    let fallback: Vec<String> = j
        .iter()
        .enumerate()
        .filter_map(|(i, x)| {
            x.cap_fallback_reason()
                .map(|why| format!("J{} ({why})", i + 1))
        })
        .collect();
    if !fallback.is_empty() {
        let _ = writeln!(
            s,
            "  WARNING: the logs support no constant below the stated {} Nm for the budget on {}: the threshold is capped at the stated constant there, and the budget is not guaranteed where the cap binds",
            f.fallback.as_ref().map_or("?".into(), constant_label),
            fallback.join(", ")
        );
    }
    let heavy: Vec<String> = j
        .iter()
        .enumerate()
        .filter(|(_, x)| x.model == "heavy")
        .map(|(i, x)| {
            format!(
                "J{} (GEV shape {:.2}…{:.2})",
                i + 1,
                x.shape_interval[0],
                x.shape_interval[1]
            )
        })
        .collect();
    if !heavy.is_empty() {
        let _ = writeln!(
            s,
            "  WARNING: the residual's block maxima are heavier-tailed than Gumbel on {}: the envelope misses a regime of the residual there, so the budget is not supported (expect more false alarms than it); the threshold is the light-tail level, never a heavy tail's extrapolation (which would not detect)",
            heavy.join(", ")
        );
    }
    let _ = writeln!(
        s,
        "  written to {} (check them on another recording: fri-ctl offline monitor --log OTHER --thresholds {}{}{})",
        path.display(),
        path.display(),
        f.calibration
            .as_deref()
            .map_or(String::new(), |c| format!(" --calibration {c}")),
        // fitted without the edges, they are checked without them
        if edge_s > 0.0 {
            format!(" --edge-s {edge_s}")
        } else {
            String::new()
        }
    );
    let _ = writeln!(
        s,
        "  install it in a service on the same arm model and cycle: fri-ctl collision configure --from {}{}",
        path.display(),
        if at_ceiling(f).is_empty() && below_configured_ceiling(f) {
            ""
        } else {
            " (with --allow-weak where it exceeds the service's [observer] calibration_ceiling_nm)"
        }
    );
    s
}

/// "6" when every joint has the same stated constant, else the seven values.
fn constant_label(k: &[f64; 7]) -> String {
    if k.iter().all(|v| *v == k[0]) {
        format!("{}", k[0])
    } else {
        format!("{k:?}")
    }
}
