//! Output: the Fig. 6 plot and CSV, campaign summaries and per-contact CSVs.

use std::fmt::Write as _;
use std::path::Path;

use plotters::prelude::*;

use crate::THRESHOLD;
use crate::campaign::{Campaign, ContactRecord};
use crate::fig6::Fig6;
use crate::metrics::{STATS_HEADER, percentile, stats, stats_row};
use crate::support::V7;

/// The seven joint values with `decimals` decimals, comma-separated.
pub fn fmt_joints(v: &V7, decimals: usize) -> String {
    v.iter()
        .map(|x| format!("{x:.decimals$}"))
        .collect::<Vec<_>>()
        .join(", ")
}

pub fn plot_fig6(fig: &Fig6, path: &Path) {
    let root = SVGBackend::new(path, (1100, 1400)).into_drawing_area();
    root.fill(&WHITE).unwrap();
    let (title, body) = root.split_vertically(40);
    title
        .titled(
            "Residuals with a 3 kg payload: controller-style estimate (blue), residual without payload (red), with estimated payload, eq. 48 (green); ±6 Nm dashed",
            ("sans-serif", 14),
        )
        .unwrap();
    let panels = body.split_evenly((7, 1));
    // Decimate: per 50 ms bin keep the sample with the largest |value| (peaks survive).
    let bin = 50;
    for (j, panel) in panels.iter().enumerate() {
        let mut series: [Vec<(f64, f64)>; 3] = Default::default();
        for chunk in fig.rows.chunks(bin) {
            for (i, s) in series.iter_mut().enumerate() {
                let best = chunk
                    .iter()
                    .max_by(|a, b| a.1[i][j].abs().partial_cmp(&b.1[i][j].abs()).unwrap())
                    .unwrap();
                s.push((best.0, best.1[i][j]));
            }
        }
        let y_max = series
            .iter()
            .flatten()
            .map(|p| p.1.abs())
            .fold(8.0_f64, f64::max)
            * 1.05;
        let t_max = fig.rows.last().map(|r| r.0).unwrap_or(1.0);
        let mut chart = ChartBuilder::on(panel)
            .margin(4)
            .x_label_area_size(if j == 6 { 30 } else { 12 })
            .y_label_area_size(50)
            .build_cartesian_2d(0.0..t_max, -y_max..y_max)
            .unwrap();
        chart
            .configure_mesh()
            .disable_mesh()
            .y_desc(format!("joint {} [Nm]", j + 1))
            .x_desc(if j == 6 { "time [s]" } else { "" })
            .draw()
            .unwrap();
        for (i, s) in series.iter().enumerate() {
            let color = match i {
                0 => RGBColor(30, 60, 220),
                1 => RGBColor(220, 40, 40),
                _ => RGBColor(0, 150, 0),
            };
            chart
                .draw_series(LineSeries::new(s.iter().copied(), color.stroke_width(1)))
                .unwrap();
        }
        for level in [THRESHOLD, -THRESHOLD] {
            chart
                .draw_series(DashedLineSeries::new(
                    vec![(0.0, level), (t_max, level)],
                    4,
                    3,
                    BLACK.stroke_width(1),
                ))
                .unwrap();
        }
        for &(t0, _) in &fig.contacts {
            chart
                .draw_series(LineSeries::new(
                    vec![(t0, -y_max), (t0, y_max)],
                    RGBColor(150, 150, 150).stroke_width(1),
                ))
                .unwrap();
        }
    }
    root.present().unwrap();
}

pub fn write_fig6_csv(fig: &Fig6, path: &Path) {
    let mut s = String::from("t_s");
    for name in ["ctrl", "r_unc", "r_comp"] {
        for j in 1..=7 {
            write!(s, ",{name}_{j}").unwrap();
        }
    }
    s.push('\n');
    for (t, signals) in fig.rows.iter().step_by(5) {
        write!(s, "{t:.3}").unwrap();
        for sig in signals {
            for x in sig.iter() {
                write!(s, ",{x:.4}").unwrap();
            }
        }
        s.push('\n');
    }
    std::fs::write(path, s).unwrap();
}

pub fn summarise_campaign(name: &str, campaigns: &[Campaign], per_link: bool, report: &mut String) {
    writeln!(report, "#### {name}\n").unwrap();
    writeln!(report, "{STATS_HEADER}").unwrap();
    for c in campaigns {
        if per_link {
            let mut links: Vec<usize> = c.records.iter().map(|r| r.link).collect();
            links.sort();
            links.dedup();
            for link in links {
                let recs: Vec<&ContactRecord> =
                    c.records.iter().filter(|r| r.link == link).collect();
                writeln!(
                    report,
                    "{}",
                    stats_row(&format!("{}, link {}", c.label, link + 1), &stats(&recs))
                )
                .unwrap();
            }
        }
        let all: Vec<&ContactRecord> = c.records.iter().collect();
        writeln!(
            report,
            "{}",
            stats_row(&format!("**{}, all**", c.label), &stats(&all))
        )
        .unwrap();
    }
    writeln!(report).unwrap();
    let mut ideal: Vec<f64> = campaigns[0]
        .records
        .iter()
        .filter_map(|r| r.ideal_delay_s)
        .map(|d| d * 1e3)
        .collect();
    ideal.sort_by(|a, b| a.partial_cmp(b).unwrap());
    writeln!(
        report,
        "Ideal detector (first tick with some unfiltered |τ_ext,j| > 6 Nm): median {:.1} ms, p95 {:.1} ms; {} of {} contacts never reach 6 Nm on any joint.\n",
        percentile(&ideal, 0.5),
        percentile(&ideal, 0.95),
        campaigns[0].records.len() - ideal.len(),
        campaigns[0].records.len()
    )
    .unwrap();
    let fa: Vec<String> = campaigns
        .iter()
        .map(|c| {
            format!(
                "{}: {} (+{} re-triggers within 1.2 s after a contact)",
                c.label, c.false_alarms, c.retriggers
            )
        })
        .collect();
    writeln!(
        report,
        "False alarms away from contacts ({:.2} h of motion between contacts): {}.\n",
        campaigns[0].free_hours,
        fa.join(", ")
    )
    .unwrap();
}

pub fn write_delays_csv(c: &Campaign, path: &Path) {
    let mut s = String::from(
        "variant,link,force_n,start_s,own_joint_torque_nm,detected,delay_ms,onset_link,episode_link\n",
    );
    for r in &c.records {
        writeln!(
            s,
            "{},{},{:.2},{:.4},{:.2},{},{},{},{}",
            c.label.replace(',', ";"),
            r.link + 1,
            r.force_n,
            r.start,
            r.own_joint_torque,
            r.delay_s.is_some(),
            r.delay_s
                .map(|d| format!("{:.1}", d * 1e3))
                .unwrap_or_default(),
            r.onset_link
                .map(|l| (l + 1).to_string())
                .unwrap_or_default(),
            r.episode_link
                .map(|l| (l + 1).to_string())
                .unwrap_or_default()
        )
        .unwrap();
    }
    std::fs::write(path, s).unwrap();
}
