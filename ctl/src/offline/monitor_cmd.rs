//! `offline monitor`: the service's collision monitor over recorded logs
//! ([`super::monitor_run`]): per joint the residual's RMS, p99 and peak, every threshold
//! crossing, and the minimum detectable force per link.

use crate::service::format::count;
use std::fmt::Write as _;
use std::io::Write;
use std::path::PathBuf;

use anyhow::bail;
use dynamics::lwr4;
use fri_api::bounds;
use fri_api::results::LinkForce;
use nalgebra::SVector;
use serde_json::json;

use super::args::MonitorArgs;
use super::monitor_run::{
    Run, Setup, arm_model, build, forces, identified, median, per_joint, played, run, summary,
};
use super::report::{force_rows, table_row};
use super::thresholds::ThresholdsFile;

type V7 = SVector<f64, 7>;

/// Where the thresholds of `offline monitor` come from.
enum Thresholds {
    Static(V7),
    File(Box<ThresholdsFile>, PathBuf),
}

fn thresholds_arg(text: &Option<String>) -> anyhow::Result<Thresholds> {
    let Some(text) = text else {
        return Ok(Thresholds::Static(V7::repeat(safety::DEFAULT_THRESHOLD_NM)));
    };
    let numbers: Result<Vec<f64>, _> = text.split(',').map(|t| t.trim().parse::<f64>()).collect();
    match numbers {
        Ok(v) => {
            let t = match v.len() {
                1 => V7::repeat(v[0]),
                7 => V7::from_column_slice(&v),
                n => bail!("--thresholds: {n} values; give one, seven, or a thresholds file"),
            };
            for j in 0..7 {
                bounds::threshold(j).check(&format!("thresholds[{}]", j + 1), t[j])?;
            }
            Ok(Thresholds::Static(t))
        }
        Err(_) => {
            let path = PathBuf::from(text);
            Ok(Thresholds::File(
                Box::new(ThresholdsFile::read(&path)?),
                path,
            ))
        }
    }
}

fn monitor_report(
    name: &str,
    r: &Run,
    setup: &Setup,
    forces_at_rest: &[LinkForce; 7],
    forces_median: &[LinkForce; 7],
    period_s: f64,
) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{name}: {:.1} s played at {} ms, {} live samples",
        r.samples as f64 * period_s,
        period_s * 1e3,
        r.residual[0].len()
    );
    let header: Vec<String> = (1..=7).map(|j| format!("{:>8}", format!("J{j}"))).collect();
    let _ = writeln!(s, "  {:<22} {:<5}{}", "", "", header.join(""));
    let stats: Vec<(f64, f64, f64)> = r.residual.iter().map(|v| summary(v)).collect();
    table_row(&mut s, "|r| RMS", "Nm", stats.iter().map(|x| x.0), 3);
    table_row(&mut s, "|r| p99", "Nm", stats.iter().map(|x| x.1), 3);
    table_row(&mut s, "|r| peak", "Nm", stats.iter().map(|x| x.2), 3);
    table_row(
        &mut s,
        "θ at rest",
        "Nm",
        setup.thresholds.iter().copied(),
        3,
    );
    table_row(
        &mut s,
        "θ median",
        "Nm",
        r.thresholds.iter().map(|v| median(v)),
        3,
    );
    table_row(
        &mut s,
        "samples over θ",
        "",
        r.over.iter().map(|&n| n as f64),
        0,
    );
    if r.crossings.is_empty() {
        let _ = writeln!(s, "  threshold crossings: none");
    } else {
        let _ = writeln!(
            s,
            "  threshold crossings (detector onsets): {}",
            r.crossings.len()
        );
        for c in &r.crossings {
            for (j, v, t) in &c.joints {
                let _ = writeln!(
                    s,
                    "    t = {:8.3} s  J{j}  |r| = {:.3} Nm > θ = {:.3} Nm",
                    c.time_s,
                    v.abs(),
                    t
                );
            }
        }
    }
    if r.rejected > 0 {
        let _ = writeln!(
            s,
            "  {} samples rejected by the observer (last fault: {})",
            r.rejected,
            r.fault.as_deref().unwrap_or("?")
        );
    }
    let links: Vec<String> = (1..=7).map(|l| format!("{:>8}", format!("L{l}"))).collect();
    let _ = writeln!(
        s,
        "  minimum detectable force (median over configurations, points, directions)"
    );
    let _ = writeln!(s, "  {:<22} {:<5}{}", "", "", links.join(""));
    force_rows(&mut s, "at θ at rest", forces_at_rest);
    force_rows(&mut s, "at the median θ", forces_median);
    s
}

/// `offline monitor`.
pub fn monitor(a: &MonitorArgs, out: &mut dyn Write) -> anyhow::Result<()> {
    let nominal = lwr4();
    let arm = identified(&a.calibration, &nominal)?;
    let thresholds = thresholds_arg(&a.thresholds)?;
    let (setup, source) = match &thresholds {
        Thresholds::Static(t) => {
            let gains = match &a.gains {
                Some(g) => per_joint("gains", g, |_| bounds::gain(a.period_s))?,
                None => V7::repeat(safety::DEFAULT_GAIN),
            };
            (
                Setup {
                    period_s: a.period_s,
                    gains,
                    thresholds: *t,
                    schedule: None,
                },
                "static".to_owned(),
            )
        }
        Thresholds::File(f, path) => {
            let gains = V7::from(f.gains);
            if let Some(g) = &a.gains
                && per_joint("gains", g, |_| bounds::gain(a.period_s))? != gains
            {
                bail!(
                    "--gains differ from the {:?} 1/s the thresholds in {} were calibrated at: the residual's noise scales with the gain",
                    f.gains,
                    path.display()
                );
            }
            if f.calibration.is_some() != a.calibration.is_some() {
                eprintln!(
                    "warning: the thresholds in {} were calibrated {} an identified arm, this run is {} one",
                    path.display(),
                    if f.calibration.is_some() {
                        "with"
                    } else {
                        "without"
                    },
                    if a.calibration.is_some() {
                        "with"
                    } else {
                        "without"
                    },
                );
            }
            (
                Setup {
                    period_s: f.period_s,
                    gains,
                    thresholds: V7::from(f.schedule.thresholds),
                    schedule: Some(f.schedule.clone()),
                },
                format!("calibrated schedule from {}", path.display()),
            )
        }
    };
    let model = arm_model(&nominal, arm.as_ref());
    let logs = played(&a.log, &nominal, setup.period_s, a.edge_s)?;
    let at_rest = forces(&nominal, &setup.thresholds);
    let mut reports = Vec::new();
    let mut text = format!(
        "Collision monitor (the service's observer and detector) over {}; observer model: {}; thresholds: {source}; gains {:?} 1/s\n",
        count(logs.len(), "log"),
        a.calibration
            .as_ref()
            .map_or("nominal (no identified arm)".to_owned(), |p| format!(
                "identified arm {}",
                p.display()
            )),
        setup.gains.as_slice()
    );
    if a.edge_s > 0.0 {
        text += &format!(
            "  {} s dropped at each end of every log (--edge-s)\n",
            a.edge_s
        );
    }
    for (name, pieces) in &logs {
        let mut m = build(&model, &setup)?;
        let r = run(&mut m, pieces, setup.period_s, None);
        let theta_median = V7::from_fn(|j, _| median(&r.thresholds[j]));
        let at_median = forces(&nominal, &theta_median);
        text += &monitor_report(name, &r, &setup, &at_rest, &at_median, setup.period_s);
        let stats: Vec<(f64, f64, f64)> = r.residual.iter().map(|v| summary(v)).collect();
        reports.push(json!({
            "log": name,
            "samples": r.samples,
            "live_samples": r.residual[0].len(),
            "residual_rms": stats.iter().map(|x| x.0).collect::<Vec<_>>(),
            "residual_p99": stats.iter().map(|x| x.1).collect::<Vec<_>>(),
            "residual_peak": stats.iter().map(|x| x.2).collect::<Vec<_>>(),
            "thresholds_at_rest": setup.thresholds.as_slice(),
            "thresholds_median": theta_median.as_slice(),
            "samples_over": r.over,
            "crossings": r.crossings,
            "rejected": r.rejected,
            "min_force_at_rest": at_rest,
            "min_force_median": at_median,
        }));
    }
    if a.json {
        let obj = json!({
            "period_s": setup.period_s,
            "gains": setup.gains.as_slice(),
            "calibration": a.calibration.as_ref().map(|p| p.display().to_string()),
            "thresholds": source,
            "logs": reports,
        });
        writeln!(out, "{}", serde_json::to_string_pretty(&obj)?)?;
    } else {
        write!(out, "{text}")?;
    }
    Ok(())
}
