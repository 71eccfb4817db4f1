//! Self-consistency of the algorithms over random states (proptest): RNEA = M q̈ + C q̇ + g,
//! regressors linear-exact, two routes to Cᵀq̇ equal to the gradient of the kinetic energy,
//! Ṁ − 2C skew, forward dynamics inverts RNEA, Jacobians match finite differences of FK,
//! classical and modified DH give the same torques (paper question Q2).
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use dynamics::{
    Data, InertialParameters, Model, compute_generalized_gravity, coriolis_centrifugal_torques,
    coriolis_matrix, coriolis_transpose_times_velocity, crba, forward_dynamics, forward_kinematics,
    gravity_regressor, joint_torque_regressor, lwr4, lwr4_modified_dh,
    mass_matrix_partial_derivatives, mass_matrix_time_derivative, nonlinear_effects,
    payload_gravity_regressor, payload_regressor, planar_2r, point_jacobian, rnea,
};
use nalgebra::{SMatrix, SVector, Vector3};
use proptest::prelude::*;

fn state7() -> impl Strategy<Value = (SVector<f64, 7>, SVector<f64, 7>, SVector<f64, 7>)> {
    let limits = lwr4().limits().position_max;
    (
        proptest::array::uniform7(-1.0f64..1.0),
        proptest::array::uniform7(-2.0f64..2.0),
        proptest::array::uniform7(-5.0f64..5.0),
    )
        .prop_map(move |(q, qd, qdd)| {
            (
                SVector::from(q).component_mul(&limits),
                SVector::from(qd),
                SVector::from(qdd),
            )
        })
}

fn rel_err<const R: usize, const C: usize>(a: &SMatrix<f64, R, C>, b: &SMatrix<f64, R, C>) -> f64 {
    (a - b).abs().max() / b.abs().max().max(1.0)
}

fn payload_strategy() -> impl Strategy<Value = InertialParameters> {
    (
        0.0f64..5.0,
        proptest::array::uniform3(-0.2f64..0.2),
        proptest::array::uniform3(0.001f64..0.05),
    )
        .prop_map(|(m, c, i)| {
            InertialParameters::from_com(
                m,
                Vector3::from(c),
                nalgebra::Matrix3::from_diagonal(&Vector3::new(
                    i[0],
                    i[1],
                    i[0].max(i[1]).min(i[0] + i[1]),
                )),
            )
        })
}

/// Kinetic energy ½ q̇ᵀ M(q) q̇.
fn kinetic<const N: usize>(
    model: &Model<N>,
    data: &mut Data<N>,
    q: &SVector<f64, N>,
    qd: &SVector<f64, N>,
) -> f64 {
    0.5 * (qd.transpose() * crba(model, data, q) * qd)[(0, 0)]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn rnea_equals_mass_matrix_coriolis_gravity((q, qd, qdd) in state7()) {
        let model = lwr4();
        let mut data = Data::new(&model);
        let tau = rnea(&model, &mut data, &q, &qd, &qdd);
        let m = crba(&model, &mut data, &q);
        let c = coriolis_matrix(&model, &mut data, &q, &qd);
        let g = compute_generalized_gravity(&model, &mut data, &q);
        prop_assert!(rel_err(&(m * qdd + c * qd + g), &tau) < 1e-12);
        let h = nonlinear_effects(&model, &mut data, &q, &qd);
        prop_assert!(rel_err(&(c * qd + g), &h) < 1e-12);
        let cqd = coriolis_centrifugal_torques(&model, &mut data, &q, &qd);
        prop_assert!((cqd - c * qd).abs().max() < 1e-12 * h.abs().max().max(1.0));
        prop_assert!(rel_err(&m, &m.transpose()) == 0.0);
    }

    #[test]
    fn coriolis_transpose_two_routes_and_energy_gradient((q, qd, _qdd) in state7()) {
        let model = lwr4();
        let mut data = Data::new(&model);
        let fast = coriolis_transpose_times_velocity(&model, &mut data, &q, &qd);
        let from_matrix = coriolis_matrix(&model, &mut data, &q, &qd).transpose() * qd;
        prop_assert!(rel_err(&fast, &from_matrix) < 1e-12, "fast {} vs Cᵀq̇ from C {}", fast, from_matrix);
        // Third route: Cᵀq̇ = Ṁq̇ − Cq̇ with Cq̇ from the RNEA (h − g).
        let mdot = mass_matrix_time_derivative(&model, &mut data, &q, &qd);
        let c_qd = nonlinear_effects(&model, &mut data, &q, &qd) - compute_generalized_gravity(&model, &mut data, &q);
        prop_assert!(rel_err(&fast, &(mdot * qd - c_qd)) < 1e-12);
        // ∂(½ q̇ᵀ M q̇)/∂q by central differences.
        let h = 1e-6;
        let gradient = SVector::<f64, 7>::from_fn(|i, _| {
            let mut qp = q;
            let mut qm = q;
            qp[i] += h;
            qm[i] -= h;
            (kinetic(&model, &mut data, &qp, &qd) - kinetic(&model, &mut data, &qm, &qd)) / (2.0 * h)
        });
        prop_assert!((fast - gradient).abs().max() < 1e-7 * fast.abs().max().max(1.0), "fast {} fd {}", fast, gradient);
    }

    #[test]
    fn mass_matrix_derivative_and_skew_symmetry((q, qd, _qdd) in state7()) {
        let model = lwr4();
        let mut data = Data::new(&model);
        let dm = mass_matrix_partial_derivatives(&model, &mut data, &q);
        let h = 1e-6;
        for k in 0..7 {
            let mut qp = q;
            let mut qm = q;
            qp[k] += h;
            qm[k] -= h;
            let fd = (crba(&model, &mut data, &qp) - crba(&model, &mut data, &qm)) / (2.0 * h);
            prop_assert!((dm[k] - fd).abs().max() < 1e-8, "dM/dq{k}");
        }
        let mdot = mass_matrix_time_derivative(&model, &mut data, &q, &qd);
        let c = coriolis_matrix(&model, &mut data, &q, &qd);
        let n = mdot - c * 2.0;
        prop_assert!((n + n.transpose()).abs().max() < 1e-12 * mdot.abs().max().max(1.0));
        // Ṁ = C + Cᵀ
        prop_assert!(rel_err(&(c + c.transpose()), &mdot) < 1e-12);
    }

    #[test]
    fn full_regressor_is_linear_exact((q, qd, qdd) in state7(), payload in payload_strategy()) {
        let model = lwr4().with_payload(&payload);
        let mut data = Data::new(&model);
        let tau = rnea(&model, &mut data, &q, &qd, &qdd);
        let blocks = joint_torque_regressor(&model, &mut data, &q, &qd, &qdd);
        let mut sum = SVector::<f64, 7>::zeros();
        for (b, block) in blocks.iter().enumerate() {
            sum += block * model.links()[b].to_vector();
        }
        prop_assert!(rel_err(&sum, &tau) < 1e-12, "Yp {} vs rnea {}", sum, tau);
        // Regressor rows above the link are zero: joint j > b does not carry link b.
        for (b, block) in blocks.iter().enumerate() {
            for j in (b + 1)..7 {
                prop_assert!(block.row(j).iter().all(|v| *v == 0.0));
            }
        }
    }

    #[test]
    fn payload_regressors_are_linear_exact((q, qd, qdd) in state7(), payload in payload_strategy()) {
        let robot = lwr4();
        let loaded = robot.with_payload(&payload);
        let mut data = Data::new(&robot);
        let delta = rnea(&loaded, &mut data, &q, &qd, &qdd) - rnea(&robot, &mut data, &q, &qd, &qdd);
        let y = payload_regressor(&robot, &mut data, &q, &qd, &qdd);
        prop_assert!((y * payload.to_vector() - delta).abs().max() < 1e-12 * delta.abs().max().max(1.0));
        // The last block of the full regressor is the payload regressor.
        let blocks = joint_torque_regressor(&robot, &mut data, &q, &qd, &qdd);
        prop_assert!(rel_err(&blocks[6], &y) == 0.0 || rel_err(&blocks[6], &y) < 1e-15);
        // Static: gravity part.
        let dg = compute_generalized_gravity(&loaded, &mut data, &q) - compute_generalized_gravity(&robot, &mut data, &q);
        let yg = payload_gravity_regressor(&robot, &mut data, &q);
        let p4 = payload.to_vector().fixed_rows::<4>(0).into_owned();
        prop_assert!((yg * p4 - dg).abs().max() < 1e-12 * dg.abs().max().max(1.0));
        let zero = SVector::<f64, 7>::zeros();
        let y_static = payload_regressor(&robot, &mut data, &q, &zero, &zero);
        prop_assert!((y_static.fixed_columns::<4>(0) - yg).abs().max() < 1e-13);
        prop_assert!(y_static.fixed_columns::<6>(4).abs().max() < 1e-13);
    }

    #[test]
    fn gravity_regressor_is_linear_exact((q, _qd, _qdd) in state7()) {
        let model = lwr4();
        let mut data = Data::new(&model);
        let g = compute_generalized_gravity(&model, &mut data, &q);
        let blocks = gravity_regressor(&model, &mut data, &q);
        let mut sum = SVector::<f64, 7>::zeros();
        for (b, block) in blocks.iter().enumerate() {
            sum += block * model.links()[b].to_vector().fixed_rows::<4>(0);
        }
        prop_assert!(rel_err(&sum, &g) < 1e-12);
    }

    #[test]
    fn forward_dynamics_inverts_rnea((q, qd, qdd) in state7()) {
        let model = lwr4();
        let mut data = Data::new(&model);
        let tau = rnea(&model, &mut data, &q, &qd, &qdd);
        let back = forward_dynamics(&model, &mut data, &q, &qd, &tau).unwrap();
        // M is ill-conditioned at the wrist (≈1e-4 kg·m²), so compare torques of the result.
        let tau_back = rnea(&model, &mut data, &q, &qd, &back);
        prop_assert!(rel_err(&tau_back, &tau) < 1e-10);
        prop_assert!((back - qdd).abs().max() < 1e-6 * qdd.abs().max().max(1.0));
    }

    #[test]
    fn point_jacobian_matches_finite_differences((q, qd, _qdd) in state7(), link in 0usize..7,
        p in proptest::array::uniform3(-0.2f64..0.2)) {
        let model = lwr4();
        let mut data = Data::new(&model);
        let point = Vector3::from(p);
        let jac = point_jacobian(&model, &mut data, &q, link, &point);
        let h = 1e-6;
        let frames_p = forward_kinematics(&model, &mut data, &(q + qd * h));
        let frames_m = forward_kinematics(&model, &mut data, &(q - qd * h));
        let v_fd = (frames_p[link] * nalgebra::Point3::from(point) - frames_m[link] * nalgebra::Point3::from(point)) / (2.0 * h);
        let v = (jac * qd).fixed_rows::<3>(0).into_owned();
        prop_assert!((v - v_fd).norm() < 1e-7, "v {} vs fd {}", v, v_fd);
        // Angular velocity: R(q + h q̇) Rᵀ(q − h q̇) ≈ exp(2h [ω]).
        let dr = frames_p[link].rotation * frames_m[link].rotation.inverse();
        let w_fd = dr.scaled_axis() / (2.0 * h);
        let w = (jac * qd).fixed_rows::<3>(3).into_owned();
        prop_assert!((w - w_fd).norm() < 1e-7, "w {} vs fd {}", w, w_fd);
    }

    /// Question Q2 of the paper: classical and modified DH descriptions of the same robot give
    /// identical torques, mass matrices, and payload regressors (frame 7 coincides), hence
    /// identical payload estimates.
    #[test]
    fn classical_and_modified_dh_agree((q, qd, qdd) in state7(), payload in payload_strategy()) {
        let dh = lwr4().with_payload(&payload);
        let mdh = lwr4_modified_dh().with_payload(&payload);
        let mut data = Data::new(&dh);
        prop_assert!(rel_err(&rnea(&mdh, &mut data, &q, &qd, &qdd), &rnea(&dh, &mut data, &q, &qd, &qdd)) < 1e-12);
        prop_assert!(rel_err(&crba(&mdh, &mut data, &q), &crba(&dh, &mut data, &q)) < 1e-12);
        prop_assert!(rel_err(
            &payload_regressor(&mdh, &mut data, &q, &qd, &qdd),
            &payload_regressor(&dh, &mut data, &q, &qd, &qdd)) < 1e-12);
        prop_assert!(rel_err(
            &coriolis_transpose_times_velocity(&mdh, &mut data, &q, &qd),
            &coriolis_transpose_times_velocity(&dh, &mut data, &q, &qd)) < 1e-12);
        let fk_dh = forward_kinematics(&dh, &mut data, &q);
        let fk_mdh = forward_kinematics(&mdh, &mut data, &q);
        // Same origins for every frame; frame 7 identical.
        for i in 0..7 {
            prop_assert!((fk_dh[i].translation.vector - fk_mdh[i].translation.vector).norm() < 1e-12);
        }
        prop_assert!((fk_dh[6].to_homogeneous() - fk_mdh[6].to_homogeneous()).abs().max() < 1e-12);
    }

    #[test]
    fn planar_2r_consistency(q in proptest::array::uniform2(-3.0f64..3.0), qd in proptest::array::uniform2(-2.0f64..2.0)) {
        let model = planar_2r();
        let mut data = Data::new(&model);
        let q = SVector::from(q);
        let qd = SVector::from(qd);
        let fast = coriolis_transpose_times_velocity(&model, &mut data, &q, &qd);
        let slow = coriolis_matrix(&model, &mut data, &q, &qd).transpose() * qd;
        prop_assert!((fast - slow).abs().max() < 1e-12);
    }
}

/// Q2 end to end: least-squares payload estimates from static torques agree between the two
/// descriptions (to rounding).
#[test]
fn classical_and_modified_dh_give_identical_payload_estimates() {
    let dh = lwr4();
    let mdh = lwr4_modified_dh();
    let payload = dynamics::lwr4_heavy_payload();
    let mut data = Data::new(&dh);
    let estimate = |model: &Model<7>, data: &mut Data<7>| {
        let loaded = model.with_payload(&payload);
        let mut normal = nalgebra::Matrix4::<f64>::zeros();
        let mut rhs = nalgebra::Vector4::<f64>::zeros();
        for k in 1..=50 {
            let primes = [2.0f64, 3.0, 5.0, 7.0, 11.0, 13.0, 17.0];
            let q = SVector::<f64, 7>::from_fn(|j, _| {
                let u = 2.0 * (k as f64 * primes[j].sqrt()).fract() - 1.0;
                u * model.limits().position_max[j]
            });
            let tau = compute_generalized_gravity(&loaded, data, &q)
                - compute_generalized_gravity(model, data, &q);
            let y = payload_gravity_regressor(model, data, &q);
            normal += y.transpose() * y;
            rhs += y.transpose() * tau;
        }
        normal.cholesky().unwrap().solve(&rhs)
    };
    let p_dh = estimate(&dh, &mut data);
    let p_mdh = estimate(&mdh, &mut data);
    assert!((p_dh - p_mdh).abs().max() < 1e-12, "{p_dh} vs {p_mdh}");
    assert!((p_dh[0] - 3.028).abs() < 1e-12);
    assert!((p_dh[3] - 3.028 * 0.119).abs() < 1e-12);
}

/// FK is the chain of the joints' public `link_pose`; at q = 0 the LWR points straight up with the
/// flange 0.4 + 0.39 + 0.078 m above frame 0.
#[test]
fn forward_kinematics_is_the_chain_of_link_poses() {
    let model = lwr4();
    let mut data = Data::new(&model);
    let q = SVector::<f64, 7>::from([0.4, -0.7, 1.1, 0.3, -1.9, 0.8, 2.2]);
    let frames = forward_kinematics(&model, &mut data, &q);
    let mut chained = nalgebra::Isometry3::identity();
    for (i, joint) in model.joints().iter().enumerate() {
        chained *= joint.link_pose(q[i]);
        assert!(
            (chained.to_homogeneous() - frames[i].to_homogeneous())
                .abs()
                .max()
                < 1e-14
        );
    }
    let zero = dynamics::flange_pose(&model, &mut data, &SVector::zeros());
    assert!((zero.translation.vector - Vector3::new(0.0, 0.0, 0.868)).norm() < 1e-15);
    assert!(zero.rotation.angle() < 1e-15);
    // Frames 5, 6, 7 share the wrist point; frames 3 and 4 the elbow.
    let frames = forward_kinematics(&model, &mut data, &q);
    assert!((frames[4].translation.vector - frames[6].translation.vector).norm() < 1e-15);
    assert!((frames[2].translation.vector - frames[3].translation.vector).norm() < 1e-15);
    assert!(
        ((frames[4].translation.vector - frames[2].translation.vector).norm() - 0.39).abs() < 1e-14
    );
}
