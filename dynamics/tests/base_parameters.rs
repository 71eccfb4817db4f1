//! Numerical base parameters against the paper: 12 gravity coefficients for the LWR (eq. 38),
//! 6 dynamic coefficients for the planar 2R (eq. 29).
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use dynamics::{
    Data, RegressorKind, base_parameters, gravity_regressor, joint_torque_regressor, lwr4,
    lwr4_modified_dh, planar_2r,
};
use nalgebra::{DVector, SVector};

#[test]
fn lwr4_gravity_regressor_has_12_base_coefficients() {
    let model = lwr4();
    let base = base_parameters(&model, RegressorKind::Gravity, 60, 7);
    assert_eq!(base.rank, 12, "pivots {:?}", base.pivots);
    // The rank decision is clear: the 13th pivot is round-off.
    assert!(base.pivots[12] < 1e-12 * base.pivots[0]);
    assert!(base.pivots[11] > 1e-3 * base.pivots[0]);
    // Link 1 (vertical axis) never appears, nor does any mass of links 1-2 alone.
    for column in 0..4 {
        assert!(base.dependent.contains(&column));
    }
    // π = K p reproduces g(q) = W_base π at fresh configurations.
    let p = DVector::from_iterator(
        28,
        model.links().iter().flat_map(|l| {
            let v = l.to_vector();
            [v[0], v[1], v[2], v[3]]
        }),
    );
    let pi = &base.map * &p;
    let mut data = Data::new(&model);
    for k in 0..10 {
        let q = SVector::<f64, 7>::from_fn(|i, _| ((k * 7 + i) as f64 * 0.731).sin() * 2.0);
        let blocks = gravity_regressor(&model, &mut data, &q);
        let full: Vec<f64> = (0..7)
            .map(|row| {
                base.independent
                    .iter()
                    .zip(pi.iter())
                    .map(|(col, value)| blocks[col / 4][(row, col % 4)] * value)
                    .sum()
            })
            .collect();
        let g = dynamics::compute_generalized_gravity(&model, &mut data, &q);
        for row in 0..7 {
            assert!(
                (full[row] - g[row]).abs() < 1e-10,
                "row {row}: {} vs {}",
                full[row],
                g[row]
            );
        }
    }
}

#[test]
fn lwr4_modified_dh_has_the_same_number_of_gravity_coefficients() {
    let base = base_parameters(&lwr4_modified_dh(), RegressorKind::Gravity, 60, 11);
    assert_eq!(base.rank, 12);
}

#[test]
fn planar_2r_has_6_base_coefficients() {
    let model = planar_2r();
    let base = base_parameters(&model, RegressorKind::Full, 40, 3);
    assert_eq!(base.rank, 6, "pivots {:?}", base.pivots);
    // Linear exactness through the base set on the full dynamics.
    let p = DVector::from_iterator(
        20,
        model
            .links()
            .iter()
            .flat_map(|l| l.to_vector().iter().copied().collect::<Vec<_>>()),
    );
    let pi = &base.map * &p;
    let mut data = Data::new(&model);
    let q = SVector::<f64, 2>::new(0.3, -1.1);
    let qd = SVector::<f64, 2>::new(0.7, 0.2);
    let qdd = SVector::<f64, 2>::new(-0.4, 1.3);
    let blocks = joint_torque_regressor(&model, &mut data, &q, &qd, &qdd);
    let tau = dynamics::rnea(&model, &mut data, &q, &qd, &qdd);
    for row in 0..2 {
        let value: f64 = base
            .independent
            .iter()
            .zip(pi.iter())
            .map(|(col, v)| blocks[col / 10][(row, col % 10)] * v)
            .sum();
        assert!((value - tau[row]).abs() < 1e-10);
    }
}

/// The paper's symbolic coefficients (eq. 29) as a 6 × 20 map of the link parameters; they span the
/// same space as the numerical base set, and evaluate to the printed values.
#[test]
fn planar_2r_numerical_base_spans_the_papers_eq29_coefficients() {
    let (a1, a2) = (1.0, 0.5);
    let mut p_map = nalgebra::DMatrix::<f64>::zeros(6, 20);
    // Columns: link 1 = 0..10, link 2 = 10..20, each (m, mcx, mcy, mcz, Jxx, Jxy, Jxz, Jyy, Jyz, Jzz).
    p_map[(0, 10)] = 0.5 * a2 * a2;
    p_map[(0, 19)] = 0.5;
    p_map[(0, 11)] = a2;
    p_map[(1, 11)] = 1.0;
    p_map[(1, 10)] = a2;
    p_map[(2, 12)] = 1.0;
    p_map[(3, 9)] = 0.5;
    p_map[(3, 0)] = 0.5 * a1 * a1;
    p_map[(3, 10)] = 0.5 * a1 * a1;
    p_map[(3, 1)] = a1;
    p_map[(4, 1)] = 1.0;
    p_map[(4, 0)] = a1;
    p_map[(4, 10)] = a1;
    p_map[(5, 2)] = 1.0;

    let model = planar_2r();
    let base = base_parameters(&model, RegressorKind::Full, 40, 5);
    let mut stacked = nalgebra::DMatrix::<f64>::zeros(12, 20);
    stacked.view_mut((0, 0), (6, 20)).copy_from(&base.map);
    stacked.view_mut((6, 0), (6, 20)).copy_from(&p_map);
    let singular = stacked.singular_values();
    let rank = singular.iter().filter(|s| **s > 1e-9 * singular[0]).count();
    assert_eq!(rank, 6, "singular values {singular}");

    let params = |m: &dynamics::Model<2>| {
        DVector::from_iterator(
            20,
            m.links()
                .iter()
                .flat_map(|l| l.to_vector().iter().copied().collect::<Vec<_>>()),
        )
    };
    let pi = &p_map * params(&model);
    let printed = [0.11125, 0.6, 0.04, 1.36515, 3.2, 0.03];
    for (got, want) in pi.iter().zip(printed) {
        assert!((got - want).abs() < 1e-12, "{pi}");
    }
    let loaded = model.with_payload(&dynamics::planar_2r_payload());
    let pi = &p_map * params(&loaded);
    let printed = [0.6144, 1.8, 0.19, 2.11515, 4.7, 0.03];
    for (got, want) in pi.iter().zip(printed) {
        assert!((got - want).abs() < 1e-12, "{pi}");
    }
}
