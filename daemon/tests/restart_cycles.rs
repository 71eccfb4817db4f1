//! The service comes back after every stop (issue 20, item 5): 50 starts of the real binary on
//! one iceoryx2 prefix, each ended by SIGTERM or SIGKILL while the simulated controller runs in
//! real time and the service publishes every cycle. A killed service leaves its iceoryx2
//! node, ports and services behind; the next start must remove them and start. Half of the
//! cycles run with a subscriber of the state in this process (as the ROS 2 bridge would), so
//! the services outlive the service's own node and its dead publisher ports pile up unless
//! they are cleaned.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod binary;

use std::net::SocketAddr;

use binary::{Daemon, config_in, free_udp_port, write_config};
use fri_service::ipc::publisher::open_service;
use fri_service::ipc::{IpcNames, RobotState};
use mock_robot::{ServerConfig, SimulationConfig, TimingMode};

const CYCLES: usize = 50;

#[test]
fn fifty_sigterm_and_sigkill_cycles_on_one_iceoryx2_prefix_all_start() {
    let dir = tempfile::tempdir().unwrap();
    let port = free_udp_port();
    let mut config = config_in(dir.path(), port);
    config.iceoryx2.enabled = true;
    config.iceoryx2.service_prefix = "restart".to_owned();
    config.iceoryx2.global_prefix = Some(format!("rc{}_", std::process::id()));
    let file = write_config(dir.path(), "fri-service.toml", &config);
    let names = IpcNames {
        service_prefix: config.iceoryx2.service_prefix.clone(),
        global_prefix: config.iceoryx2.global_prefix.clone(),
    };
    let robot = mock_robot::spawn_new(
        SimulationConfig::default(),
        ServerConfig::loopback(
            SocketAddr::from(([127, 0, 0, 1], port)),
            TimingMode::RealTime,
        ),
    )
    .unwrap();

    let mut failures = Vec::new();
    let (mut kills, mut interrupted_starts) = (0, 0);
    for i in 0..CYCLES {
        // Every fifth cycle first starts a service and kills it while it starts (after 0 to
        // 40 ms): iceoryx2 resources half created.
        if i % 5 == 3 {
            let log = dir.path().join(format!("cycle{i}-interrupted.log"));
            let mut daemon = Daemon::spawn(&file, &config, &log);
            std::thread::sleep(std::time::Duration::from_millis((i as u64 * 7) % 41));
            daemon.signal(libc::SIGKILL);
            daemon.wait_exit().expect("a killed service did not end");
            interrupted_starts += 1;
        }
        let log = dir.path().join(format!("cycle{i}.log"));
        let mut daemon = Daemon::spawn(&file, &config, &log);
        if let Err(e) = daemon.wait_running() {
            failures.push(format!("start {i}: {e}"));
            continue;
        }
        // The service publishes: a subscriber receives its states. In every other pair of
        // cycles the subscriber stays until after the stop, as the ROS 2 bridge would, so the
        // services outlive the service's node.
        let node = names.node().unwrap();
        let sub = open_service::<RobotState>(&node, &names.state(), 1)
            .unwrap()
            .subscriber_builder()
            .create()
            .unwrap();
        let deadline = std::time::Instant::now() + binary::PATIENCE;
        while sub.receive().unwrap().is_none() {
            if std::time::Instant::now() > deadline {
                failures.push(format!("start {i}: no state published"));
                break;
            }
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
        let keep = i % 4 < 2;
        let subscriber = if keep {
            Some((sub, node))
        } else {
            drop(sub);
            drop(node);
            None
        };
        let kill = i % 3 == 1;
        daemon.signal(if kill { libc::SIGKILL } else { libc::SIGTERM });
        let status = daemon.wait_exit().expect("the service did not end");
        if kill {
            kills += 1;
        } else if !status.success() {
            failures.push(format!("stop {i} (SIGTERM): {status}: {}", daemon.stderr()));
        }
        drop(subscriber);
    }
    drop(robot.join());
    let recovered = (0..CYCLES)
        .filter(|i| {
            std::fs::read_to_string(dir.path().join(format!("cycle{i}.log")))
                .is_ok_and(|l| l.contains("left stuck by a process that died"))
        })
        .count();
    eprintln!("{recovered} of {CYCLES} starts removed a stuck iceoryx2 service");
    assert!(
        failures.is_empty(),
        "{} failures:\n{}",
        failures.len(),
        failures.join("\n")
    );
    assert!(
        kills >= 16 && interrupted_starts >= 10,
        "{kills} kills, {interrupted_starts} interrupted starts"
    );
}
