//! The O(n²) recursive Coriolis matrix equals the Christoffel-symbol matrix of M(q) (the former
//! O(n⁴) route, kept as a test-only reference in `common/christoffel.rs`) over random states of the
//! LWR (classical and modified DH, with a payload) and of the planar 2R arm.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use dynamics::{
    Data, InertialParameters, Model, coriolis_matrix, lwr4, lwr4_modified_dh, planar_2r,
    planar_2r_payload,
};
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};
use proptest::prelude::*;

mod common;
use common::christoffel::christoffel_coriolis_matrix;

fn relative_difference<const N: usize>(a: &SMatrix<f64, N, N>, b: &SMatrix<f64, N, N>) -> f64 {
    (a - b).abs().max() / b.abs().max().max(1.0)
}

fn assert_same_as_christoffel<const N: usize>(
    model: &Model<N>,
    q: &SVector<f64, N>,
    qd: &SVector<f64, N>,
) -> Result<(), TestCaseError> {
    let mut data = Data::new(model);
    let recursive = coriolis_matrix(model, &mut data, q, qd);
    let reference = christoffel_coriolis_matrix(model, &mut data, q, qd);
    let difference = relative_difference(&recursive, &reference);
    prop_assert!(
        difference < 1e-12,
        "relative difference {difference:e}\nrecursive {recursive}\nChristoffel {reference}"
    );
    Ok(())
}

fn payload() -> impl Strategy<Value = InertialParameters> {
    (
        0.0f64..5.0,
        proptest::array::uniform3(-0.2f64..0.2),
        proptest::array::uniform3(0.001f64..0.05),
    )
        .prop_map(|(m, c, i)| {
            let moments = Vector3::new(i[0], i[1], i[2].min(i[0] + i[1]));
            InertialParameters::from_com(m, Vector3::from(c), Matrix3::from_diagonal(&moments))
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn lwr4_recursive_equals_christoffel(
        q in proptest::array::uniform7(-3.0f64..3.0),
        qd in proptest::array::uniform7(-3.0f64..3.0),
        payload in payload(),
    ) {
        let (q, qd) = (SVector::from(q), SVector::from(qd));
        assert_same_as_christoffel(&lwr4().with_payload(&payload), &q, &qd)?;
        assert_same_as_christoffel(&lwr4_modified_dh().with_payload(&payload), &q, &qd)?;
    }

    #[test]
    fn planar_2r_recursive_equals_christoffel(
        q in proptest::array::uniform2(-3.0f64..3.0),
        qd in proptest::array::uniform2(-3.0f64..3.0),
    ) {
        let model = planar_2r().with_payload(&planar_2r_payload());
        assert_same_as_christoffel(&model, &SVector::from(q), &SVector::from(qd))?;
    }
}

/// C(q, 0) = 0 and C is linear in q̇.
#[test]
fn coriolis_matrix_is_linear_in_velocity() {
    let model = lwr4();
    let mut data = Data::new(&model);
    let q = SVector::<f64, 7>::from([0.1, 0.5, -0.3, -1.2, 0.4, 0.9, -0.2]);
    let a = SVector::<f64, 7>::from([0.3, -0.2, 0.5, 0.1, -0.4, 0.6, 0.2]);
    let b = SVector::<f64, 7>::from([-0.7, 0.1, 0.2, -0.3, 0.9, -0.5, 1.1]);
    assert_eq!(
        coriolis_matrix(&model, &mut data, &q, &SVector::zeros()),
        SMatrix::<f64, 7, 7>::zeros()
    );
    let sum = coriolis_matrix(&model, &mut data, &q, &(a * 2.0 + b));
    let parts = coriolis_matrix(&model, &mut data, &q, &a) * 2.0
        + coriolis_matrix(&model, &mut data, &q, &b);
    assert!(relative_difference(&sum, &parts) < 1e-13);
    assert!(
        sum.abs().max() > 1e-3,
        "the test state must have Coriolis terms"
    );
}
