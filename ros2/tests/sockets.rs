//! `interface = "lo"`: every UDP socket of the `fri-ros2` process is bound to the loopback
//! device (RustDDS binds `0.0.0.0`; the bridge binds each socket to the device), as `ss -uanp`
//! shows them: `0.0.0.0%lo:7400`, never a bare `0.0.0.0:port` that datagrams from any interface
//! reach.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod common;

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The `ss -uanp` lines of process `pid`.
fn udp_sockets_of(pid: u32) -> Vec<String> {
    let out = Command::new("ss").args(["-uanp"]).output().unwrap();
    assert!(out.status.success(), "ss -uanp: {out:?}");
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter(|l| l.contains(&format!("pid={pid},")))
        .map(str::to_owned)
        .collect()
}

#[test]
fn with_interface_lo_every_dds_socket_of_the_bridge_is_bound_to_lo() {
    common::loopback_multicast();
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("bridge.toml");
    std::fs::write(
        &config,
        format!(
            "[operator]\nsocket = \"{}\"\n[iceoryx2]\nservice_prefix = \"sockets_test\"\n\
             [ros2]\ndomain_id = 157\ninterface = \"lo\"\n",
            dir.path().join("op.sock").display()
        ),
    )
    .unwrap();
    let mut bridge = Command::new(env!("CARGO_BIN_EXE_fri-ros2"))
        .arg("--config")
        .arg(&config)
        .stdout(Stdio::null())
        .stderr(Stdio::inherit())
        .spawn()
        .unwrap();
    let pid = bridge.id();
    // The participant's sockets: SPDP and user traffic, multicast and unicast, and the senders.
    let deadline = Instant::now() + Duration::from_secs(30);
    let mut lines = Vec::new();
    while Instant::now() < deadline {
        lines = udp_sockets_of(pid);
        if lines.len() >= 4 {
            // Let the start finish binding (the pinning follows the build at once).
            std::thread::sleep(Duration::from_millis(500));
            lines = udp_sockets_of(pid);
            break;
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    let _ = bridge.kill();
    let _ = bridge.wait();
    assert!(
        lines.len() >= 4,
        "the bridge opened no DDS sockets: {lines:?}"
    );
    for l in &lines {
        let local = l.split_whitespace().nth(3).unwrap_or_default();
        assert!(
            local.contains("%lo:") || local.starts_with("127."),
            "a socket of the bridge listens beyond lo: {l}"
        );
    }
}
