//! Tare and calibration remove the controller's model error: data generated with `dynamics`,
//! the documented perturbation (lwr4-model.md §4) and σ = 0.05 Nm torque noise.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use dynamics::{InertialParameters, lwr4};
use estimator::EstimatorError;
use estimator::correction::{
    Calibration, DEFAULT_TARE_TOLERANCE, estimate_with_calibration, estimate_with_tare,
};
use estimator::estimate::{Correction, EstimateOptions, Method, estimate};
use estimator::sim::{LWR4_EXAMPLE_PERTURBATION, perturbed_model, static_samples};
use nalgebra::{SVector, Vector3};
use rand::{Rng, SeedableRng, rngs::StdRng};
use rand_distr::Normal;

fn u(k: usize, j: usize) -> f64 {
    let p = [2.0f64, 3.0, 5.0, 7.0, 11.0, 13.0, 17.0];
    2.0 * (k as f64 * p[j].sqrt()).fract() - 1.0
}

fn q10() -> Vec<SVector<f64, 7>> {
    let pick = SVector::<f64, 7>::from(dynamics::LWR4_PICK_POSE_RAD);
    (1..=10)
        .map(|k| pick + SVector::from_fn(|j, _| 7f64.to_radians() * u(k, j)))
        .collect()
}

fn workspace(n: usize, offset: usize) -> Vec<SVector<f64, 7>> {
    let qmax = [170.0, 120.0, 170.0, 120.0, 170.0, 120.0, 170.0];
    (1..=n)
        .map(|k| SVector::from_fn(|j, _| 0.95 * f64::to_radians(qmax[j]) * u(k + offset, j)))
        .collect()
}

fn heavy() -> InertialParameters {
    InertialParameters::point_mass(3.028, Vector3::new(0.0, 0.0, 0.119))
}

#[test]
fn one_shot_is_biased_tare_and_calibration_are_not() {
    let model = lwr4();
    let ctrl = perturbed_model(&model, &LWR4_EXAMPLE_PERTURBATION);
    let normal = Normal::new(0.0, 0.05).unwrap();
    let mut rng = StdRng::seed_from_u64(7);
    let opts = EstimateOptions::default();
    let none = InertialParameters::zero();

    // calibration once, from 200 unloaded workspace poses
    let unloaded_ws = static_samples(&model, &none, &ctrl, &workspace(200, 1000), |_, _| {
        rng.sample(normal)
    });
    let cal = Calibration::identify(&model, &unloaded_ws, &opts).unwrap();
    assert_eq!(cal.delta.len(), 12);
    assert!(
        cal.residual_rms[1..].iter().all(|r| *r < 0.07),
        "{:?}",
        cal.residual_rms
    );

    let trials = 40;
    let (mut e_one, mut e_tare, mut e_cal) = (0.0, 0.0, 0.0);
    let mut com_err_tare: f64 = 0.0;
    for _ in 0..trials {
        let loaded = static_samples(&model, &heavy(), &ctrl, &q10(), |_, _| rng.sample(normal));
        let tare = static_samples(&model, &none, &ctrl, &q10(), |_, _| rng.sample(normal));
        let one = estimate(&model, &loaded, &opts).unwrap();
        let t = estimate_with_tare(&model, &loaded, &tare, DEFAULT_TARE_TOLERANCE, &opts).unwrap();
        let c = estimate_with_calibration(&model, &loaded, &cal, &opts).unwrap();
        assert_eq!(t.correction, Correction::Tare);
        assert_eq!(c.correction, Correction::Calibration);
        e_one += one.mass / 3.028 - 1.0;
        e_tare += t.mass / 3.028 - 1.0;
        e_cal += c.mass / 3.028 - 1.0;
        com_err_tare =
            com_err_tare.max((Vector3::from(t.com) - Vector3::new(0.0, 0.0, 0.119)).norm());
    }
    let n = trials as f64;
    let (b_one, b_tare, b_cal) = (e_one / n, e_tare / n, e_cal / n);
    // one-shot: +1.02 % bias of the example draw (noise-free value 3.0588 kg)
    assert!((0.007..0.014).contains(&b_one), "one-shot bias {b_one}");
    assert!(b_tare.abs() < 0.0025, "tare bias {b_tare}");
    assert!(b_cal.abs() < 0.0025, "calibration bias {b_cal}");
    assert!(com_err_tare < 0.02, "{com_err_tare}");
}

#[test]
fn calibration_round_trips_through_json_and_toml() {
    let model = lwr4();
    let ctrl = perturbed_model(&model, &LWR4_EXAMPLE_PERTURBATION);
    let s = static_samples(
        &model,
        &InertialParameters::zero(),
        &ctrl,
        &workspace(60, 0),
        |_, _| 0.0,
    );
    let cal = Calibration::identify(&model, &s, &EstimateOptions::default()).unwrap();
    let dir = std::env::temp_dir().join(format!("estimator-cal-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for name in ["cal.json", "cal.toml"] {
        let path = dir.join(name);
        cal.save(&path).unwrap();
        let back = Calibration::load(&path).unwrap();
        assert_eq!(back.base_columns, cal.base_columns);
        for (a, b) in back.delta.iter().zip(&cal.delta) {
            assert!((a - b).abs() <= 1e-12 * a.abs().max(1e-12));
        }
    }
    // noise-free: calibration + one-shot is exact for both methods
    let loaded = static_samples(&model, &heavy(), &ctrl, &q10(), |_, _| 0.0);
    for method in [Method::Direct, Method::Coefficients] {
        let e = estimate_with_calibration(
            &model,
            &loaded,
            &cal,
            &EstimateOptions {
                method,
                ..Default::default()
            },
        )
        .unwrap();
        assert!((e.mass - 3.028).abs() < 1e-6, "{method:?} {}", e.mass);
    }
    // a 2R calibration does not fit the LWR
    let wrong = Calibration { joints: 2, ..cal };
    assert!(matches!(
        estimate_with_calibration(&model, &loaded, &wrong, &EstimateOptions::default()),
        Err(EstimatorError::CalibrationMismatch(_))
    ));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn tare_pose_mismatch_is_a_clear_error() {
    let model = lwr4();
    let loaded = static_samples(&model, &heavy(), &model, &q10(), |_, _| 0.0);
    let mut shifted = q10();
    shifted[3][4] += 0.01;
    let tare = static_samples(
        &model,
        &InertialParameters::zero(),
        &model,
        &shifted,
        |_, _| 0.0,
    );
    let err = estimate_with_tare(
        &model,
        &loaded,
        &tare,
        DEFAULT_TARE_TOLERANCE,
        &EstimateOptions::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(
        err.contains("sample 4") && err.contains("joint 5") && err.contains("same poses"),
        "{err}"
    );
    let err = estimate_with_tare(
        &model,
        &loaded,
        &tare[..9],
        DEFAULT_TARE_TOLERANCE,
        &EstimateOptions::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(
        err.contains("10 loaded samples but 9 tare samples"),
        "{err}"
    );
}

#[test]
fn validation_errors_say_what_to_do() {
    let model = lwr4();
    let opts = EstimateOptions::default();
    let poses = q10();
    let one = static_samples(&model, &heavy(), &model, &poses[..1], |_, _| 0.0);
    assert!(matches!(
        estimate(&model, &one, &opts),
        Err(EstimatorError::TooFewSamples { .. })
    ));
    // the same pose ten times: rank deficient
    let same = static_samples(&model, &heavy(), &model, &vec![poses[0]; 10], |_, _| 0.0);
    let err = estimate(&model, &same, &opts).unwrap_err().to_string();
    assert!(err.contains("poses too similar: condition number"), "{err}");
    let mut nan = static_samples(&model, &heavy(), &model, &poses, |_, _| 0.0);
    nan[2].tau[3] = f64::NAN;
    let err = estimate(&model, &nan, &opts).unwrap_err().to_string();
    assert!(err.contains("sample 3") && err.contains("tau4"), "{err}");
    let mut moving = static_samples(&model, &heavy(), &model, &poses, |_, _| 0.0);
    moving[5].qd = Some(SVector::from_element(0.2));
    let err = estimate(&model, &moving, &opts).unwrap_err().to_string();
    assert!(err.contains("not static"), "{err}");
    // no payload at all: mass ≈ 0 → negative in half the cases; never a CoM from nothing
    let empty = static_samples(
        &model,
        &InertialParameters::zero(),
        &model,
        &poses,
        |k, j| if (k + j) % 2 == 0 { 0.05 } else { -0.05 },
    );
    if let Ok(e) = estimate(&model, &empty, &opts) {
        assert!(
            e.mass < 5.0 * e.mass_std,
            "an empty gripper must not look like a payload: {} ± {}",
            e.mass,
            e.mass_std
        );
    }
}
