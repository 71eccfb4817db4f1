//! Bad input through the public API: typed errors that say what and where, never a panic.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use dynamics::{
    Data, DynamicsError, InertialParameters, JointLimits, Model, check_finite,
    compute_generalized_gravity, crba, forward_dynamics, lwr4, planar_2r, point_jacobian, rnea,
};
use nalgebra::{Matrix3, SVector, Vector3};

#[test]
fn non_finite_states_are_reported_with_name_and_index() {
    let model = lwr4();
    let mut data = Data::new(&model);
    let ok = SVector::<f64, 7>::zeros();
    let mut bad = ok;
    bad[3] = f64::NAN;
    match forward_dynamics(&model, &mut data, &bad, &ok, &ok).unwrap_err() {
        DynamicsError::NonFinite { what, index, value } => {
            assert_eq!((what, index), ("q", 3));
            assert!(value.is_nan());
        }
        other => panic!("unexpected {other:?}"),
    }
    let mut inf = ok;
    inf[6] = f64::INFINITY;
    assert_eq!(
        forward_dynamics(&model, &mut data, &ok, &inf, &ok).unwrap_err(),
        DynamicsError::NonFinite {
            what: "qd",
            index: 6,
            value: f64::INFINITY
        }
    );
    assert_eq!(
        forward_dynamics(&model, &mut data, &ok, &ok, &inf).unwrap_err(),
        DynamicsError::NonFinite {
            what: "tau",
            index: 6,
            value: f64::INFINITY
        }
    );
    assert_eq!(
        check_finite("qdd", &inf).unwrap_err(),
        DynamicsError::NonFinite {
            what: "qdd",
            index: 6,
            value: f64::INFINITY
        }
    );
    assert!(check_finite("q", &ok).is_ok());
    // The infallible algorithms propagate NaN instead of panicking.
    let tau = rnea(&model, &mut data, &bad, &ok, &ok);
    assert!(tau.iter().any(|v| v.is_nan()));
    let g = compute_generalized_gravity(&model, &mut data, &bad);
    assert!(g.iter().any(|v| v.is_nan()));
    // An out-of-range link index gives the zero Jacobian rather than a panic.
    assert_eq!(
        point_jacobian(&model, &mut data, &ok, 7, &Vector3::zeros())
            .abs()
            .max(),
        0.0
    );
}

#[test]
fn singular_mass_matrix_is_reported() {
    // Massless links: M(q) = 0.
    let model = planar_2r().with_links([InertialParameters::zero(), InertialParameters::zero()]);
    let mut data = Data::new(&model);
    let q = SVector::<f64, 2>::new(0.1, 0.2);
    assert_eq!(crba(&model, &mut data, &q).abs().max(), 0.0);
    assert_eq!(
        forward_dynamics(&model, &mut data, &q, &SVector::zeros(), &SVector::zeros()).unwrap_err(),
        DynamicsError::SingularMassMatrix
    );
    // A point mass on the axis of the last joint of the 2R: link 2 contributes nothing about
    // joint 2, so M is singular.
    let on_axis = InertialParameters::point_mass(1.0, Vector3::new(-0.5, 0.0, 0.0));
    let model = planar_2r().with_links([planar_2r().links()[0], on_axis]);
    assert_eq!(
        forward_dynamics(
            &model,
            &mut data,
            &q,
            &SVector::zeros(),
            &SVector::<f64, 2>::new(1.0, 1.0)
        )
        .unwrap_err(),
        DynamicsError::SingularMassMatrix
    );
}

#[test]
fn non_physical_parameters_are_rejected() {
    let good = lwr4().links()[3];
    assert!(good.check_physical().is_ok());
    for link in lwr4().links() {
        assert!(link.check_physical().is_ok());
    }
    assert!(InertialParameters::zero().check_physical().is_ok());
    assert!(
        InertialParameters::point_mass(1.0, Vector3::new(0.1, 0.2, 0.3))
            .check_physical()
            .is_ok()
    );

    let negative = InertialParameters { mass: -1.0, ..good };
    assert_eq!(
        negative.check_physical().unwrap_err(),
        DynamicsError::NegativeMass { mass: -1.0 }
    );

    let mut nan = good;
    nan.first_moment.y = f64::NAN;
    assert!(matches!(
        nan.check_physical().unwrap_err(),
        DynamicsError::NonFinite {
            what: "first_moment",
            index: 1,
            ..
        }
    ));

    let mut asymmetric = good;
    asymmetric.inertia_origin[(0, 1)] += 0.01;
    assert!(matches!(
        asymmetric.check_physical().unwrap_err(),
        DynamicsError::InertiaNotSymmetric { .. }
    ));

    let indefinite = InertialParameters::from_com(
        1.0,
        Vector3::zeros(),
        Matrix3::from_diagonal(&Vector3::new(-0.1, 0.2, 0.2)),
    );
    assert!(matches!(
        indefinite.check_physical().unwrap_err(),
        DynamicsError::InertiaNotPositive { .. }
    ));

    let triangle = InertialParameters::from_com(
        1.0,
        Vector3::zeros(),
        Matrix3::from_diagonal(&Vector3::new(0.1, 0.1, 0.3)),
    );
    match triangle.check_physical().unwrap_err() {
        DynamicsError::TriangleInequality { principal_moments } => {
            assert!((principal_moments[2] - 0.3).abs() < 1e-12)
        }
        other => panic!("unexpected {other:?}"),
    }

    let ghost = InertialParameters {
        mass: 0.0,
        first_moment: Vector3::new(0.1, 0.0, 0.0),
        inertia_origin: Matrix3::zeros(),
    };
    assert!(matches!(
        ghost.check_physical().unwrap_err(),
        DynamicsError::FirstMomentWithoutMass { .. }
    ));

    // Through the model: the error names the link.
    let mut links = *lwr4().links();
    links[4] = negative;
    assert_eq!(
        lwr4().try_with_links(links).unwrap_err(),
        DynamicsError::Link {
            link: 4,
            source: Box::new(DynamicsError::NegativeMass { mass: -1.0 })
        }
    );
}

#[test]
fn invalid_models_are_rejected() {
    let base = lwr4();
    let joints = *base.joints();
    let links = *base.links();
    let bad_gravity = Model::new(
        "x",
        joints,
        links,
        Vector3::new(0.0, f64::NAN, 0.0),
        base.flange(),
        *base.limits(),
    );
    assert!(matches!(
        bad_gravity.unwrap_err(),
        DynamicsError::NonFinite {
            what: "gravity",
            index: 1,
            ..
        }
    ));

    let mut limits = *base.limits();
    limits.velocity_max[2] = 0.0;
    let bad_limits = Model::new("x", joints, links, base.gravity(), base.flange(), limits);
    assert!(matches!(
        bad_limits.unwrap_err(),
        DynamicsError::InvalidLimits { joint: 2, .. }
    ));

    let mut limits = JointLimits::<7>::unlimited();
    limits.position_min[5] = f64::NAN;
    let bad_limits = Model::new("x", joints, links, base.gravity(), base.flange(), limits);
    assert!(matches!(
        bad_limits.unwrap_err(),
        DynamicsError::InvalidLimits { joint: 5, .. }
    ));
}

#[test]
fn inertial_parameter_conversions() {
    let com = Vector3::new(0.01, -0.02, 0.15);
    let about_com = Matrix3::new(
        0.02, 0.001, -0.002, 0.001, 0.03, 0.0005, -0.002, 0.0005, 0.025,
    );
    let p = InertialParameters::from_com(2.5, com, about_com);
    assert!((p.com().unwrap() - com).norm() < 1e-15);
    assert!((p.inertia_about_com() - about_com).abs().max() < 1e-15);
    // Steiner: J_zz about the origin gains m (cx² + cy²).
    assert!(
        (p.inertia_origin[(2, 2)] - (0.025 + 2.5 * (0.01f64.powi(2) + 0.02f64.powi(2)))).abs()
            < 1e-15
    );
    // J_xy about the origin: I_xy − m cx cy.
    assert!((p.inertia_origin[(0, 1)] - (0.001 - 2.5 * 0.01 * -0.02)).abs() < 1e-15);
    let v = p.to_vector();
    assert_eq!(v[0], 2.5);
    assert_eq!(v[5], p.inertia_origin[(0, 1)]);
    assert_eq!(v[6], p.inertia_origin[(0, 2)]);
    assert_eq!(v[7], p.inertia_origin[(1, 1)]);
    assert_eq!(InertialParameters::from_vector(&v), p);
    assert_eq!(InertialParameters::zero().com(), None);
    // Adding a payload is additive in the ten parameters (eqs. 16-19).
    let model = lwr4();
    let loaded = model.with_payload(&p);
    assert_eq!(
        loaded.links()[6].to_vector(),
        model.links()[6].to_vector() + v
    );
    assert_eq!(loaded.links()[5], model.links()[5]);
    // The combined CoM is the mass-weighted average (eq. 16).
    let combined = loaded.links()[6].com().unwrap();
    let m7 = model.links()[6].mass;
    let expected = (model.links()[6].com().unwrap() * m7 + com * 2.5) / (m7 + 2.5);
    assert!((combined - expected).norm() < 1e-15);
}
