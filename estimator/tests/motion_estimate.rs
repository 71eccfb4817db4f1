//! Full inertial estimation (Sec. V, eq. 45) on data simulated with `dynamics`: the paper's
//! q_A, q_B, q_C joint-1 sweeps (15 s each, 5 ms sampling, up to ±100°/s and ±150°/s²), the
//! loaded arm's exact inverse dynamics as measured torque plus σ = 0.05 Nm white noise.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::f64::consts::FRAC_PI_2;

use dynamics::{Data, InertialParameters, Model, lwr4, rnea};
use estimator::motion::{MotionOptions, Trajectory, Unloaded, chirp, estimate_motion};
use estimator::poses::paper_pattern;
use estimator::sim::{LWR4_EXAMPLE_PERTURBATION, perturbed_model, static_samples};
use nalgebra::{Matrix3, SVector, Vector3};
use rand::{Rng, SeedableRng, rngs::StdRng};
use rand_distr::Normal;

/// A 3.028 kg payload with a realistic, asymmetric inertia: CoM (0.004, −0.003, 0.119) m in
/// frame 7, inertia about the CoM of a 10 × 8 × 15 cm box, slightly rotated.
fn payload() -> InertialParameters {
    let m: f64 = 3.028;
    let (a, b, c): (f64, f64, f64) = (0.10, 0.08, 0.15);
    let box_inertia = Matrix3::from_diagonal(&Vector3::new(
        m * (b * b + c * c) / 12.0,
        m * (a * a + c * c) / 12.0,
        m * (a * a + b * b) / 12.0,
    ));
    let r = nalgebra::Rotation3::from_euler_angles(0.2, -0.1, 0.3);
    let i = r.matrix() * box_inertia * r.matrix().transpose();
    InertialParameters::from_com(m, Vector3::new(0.004, -0.003, 0.119), i)
}

fn sweep(truth: &Model<7>, fixed: [f64; 6], rng: &mut StdRng, sigma: f64) -> Trajectory<7> {
    let noise = Normal::new(0.0, sigma).unwrap();
    let mut data = Data::new(truth);
    let dt = 0.005;
    let n = (15.0 / dt) as usize + 1;
    let mut tr = Trajectory {
        t: Vec::new(),
        q: Vec::new(),
        tau: Vec::new(),
    };
    for k in 0..n {
        let t = k as f64 * dt;
        let (q1, qd1, qdd1) = chirp(t, 15.0, 100f64.to_radians(), 150f64.to_radians());
        let q = SVector::<f64, 7>::from([
            q1, fixed[0], fixed[1], fixed[2], fixed[3], fixed[4], fixed[5],
        ]);
        let qd = SVector::<f64, 7>::from([qd1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        let qdd = SVector::<f64, 7>::from([qdd1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        let mut tau = rnea(truth, &mut data, &q, &qd, &qdd);
        for j in 0..7 {
            tau[j] += rng.sample(noise);
        }
        tr.t.push(t);
        tr.q.push(q);
        tr.tau.push(tau);
    }
    tr
}

fn sweeps(truth: &Model<7>, rng: &mut StdRng) -> Vec<Trajectory<7>> {
    vec![
        sweep(truth, [FRAC_PI_2, 0.0, 0.0, 0.0, 0.0, 0.0], rng, 0.05),
        sweep(
            truth,
            [FRAC_PI_2, 0.0, 0.0, 0.0, -FRAC_PI_2, 0.0],
            rng,
            0.05,
        ),
        sweep(
            truth,
            [FRAC_PI_2, 0.0, 0.0, -FRAC_PI_2, 0.0, 0.0],
            rng,
            0.05,
        ),
    ]
}

/// Accuracy criteria of issue 5: mass ≤ 0.5 %, CoM ≤ 3 mm, every inertia element within 10 % of
/// the largest principal inertia. The inertia is taken about the frame-7 origin, as the paper
/// reports it (eq. 46); about the CoM the same absolute errors are printed for the record (the
/// CoM tensor of a 3 kg, 15 cm payload is ~6× smaller, so its 10 % band is not reachable with
/// σ = 0.05 Nm and these sweeps: see BENCHMARKS.md).
fn check(e: &estimator::motion::InertialEstimate, label: &str) {
    let truth = payload();
    let m_err = (e.mass / truth.mass - 1.0).abs();
    let c_err = (Vector3::from(e.com) - truth.com().unwrap()).norm();
    let i_true = truth.inertia_origin;
    let largest = i_true.symmetric_eigenvalues().max();
    let i_est = Matrix3::from_fn(|r, c| e.inertia_origin[r][c]);
    let i_err = (i_est - i_true).amax();
    let ic_err = (Matrix3::from_fn(|r, c| e.inertia_com[r][c]) - truth.inertia_about_com()).amax();
    eprintln!(
        "{label}: mass err {:.4} %, CoM err {:.3} mm, inertia (origin) err {:.2e} kg·m² = {:.1} % of {:.3e}, about CoM err {:.2e}, cond {:.1}",
        100.0 * m_err,
        1000.0 * c_err,
        i_err,
        100.0 * i_err / largest,
        largest,
        ic_err,
        e.condition_number
    );
    // The paper's sweeps rotate the payload: its inertia is resolved (an estimate, not a note).
    assert!(e.inertia_resolved, "{label}: {:?}", e.physical_warning);
    assert!(m_err <= 0.005, "{label}: mass {}", e.mass);
    assert!(c_err <= 0.003, "{label}: CoM {:?}", e.com);
    assert!(
        i_err <= 0.1 * largest,
        "{label}: inertia about origin {:?} vs {i_true}",
        e.inertia_origin
    );
    // the reported 1σ is honest to within a factor 4 (residual-based, filtered noise is correlated)
    let z = (Matrix3::from_fn(|r, c| e.inertia_origin[r][c]) - i_true)[(2, 2)].abs()
        / e.parameters_std[9];
    assert!(z < 12.0, "{label}: Jzz error is {z} sigma");
}

#[test]
fn paper_sweeps_with_model_unloaded_torques() {
    let model = lwr4();
    let truth = model.with_payload(&payload());
    let mut rng = StdRng::seed_from_u64(45);
    let loaded = sweeps(&truth, &mut rng);
    let pick = SVector::<f64, 7>::from(dynamics::LWR4_PICK_POSE_RAD);
    let noise = Normal::new(0.0, 0.05).unwrap();
    let statics = static_samples(
        &model,
        &payload(),
        &model,
        &paper_pattern(&model, &pick, 7f64.to_radians(), 10),
        |_, _| rng.sample(noise),
    );
    let e = estimate_motion(
        &model,
        &loaded,
        Unloaded::Model(&model),
        &statics,
        &MotionOptions::default(),
    )
    .unwrap();
    check(&e, "model, with statics");
    assert_eq!(e.static_samples, 10);
    let e = estimate_motion(
        &model,
        &loaded,
        Unloaded::Model(&model),
        &[],
        &MotionOptions::default(),
    )
    .unwrap();
    check(&e, "model, motion only");
}

#[test]
fn paper_sweeps_with_tare_runs_cancel_the_controller_model_error() {
    // the controller model is wrong (lwr4-model.md §4), the tare runs see the same wrong... robot:
    // tare subtracts measured unloaded torques, so only the true arm matters
    let model = lwr4();
    let ctrl = perturbed_model(&model, &LWR4_EXAMPLE_PERTURBATION);
    let truth = model.with_payload(&payload());
    let mut rng = StdRng::seed_from_u64(46);
    let loaded = sweeps(&truth, &mut rng);
    let tare = sweeps(&model, &mut rng);
    let e = estimate_motion(
        &ctrl,
        &loaded,
        Unloaded::Tare(&tare),
        &[],
        &MotionOptions::default(),
    )
    .unwrap();
    check(&e, "tare");
}
