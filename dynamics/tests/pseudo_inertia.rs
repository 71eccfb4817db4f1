//! The pseudo-inertia test of a rigid body (Wensing, Kim & Slotine 2017): positive definite
//! for a solid body, singular for a point mass, indefinite for parameters no body has.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use dynamics::{InertialParameters, lwr4};
use nalgebra::{Matrix3, Vector3};

/// A solid box of `mass` kg and sides `a`, `b`, `c` m, its centre at `com` (m).
fn solid_box(mass: f64, [a, b, c]: [f64; 3], com: Vector3<f64>) -> InertialParameters {
    let k = mass / 12.0;
    let inertia = Matrix3::from_diagonal(&Vector3::new(
        k * (b * b + c * c),
        k * (a * a + c * c),
        k * (a * a + b * b),
    ));
    InertialParameters::from_com(mass, com, inertia)
}

#[test]
fn a_solid_body_is_positive_definite_a_point_mass_singular_and_a_thin_shell_of_nothing_not() {
    let body = solid_box(2.0, [0.1, 0.2, 0.3], Vector3::new(0.05, -0.02, 0.3));
    // the smallest second moment about the centre, m·a²/12 along x, bounds the eigenvalue
    let e = body.smallest_pseudo_eigenvalue();
    assert!(e > 0.0 && e <= 2.0 * 0.1 * 0.1 / 12.0 + 1e-12, "{e}");
    // a point mass has no extent: singular, not positive definite
    let point = InertialParameters::point_mass(1.0, Vector3::new(0.1, 0.0, 0.0));
    assert!(point.smallest_pseudo_eigenvalue().abs() < 1e-12);
    // less inertia than the parallel axis puts at the first moment: no body
    let mut ghost = body;
    ghost.inertia_origin *= 0.5;
    assert!(ghost.smallest_pseudo_eigenvalue() < 0.0);
    assert!(ghost.check_physical().is_err());
    // the pseudo-inertia is symmetric with m in its corner and h beside it
    let p = body.pseudo_inertia();
    assert_eq!(p, p.transpose());
    assert_eq!(p[(3, 3)], 2.0);
    assert!((p[(0, 3)] - 0.1).abs() < 1e-12);
}

#[test]
fn every_nominal_lwr4_link_is_a_rigid_body() {
    for (l, link) in lwr4().links().iter().enumerate() {
        let e = link.smallest_pseudo_eigenvalue();
        assert!(e > 0.0, "link {}: {e}", l + 1);
    }
}
