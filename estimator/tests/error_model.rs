//! The error model's 1σ against Monte Carlo truth: tare and estimate ten seconds apart, the
//! mock robot's sensor model (white noise averaged over a window, per-joint offsets, a random
//! walk drift of 0.002 Nm/√s), the paper's 10 poses plus a revisit of the first. The reported σ
//! must cover the real error (RMS of error/σ near 1, ±2σ coverage ≥ 90 %), where the
//! scatter-only σ of the plain least-squares fit is overconfident.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use dynamics::{Data, InertialParameters, Model, compute_generalized_gravity, lwr4};
use estimator::error_model::{
    DriftPrior, PlannedSample, Reference, Source, estimate_modelled, predict_modelled,
};
use estimator::estimate::{EstimateOptions, estimate_direct};
use estimator::poses::Nominal;
use estimator::samples::{SampleEvidence, StaticSample};
use nalgebra::{SVector, Vector3};
use rand::{Rng, SeedableRng, rngs::StdRng};
use rand_distr::{ChiSquared, Normal};

const MASS: f64 = 3.028; // kg
const COM: [f64; 3] = [0.0, 0.0, 0.119]; // m, frame 7
const NOISE: f64 = 0.05; // Nm per cycle
const CYCLES: f64 = 500.0; // per averaging window
const BATCHES: f64 = 10.0; // batch means per window
const OFFSET: f64 = 0.05; // Nm, per joint
const DRIFT: f64 = 0.002; // Nm/√s
const POSE_TIME: f64 = 1.2; // s between samples
const GAP: f64 = 10.0; // s from the tare's end to the estimate's start

fn poses() -> Vec<SVector<f64, 7>> {
    let p = [2.0f64, 3.0, 5.0, 7.0, 11.0, 13.0, 17.0];
    let pick = SVector::<f64, 7>::from(dynamics::LWR4_PICK_POSE_RAD);
    let mut v: Vec<_> = (1..=10)
        .map(|k| {
            pick + SVector::from_fn(|j, _| {
                7f64.to_radians() * (2.0 * (k as f64 * p[j].sqrt()).fract() - 1.0)
            })
        })
        .collect();
    v.push(v[0]); // the revisit
    v
}

/// A sensor: offsets and a random walk, read at increasing times.
struct Sensor {
    offset: [f64; 7],
    walk: [f64; 7],
    t: f64,
    rate: f64,
}

impl Sensor {
    fn read(&mut self, rng: &mut StdRng, t: f64) -> [f64; 7] {
        let dt = t - self.t;
        assert!(dt >= 0.0);
        let step = Normal::new(0.0, self.rate * dt.sqrt()).unwrap();
        for w in &mut self.walk {
            *w += rng.sample(step);
        }
        self.t = t;
        std::array::from_fn(|j| self.offset[j] + self.walk[j])
    }
}

/// Window-mean samples of `model` at `poses` from time `t0`, with evidence whose standard
/// error is itself estimated from batch means (9 degrees of freedom).
fn procedure(
    model: &Model<7>,
    controller: &Model<7>,
    poses: &[SVector<f64, 7>],
    t0: f64,
    sensor: &mut Sensor,
    rng: &mut StdRng,
) -> Vec<StaticSample<7>> {
    let mut data = Data::new(model);
    let mut data_c = Data::new(controller);
    let sem = NOISE / CYCLES.sqrt();
    let white = Normal::new(0.0, sem).unwrap();
    let chi = ChiSquared::new(BATCHES - 1.0).unwrap();
    poses
        .iter()
        .enumerate()
        .map(|(k, q)| {
            let t = t0 + POSE_TIME * k as f64;
            let bias = sensor.read(rng, t);
            let g = compute_generalized_gravity(model, &mut data, q);
            let tau = SVector::from_fn(|j, _| g[j] + bias[j] + rng.sample(white));
            // the controller's gravity vector: its own model, without the payload
            let g_ctrl = compute_generalized_gravity(controller, &mut data_c, q);
            let mut s = StaticSample::new(*q, tau, g_ctrl);
            s.evidence = Some(SampleEvidence {
                time_s: t,
                window_s: CYCLES * 1e-3,
                settle_s: 0.1,
                max_qd: 1e-4,
                tau_std: SVector::repeat(NOISE),
                tau_sem: SVector::from_fn(|_, _| sem * (rng.sample(chi) / (BATCHES - 1.0)).sqrt()),
            });
            s
        })
        .collect()
}

struct Run {
    mass_z: Vec<f64>,
    com_z: Vec<[f64; 3]>,
    ols_mass_z: Vec<f64>,
    drift_measured: Vec<f64>,
    drift_share: Vec<f64>,
}

fn run(trials: usize, prior_rate: f64, seed: u64) -> Run {
    let robot = lwr4();
    let payload = InertialParameters::point_mass(MASS, Vector3::from(COM));
    let loaded = robot.with_payload(&payload);
    let poses = poses();
    let mut rng = StdRng::seed_from_u64(seed);
    let offset = Normal::new(0.0, OFFSET).unwrap();
    let mut out = Run {
        mass_z: vec![],
        com_z: vec![],
        ols_mass_z: vec![],
        drift_measured: vec![],
        drift_share: vec![],
    };
    for _ in 0..trials {
        let mut sensor = Sensor {
            offset: std::array::from_fn(|_| rng.sample(offset)),
            walk: [0.0; 7],
            t: 0.0,
            rate: DRIFT,
        };
        let tare = procedure(&robot, &robot, &poses, 0.0, &mut sensor, &mut rng);
        let start = POSE_TIME * poses.len() as f64 + GAP;
        let est = procedure(&loaded, &robot, &poses, start, &mut sensor, &mut rng);
        let prior = DriftPrior {
            rate: prior_rate,
            weight: 7.0,
        };
        let (e, u) = estimate_modelled(
            &robot,
            &est,
            Reference::Tare(&tare),
            prior,
            &EstimateOptions::default(),
        )
        .unwrap();
        out.mass_z.push((e.mass - MASS) / e.mass_std);
        out.com_z
            .push(std::array::from_fn(|i| (e.com[i] - COM[i]) / e.com_std[i]));
        out.drift_measured.push(u.drift_rate_measured.unwrap());
        let drift = u
            .sources
            .iter()
            .find(|s| s.source == Source::Drift)
            .unwrap();
        out.drift_share.push(drift.mass_std / e.mass_std);
        // The plain fit on the same Δτ: σ from the pose-to-pose scatter only.
        let paired: Vec<_> = est
            .iter()
            .zip(&tare)
            .map(|(l, t)| StaticSample::new(l.q, l.tau, t.tau))
            .collect();
        let ols = estimate_direct(&robot, &paired, &EstimateOptions::default()).unwrap();
        out.ols_mass_z.push((ols.mass - MASS) / ols.mass_std);
    }
    out
}

fn rms(z: impl Iterator<Item = f64>) -> f64 {
    let v: Vec<f64> = z.collect();
    (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
}

fn coverage(z: &[f64]) -> f64 {
    z.iter().filter(|x| x.abs() <= 2.0).count() as f64 / z.len() as f64
}

#[test]
fn sigma_covers_drift_and_noise_where_the_scatter_alone_does_not() {
    let r = run(400, DRIFT, 2017);
    let m = rms(r.mass_z.iter().copied());
    eprintln!(
        "mass: RMS error/σ {m:.3}, ±2σ coverage {:.3}; CoM RMS error/σ {:.3} {:.3} {:.3}; plain fit {:.3}",
        coverage(&r.mass_z),
        rms(r.com_z.iter().map(|z| z[0])),
        rms(r.com_z.iter().map(|z| z[1])),
        rms(r.com_z.iter().map(|z| z[2])),
        rms(r.ols_mass_z.iter().copied())
    );
    assert!((0.85..=1.2).contains(&m), "RMS of mass error/σ = {m}");
    assert!(
        coverage(&r.mass_z) >= 0.9,
        "±2σ coverage {}",
        coverage(&r.mass_z)
    );
    // CoM x and y of a payload on the flange axis; z is the lever arm
    for i in 0..3 {
        let c = rms(r.com_z.iter().map(|z| z[i]));
        assert!((0.8..=1.25).contains(&c), "RMS of CoM[{i}] error/σ = {c}");
    }
    // drift is what the scatter misses: most of the σ, and the plain fit is overconfident
    let share = r.drift_share.iter().sum::<f64>() / r.drift_share.len() as f64;
    assert!(share > 0.5, "drift share of σ(mass) {share}");
    let ols = rms(r.ols_mass_z.iter().copied());
    assert!(ols > 1.5, "plain least squares RMS error/σ = {ols}");
}

#[test]
fn revisits_measure_the_drift_rate_when_the_prior_is_wrong() {
    let r = run(200, DRIFT / 4.0, 7);
    // each trial measures 14 increments; their pooled mean of q is unbiased
    let q = r.drift_measured.iter().map(|x| x * x).sum::<f64>() / r.drift_measured.len() as f64;
    let rate = q.sqrt();
    eprintln!(
        "measured drift rate {rate:.5} Nm/√s; RMS error/σ with a 4× small prior {:.3}",
        rms(r.mass_z.iter().copied())
    );
    assert!(
        (0.8 * DRIFT..=1.2 * DRIFT).contains(&rate),
        "measured drift rate {rate} Nm/√s, truth {DRIFT}"
    );
    // a prior four times too small is mostly overruled: σ stays within 35 % of honest
    let m = rms(r.mass_z.iter().copied());
    assert!((0.8..=1.35).contains(&m), "RMS of mass error/σ = {m}");
}

#[test]
fn the_prediction_before_moving_is_the_sigma_the_estimate_reports() {
    // A centred plan: the centre first and last, the other poses in between; the estimate
    // visits them in reverse order 5 s after the tare. With a prior that outweighs the
    // revisits and no excess scatter, the estimate's σ (without the scatter share) is what
    // `predict_modelled` gives for the same times before the robot moves.
    let robot = lwr4();
    let payload = InertialParameters::point_mass(MASS, Vector3::from(COM));
    let loaded = robot.with_payload(&payload);
    let mut poses = poses();
    poses.pop();
    let centre = SVector::<f64, 7>::from(dynamics::LWR4_PICK_POSE_RAD);
    poses.insert(0, centre);
    poses.push(centre);
    let mut rng = StdRng::seed_from_u64(3);
    let mut sensor = Sensor {
        offset: [0.01; 7],
        walk: [0.0; 7],
        t: 0.0,
        rate: DRIFT,
    };
    let tare = procedure(&robot, &robot, &poses, 0.0, &mut sensor, &mut rng);
    let reversed: Vec<_> = poses.iter().rev().copied().collect();
    let start = POSE_TIME * poses.len() as f64 + 5.0;
    let est = procedure(&loaded, &robot, &reversed, start, &mut sensor, &mut rng);
    let prior = DriftPrior {
        rate: DRIFT,
        weight: 1e9,
    };
    let (e, u) = estimate_modelled(
        &robot,
        &est,
        Reference::Tare(&tare),
        prior,
        &EstimateOptions::default(),
    )
    .unwrap();
    let modelled: f64 = u
        .sources
        .iter()
        .filter(|s| s.source != Source::Scatter)
        .map(|s| s.mass_std.powi(2))
        .sum::<f64>()
        .sqrt();
    assert!(
        (e.mass - MASS).abs() < 6.0 * e.mass_std,
        "{} ± {}",
        e.mass,
        e.mass_std
    );
    let pooled = |s: &[StaticSample<7>]| {
        SVector::<f64, 7>::from_fn(|j, _| {
            (s.iter()
                .map(|x| x.evidence.unwrap().tau_sem[j].powi(2))
                .sum::<f64>()
                / s.len() as f64)
                .sqrt()
        })
    };
    // one σ per joint for both phases in the prediction: the mean of the two pooled ones
    let (pt, pl) = (pooled(&tare), pooled(&est));
    let sem = SVector::<f64, 7>::from_fn(|j, _| ((pt[j].powi(2) + pl[j].powi(2)) / 2.0).sqrt());
    let plan: Vec<PlannedSample<7>> = tare
        .iter()
        .map(|s| (s, false))
        .chain(est.iter().map(|s| (s, true)))
        .map(|(s, loaded)| PlannedSample {
            q: s.q,
            time_s: s.evidence.unwrap().time_s,
            loaded,
        })
        .collect();
    let nominal = Nominal {
        mass: e.mass,
        com: e.com,
    };
    let p = predict_modelled(&robot, &plan, &sem, DRIFT, 0.2, &nominal).unwrap();
    let rel = (p.mass_std - modelled).abs() / modelled;
    assert!(
        rel < 0.05,
        "predicted {} vs reported {modelled}",
        p.mass_std
    );
    let drift = |s: &[estimator::error_model::SourceStd]| {
        s.iter()
            .find(|x| x.source == Source::Drift)
            .unwrap()
            .mass_std
    };
    assert!((drift(&p.sources) - drift(&u.sources)).abs() < 1e-6 * MASS);
}
