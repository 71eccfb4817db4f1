//! Cross-check against Pinocchio 4.1 (an independent implementation): fixtures written by
//! tools/gen_dynamics_fixtures.py at 50 random states within the LWR limits. Every quantity must
//! agree to 1e-9 relative to its largest entry.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use dynamics::{
    Data, compute_generalized_gravity, coriolis_matrix, coriolis_transpose_times_velocity, crba,
    flange_jacobian, flange_pose, forward_dynamics, joint_torque_regressor, lwr4,
    nonlinear_effects, payload_gravity_regressor, payload_regressor, rnea,
};
use nalgebra::{DMatrix, SMatrix, SVector};
use serde_json::Value;

mod common;
use common::christoffel::christoffel_coriolis_matrix;
use common::{matrix, vector};

const TOLERANCE: f64 = 1e-9;

fn fixture() -> Value {
    let text = include_str!("fixtures/pinocchio-lwr4.json");
    serde_json::from_str(text).unwrap()
}

fn check<const R: usize, const C: usize>(
    what: &str,
    state: usize,
    got: &SMatrix<f64, R, C>,
    want: &SMatrix<f64, R, C>,
) -> f64 {
    let scale = want.abs().max();
    let err = (got - want).abs().max();
    let relative = if scale > 0.0 { err / scale } else { err };
    assert!(
        relative <= TOLERANCE,
        "state {state}: {what} differs by {err:e} (relative {relative:e})\n got {got}\nwant {want}"
    );
    relative
}

#[test]
fn lwr4_matches_pinocchio_at_50_random_states() {
    let fixture = fixture();
    let states = fixture["states"].as_array().unwrap();
    assert!(states.len() >= 50);
    let model = lwr4();
    let mut data = Data::new(&model);
    let mut worst: f64 = 0.0;
    for (k, s) in states.iter().enumerate() {
        let q: SVector<f64, 7> = vector(&s["q"]);
        let qd: SVector<f64, 7> = vector(&s["qd"]);
        let qdd: SVector<f64, 7> = vector(&s["qdd"]);
        assert!(model.limits().contains_position(&q));
        let checks = [
            check("M", k, &crba(&model, &mut data, &q), &matrix(&s["M"])),
            check(
                "g",
                k,
                &compute_generalized_gravity(&model, &mut data, &q),
                &vector(&s["g"]),
            ),
            check(
                "tau",
                k,
                &rnea(&model, &mut data, &q, &qd, &qdd),
                &vector(&s["tau"]),
            ),
            check(
                "nonlinear effects",
                k,
                &nonlinear_effects(&model, &mut data, &q, &qd),
                &vector(&s["nonlinear_effects"]),
            ),
            check(
                "C^T qd (O(n) route)",
                k,
                &coriolis_transpose_times_velocity(&model, &mut data, &q, &qd),
                &vector(&s["coriolis_transpose_qd"]),
            ),
            check(
                "C^T qd (from coriolis_matrix)",
                k,
                &(coriolis_matrix(&model, &mut data, &q, &qd).transpose() * qd),
                &vector(&s["coriolis_transpose_qd"]),
            ),
            check(
                "payload regressor",
                k,
                &payload_regressor(&model, &mut data, &q, &qd, &qdd),
                &matrix(&s["payload_regressor"]),
            ),
            check(
                "payload gravity regressor",
                k,
                &payload_gravity_regressor(&model, &mut data, &q),
                &matrix(&s["payload_gravity_regressor"]),
            ),
            check(
                "flange pose",
                k,
                &flange_pose(&model, &mut data, &q).to_homogeneous(),
                &matrix(&s["flange_pose"]),
            ),
            check(
                "flange Jacobian",
                k,
                &flange_jacobian(&model, &mut data, &q),
                &matrix(&s["flange_jacobian"]),
            ),
        ];
        worst = checks.iter().fold(worst, |a, b| a.max(*b));

        // Forward dynamics: Pinocchio's ABA applied to τ = RNEA(q, q̇, q̈).
        let tau: SVector<f64, 7> = vector(&s["tau"]);
        let qdd_fd = forward_dynamics(&model, &mut data, &q, &qd, &tau).unwrap();
        check(
            "forward dynamics",
            k,
            &qdd_fd,
            &vector(&s["forward_dynamics_qdd"]),
        );

        // Full 7×70 regressor, block by block.
        let want: SMatrix<f64, 7, 70> = matrix(&s["regressor"]);
        let blocks = joint_torque_regressor(&model, &mut data, &q, &qd, &qdd);
        let mut got = DMatrix::<f64>::zeros(7, 70);
        for (b, block) in blocks.iter().enumerate() {
            got.view_mut((0, 10 * b), (7, 10)).copy_from(block);
        }
        let got = SMatrix::<f64, 7, 70>::from_iterator(got.iter().copied());
        worst = worst.max(check("regressor", k, &got, &want));
    }
    eprintln!("worst relative difference to Pinocchio: {worst:e}");
    assert!(worst <= TOLERANCE);
}

/// A 5-joint arm with a_i ≠ 0, joint offsets θ_i, two prismatic joints, a tilted gravity vector
/// and a rotated flange (built in Pinocchio from the same classical DH rows), loaded here through
/// the TOML robot-file types.
#[test]
fn generic_arm_with_prismatic_joints_matches_pinocchio() {
    use dynamics::{ClassicalDh, JointKind, JointSpec, LinkSpec, Model, PoseSpec, RobotFile};
    let fixture = fixture();
    let generic = &fixture["generic_5dof"];
    let rows = generic["dh"].as_array().unwrap();
    let links = generic["links"].as_array().unwrap();
    let f64_of = |v: &Value| v.as_f64().unwrap();
    let array3 = |v: &Value| -> [f64; 3] {
        let a = v.as_array().unwrap();
        [f64_of(&a[0]), f64_of(&a[1]), f64_of(&a[2])]
    };
    let joints = rows
        .iter()
        .zip(links)
        .map(|(row, link)| {
            let inertia = link["I_com"].as_array().unwrap();
            JointSpec {
                name: None,
                kind: Some(match row["type"].as_str().unwrap() {
                    "revolute" => JointKind::Revolute,
                    _ => JointKind::Prismatic,
                }),
                dh: Some(ClassicalDh {
                    a: f64_of(&row["a"]),
                    alpha: f64_of(&row["alpha"]),
                    d: f64_of(&row["d"]),
                    theta: f64_of(&row["theta"]),
                }),
                link: Some(LinkSpec {
                    mass: f64_of(&link["m"]),
                    com: array3(&link["c"]),
                    inertia_com: Some(std::array::from_fn(|i| f64_of(&inertia[i]))),
                    inertia_origin: None,
                }),
                ..Default::default()
            }
        })
        .collect();
    let flange_rotation: SMatrix<f64, 3, 3> = matrix(&generic["flange"]["rotation"]);
    let (roll, pitch, yaw) =
        nalgebra::Rotation3::from_matrix_unchecked(flange_rotation).euler_angles();
    let file = RobotFile {
        name: "generic".into(),
        gravity: array3(&generic["gravity"]),
        flange: PoseSpec {
            translation: array3(&generic["flange"]["translation"]),
            rpy: [roll, pitch, yaw],
        },
        joints,
    };
    // Through the TOML text, to exercise the writer and the reader as well.
    let text = file.to_toml_string().unwrap();
    let model = Model::<5>::from_toml_str(&text).unwrap();
    let mut data = Data::new(&model);
    let states = generic["states"].as_array().unwrap();
    assert_eq!(states.len(), 20);
    let mut worst: f64 = 0.0;
    for (k, s) in states.iter().enumerate() {
        let q: SVector<f64, 5> = vector(&s["q"]);
        let qd: SVector<f64, 5> = vector(&s["qd"]);
        let qdd: SVector<f64, 5> = vector(&s["qdd"]);
        worst = worst.max(check(
            "M",
            k,
            &crba(&model, &mut data, &q),
            &matrix(&s["M"]),
        ));
        worst = worst.max(check(
            "g",
            k,
            &compute_generalized_gravity(&model, &mut data, &q),
            &vector(&s["g"]),
        ));
        worst = worst.max(check(
            "tau",
            k,
            &rnea(&model, &mut data, &q, &qd, &qdd),
            &vector(&s["tau"]),
        ));
        worst = worst.max(check(
            "flange pose",
            k,
            &flange_pose(&model, &mut data, &q).to_homogeneous(),
            &matrix(&s["flange_pose"]),
        ));
        // Regressor linear-exact and Cᵀq̇ routes agree on this arm too.
        let blocks = joint_torque_regressor(&model, &mut data, &q, &qd, &qdd);
        let mut sum = SVector::<f64, 5>::zeros();
        for (b, block) in blocks.iter().enumerate() {
            sum += block * model.links()[b].to_vector();
        }
        check("Y p", k, &sum, &vector(&s["tau"]));
        check(
            "C^T qd routes",
            k,
            &coriolis_transpose_times_velocity(&model, &mut data, &q, &qd),
            &(coriolis_matrix(&model, &mut data, &q, &qd).transpose() * qd),
        );
        // Prismatic joints and a ≠ 0: the recursion is still the Christoffel matrix.
        check(
            "C recursive vs Christoffel",
            k,
            &coriolis_matrix(&model, &mut data, &q, &qd),
            &christoffel_coriolis_matrix(&model, &mut data, &q, &qd),
        );
    }
    eprintln!("generic arm: worst relative difference to Pinocchio {worst:e}");
}
