//! The collision monitor's settings through the operator socket of the whole daemon in-process:
//! out-of-range values refused naming the field and its range, settings stored with their
//! payload and restored by the next start, a stored file that no longer fits stops the start.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod common;

use common::collision_show as show;
use fri_api::cause::Cause;
use fri_api::client::Client;
use fri_api::protocol::{CollisionAction, Command, ErrorCode, OperatorError, ReactionMode};
use fri_api::results::{CollisionResult, StatusResult};
use fri_service::config::Config;
use fri_service::testkit::{InProcess, local_config};

fn configure(
    thresholds: Option<[f64; 7]>,
    gains: Option<[f64; 7]>,
    reaction: Option<ReactionMode>,
    pause_s: Option<f64>,
) -> Command {
    Command::Collision {
        action: CollisionAction::Configure,
        thresholds,
        gains,
        reaction,
        pause_s,
    }
}

async fn call<T: serde::de::DeserializeOwned>(
    c: &mut Client,
    cmd: Command,
) -> Result<T, OperatorError> {
    c.call(cmd, |_, _| {})
        .await
        .unwrap()
        .map(|v| serde_json::from_value(v).unwrap())
}

fn config(dir: &std::path::Path) -> Config {
    local_config(dir, "monitor")
}

const PER_JOINT: [f64; 7] = [9.0, 9.0, 6.0, 6.0, 4.0, 2.0, 2.0];

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn out_of_range_settings_are_refused_naming_the_field_and_nothing_changes() {
    let dir = tempfile::tempdir().unwrap();
    let h = InProcess::start(config(dir.path())).await.unwrap();
    let mut c = h.client().await.unwrap();
    let mut gains = [400.0; 7];
    gains[2] = 1e5;
    let mut thresholds = [6.0; 7];
    thresholds[6] = 10.0;
    let cases = [
        (
            configure(None, Some(gains), None, None),
            "gains[2]",
            "gains[2] = 100000 1/s is outside 1…500 1/s (joint 3)",
        ),
        (
            configure(Some(thresholds), None, None, None),
            "thresholds[6]",
            "thresholds[6] = 10 Nm is outside 0.1…9.5 Nm (joint 7)",
        ),
        (
            configure(Some([0.0; 7]), None, None, None),
            "thresholds[0]",
            "thresholds[0] = 0 Nm is outside 0.1…44 Nm (joint 1)",
        ),
        (
            configure(None, None, Some(ReactionMode::Pause), Some(600.0)),
            "pause_s",
            "pause_s = 600 s is outside 0…60 s",
        ),
    ];
    for (command, field, message) in cases {
        let e = call::<CollisionResult>(&mut c, command).await.unwrap_err();
        assert_eq!(e.code, ErrorCode::InvalidArguments, "{e:?}");
        assert_eq!(e.message, message);
        match e.cause.as_deref() {
            Some(Cause::OutOfRange { field: f, .. }) => assert_eq!(f, field),
            other => panic!("{field}: cause {other:?}"),
        }
    }
    let e = call::<CollisionResult>(&mut c, configure(None, None, None, None))
        .await
        .unwrap_err();
    assert_eq!(e.code, ErrorCode::InvalidArguments);
    // Nothing was applied or stored.
    let m: CollisionResult = call(&mut c, show()).await.unwrap();
    assert_eq!((m.thresholds, m.gains), ([6.0; 7], [400.0; 7]));
    assert!(!m.persisted);
    assert!(!dir.path().join("state/monitor.json").exists());
    h.stop().await.unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn settings_survive_a_restart_with_the_payload_they_were_set_for() {
    let dir = tempfile::tempdir().unwrap();
    let h = InProcess::start(config(dir.path())).await.unwrap();
    let mut c = h.client().await.unwrap();
    // No controller: nothing to check the payload against, so forced (the settings' binding
    // to the payload is under test).
    let apply = |mass| Command::ApplyPayload {
        mass,
        com: [0.0, 0.0, 0.119],
        force: Some(true),
    };
    call::<serde_json::Value>(&mut c, apply(3.028))
        .await
        .unwrap();
    let m: CollisionResult = call(
        &mut c,
        configure(
            Some(PER_JOINT),
            Some([300.0; 7]),
            Some(ReactionMode::Pause),
            Some(1.5),
        ),
    )
    .await
    .unwrap();
    assert_eq!(m.thresholds, PER_JOINT);
    assert!(m.persisted && !m.payload_changed);
    assert_eq!(m.set_for_payload.as_ref().unwrap().mass, 3.028);
    // Only what is given changes.
    let m: CollisionResult = call(&mut c, configure(None, None, None, Some(2.5)))
        .await
        .unwrap();
    assert_eq!(
        (m.thresholds, m.gains, m.reaction, m.pause_s),
        (PER_JOINT, [300.0; 7], ReactionMode::Pause, 2.5)
    );
    // Disarming is not stored.
    call::<CollisionResult>(
        &mut c,
        Command::Collision {
            action: CollisionAction::Disarm,
            thresholds: None,
            gains: None,
            reaction: None,
            pause_s: None,
        },
    )
    .await
    .unwrap();
    drop(c);
    h.stop().await.unwrap();

    let h = InProcess::start(config(dir.path())).await.unwrap();
    let mut c = h.client().await.unwrap();
    let status: StatusResult = call(&mut c, Command::Status).await.unwrap();
    let m = status.monitor;
    assert_eq!(m.thresholds, PER_JOINT);
    assert_eq!(m.gains, [300.0; 7]);
    assert_eq!((m.reaction, m.pause_s), (ReactionMode::Pause, 2.5));
    assert!(m.persisted && !m.payload_changed);
    assert!(m.armed, "a restart arms as the configuration says");
    // Another payload: the stored settings were set for the first one.
    call::<serde_json::Value>(&mut c, apply(1.0)).await.unwrap();
    let m: CollisionResult = call(&mut c, show()).await.unwrap();
    assert!(m.payload_changed, "{m:?}");
    // A re-estimate of the same load (1 % off) is the same payload.
    call::<serde_json::Value>(&mut c, apply(3.028 * 1.01))
        .await
        .unwrap();
    let m: CollisionResult = call(&mut c, show()).await.unwrap();
    assert!(!m.payload_changed, "{m:?}");
    call::<serde_json::Value>(&mut c, Command::ClearPayload)
        .await
        .unwrap();
    let m: CollisionResult = call(&mut c, show()).await.unwrap();
    assert!(m.payload_changed, "{m:?}");
    drop(c);
    h.stop().await.unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_stored_gain_outside_the_range_stops_the_start_naming_the_file_and_key() {
    let dir = tempfile::tempdir().unwrap();
    let h = InProcess::start(config(dir.path())).await.unwrap();
    let mut c = h.client().await.unwrap();
    call::<CollisionResult>(&mut c, configure(Some([5.0; 7]), None, None, None))
        .await
        .unwrap();
    drop(c);
    h.stop().await.unwrap();
    let file = dir.path().join("state/monitor.json");
    let text = std::fs::read_to_string(&file).unwrap();
    let mut stored: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(stored["thresholds"][0], 5.0);
    stored["gains"][4] = serde_json::json!(1e5);
    std::fs::write(&file, serde_json::to_string(&stored).unwrap()).unwrap();
    let e = InProcess::start(config(dir.path())).await.unwrap_err();
    let text = format!("{e:#}");
    assert!(text.contains("monitor.json"), "{text}");
    assert!(text.contains("observer.gains[4] (joint 5)"), "{text}");
    assert!(text.contains("1…500 1/s"), "{text}");
}
