//! Analyses beyond the campaigns: ROC, minimum detectable force, neglected payload inertia.

use std::fmt::Write as _;
use std::path::Path;

use dynamics::{Data, lwr4, point_jacobian};
use plotters::prelude::*;
use rand::SeedableRng;
use rand::rngs::StdRng;
use safety::{DetectorConfig, PayloadCompensation};

use crate::campaign::Campaign;
use crate::free_motion::FreeMotion;
use crate::metrics::{percentile, replay_onsets};
use crate::scenario::{random_contact_geometry, random_unit, random_waypoints};
use crate::support::{Quintic, V7, random_configuration};
use crate::variant::observer;
use crate::world::World;
use crate::{T, THRESHOLD};

/// Start pose of the inertia experiment (the Fig. 6 start pose), rad.
const Q0: [f64; 7] = [0.0, 0.6, 0.0, -1.2, 0.0, 0.8, 0.0];

/// ROC: threshold sweep 1–15 Nm replayed on the free-motion and contact series (roc.csv, roc.svg).
pub fn roc(free: &FreeMotion, contacts: &Campaign, out: &Path, report: &mut String) {
    let cfg = DetectorConfig::<7>::default();
    let mut rows = Vec::new();
    let mut csv = String::from(
        "threshold_nm,detection_rate,false_alarms_per_hour,free_motion_false_alarms,contacts_detected,contacts\n",
    );
    let mut theta = 1.0;
    while theta <= 15.0 + 1e-9 {
        let fa = replay_onsets(&free.series, theta, &cfg).len();
        let onsets = replay_onsets(&contacts.series, theta, &cfg);
        let detected = contacts
            .records
            .iter()
            .filter(|r| onsets.iter().any(|&k| k >= r.window.0 && k <= r.window.1))
            .count();
        let rate = detected as f64 / contacts.records.len() as f64;
        let fa_h = fa as f64 / free.hours;
        writeln!(
            csv,
            "{theta:.2},{rate:.4},{fa_h:.3},{fa},{detected},{}",
            contacts.records.len()
        )
        .unwrap();
        rows.push((theta, rate, fa_h));
        theta += 0.5;
    }
    std::fs::write(out.join("roc.csv"), csv).unwrap();
    writeln!(report, "### ROC (threshold sweep 1–15 Nm; contacts 15–80 N, 20 ms half-sine, links 1–7; false alarms from the free-motion hours)\n").unwrap();
    writeln!(report, "| θ [Nm] | detection rate | false alarms / h |").unwrap();
    writeln!(report, "|---|---|---|").unwrap();
    for &(theta, rate, fa) in &rows {
        if [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0, 12.0, 15.0]
            .iter()
            .any(|x| (x - theta).abs() < 1e-9)
        {
            writeln!(report, "| {theta:.1} | {:.1} % | {fa:.2} |", rate * 100.0).unwrap();
        }
    }
    writeln!(report).unwrap();
    // Plot: detection rate vs false alarms per hour (log1p x axis keeps zero visible).
    let path = out.join("roc.svg");
    let root = SVGBackend::new(&path, (700, 500)).into_drawing_area();
    root.fill(&WHITE).unwrap();
    let x_max = rows
        .iter()
        .map(|r| (1.0 + r.2).log10())
        .fold(1.0_f64, f64::max)
        * 1.05;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            "ROC: detection rate vs false alarms (threshold sweep 1-15 Nm)",
            ("sans-serif", 16),
        )
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(50)
        .build_cartesian_2d(0.0..x_max, 0.0..1.02)
        .unwrap();
    chart
        .configure_mesh()
        .x_desc("log10(1 + false alarms per hour)")
        .y_desc("detection rate")
        .draw()
        .unwrap();
    let points: Vec<(f64, f64)> = rows.iter().map(|r| ((1.0 + r.2).log10(), r.1)).collect();
    chart
        .draw_series(LineSeries::new(
            points.iter().copied(),
            BLUE.stroke_width(2),
        ))
        .unwrap();
    chart
        .draw_series(points.iter().map(|&p| Circle::new(p, 3, BLUE.filled())))
        .unwrap();
    for &(theta, rate, fa) in &rows {
        if [2.0, 4.0, 6.0, 10.0]
            .iter()
            .any(|x| (x - theta).abs() < 1e-9)
        {
            chart
                .draw_series(std::iter::once(Text::new(
                    format!("{theta:.0} Nm"),
                    ((1.0 + fa).log10(), rate - 0.05),
                    ("sans-serif", 12),
                )))
                .unwrap();
        }
    }
    root.present().unwrap();
}

/// Static minimum detectable force per link at θ = 6 Nm (fmin.csv).
pub fn minimum_detectable_force(seed: u64, report: &mut String, out: &Path) {
    let model = lwr4();
    let mut data = Data::new(&model);
    let mut rng = StdRng::seed_from_u64(seed ^ 0xF0);
    writeln!(report, "### Minimum detectable force (static, θ = 6 Nm: F_min = min_j θ/|(J_vᵀn)_j|; 2000 random configurations, points and directions per link)\n").unwrap();
    writeln!(
        report,
        "| link | median F_min [N] | p10 [N] | p90 [N] | median with the best direction [N] |"
    )
    .unwrap();
    writeln!(report, "|---|---|---|---|---|").unwrap();
    let mut csv = String::from("link,median_n,p10_n,p90_n,best_direction_median_n\n");
    for link in 0..7 {
        let mut values = Vec::new();
        let mut best = Vec::new();
        for _ in 0..2000 {
            let q = random_configuration(&mut rng, 0.8);
            let (point, _) = random_contact_geometry(&mut rng, link);
            let j = point_jacobian(&model, &mut data, &q, link, &point);
            let jv = j.fixed_rows::<3>(0).into_owned();
            let n = random_unit(&mut rng);
            let tau = jv.transpose() * n;
            values.push(THRESHOLD / tau.amax());
            // Best direction: the largest column norm of J_v gives the largest single-joint torque.
            let best_gain = (0..7).map(|c| jv.column(c).norm()).fold(0.0_f64, f64::max);
            best.push(THRESHOLD / best_gain);
        }
        values.sort_by(|a, b| a.partial_cmp(b).unwrap());
        best.sort_by(|a, b| a.partial_cmp(b).unwrap());
        let (m, p10, p90, b) = (
            percentile(&values, 0.5),
            percentile(&values, 0.1),
            percentile(&values, 0.9),
            percentile(&best, 0.5),
        );
        writeln!(
            report,
            "| {} | {m:.1} | {p10:.1} | {p90:.1} | {b:.1} |",
            link + 1
        )
        .unwrap();
        writeln!(csv, "{},{m:.3},{p10:.3},{p90:.3},{b:.3}", link + 1).unwrap();
    }
    writeln!(report).unwrap();
    std::fs::write(out.join("fmin.csv"), csv).unwrap();
}

/// Peak free-motion |r| without payload, gravity-only and full compensation, per a_max.
pub fn neglected_inertia(seed: u64, report: &mut String) {
    writeln!(report, "### Where neglecting the payload inertia breaks the margin (20 s free motion, v ≤ 1 rad/s; peak free-motion \\|r\\| [Nm])\n").unwrap();
    writeln!(
        report,
        "| a_max [rad/s²] | no payload | gravity only (eq. 48) | full inertial parameters |"
    )
    .unwrap();
    writeln!(report, "|---|---|---|---|").unwrap();
    for a_max in [0.25, 0.5, 1.0, 2.0, 4.0] {
        let mut rng = StdRng::seed_from_u64(seed ^ 0x1A);
        let q0 = V7::from_column_slice(&Q0);
        let mut waypoints = vec![q0];
        waypoints.extend(random_waypoints(&mut rng, 6));
        let trajectory = Quintic::new(&waypoints, 1.0, a_max, 0.2);
        let mut world = World::new(seed, &q0, &[]);
        let nominal = world.nominal.clone();
        let mut obs = [
            observer(&nominal, PayloadCompensation::None),
            observer(&nominal, world.payload()),
            observer(&nominal, world.payload_full()),
        ];
        let mut peak = [0.0_f64; 3];
        let ticks = (20.0_f64.min(trajectory.duration()) / T) as usize;
        for k in 0..ticks {
            let (input, _) = world.measure();
            for (i, o) in obs.iter_mut().enumerate() {
                let r = o.step(&input).residual.amax();
                if k > 50 {
                    peak[i] = peak[i].max(r);
                }
            }
            world.advance(&trajectory);
        }
        writeln!(
            report,
            "| {a_max} | {:.2} | {:.2} | {:.2} |",
            peak[0], peak[1], peak[2]
        )
        .unwrap();
    }
    writeln!(report).unwrap();
}
