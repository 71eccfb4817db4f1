//! The unknown-payload mode's per-cycle path (the plausible fit at one pose with the settle
//! detection, the pin at the grasp window's end, the fit against a pinned load, the pin of the
//! samples' fit, the inertia allowance while moving, an inconsistent sample set, the onset it
//! causes, the expiry) never touches the heap, inside the monitor's step.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

#[global_allocator]
static ALLOCATOR: alloc_counter::CountingAllocator = alloc_counter::CountingAllocator;

use dynamics::{Data, compute_generalized_gravity, lwr4, payload_gravity_regressor};
use nalgebra::{SVector, Vector3, Vector4};
use safety::{
    CollisionMonitor, FlangeLoadBounds, GraspTiming, LoadSample, MonitorConfig, ObserverInput,
    PayloadCompensation, PayloadTolerance, fit_hypothesis,
};

type V7 = SVector<f64, 7>;
const T: f64 = 1e-3;
const BOUNDS: FlangeLoadBounds = FlangeLoadBounds {
    max_mass_kg: 7.0,
    radius_m: 0.3,
};

/// Quasi-static samples of an arm carrying 3 kg, moving slowly, with a push from `push_from` on.
fn inputs(push_from: usize) -> Vec<ObserverInput<7>> {
    let model = lwr4();
    let mut data = Data::new(&model);
    let payload = PayloadCompensation::gravity_from_com(3.0, Vector3::new(0.0, 0.0, 0.12))
        .gravity_parameters();
    (0..300)
        .map(|k| {
            let s = k as f64 * T;
            let mut q = V7::from(dynamics::LWR4_PICK_POSE_RAD);
            q[1] += 0.05 * s;
            q[3] -= 0.05 * s;
            let mut tau = compute_generalized_gravity(&model, &mut data, &q)
                + payload_gravity_regressor(&model, &mut data, &q) * payload;
            tau[0] += 1e-4 * (k % 7) as f64;
            if k >= push_from {
                tau[2] += 30.0;
            }
            ObserverInput::new(q, tau, T)
        })
        .collect()
}

#[test]
fn the_unknown_payload_path_does_not_allocate() {
    let model = lwr4();
    let samples = inputs(200);
    let mut data = Data::new(&model);
    let q0 = V7::from(dynamics::LWR4_PICK_POSE_RAD);
    let payload = PayloadCompensation::gravity_from_com(3.0, Vector3::new(0.0, 0.0, 0.12))
        .gravity_parameters();
    let load = LoadSample {
        q: q0,
        load_torque: payload_gravity_regressor(&model, &mut data, &q0) * payload,
    };
    let consistent = fit_hypothesis(&model, 1, &[load], &V7::repeat(6.0), &BOUNDS).unwrap();
    let mut tainted = load;
    tainted.load_torque[0] += 20.0;
    let inconsistent =
        fit_hypothesis(&model, 1, &[load, tainted], &V7::repeat(6.0), &BOUNDS).unwrap();
    assert!(consistent.consistent && !inconsistent.consistent);
    let peak = V7::from_fn(|j, _| if j == 1 || j == 3 { 0.3 } else { 0.0 });
    // A grasp window of 0.1 s pins the load inside the counted cycles; the expiry at 0.25 s ends
    // the mode inside them too (the push from 0.2 s is detected before it).
    let short = GraspTiming {
        grasp_window_s: 0.1,
        settle_s: 0.05,
        expire_s: 0.25,
    };
    for (hypothesis, timing) in [
        (None, GraspTiming::default()),
        (None, short),
        (Some(consistent), GraspTiming::default()),
        (Some(inconsistent), GraspTiming::default()),
    ] {
        for moving in [false, true] {
            let mut monitor =
                CollisionMonitor::new(model.clone(), MonitorConfig::new(T, 400.0)).unwrap();
            let mut tolerance = PayloadTolerance::new(&model);
            tolerance.declare(1, BOUNDS, timing, 0.0).unwrap();
            if let Some(h) = hypothesis {
                assert!(tolerance.set_hypothesis(h));
            }
            tolerance.set_motion(moving, &peak);
            let applied = Vector4::zeros();
            let mut onsets = 0;
            let mut now = 0.0;
            let n = alloc_counter::count_allocations(|| {
                for input in &samples {
                    now += T;
                    tolerance.advance(now);
                    let _ = tolerance.take_changed();
                    let _ = tolerance.status();
                    let out = monitor.step_with(input, |input, observed, thresholds| {
                        tolerance.contact_residual(
                            &input.q,
                            &observed.velocity,
                            &observed.residual,
                            &applied,
                            thresholds,
                        )
                    });
                    if matches!(out.detection, Some(safety::Detection::Onset(_))) {
                        onsets += 1;
                    }
                }
            });
            assert_eq!(n, 0, "{hypothesis:?}, moving {moving}: {n} allocations");
            if timing == short {
                assert!(!tolerance.is_active(), "the short timing expired");
            }
            // Not vacuous: the push (30 Nm on joint 3, which no flange load explains there)
            // is detected on every path.
            assert!(onsets >= 1, "{hypothesis:?}, moving {moving}");
        }
    }
}
