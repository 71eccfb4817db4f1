//! Seeded Monte Carlo accuracy report of the static estimator (issue 5):
//! `cargo run --release -p estimator --example accuracy [-- TRIALS]`.
//!
//! Truth: `dynamics::lwr4()` plus the payload; τ_J = g_true+payload(q) + N(0, σ²) with σ = 0.05 Nm on
//! every joint; g_ctrl from the controller model, either exact ("noise only") or perturbed per
//! trial as in lwr4-model.md §4 (δm ~ N(0, 0.02²) kg, δ(mc) ~ N(0, 0.005²) kg·m per link).
//! Cramér–Rao bound: σ²(YᵀY)⁻¹ of the noise model (2σ² for tare), CoM by the delta method,
//! averaged over trials as a mean variance.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use dynamics::{Data, InertialParameters, Model, lwr4, payload_gravity_regressor};
use estimator::correction::{Calibration, estimate_with_calibration, estimate_with_tare};
use estimator::estimate::{EstimateOptions, Method, PayloadEstimate, estimate};
use estimator::poses::{Criterion, Nominal, optimize, paper_pattern};
use estimator::sim::{perturbed_model, static_samples};
use nalgebra::{Matrix3, Matrix3x4, Matrix4, SVector, Vector3};
use rand::{Rng, SeedableRng, rngs::StdRng};
use rand_distr::Normal;

const SIGMA: f64 = 0.05;

/// Pose generator of a row (fixed set or drawn per trial).
type PoseSource<'a> = Box<dyn FnMut(&mut StdRng) -> Vec<SVector<f64, 7>> + 'a>;
/// One row: label, payload, mode, method, trials, poses.
type Case<'a> = (
    &'a str,
    &'a InertialParameters,
    Mode,
    Method,
    usize,
    PoseSource<'a>,
);

#[derive(Clone, Copy, PartialEq)]
enum Mode {
    NoiseOnly,
    OneShot,
    Tare,
    Calibration,
}

struct Row {
    label: String,
    mass_sq: f64,
    com_sq: f64,
    crb_mass_var: f64,
    crb_com_var: f64,
    max_abs_mass: f64,
    n: usize,
}

fn crb(
    model: &Model<7>,
    poses: &[SVector<f64, 7>],
    var: f64,
    m: f64,
    c: &Vector3<f64>,
) -> (f64, f64) {
    let mut data = Data::new(model);
    let info: Matrix4<f64> = poses
        .iter()
        .map(|q| {
            let y = payload_gravity_regressor(model, &mut data, q);
            y.transpose() * y
        })
        .sum();
    let cov = info.try_inverse().unwrap() * var;
    let h = c * m;
    let mut j = Matrix3x4::zeros();
    j.set_column(0, &(-h / (m * m)));
    j.fixed_view_mut::<3, 3>(0, 1)
        .copy_from(&(Matrix3::identity() / m));
    let cc = j * cov * j.transpose();
    (cov[(0, 0)], cc.trace())
}

fn draw_perturbation(rng: &mut StdRng) -> [[f64; 4]; 7] {
    let dm = Normal::new(0.0, 0.02).unwrap();
    let dh = Normal::new(0.0, 0.005).unwrap();
    std::array::from_fn(|_| {
        [
            rng.sample(dm),
            rng.sample(dh),
            rng.sample(dh),
            rng.sample(dh),
        ]
    })
}

fn uniform_poses(model: &Model<7>, n: usize, rng: &mut StdRng) -> Vec<SVector<f64, 7>> {
    let lim = model.limits();
    (0..n)
        .map(|_| {
            SVector::from_fn(|j, _| rng.random_range(lim.position_min[j]..lim.position_max[j]))
        })
        .collect()
}

#[allow(clippy::too_many_arguments)]
fn run(
    label: &str,
    model: &Model<7>,
    payload: &InertialParameters,
    mode: Mode,
    method: Method,
    trials: usize,
    poses_of: &mut dyn FnMut(&mut StdRng) -> Vec<SVector<f64, 7>>,
    rng: &mut StdRng,
) -> Row {
    let normal = Normal::new(0.0, SIGMA).unwrap();
    let opts = EstimateOptions {
        method,
        ..Default::default()
    };
    let m_true = payload.mass;
    let c_true = payload.com().unwrap();
    let mut row = Row {
        label: label.into(),
        mass_sq: 0.0,
        com_sq: 0.0,
        crb_mass_var: 0.0,
        crb_com_var: 0.0,
        max_abs_mass: 0.0,
        n: 0,
    };
    let none = InertialParameters::zero();
    let lim = model.limits();
    let ws =
        estimator::basis::spread_poses(&(lim.position_min * 0.95), &(lim.position_max * 0.95), 100);
    for _ in 0..trials {
        let poses = poses_of(rng);
        let ctrl = if mode == Mode::NoiseOnly {
            model.clone()
        } else {
            perturbed_model(model, &draw_perturbation(rng))
        };
        let loaded = static_samples(model, payload, &ctrl, &poses, |_, _| rng.sample(normal));
        let e: PayloadEstimate = match mode {
            Mode::NoiseOnly | Mode::OneShot => estimate(model, &loaded, &opts).unwrap(),
            Mode::Tare => {
                let tare = static_samples(model, &none, &ctrl, &poses, |_, _| rng.sample(normal));
                estimate_with_tare(model, &loaded, &tare, 2e-3, &opts).unwrap()
            }
            Mode::Calibration => {
                let unloaded = static_samples(model, &none, &ctrl, &ws, |_, _| rng.sample(normal));
                let cal = Calibration::identify(model, &unloaded, &opts).unwrap();
                estimate_with_calibration(model, &loaded, &cal, &opts).unwrap()
            }
        };
        let dm = e.mass - m_true;
        row.mass_sq += dm * dm;
        row.max_abs_mass = row.max_abs_mass.max(dm.abs());
        row.com_sq += (Vector3::from(e.com) - c_true).norm_squared();
        let var = if mode == Mode::Tare {
            2.0 * SIGMA * SIGMA
        } else {
            SIGMA * SIGMA
        };
        let (cm, cc) = crb(model, &poses, var, m_true, &c_true);
        row.crb_mass_var += cm;
        row.crb_com_var += cc;
        row.n += 1;
    }
    row
}

fn print(row: &Row, m_true: f64, with_crb: bool) {
    let n = row.n as f64;
    let mass_rms = (row.mass_sq / n).sqrt();
    let com_rms = (row.com_sq / n).sqrt();
    let crb_m = (row.crb_mass_var / n).sqrt();
    let crb_c = (row.crb_com_var / n).sqrt();
    let ratio = if with_crb {
        format!("{:.2} / {:.2}", mass_rms / crb_m, com_rms / crb_c)
    } else {
        format!(
            "({:.1} / {:.1}: not the noise bound)",
            mass_rms / crb_m,
            com_rms / crb_c
        )
    };
    println!(
        "| {} | {} | {:.4} % ({:.2} g) | {:.3} % | {:.2} mm | {:.4} % / {:.2} mm | {} |",
        row.label,
        row.n,
        100.0 * mass_rms / m_true,
        1000.0 * mass_rms,
        100.0 * row.max_abs_mass / m_true,
        1000.0 * com_rms,
        100.0 * crb_m / m_true,
        1000.0 * crb_c,
        ratio
    );
}

fn main() {
    let trials: usize = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(1000);
    let model = lwr4();
    let heavy = InertialParameters::point_mass(3.028, Vector3::new(0.0, 0.0, 0.119));
    let light = InertialParameters::point_mass(0.144, Vector3::new(0.0, 0.0, 0.1146));
    let pick = SVector::<f64, 7>::from(dynamics::LWR4_PICK_POSE_RAD);
    let q10 = paper_pattern(&model, &pick, 7f64.to_radians(), 10);
    let nominal = Nominal {
        mass: 3.028,
        com: [0.0, 0.0, 0.119],
    };
    let opt10_3deg = optimize(
        &model,
        &pick,
        3f64.to_radians(),
        10,
        Criterion::D,
        300,
        &nominal,
    )
    .unwrap();
    let opt5_7deg = optimize(
        &model,
        &pick,
        7f64.to_radians(),
        5,
        Criterion::A,
        300,
        &nominal,
    )
    .unwrap();
    let mut rng = StdRng::seed_from_u64(2017);
    println!(
        "σ = {SIGMA} Nm, seed 2017, {trials} trials per row (500-pose rows: {} trials)\n",
        trials.min(500)
    );
    println!(
        "| case | trials | mass RMS error | max mass error | CoM RMS error | Cramér–Rao bound (mass / CoM) | RMS / CRB (mass / CoM) |"
    );
    println!("|---|---|---|---|---|---|---|");
    let d = Method::Direct;
    let fixed = |p: Vec<SVector<f64, 7>>| move |_: &mut StdRng| p.clone();
    let cases: Vec<Case> = vec![
        (
            "3.028 kg, 10 paper-pattern poses (pick ± 7°), noise only",
            &heavy,
            Mode::NoiseOnly,
            d,
            trials,
            Box::new(fixed(q10.clone())),
        ),
        (
            "3.028 kg, 10 paper-pattern poses, one-shot with controller model error",
            &heavy,
            Mode::OneShot,
            d,
            trials,
            Box::new(fixed(q10.clone())),
        ),
        (
            "3.028 kg, 10 paper-pattern poses, model error + tare",
            &heavy,
            Mode::Tare,
            d,
            trials,
            Box::new(fixed(q10.clone())),
        ),
        (
            "3.028 kg, 10 paper-pattern poses, model error + calibration (100 unloaded workspace poses)",
            &heavy,
            Mode::Calibration,
            d,
            trials.min(500),
            Box::new(fixed(q10.clone())),
        ),
        (
            "3.028 kg, 10 paper-pattern poses, paper's coefficient route, noise only",
            &heavy,
            Mode::NoiseOnly,
            Method::Coefficients,
            trials.min(500),
            Box::new(fixed(q10.clone())),
        ),
        (
            "3.028 kg, 10 D-optimal poses in pick ± 3°, noise only",
            &heavy,
            Mode::NoiseOnly,
            d,
            trials,
            Box::new(fixed(opt10_3deg.clone())),
        ),
        (
            "3.028 kg, 5 A-optimal poses in pick ± 7°, noise only",
            &heavy,
            Mode::NoiseOnly,
            d,
            trials,
            Box::new(fixed(opt5_7deg.clone())),
        ),
        (
            "3.028 kg, 500 random poses (uniform in limits), noise only",
            &heavy,
            Mode::NoiseOnly,
            d,
            trials.min(500),
            Box::new(|r: &mut StdRng| uniform_poses(&lwr4(), 500, r)),
        ),
        (
            "3.028 kg, 500 random poses, one-shot with controller model error",
            &heavy,
            Mode::OneShot,
            d,
            trials.min(500),
            Box::new(|r: &mut StdRng| uniform_poses(&lwr4(), 500, r)),
        ),
        (
            "0.144 kg, 10 paper-pattern poses, noise only",
            &light,
            Mode::NoiseOnly,
            d,
            trials,
            Box::new(fixed(q10.clone())),
        ),
        (
            "0.144 kg, 10 paper-pattern poses, model error + tare",
            &light,
            Mode::Tare,
            d,
            trials,
            Box::new(fixed(q10.clone())),
        ),
    ];
    for (label, payload, mode, method, n, mut poses_of) in cases {
        let row = run(
            label,
            &model,
            payload,
            mode,
            method,
            n,
            &mut *poses_of,
            &mut rng,
        );
        print(
            &row,
            payload.mass,
            mode != Mode::OneShot && method == Method::Direct,
        );
    }
}
