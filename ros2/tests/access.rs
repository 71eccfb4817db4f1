//! Who may command through the bridge, attacked from a rogue DDS participant (Eclipse Cyclone
//! DDS from Python, no security, on the bridge's domain): read-only by default; in the explicit
//! unauthenticated mode every command names its participant in the service's audit trail and
//! status; requests written before the bridge started (transient-local) are never executed; a
//! flood is answered or counted, never dropped silently.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod common;

use std::time::Duration;

use fri_api::origin::Origin;
use fri_api::protocol::Command;
use fri_api::results::Change;
use fri_ros_msgs::RosMessage;
use fri_ros_msgs::diagnostic_msgs::{DiagnosticArray, WARN};
use fri_service::testkit::InProcess;

fn args(list: &[&str]) -> Vec<String> {
    list.iter().map(|s| (*s).to_owned()).collect()
}

/// A rogue Cyclone peer calling once in `domain` (waits 8 s for a match, quiet for 3 s after).
fn quiet_rogue(call: &[&str], domain: &str) -> common::JsonPeer {
    let mut a = args(call);
    a.extend(args(&[
        "--domain",
        domain,
        "--wait-match",
        "8",
        "--quiet",
        "3",
    ]));
    common::JsonPeer::start("rogue_peer.py", &a)
}

/// The service with the mock robot (no payload: the armed monitor leaves the arm free).
async fn service_with_robot(
    dir: &std::path::Path,
    name: &str,
    unauthenticated: bool,
) -> (
    fri_service::config::Config,
    InProcess,
    mock_robot::MockRobotHandle,
) {
    common::loopback_multicast();
    let mut config = common::service_config(dir, name);
    config.observer.armed = true;
    if unauthenticated {
        common::service_accepts_unauthenticated(&mut config);
    }
    let service = InProcess::start(config.clone()).await.unwrap();
    let mut sim = mock_robot::SimulationConfig::default();
    sim.payload.attached_at_start = false;
    let robot = common::robot(sim, service.fri, None);
    common::wait_connected(&service).await;
    (config, service, robot)
}

async fn stop_all(
    bridge: Option<common::Bridge>,
    robot: mock_robot::MockRobotHandle,
    service: InProcess,
) {
    if let Some(b) = bridge {
        b.stop().await;
    }
    robot.stop();
    let _ = robot.join();
    service.stop().await.unwrap();
}

/// The value of `key` in the bridge's "ROS 2 commands" diagnostics, with the status's level.
async fn command_diagnostics(node: &mut common::TestNode, key: &str) -> (u8, String) {
    let sub = node.subscribe::<DiagnosticArray>(
        "/lwr",
        "diagnostics",
        DiagnosticArray::TYPE,
        fri_ros2::dds::stream_qos(),
    );
    let a = common::next_where(&sub, "command diagnostics", |a: &DiagnosticArray| {
        a.status.iter().any(|s| s.name.ends_with("ROS 2 commands"))
    })
    .await;
    let s = a
        .status
        .iter()
        .find(|s| s.name.ends_with("ROS 2 commands"))
        .unwrap();
    let v = s.values.iter().find(|v| v.key == key).unwrap();
    (s.level, v.value.clone())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_default_bridge_serves_no_command_to_a_rogue_participant() {
    let dir = tempfile::tempdir().unwrap();
    let (config, service, robot) = service_with_robot(dir.path(), "ro", false).await;
    let mut client = service.client().await.unwrap();
    let audit = common::AuditWatch::start(service.client().await.unwrap()).await;
    let domain = 150;
    let bridge = common::Bridge::start(config, domain, 50);
    let d = domain.to_string();
    // The attacks: stop, disarm, a tare (it moves the arm), apply a wrong payload. No
    // reader exists to match.
    let stop = quiet_rogue(&["trigger", "--service", "stop"], &d);
    let disarm = quiet_rogue(
        &["setbool", "--service", "collision_arm", "--data", "false"],
        &d,
    );
    let tare = quiet_rogue(&["trigger", "--service", "tare"], &d);
    let payload = common::JsonPeer::start(
        "rogue_peer.py",
        &args(&[
            "payload",
            "--service",
            "apply_payload",
            "--mass",
            "3.9",
            "--domain",
            &d,
            "--wait-match",
            "8",
        ]),
    );
    let q_before = common::status(&mut client).await.q.unwrap();
    for peer in [&stop, &disarm, &tare, &payload] {
        assert_eq!(
            peer.next_with("matched", 60).await["matched"],
            0,
            "a command reader exists"
        );
    }
    assert_eq!(stop.next_with("replies", 60).await["replies"], 0);
    assert_eq!(disarm.next_with("replies", 60).await["replies"], 0);
    assert_eq!(tare.next_with("replies", 60).await["replies"], 0);
    payload.next_with("written", 60).await;
    tokio::time::sleep(Duration::from_secs(2)).await;
    let s = common::status(&mut client).await;
    assert!(
        !s.stopped && s.monitor.armed && s.payload.is_none(),
        "{s:?}"
    );
    // The arm did not move (a tare's poses lie degrees apart; 0.01 rad is above the noise).
    let q_after = s.q.unwrap();
    let moved = (0..7)
        .map(|j| (q_after[j] - q_before[j]).abs())
        .fold(0.0, f64::max);
    assert!(moved < 0.01, "the arm moved {moved} rad");
    // Nothing changed at anyone's request: the only records allowed are the loop's own
    // (a monitor restart after a gap the loaded test host causes).
    let records = audit.finish().await;
    assert!(
        records
            .iter()
            .all(|r| matches!(r.change, Change::MonitorRestarted { .. })),
        "{records:?}"
    );
    stop_all(Some(bridge), robot, service).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn unauthenticated_mode_names_the_participant_who_applied_the_payload_and_warns() {
    let dir = tempfile::tempdir().unwrap();
    common::loopback_multicast();
    let mut config = common::service_config(dir.path(), "unauth");
    common::service_accepts_unauthenticated(&mut config);
    let service = InProcess::start(config.clone()).await.unwrap();
    // A controller with an empty flange: the payload check (issue 34 item 5) needs the
    // measured torques, and the topic cannot force.
    let mut sim = mock_robot::SimulationConfig::default();
    sim.payload.attached_at_start = false;
    let robot = common::robot(sim, service.fri, None);
    common::wait_connected(&service).await;
    let mut client = service.client().await.unwrap();
    let audit = common::AuditWatch::start(service.client().await.unwrap()).await;
    let domain = 151;
    // collision_arm without ros2.allow_disarm: it arms, it never disarms.
    let mut ros2 = common::unauthenticated(domain, &["apply_payload", "collision_arm"]);
    ros2.allow_disarm = false;
    let bridge = common::Bridge::start_with(config, ros2);
    let d = domain.to_string();
    let payload = common::JsonPeer::start(
        "rogue_peer.py",
        &args(&[
            "payload",
            "--service",
            "apply_payload",
            "--mass",
            // The flange is empty: the service's check applies only its true payload.
            "0",
            "--domain",
            &d,
        ]),
    );
    let participant = payload.next_with("ready", 60).await["participant"]
        .as_str()
        .unwrap()
        .to_owned();
    assert_eq!(payload.next_with("matched", 60).await["matched"], 1);
    let mut s = common::status(&mut client).await;
    for _ in 0..500 {
        if s.payload.is_some() {
            break;
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
        s = common::status(&mut client).await;
    }
    assert_eq!(s.payload.as_ref().map(|p| p.mass), Some(0.0), "{s:?}");
    assert!(
        matches!(&s.payload_origin, Some(Origin::Ros2 { participant: p, authenticated: false, .. }) if *p == participant),
        "{:?} vs {participant}",
        s.payload_origin
    );
    assert!(s.ros2_unauthenticated_commands);
    let disarm = common::JsonPeer::start(
        "rogue_peer.py",
        &args(&[
            "setbool",
            "--service",
            "collision_arm",
            "--data",
            "false",
            "--domain",
            &d,
            "--quiet",
            "3",
        ]),
    );
    let r = disarm.next_with("replies", 90).await;
    assert_eq!(r["replies"], 1, "{r}");
    assert_eq!(r["messages"][0]["success"], false, "{r}");
    assert!(
        r["messages"][0]["message"]
            .as_str()
            .unwrap()
            .contains("ros2.allow_disarm"),
        "{r}"
    );
    assert!(common::status(&mut client).await.monitor.armed);
    // /lwr/diagnostics: a WARN naming the unauthenticated mode while it holds.
    let mut node = common::TestNode::new(domain, "diag_reader");
    let (level, value) = command_diagnostics(&mut node, "unauthenticated commands").await;
    assert_eq!((level, value.as_str()), (WARN, "true"));
    drop(node);
    bridge.stop().await;
    let records = audit.finish().await;
    assert!(
        records.iter().any(
            |r| matches!(r.change, Change::PayloadApplied { mass, .. } if mass == 0.0)
                && matches!(&r.origin, Origin::Ros2 { participant: p, .. } if *p == participant)
        ),
        "{records:?}"
    );
    // Nothing else was applied meanwhile (the one sample, once).
    let applied = records
        .iter()
        .filter(|r| matches!(r.change, Change::PayloadApplied { .. }))
        .count();
    assert_eq!(applied, 1, "{records:?}");
    assert!(
        !records.iter().any(|r| r.change == Change::Disarmed),
        "{records:?}"
    );
    robot.stop();
    let _ = robot.join();
    service.stop().await.unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn transient_local_requests_written_while_the_bridge_was_down_are_never_executed() {
    let dir = tempfile::tempdir().unwrap();
    let (config, service, robot) = service_with_robot(dir.path(), "replay", true).await;
    let mut client = service.client().await.unwrap();
    // An operator holds the arm.
    client
        .call(Command::Stop, |_, _| {})
        .await
        .unwrap()
        .unwrap();
    assert!(common::status(&mut client).await.stopped);
    let audit = common::AuditWatch::start(service.client().await.unwrap()).await;
    let domain = 152;
    let d = domain.to_string();
    // The attack: transient-local requests written while no bridge runs, kept alive.
    let resume = common::JsonPeer::start(
        "rogue_peer.py",
        &args(&[
            "trigger",
            "--service",
            "resume",
            "--transient-local",
            "--domain",
            &d,
            "--wait-match",
            "0",
            "--quiet",
            "25",
            "--timeout",
            "40",
        ]),
    );
    let payload = common::JsonPeer::start(
        "rogue_peer.py",
        &args(&[
            "payload",
            "--service",
            "apply_payload",
            "--mass",
            "3.9",
            "--transient-local",
            "--domain",
            &d,
            "--wait-match",
            "0",
            "--hold",
            "40",
        ]),
    );
    resume.next_with("written", 60).await;
    payload.next_with("written", 60).await;
    tokio::time::sleep(Duration::from_secs(1)).await;
    let bridge = common::Bridge::start_with(
        config,
        common::unauthenticated(domain, &["resume", "apply_payload"]),
    );
    // The bridge's readers match the writers and receive their history, and ignore it.
    loop {
        let m = payload.next_with("matched", 60).await;
        if m["matched"].as_u64().unwrap_or(0) > 0 {
            break;
        }
    }
    // The historical samples arrive right after the match: give them time to act (or not).
    for _ in 0..15 {
        let s = common::status(&mut client).await;
        assert!(s.stopped, "the operator's stop was released: {s:?}");
        assert!(s.payload.is_none(), "a payload was applied: {s:?}");
        tokio::time::sleep(Duration::from_millis(200)).await;
    }
    let mut node = common::TestNode::new(domain, "replay_diag");
    let mut ignored = 0;
    for _ in 0..30 {
        let (_, v) = command_diagnostics(&mut node, "ignored requests").await;
        ignored = v.parse().unwrap();
        if ignored >= 2 {
            break;
        }
    }
    assert_eq!(
        ignored, 2,
        "both historical requests reached the bridge and were ignored"
    );
    assert_eq!(resume.next_with("replies", 90).await["replies"], 0);
    let s = common::status(&mut client).await;
    assert!(s.stopped && s.payload.is_none(), "{s:?}");
    let records = audit.finish().await;
    assert!(
        !records
            .iter()
            .any(|r| matches!(r.change, Change::Resumed | Change::PayloadApplied { .. })),
        "{records:?}"
    );
    drop(node);
    stop_all(Some(bridge), robot, service).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_flood_of_3000_requests_is_answered_or_counted() {
    let dir = tempfile::tempdir().unwrap();
    let (config, service, robot) = service_with_robot(dir.path(), "flood", true).await;
    let domain = 153;
    let bridge = common::Bridge::start_with(config, common::unauthenticated(domain, &["stop"]));
    let sent = 3000;
    let flood = common::JsonPeer::start(
        "rogue_peer.py",
        &args(&[
            "trigger",
            "--service",
            "stop",
            "--domain",
            &domain.to_string(),
            "--count",
            &sent.to_string(),
            "--quiet",
            "10",
            "--timeout",
            "180",
        ]),
    );
    assert_eq!(flood.next_with("matched", 60).await["matched"], 1);
    let r = flood.next_with("replies", 240).await;
    let answered = r["replies"].as_u64().unwrap();
    // The bridge's count, after the last reply.
    tokio::time::sleep(Duration::from_secs(2)).await;
    let mut node = common::TestNode::new(domain, "flood_diag");
    let (_, dropped) = command_diagnostics(&mut node, "dropped_requests").await;
    let (_, busy) = command_diagnostics(&mut node, "busy").await;
    let dropped: u64 = dropped.parse().unwrap();
    let busy: u64 = busy.parse().unwrap();
    eprintln!("flood of {sent}: {answered} answered ({busy} busy), {dropped} counted as dropped");
    assert_eq!(answered + dropped, sent, "{r}");
    assert!(answered > 0 && busy > 0, "{r}");
    drop(node);
    stop_all(Some(bridge), robot, service).await;
}
