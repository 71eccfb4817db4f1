//! The service's per-cycle work (session + observer + motion + handshake + hand-off) never
//! allocates once warmed up.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

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
