//! The reference model's golden values (shared/data/lwr4-golden.json, copied to
//! tests/fixtures/) and the paper's planar 2R numbers (lwr4-model.md §7).
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use dynamics::{
    Data, InertialParameters, compute_generalized_gravity, crba, lwr4, lwr4_heavy_payload,
    lwr4_light_payload, payload_gravity_regressor, planar_2r, planar_2r_payload, rnea,
};
use nalgebra::{SMatrix, SVector, Vector3, Vector4};
use serde_json::Value;

mod common;
use common::{matrix, vector};

fn golden() -> Value {
    let text = include_str!("fixtures/lwr4-golden.json");
    serde_json::from_str(text).unwrap()
}

/// The JSON holds 12 significant digits: compare at 1e-10 relative to the largest entry.
fn assert_close<const R: usize, const C: usize>(
    what: &str,
    got: &SMatrix<f64, R, C>,
    want: &SMatrix<f64, R, C>,
    tol: f64,
) {
    let scale = want.abs().max().max(1.0);
    let err = (got - want).abs().max();
    assert!(
        err <= tol * scale,
        "{what}: max abs error {err:e} (scale {scale})\n got {got}\nwant {want}"
    );
}

#[test]
fn lwr4_gravity_mass_matrix_and_payload_match_golden_configs() {
    let g = golden();
    let model = lwr4();
    let mut data = Data::new(&model);
    let heavy = lwr4_heavy_payload();
    let light = lwr4_light_payload();
    let heavy_model = model.with_payload(&heavy);
    let configs = g["configs"].as_array().unwrap();
    assert_eq!(configs.len(), 5);
    for config in configs {
        let name = config["name"].as_str().unwrap();
        let q: SVector<f64, 7> = vector(&config["q"]);
        let g_robot = compute_generalized_gravity(&model, &mut data, &q);
        assert_close(
            &format!("{name} g"),
            &g_robot,
            &vector(&config["g_robot"]),
            1e-10,
        );
        let mass = crba(&model, &mut data, &q);
        assert_close(&format!("{name} M"), &mass, &matrix(&config["M"]), 1e-10);

        let y = payload_gravity_regressor(&model, &mut data, &q);
        assert_close(
            &format!("{name} Y_payload"),
            &y,
            &matrix(&config["Y_payload"]),
            1e-10,
        );
        let p_heavy = Vector4::new(heavy.mass, 0.0, 0.0, heavy.first_moment.z);
        let p_light = Vector4::new(light.mass, 0.0, 0.0, light.first_moment.z);
        assert_close(
            &format!("{name} g_payload"),
            &(y * p_heavy),
            &vector(&config["g_payload"]),
            1e-10,
        );
        assert_close(
            &format!("{name} g_payload_light"),
            &(y * p_light),
            &vector(&config["g_payload_light"]),
            1e-10,
        );
        // The same through the model with the payload added (eqs. 16-19).
        let g_loaded = compute_generalized_gravity(&heavy_model, &mut data, &q);
        assert_close(
            &format!("{name} g with payload"),
            &(g_loaded - g_robot),
            &vector(&config["g_payload"]),
            1e-10,
        );
    }
}

#[test]
fn lwr4_printed_values_of_the_model_document() {
    // lwr4-model.md §3, rounded to the printed 4 decimals: qA row of g_robot and g_payload.
    let model = lwr4();
    let mut data = Data::new(&model);
    let q = SVector::<f64, 7>::from([0.3, std::f64::consts::FRAC_PI_2, 0.0, 0.0, 0.0, 0.0, 0.0]);
    let g = compute_generalized_gravity(&model, &mut data, &q);
    let printed = [0.0, -47.2782, -0.4040, 13.3670, -0.4087, -0.2806, -0.0094];
    for (i, p) in printed.iter().enumerate() {
        assert!(
            (g[i] - p).abs() <= 0.5e-4,
            "g[{i}] = {} vs printed {p}",
            g[i]
        );
    }
    // Flange variant of the pick pose: payload CoM measured from the flange (z + 0.078).
    let pick = SVector::<f64, 7>::from(dynamics::LWR4_PICK_POSE_RAD);
    let y = payload_gravity_regressor(&model, &mut data, &pick);
    let g_flange = y * Vector4::new(3.028, 0.0, 0.0, 3.028 * (0.119 + 0.078));
    let printed = [0.0, -20.4517, 0.0, 14.5107, 0.0, -2.9259, 0.0];
    for (i, p) in printed.iter().enumerate() {
        assert!(
            (g_flange[i] - p).abs() <= 0.5e-4,
            "flange variant g[{i}] = {}",
            g_flange[i]
        );
    }
    // Total link mass printed as 17.29 kg.
    assert!((model.total_mass() - 17.29).abs() < 0.005);
    // Gravity at the horizontal arm, printed −47.3 Nm.
    assert!((g[1] + 47.3).abs() < 0.05);
}

#[test]
fn rnea_at_rest_equals_gravity_on_golden_configs() {
    let g = golden();
    let model = lwr4();
    let mut data = Data::new(&model);
    let zero = SVector::<f64, 7>::zeros();
    for config in g["configs"].as_array().unwrap() {
        let q: SVector<f64, 7> = vector(&config["q"]);
        let tau = rnea(&model, &mut data, &q, &zero, &zero);
        assert_close("rnea(q,0,0)", &tau, &vector(&config["g_robot"]), 1e-10);
    }
}

#[test]
fn planar_2r_matches_paper_golden_values() {
    let g = golden();
    let robot = planar_2r();
    let loaded = robot.with_payload(&planar_2r_payload());
    let mut data = Data::new(&robot);
    let cases = g["planar_2r"]["golden"].as_array().unwrap();
    assert_eq!(cases.len(), 4);
    for case in cases {
        let model = if case["payload"].as_bool().unwrap() {
            &loaded
        } else {
            &robot
        };
        let q: SVector<f64, 2> = vector(&case["q"]);
        let gq = compute_generalized_gravity(model, &mut data, &q);
        assert_close("2R g", &gq, &vector(&case["g"]), 1e-10);
        let mass = crba(model, &mut data, &q);
        assert_close("2R M", &mass, &matrix(&case["M"]), 1e-10);
    }
}

/// The paper's coefficient vector π (eq. 29) reproduces M and g through the closed forms of
/// lwr4-model.md §7 at arbitrary configurations, with and without payload.
#[test]
fn planar_2r_coefficients_of_eq29_reproduce_the_dynamics() {
    let g = golden();
    let pi_robot: SVector<f64, 6> = vector(&g["planar_2r"]["pi_robot"]);
    let pi_loaded: SVector<f64, 6> = vector(&g["planar_2r"]["pi_with_payload"]);
    // Printed in the document: (0.11125, 0.6, 0.04, 1.36515, 3.2, 0.03).
    assert_eq!(
        pi_robot.as_slice(),
        &[0.11125, 0.6, 0.04, 1.36515, 3.2, 0.03]
    );
    let robot = planar_2r();
    let loaded = robot.with_payload(&planar_2r_payload());
    let mut data = Data::new(&robot);
    for (model, pi) in [(&robot, pi_robot), (&loaded, pi_loaded)] {
        for k in 0..20 {
            let q = SVector::<f64, 2>::new(0.37 * k as f64 - 3.0, 1.1 - 0.29 * k as f64);
            let kq = pi[1] * q[1].cos() - pi[2] * q[1].sin();
            let m_formula = SMatrix::<f64, 2, 2>::new(
                2.0 * (pi[0] + pi[3]) + 2.0 * kq,
                2.0 * pi[0] + kq,
                2.0 * pi[0] + kq,
                2.0 * pi[0],
            );
            let g0 = 9.81;
            let g2 = g0 * (pi[1] * (q[0] + q[1]).cos() - pi[2] * (q[0] + q[1]).sin());
            let g1 = g0 * (pi[4] * q[0].cos() - pi[5] * q[0].sin()) + g2;
            assert_close("M(π)", &crba(model, &mut data, &q), &m_formula, 1e-12);
            assert_close(
                "g(π)",
                &compute_generalized_gravity(model, &mut data, &q),
                &SVector::<f64, 2>::new(g1, g2),
                1e-12,
            );
        }
    }
}

#[test]
fn planar_2r_parameters_are_the_papers() {
    let robot = planar_2r();
    let links = robot.links();
    assert_eq!(links[0].mass, 3.0);
    assert!((links[0].inertia_origin[(2, 2)] - 1.3303).abs() < 1e-12);
    assert!((links[1].inertia_origin[(2, 2)] - 0.1225).abs() < 1e-12);
    let payload: InertialParameters = planar_2r_payload();
    assert!((payload.inertia_origin[(2, 2)] - 0.1813).abs() < 1e-12);
    assert!((payload.com().unwrap() - Vector3::new(0.3, 0.1, 0.0)).norm() < 1e-15);
    assert_eq!(robot.gravity(), Vector3::new(0.0, -9.81, 0.0));
}
