//! iceoryx2 publication: a subscriber in the same process receives exactly what was published,
//! each test in its own global prefix, with no shared-memory files left behind.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::sync::atomic::{AtomicU32, Ordering};

use std::os::unix::fs::PermissionsExt;

use fri_api::ipc::flags;
use fri_service::ipc::publisher::open_service;
use fri_service::ipc::{CollisionMessage, IpcNames, PayloadEstimate, Publisher, RobotState};
use iceoryx2::prelude::ServiceName;

#[global_allocator]
static A: alloc_counter::CountingAllocator = alloc_counter::CountingAllocator;

static NEXT: AtomicU32 = AtomicU32::new(0);

fn unique_names() -> IpcNames {
    IpcNames {
        service_prefix: "fri-test".to_owned(),
        global_prefix: Some(format!(
            "frit{}x{}_",
            std::process::id(),
            NEXT.fetch_add(1, Ordering::SeqCst)
        )),
    }
}

/// Files of the iceoryx2 installation that carry `prefix` in their name.
fn files_with_prefix(names: &IpcNames) -> Vec<std::path::PathBuf> {
    let prefix = names.global_prefix.clone().unwrap();
    let mut found = Vec::new();
    let mut stack = vec![
        std::path::PathBuf::from("/tmp/iceoryx2"),
        std::path::PathBuf::from("/dev/shm"),
    ];
    while let Some(dir) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(&dir) else {
            continue;
        };
        for e in entries.flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p.clone());
            }
            if e.file_name().to_string_lossy().contains(&prefix) {
                found.push(p);
            }
        }
    }
    found
}

#[test]
fn subscriber_receives_state_events_and_payload_and_cleanup_leaves_nothing() {
    let names = unique_names();
    {
        let publisher = Publisher::new(&names).unwrap();
        let node = names.node().unwrap();
        let state_sub = open_service::<RobotState>(&node, &names.state(), 1)
            .unwrap()
            .subscriber_builder()
            .create()
            .unwrap();
        let coll_sub = open_service::<CollisionMessage>(&node, &names.collision(), 16)
            .unwrap()
            .subscriber_builder()
            .create()
            .unwrap();
        let pay_sub = open_service::<PayloadEstimate>(&node, &names.payload(), 4)
            .unwrap()
            .subscriber_builder()
            .create()
            .unwrap();
        assert!(
            !files_with_prefix(&names).is_empty(),
            "expected shared-memory files"
        );

        for cycle in 1..=5u64 {
            let mut s = RobotState {
                cycle,
                time_s: cycle as f64 * 1e-3,
                flags: flags::COMMAND_MODE | flags::PAYLOAD_APPLIED,
                fri_state: 2,
                quality: 3,
                ..RobotState::default()
            };
            s.q[6] = 0.1 * cycle as f64;
            s.residual[3] = -2.5;
            publisher.publish_state(&s).unwrap();
        }
        let mut received = Vec::new();
        while let Some(sample) = state_sub.receive().unwrap() {
            received.push(*sample.payload());
        }
        assert_eq!(
            received.iter().map(|s| s.cycle).collect::<Vec<_>>(),
            vec![1, 2, 3, 4, 5]
        );
        assert_eq!(received[4].q[6], 0.5);
        assert_eq!(received[4].residual[3], -2.5);
        assert_eq!(
            received[4].flags,
            flags::COMMAND_MODE | flags::PAYLOAD_APPLIED
        );

        let ev = CollisionMessage {
            cycle: 8000,
            time_s: 8.0,
            residual: [0.0, 0.0, 0.0, 9.5, 0.0, 7.0, 0.0],
            joints_mask: 0b10_1000,
            link: 6,
            ..Default::default()
        };
        publisher.publish_collision(&ev).unwrap();
        assert_eq!(*coll_sub.receive().unwrap().unwrap().payload(), ev);

        let p = PayloadEstimate {
            time_s: 1.0,
            mass: 3.03,
            com: [0.0, 0.001, 0.119],
            mass_std: 0.004,
            com_std: [0.001; 3],
            samples: 10,
            applied: 1,
        };
        publisher.publish_payload(&p).unwrap();
        assert_eq!(*pay_sub.receive().unwrap().unwrap().payload(), p);
        assert!(state_sub.receive().unwrap().is_none());
    }
    assert_clean(&names);
}

/// Nodes and services are gone once dropped; iceoryx2 keeps one global management segment per
/// prefix, which the test removes.
fn assert_clean(names: &IpcNames) {
    let mut left = files_with_prefix(names);
    left.retain(|p| {
        if p.to_string_lossy().ends_with(".global_mgmt") {
            let _ = std::fs::remove_file(p);
            false
        } else {
            true
        }
    });
    assert!(left.is_empty(), "left behind: {left:?}");
}

#[test]
fn loop_side_handoff_does_not_allocate_and_thread_publishes_every_state() {
    let names = unique_names();
    {
        let node = names.node().unwrap();
        let (thread, sender) = fri_service::ipc::IpcThread::spawn(names.clone()).unwrap();
        let sub = open_service::<RobotState>(&node, &names.state(), 1)
            .unwrap()
            .subscriber_builder()
            .create()
            .unwrap();
        let mut state = RobotState::default();
        sender.state(&state); // warm-up
        let n = alloc_counter::count_allocations(|| {
            for cycle in 1..=100 {
                state.cycle = cycle;
                assert!(sender.state(&state));
            }
        });
        assert_eq!(n, 0, "the loop side must not allocate");
        drop(sender);
        // Every state queued before the stop is published first.
        thread.stop();
        // The subscriber buffer holds the newest 16 (subscriber_max_buffer_size); the last
        // published cycle must be there.
        let mut last = 0;
        while let Some(s) = sub.receive().unwrap() {
            last = s.payload().cycle;
        }
        assert_eq!(last, 100);
    }
    assert_clean(&names);
}

#[test]
fn a_service_its_dead_creator_left_unfinished_is_removed_and_created_again() {
    // A creator killed between creating the service's static configuration and finalising it
    // leaves the file with mode 0600: iceoryx2 then reports `HangsInCreation` forever, and
    // its own forced removal does not see it.
    let names = unique_names();
    {
        let config = names.config().unwrap();
        let name = ServiceName::new(&names.state()).unwrap();
        let path = fri_service::ipc::recovery::static_config_path(&config, &name);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(&path, "partial").unwrap();
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o600)).unwrap();
        let node = names.node().unwrap();
        let stuck = open_service::<RobotState>(&node, &names.state(), 1).unwrap_err();
        assert!(stuck.to_string().contains("HangsInCreation"), "{stuck}");
        let publisher = Publisher::new(&names).unwrap();
        let sub = open_service::<RobotState>(&node, &names.state(), 1)
            .unwrap()
            .subscriber_builder()
            .create()
            .unwrap();
        publisher.publish_state(&RobotState::default()).unwrap();
        assert!(sub.receive().unwrap().is_some());
    }
    assert_clean(&names);
}

#[test]
fn invalid_global_prefix_is_an_error_not_a_panic() {
    let names = IpcNames {
        service_prefix: "x".into(),
        global_prefix: Some("a/b".into()),
    };
    assert!(Publisher::new(&names).is_err());
}
