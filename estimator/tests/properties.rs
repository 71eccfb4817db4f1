//! Properties over random payloads, controller-model errors and poses (noise-free data):
//! tare cancels any model error exactly, the estimate does not depend on sample order, and the
//! coefficient route agrees with the direct route.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use dynamics::{InertialParameters, lwr4};
use estimator::correction::estimate_with_tare;
use estimator::estimate::{EstimateOptions, Method, estimate};
use estimator::sim::{perturbed_model, static_samples};
use nalgebra::{SVector, Vector3};
use proptest::prelude::*;

fn poses(seed: &[f64]) -> Vec<SVector<f64, 7>> {
    (0..12)
        .map(|k| {
            SVector::from_fn(|j, _| (seed[(k * 7 + j) % seed.len()] * (1.0 + k as f64)).sin() * 1.9)
        })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 16, .. ProptestConfig::default() })]

    #[test]
    fn tare_cancels_any_model_error(
        m in 0.05f64..8.0,
        cx in -0.1f64..0.1, cy in -0.1f64..0.1, cz in 0.0f64..0.3,
        dp in proptest::collection::vec(-0.05f64..0.05, 28),
        seed in proptest::collection::vec(-3.0f64..3.0, 10),
    ) {
        let model = lwr4();
        let d: [[f64; 4]; 7] = std::array::from_fn(|i| [dp[4 * i], dp[4 * i + 1] * 0.2, dp[4 * i + 2] * 0.2, dp[4 * i + 3] * 0.2]);
        let ctrl = perturbed_model(&model, &d);
        let payload = InertialParameters::point_mass(m, Vector3::new(cx, cy, cz));
        let q = poses(&seed);
        let loaded = static_samples(&model, &payload, &ctrl, &q, |_, _| 0.0);
        let tare = static_samples(&model, &InertialParameters::zero(), &ctrl, &q, |_, _| 0.0);
        let e = estimate_with_tare(&model, &loaded, &tare, 1e-9, &EstimateOptions::default()).unwrap();
        prop_assert!((e.mass - m).abs() < 1e-8 * m.max(1.0), "{} vs {m}", e.mass);
        prop_assert!((Vector3::from(e.com) - Vector3::new(cx, cy, cz)).norm() < 1e-8 / m.min(1.0));
    }

    #[test]
    fn order_invariant_and_methods_agree_without_model_error(
        m in 0.1f64..5.0,
        cz in 0.0f64..0.3,
        seed in proptest::collection::vec(-3.0f64..3.0, 10),
    ) {
        let model = lwr4();
        let payload = InertialParameters::point_mass(m, Vector3::new(0.01, -0.02, cz));
        let q = poses(&seed);
        let mut s = static_samples(&model, &payload, &model, &q, |k, j| 0.01 * (((k + 2 * j) % 7) as f64 - 3.0));
        let a = estimate(&model, &s, &EstimateOptions::default()).unwrap();
        s.reverse();
        let b = estimate(&model, &s, &EstimateOptions::default()).unwrap();
        // Equal up to rounding, which the least-squares solve amplifies by its condition number:
        // random poses over ±1.9 rad reach ~3e-11 relative (seen: 1.2e-10 kg at 4.1 kg).
        prop_assert!((a.mass - b.mass).abs() < 1e-9 * m.max(1.0), "{} vs {}", a.mass, b.mass);
        prop_assert!((a.mass_std - b.mass_std).abs() < 1e-10);
        let s0 = static_samples(&model, &payload, &model, &q, |_, _| 0.0);
        let c = estimate(&model, &s0, &EstimateOptions { method: Method::Coefficients, ..Default::default() }).unwrap();
        prop_assert!((c.mass - m).abs() < 1e-8, "{} vs {m}", c.mass);
    }
}
