//! The service's per-cycle work (session + observer + motion + handshake + hand-off) never
//! allocates once warmed up.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use fri_service::service::cycle::CycleRequest;
use fri_service::service::replay::Replay;
use mock_robot::{Simulation, SimulationConfig};

#[global_allocator]
static A: alloc_counter::CountingAllocator = alloc_counter::CountingAllocator;

#[test]
fn service_cycle_is_allocation_free() {
    let mut config = SimulationConfig::default();
    config.payload.attached_at_start = true;
    let mut sim = Simulation::new(config).unwrap();
    for _ in 0..20 {
        sim.step_cycle(None);
    }
    let mut kit = Replay::new(*sim.measurement()).unwrap();
    for _ in 0..200 {
        kit.prepare();
        assert!(kit.cycle());
    }
    kit.drain();
    // An applied payload reaches the loop as a point mass (M changes): the first counted cycle
    // installs it.
    let applied = fri_service::persistence::AppliedPayload {
        mass: 3.0,
        com: [0.0, 0.0, 0.12],
    };
    assert!(kit.send(CycleRequest::SetPayload(Some(
        fri_service::service::core::compensation(&applied)
    ))));
    let mut ok = 0;
    let n = alloc_counter::count_allocations(|| {
        for _ in 0..2000 {
            kit.prepare();
            if kit.cycle() {
                ok += 1;
            }
        }
    });
    assert_eq!(ok, 2000);
    assert_eq!(n, 0, "allocations in 2000 cycles");
    // Every cycle handed its state over (2000 states, no drops: the queue holds 65536).
    assert!(kit.drain() >= 2000);
}

/// The same with the payload declared unknown: the plausible fit at the current pose during the
/// grasp window and the pin at its end, then the refit of a sample set pinned (after it reached
/// the loop), then its end and a new declaration that expires; each change leaves the loop as an
/// event.
#[test]
fn service_cycle_with_the_payload_declared_unknown_is_allocation_free() {
    let mut config = SimulationConfig::default();
    config.payload.attached_at_start = true;
    let mut sim = Simulation::new(config).unwrap();
    for _ in 0..20 {
        sim.step_cycle(None);
    }
    let measurement = *sim.measurement();
    let mut kit = Replay::new(measurement).unwrap();
    let bounds = safety::FlangeLoadBounds {
        max_mass_kg: 7.0,
        radius_m: 0.3,
    };
    // The window ends 0.6 s after the declaration: inside the first counted phase.
    let timing = safety::GraspTiming {
        grasp_window_s: 0.6,
        settle_s: 0.5,
        expire_s: 60.0,
    };
    assert!(kit.send(CycleRequest::ExpectPayload {
        declaration: 1,
        bounds,
        timing,
    }));
    for _ in 0..200 {
        kit.prepare();
        assert!(kit.cycle());
    }
    kit.drain();
    let model = dynamics::lwr4();
    let q = nalgebra::SVector::from(measurement.data.msr_jnt_pos);
    let tau = nalgebra::SVector::from(measurement.data.msr_jnt_trq);
    let g = dynamics::compute_generalized_gravity(&model, &mut dynamics::Data::new(&model), &q);
    let sample = safety::LoadSample {
        q,
        load_torque: tau - g,
    };
    let hypothesis = safety::fit_hypothesis(
        &model,
        1,
        &[sample],
        &nalgebra::SVector::repeat(6.0),
        &bounds,
    )
    .unwrap();
    for phase in [None, Some(hypothesis), None] {
        if let Some(h) = phase {
            assert!(kit.send(CycleRequest::PayloadHypothesis(h)));
            kit.prepare();
            assert!(kit.cycle());
            kit.drain();
        } else if kit.processor().payload_tolerance().pinned().is_some() {
            // The last phase: ended and declared again (a declaration while one is active is
            // refused), expiring inside the counted cycles.
            assert!(kit.send(CycleRequest::EndExpectPayload));
            assert!(kit.send(CycleRequest::ExpectPayload {
                declaration: 2,
                bounds,
                timing: safety::GraspTiming {
                    expire_s: 0.5,
                    ..timing
                },
            }));
        }
        let mut ok = 0;
        let n = alloc_counter::count_allocations(|| {
            for _ in 0..1000 {
                kit.prepare();
                if kit.cycle() {
                    ok += 1;
                }
            }
        });
        assert_eq!(ok, 1000);
        assert_eq!(
            n,
            0,
            "allocations in 1000 cycles ({:?})",
            phase.map(|h| h.samples)
        );
        kit.drain();
        // Not vacuous: the window's pin, the samples' pin, the expiry happened in the phase.
        let tolerance = kit.processor().payload_tolerance();
        match tolerance.pinned().map(|p| p.source) {
            Some(safety::PinSource::GraspWindow) => assert!(phase.is_none()),
            Some(safety::PinSource::Samples(1)) => assert!(phase.is_some()),
            None => assert_eq!(tolerance.last_end().map(|(d, _)| d), Some(2)),
            other => panic!("{other:?}"),
        }
    }
}
