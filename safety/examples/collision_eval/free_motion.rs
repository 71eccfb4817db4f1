//! Randomised free motion: false alarms and peak residuals per variant.

use std::fmt::Write as _;

use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use safety::{CollisionDetector, Detection, MomentumObserver};

use crate::T;
use crate::report::fmt_joints;
use crate::scenario::random_waypoints;
use crate::support::{Quintic, V7};
use crate::variant::Variant;
use crate::world::World;

pub struct FreeMotion {
    pub label: String,
    pub series: Vec<f32>,
    pub hours: f64,
    pub peak_per_joint: V7,
    pub onsets_at_default: usize,
}

/// Randomised free motion, observed by one compensated observer and detector per variant.
pub fn free_motion(seed: u64, hours: f64, variants: &[Variant]) -> Vec<FreeMotion> {
    let segment_s = 300.0_f64.min(hours * 3600.0);
    let segments = (hours * 3600.0 / segment_s).ceil() as usize;
    let mut results: Vec<FreeMotion> = variants
        .iter()
        .map(|v| FreeMotion {
            label: v.label.clone(),
            series: Vec::with_capacity((hours * 3.6e6) as usize + 10),
            hours: 0.0,
            peak_per_joint: V7::zeros(),
            onsets_at_default: 0,
        })
        .collect();
    for seg in 0..segments {
        let mut rng = StdRng::seed_from_u64(seed.wrapping_mul(31).wrapping_add(seg as u64));
        let mut waypoints = random_waypoints(&mut rng, 1);
        let q0 = waypoints[0];
        let v_max = rng.random_range(0.3..1.0);
        let a_max = rng.random_range(0.2..0.6);
        let dwell = rng.random_range(0.0..1.0);
        waypoints.extend(random_waypoints(&mut rng, 200));
        let trajectory = Quintic::new(&waypoints, v_max, a_max, dwell);
        let mut world = World::new(seed.wrapping_add(1000 + seg as u64), &q0, &[]);
        let mut observers: Vec<MomentumObserver<7>> =
            variants.iter().map(|v| v.observer(&world)).collect();
        let mut detectors: Vec<CollisionDetector<7>> =
            variants.iter().map(Variant::detector).collect();
        let ticks = (segment_s / T) as usize;
        for k in 0..ticks {
            let t = k as f64 * T;
            let (input, _) = world.measure();
            for ((obs, det), res) in observers
                .iter_mut()
                .zip(detectors.iter_mut())
                .zip(results.iter_mut())
            {
                let out = obs.step(&input);
                if k > 0 {
                    res.peak_per_joint = res.peak_per_joint.sup(&out.residual.abs());
                    res.series.push(out.residual.amax() as f32);
                    if let Detection::Onset(_) =
                        det.update(&out.residual, &out.velocity, out.cycle, t)
                    {
                        res.onsets_at_default += 1;
                    }
                }
            }
            world.advance(&trajectory);
        }
        eprintln!(
            "free motion segment {}/{} done (v_max {v_max:.2} rad/s, a_max {a_max:.2} rad/s²)",
            seg + 1,
            segments
        );
    }
    for r in &mut results {
        r.hours = r.series.len() as f64 * T / 3600.0;
    }
    results
}

/// Markdown table of free-motion runs (false alarms and peak |r_j| per variant); `onsets_column`
/// names the column of onset counts.
pub fn free_motion_table(report: &mut String, onsets_column: &str, runs: &[FreeMotion]) {
    writeln!(
        report,
        "| variant | {onsets_column} | false alarms / h | peak \\|r\\| per joint [Nm] |\n|---|---|---|---|"
    )
    .unwrap();
    for f in runs {
        writeln!(
            report,
            "| {} | {} | {:.2} | {} |",
            f.label,
            f.onsets_at_default,
            f.onsets_at_default as f64 / f.hours,
            fmt_joints(&f.peak_per_joint, 2)
        )
        .unwrap();
    }
    writeln!(report).unwrap();
}
