//! Design study: the predicted accuracy of a tare + estimate under the drift-aware error model
//! (`estimator::error_model::predict_modelled`) against the robot time of one phase, for pose
//! patterns, amplitudes, averaging windows, move profiles and visiting orders.
//!
//! `cargo run --release -p estimator --example design_floor -- [--mass 3.028] [--gap-s 5]`
#![allow(clippy::unwrap_used, clippy::expect_used)]

use dynamics::{LWR4_PICK_POSE_RAD, Model, lwr4};
use estimator::error_model::{PlannedSample, predict_modelled};
use estimator::poses::{Criterion, Nominal, centred, optimize, paper_pattern};
use nalgebra::SVector;
use trajectory::double_s::DoubleS;

type V7 = SVector<f64, 7>;

const NOISE: f64 = 0.05; // Nm per 1 ms cycle (mock default)
const QUANTUM: f64 = 0.0357; // Nm, J1–J4 (dithered by the noise: + q²/12)
const DRIFT: f64 = 0.002; // Nm/√s
const V: f64 = 0.18;
const A: f64 = 1.0;
const J: f64 = 5.0;

#[derive(Clone, Copy, Debug)]
enum Profile {
    Quintic,
    DoubleS,
}

fn move_time(a: &V7, b: &V7, p: Profile) -> f64 {
    let d = (b - a).amax();
    if d == 0.0 {
        return 0.0;
    }
    match p {
        Profile::Quintic => (trajectory::quintic::PEAK_VELOCITY * d / V)
            .max((trajectory::quintic::PEAK_ACCELERATION * d / A).sqrt())
            .max((trajectory::quintic::PEAK_JERK * d / J).cbrt()),
        Profile::DoubleS => DoubleS::plan(V / d, A / d, J / d).duration(),
    }
}

/// One phase: the visiting sequence (every entry sampled), move profile, settle and window.
struct Phase {
    seq: Vec<V7>,
    /// Whether the phase ends with a move back to the start (not sampled).
    return_home: Option<V7>,
}

/// Sample times (window middles) from `t0` and the phase's end time; moving time.
fn schedule(
    ph: &Phase,
    start: &V7,
    t0: f64,
    settle: f64,
    w: f64,
    p: Profile,
) -> (Vec<f64>, f64, f64) {
    let mut t = t0;
    let mut at = *start;
    let mut times = vec![];
    let mut moving = 0.0;
    for q in &ph.seq {
        let m = move_time(&at, q, p);
        moving += m;
        t += m + if m > 0.0 { settle } else { 0.02 };
        times.push(t + 0.5 * w);
        t += w;
        at = *q;
    }
    if let Some(h) = ph.return_home {
        let m = move_time(&at, &h, p);
        moving += m;
        t += m;
    }
    (times, t, moving)
}

struct Case {
    name: String,
    tare: Phase,
    reverse: bool,
}

fn tour(start: &V7, targets: &[V7], revisit: bool, p: Profile) -> Vec<V7> {
    trajectory::tour::order(start, targets, revisit, |a, b| move_time(a, b, p))
        .into_iter()
        .map(|i| targets[i])
        .collect()
}

#[allow(clippy::too_many_arguments)]
fn evaluate(
    model: &Model<7>,
    c: &Case,
    start: &V7,
    settle: f64,
    w: f64,
    gap: f64,
    p: Profile,
    nominal: &Nominal,
) -> (f64, f64, f64, [f64; 3], f64) {
    let (tt, tend, moving) = schedule(&c.tare, start, 0.0, settle, w, p);
    let loaded_seq: Vec<V7> = if c.reverse {
        c.tare.seq.iter().rev().copied().collect()
    } else {
        c.tare.seq.clone()
    };
    let lph = Phase {
        seq: loaded_seq,
        return_home: c.tare.return_home,
    };
    let (lt, _, _) = schedule(&lph, start, tend + gap, settle, w, p);
    let mut plan: Vec<PlannedSample<7>> = c
        .tare
        .seq
        .iter()
        .zip(&tt)
        .map(|(q, t)| PlannedSample {
            q: *q,
            time_s: *t,
            loaded: false,
        })
        .collect();
    plan.extend(lph.seq.iter().zip(&lt).map(|(q, t)| PlannedSample {
        q: *q,
        time_s: *t,
        loaded: true,
    }));
    let cycles = (w * 1000.0).round();
    let sem = V7::from_fn(|j, _| {
        let q2 = if j < 4 { QUANTUM * QUANTUM / 12.0 } else { 0.0 };
        ((NOISE * NOISE + q2) / cycles).sqrt()
    });
    let pr = predict_modelled(model, &plan, &sem, DRIFT, 0.2, nominal).unwrap();
    let drift = pr
        .sources
        .iter()
        .find(|s| s.source == estimator::error_model::Source::Drift)
        .map_or(0.0, |s| s.mass_std);
    (tend, moving, pr.mass_std, pr.com_std, drift)
}

fn main() {
    let mut mass = 3.028;
    let mut gap = 5.0;
    let args: Vec<String> = std::env::args().skip(1).collect();
    for w in args.chunks(2) {
        match w[0].as_str() {
            "--mass" => mass = w[1].parse().unwrap(),
            "--gap-s" => gap = w[1].parse().unwrap(),
            other => panic!("unknown {other}"),
        }
    }
    let nominal = Nominal {
        mass,
        com: [0.0, 0.0, if mass < 1.0 { 0.1146 } else { 0.119 }],
    };
    let model = lwr4();
    let c = V7::from(LWR4_PICK_POSE_RAD);
    println!(
        "mass {mass} kg, gap {gap} s; per case: phase time (moving), mass σ (drift share), CoM σ x/y/z"
    );
    for p in [Profile::Quintic, Profile::DoubleS] {
        for (settle, w) in [(0.1, 0.5), (0.1, 0.3), (0.1, 0.2)] {
            println!("== profile {p:?}, settle {settle} s, window {w} s");
            let mut cases = vec![];
            // current default: paper ±7°, tour, revisit first, return home
            let paper = paper_pattern(&model, &c, 7f64.to_radians(), 10);
            let mut seq = tour(&c, &paper, true, p);
            seq.push(seq[0]);
            cases.push(Case {
                name: "paper ±7° (now)".into(),
                tare: Phase {
                    seq,
                    return_home: Some(c),
                },
                reverse: false,
            });
            for deg in [1.0f64, 2.0, 3.0, 4.0, 5.0, 7.0] {
                let a = deg.to_radians();
                let designs = [
                    ("paper", paper_pattern(&model, &c, a, 9)),
                    (
                        "D-opt",
                        optimize(&model, &c, a, 9, Criterion::D, 256, &nominal).unwrap(),
                    ),
                    (
                        "A-opt",
                        optimize(&model, &c, a, 9, Criterion::A, 256, &nominal).unwrap(),
                    ),
                ];
                let centred = centred(&model, &c, a, 10, 256, &nominal).unwrap();
                let designs = designs
                    .into_iter()
                    .chain([("centred", centred[1..].to_vec())]);
                for (name, poses) in designs {
                    let mut seq = vec![c];
                    seq.extend(tour(&c, &poses, false, p));
                    seq.push(c);
                    for reverse in [false, true] {
                        cases.push(Case {
                            name: format!(
                                "C+{name} ±{deg}°+C {}",
                                if reverse { "reversed" } else { "same order" }
                            ),
                            tare: Phase {
                                seq: seq.clone(),
                                return_home: None,
                            },
                            reverse,
                        });
                    }
                }
            }
            for case in &cases {
                let (t, mv, ms, cs, dr) = evaluate(&model, case, &c, settle, w, gap, p, &nominal);
                println!(
                    "{:<36} {:5.1} s ({:4.1})  mass {:.2} g (drift {:.2})  CoM {:.3}/{:.3}/{:.3} mm",
                    case.name,
                    t,
                    mv,
                    ms * 1e3,
                    dr * 1e3,
                    cs[0] * 1e3,
                    cs[1] * 1e3,
                    cs[2] * 1e3
                );
            }
        }
    }
}
