//! The paper's printed numbers, reproduced to the printed digits through the coefficient workflow.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use estimator::CoefficientSet;

fn round_to(x: f64, digits: i32) -> f64 {
    let s = 10f64.powi(digits);
    (x * s).round() / s
}

/// Eq. (34) → eq. (35): p̂_L = (1.5, 0.45, 0.15, 0.1814) from π̂ and π̂_L as printed.
#[test]
fn planar_2r_eq34_to_eq35() {
    let set = CoefficientSet::builtin("planar-2r").unwrap();
    let pi_hat = [0.1112, 0.6, 0.04, 1.3651, 3.2, 0.03];
    let pi_hat_l = [0.6144, 1.8, 0.19, 2.1152, 4.7, 0.03];
    let est = set.estimate(&pi_hat, &pi_hat_l).unwrap();
    let printed = [1.5, 0.45, 0.15, 0.1814];
    for (k, (got, want)) in est.p_l.iter().zip(printed).enumerate() {
        assert_eq!(round_to(*got, 4), want, "p_L[{k}] = {got}");
    }
    // ε̂_nz of eq. (34): (0.5032, 1.2, 0.15, 0.75, 1.5) (0.7501 before rounding)
    assert_eq!(est.nonzero_rows, vec![1, 2, 3, 4, 5]);
    let eps_printed = [0.5032, 1.2, 0.15, 0.75, 1.5];
    for (k, want) in eps_printed.iter().enumerate() {
        assert_eq!(round_to(est.epsilon[k], 3), round_to(*want, 3), "eps[{k}]");
    }
    // and from the printed ε̂_nz itself
    let est2 = set
        .estimate_from_difference(&[0.5032, 1.2, 0.15, 0.75, 1.5, 0.0])
        .unwrap();
    for (got, want) in est2.p_l.iter().zip(printed) {
        assert_eq!(round_to(*got, 4), want);
    }
    let m = est.mass.unwrap();
    assert_eq!(round_to(m, 4), 1.5);
    assert_eq!(round_to(est.com[0].unwrap(), 4), 0.3);
    assert_eq!(round_to(est.com[1].unwrap(), 4), 0.1);
    assert!(est.com[2].is_none());
}

/// Eq. (42)/(43) → eq. (44): 3.067 kg, CoM (−2.6e-4, 5e-4, 0.1196) m.
#[test]
fn lwr4_eq42_to_eq44() {
    let set = CoefficientSet::builtin("lwr4-gravity").unwrap();
    let pi_g = [
        1.6136e-5, -0.0013, -0.0046, 0.0315, -0.0417, 0.0054, 1.3544, 0.0183, -0.0036, 0.0271,
        -0.0129, 3.4459,
    ];
    // eq. (42) as printed lacks its 6th element (c5x·m5, which the payload does not change)
    let pi_lg = [
        0.0016, -0.0021, -0.0093, 0.3983, -0.0033, 0.0054, 2.5458, 0.005, -0.0032, 0.0629, -0.0028,
        4.6775,
    ];
    let est = set.estimate(&pi_g, &pi_lg).unwrap();
    assert_eq!(est.nonzero_rows, vec![1, 2, 4, 7, 12]);
    let m = est.mass.unwrap();
    // worked check: (d2·1.1914 + d1·1.2316)/(d1² + d2²)
    let worked = (0.39 * 1.1914 + 0.4 * 1.2316) / (0.4f64 * 0.4 + 0.39 * 0.39);
    assert!((m - worked).abs() < 1e-12, "{m} vs {worked}");
    assert_eq!(round_to(m, 3), 3.067);
    let c = est.com.map(|c| c.unwrap());
    assert_eq!(round_to(c[0], 5), -0.00026, "cx {}", c[0]);
    assert_eq!(round_to(c[1], 4), 0.0005, "cy {}", c[1]);
    assert_eq!(round_to(c[2], 4), 0.1196, "cz {}", c[2]);
    // eq. (43): ε̂_nz = (0.0016, −8.13e-4, 0.3667, 1.1914, 1.2316) (the 3rd element is 0.3668 from eq. 42's rounded values)
    let e = &est.epsilon;
    assert_eq!(round_to(e[0], 4), 0.0016);
    assert_eq!(round_to(e[1], 4), -0.0008);
    assert!((e[3] - 0.3667).abs() <= 1.5e-4);
    assert_eq!(round_to(e[6], 4), 1.1914);
    assert_eq!(round_to(e[11], 4), 1.2316);
}

/// Eq. (43) → eq. (44) from the printed ε̂_nz directly.
#[test]
fn lwr4_eq43_to_eq44() {
    let set = CoefficientSet::builtin("lwr4-gravity").unwrap();
    let mut eps = [0.0; 12];
    eps[0] = 0.0016;
    eps[1] = -8.13e-4;
    eps[3] = 0.3667;
    eps[6] = 1.1914;
    eps[11] = 1.2316;
    let est = set.estimate_from_difference(&eps).unwrap();
    let m = est.mass.unwrap();
    assert_eq!(round_to(m, 3), 3.067);
    let c = est.com.map(|c| c.unwrap());
    // −8.13e-4 / 3.0673 = −2.651e-4: eq. (43) prints ε̂ with more digits than eq. (42) gives, and
    // eq. (44)'s −2.6e-4 comes from the unrounded data; agreement to within 0.06e-4.
    assert!((c[0] + 2.6e-4).abs() < 0.06e-4, "cx {}", c[0]);
    assert_eq!(round_to(c[1], 4), 0.0005);
    assert_eq!(round_to(c[2], 4), 0.1196);
}

#[test]
fn wrong_vector_length_is_a_clear_error() {
    let set = CoefficientSet::builtin("lwr4-gravity").unwrap();
    let err = set
        .estimate(&[0.0; 11], &[0.0; 12])
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("11 elements") && err.contains("12 coefficients"),
        "{err}"
    );
}
