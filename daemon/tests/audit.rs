//! The audit trail through the whole daemon in-process: every safety-relevant change reaches a
//! `watch` as an `audit` event naming who made it (the operator's uid from the kernel, or the
//! ROS 2 participant a bridge forwards for), and `status` names who applied the payload.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::time::Duration;

use fri_api::client::Client;
use fri_api::origin::Origin;
use fri_api::protocol::{CollisionAction, Command, Ros2Caller};
use fri_api::results::{AuditRecord, Change, Event, StatusResult};
use fri_service::testkit::{InProcess, local_config};

fn collision(action: CollisionAction) -> Command {
    Command::Collision {
        action,
        thresholds: None,
        gains: None,
        reaction: None,
        pause_s: None,
    }
}

/// Starts a `watch` on its own connection; returns once it is live, with the task that
/// collects the first `n` audit records it sees (10 s at most).
async fn watch_audit(mut c: Client, n: usize) -> tokio::task::JoinHandle<Vec<AuditRecord>> {
    let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel();
    let (live_tx, live_rx) = tokio::sync::oneshot::channel();
    let watcher = tokio::spawn(async move {
        let mut live = Some(live_tx);
        let _ = c
            .call_typed::<serde_json::Value>(Command::Watch { state_every: None }, |e| match e {
                Ok(Event::Watching(_)) => {
                    if let Some(l) = live.take() {
                        let _ = l.send(());
                    }
                }
                Ok(Event::Audit(a)) => {
                    let _ = tx.send(a);
                }
                _ => {}
            })
            .await;
    });
    live_rx.await.unwrap();
    tokio::spawn(async move {
        let mut seen = Vec::new();
        while seen.len() < n {
            match tokio::time::timeout(Duration::from_secs(10), rx.recv()).await {
                Ok(Some(a)) => seen.push(a),
                _ => break,
            }
        }
        watcher.abort();
        seen
    })
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn every_change_names_its_origin_operator_or_ros2_participant() {
    let dir = tempfile::tempdir().unwrap();
    let mut config = local_config(dir.path(), "audit");
    config.ros2 = Some(toml::from_str("allow_unauthenticated_commands = true").unwrap());
    let h = InProcess::start(config).await.unwrap();
    // command, disarmed; command, payload applied.
    let audit = watch_audit(h.client().await.unwrap(), 4).await;
    let mut c = h.client().await.unwrap();
    c.call(collision(CollisionAction::Disarm), |_, _| {})
        .await
        .unwrap()
        .unwrap();
    let participant = "010f2c4d.00001234.00000001.000001c1";
    c.call_for(
        Some(Ros2Caller {
            participant: participant.into(),
            authenticated: false,
        }),
        Command::ApplyPayload {
            mass: 1.5,
            com: [0.0, 0.0, 0.1],
            // No controller to check against: the origin of the change is under test.
            force: Some(true),
        },
        |_, _| {},
    )
    .await
    .unwrap()
    .unwrap();
    let records = audit.await.unwrap();
    // SAFETY: no preconditions.
    let uid = unsafe { libc::geteuid() };
    let changes: Vec<(&Change, &Origin)> = records.iter().map(|r| (&r.change, &r.origin)).collect();
    assert!(
        changes.iter().any(|(c, o)| **c == Change::Disarmed
            && matches!(o, Origin::Operator { uid: u, pid } if *u == uid && *pid == std::process::id() as i32)),
        "{changes:?}"
    );
    assert!(
        changes.iter().any(|(c, o)| matches!(c, Change::PayloadApplied { mass, .. } if *mass == 1.5)
            && matches!(o, Origin::Ros2 { participant: p, authenticated: false, .. } if p == participant)),
        "{changes:?}"
    );
    let status: StatusResult =
        serde_json::from_value(c.call(Command::Status, |_, _| {}).await.unwrap().unwrap()).unwrap();
    assert!(
        matches!(&status.payload_origin, Some(Origin::Ros2 { participant: p, .. }) if p == participant),
        "{:?}",
        status.payload_origin
    );
    assert!(status.ros2_unauthenticated_commands);
    // A payload declared unknown over ROS 2: status names the participant who declared it.
    let declared = c
        .call_for(
            Some(Ros2Caller {
                participant: participant.into(),
                authenticated: false,
            }),
            Command::ExpectPayload {
                max_mass: None,
                max_radius: None,
                end: None,
            },
            |_, _| {},
        )
        .await
        .unwrap();
    assert!(declared.is_ok(), "{declared:?}");
    let status: StatusResult =
        serde_json::from_value(c.call(Command::Status, |_, _| {}).await.unwrap().unwrap()).unwrap();
    let declared_by = status
        .unknown_payload
        .as_ref()
        .and_then(|u| u.origin.as_ref());
    assert!(
        matches!(declared_by, Some(Origin::Ros2 { participant: p, authenticated: false, .. }) if p == participant),
        "{:?}",
        status.unknown_payload
    );
    // Disarmed while the configuration arms: status says the monitor is weaker.
    assert!(
        status
            .weaker_than_configuration
            .iter()
            .any(|w| w.starts_with("disarmed")),
        "{:?}",
        status.weaker_than_configuration
    );
    h.stop().await.unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_unauthenticated_ros2_caller_is_refused_unless_the_configuration_allows_it() {
    let dir = tempfile::tempdir().unwrap();
    let h = InProcess::start(local_config(dir.path(), "auditunauth"))
        .await
        .unwrap();
    let mut c = h.client().await.unwrap();
    let caller = |authenticated| {
        Some(Ros2Caller {
            participant: "010f2c4d.00001234.00000001.000001c1".into(),
            authenticated,
        })
    };
    let e = c
        .call_for(caller(false), collision(CollisionAction::Disarm), |_, _| {})
        .await
        .unwrap()
        .unwrap_err();
    assert!(
        e.message.contains("allow_unauthenticated_commands") && e.message.contains("010f2c4d"),
        "{e:?}"
    );
    let status: StatusResult =
        serde_json::from_value(c.call(Command::Status, |_, _| {}).await.unwrap().unwrap()).unwrap();
    assert!(status.monitor.armed, "the refused disarm did nothing");
    assert!(!status.ros2_unauthenticated_commands);
    // An authenticated participant (the bridge runs with DDS Security) is served.
    c.call_for(caller(true), collision(CollisionAction::Disarm), |_, _| {})
        .await
        .unwrap()
        .unwrap();
    h.stop().await.unwrap();
}
