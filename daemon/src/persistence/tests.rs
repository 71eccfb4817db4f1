//! The state store: round trips, corrupt files, stale temporary files, planted files.

use super::*;
use std::fs;

#[test]
fn payload_round_trips_and_clears() {
    let dir = tempfile::tempdir().unwrap();
    let store = StateStore::open(dir.path()).unwrap();
    assert_eq!(store.load_payload().unwrap(), None);
    let p = AppliedPayload {
        mass: 3.028,
        com: [0.0, 0.0, 0.119],
    };
    store.save_payload(Some(&p)).unwrap();
    let reopened = StateStore::open(dir.path()).unwrap();
    assert_eq!(reopened.load_payload().unwrap(), Some(p));
    reopened.save_payload(None).unwrap();
    assert_eq!(reopened.load_payload().unwrap(), None);
}

#[test]
fn tare_and_calibration_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let store = StateStore::open(&dir.path().join("nested/state")).unwrap();
    let tare = Tare {
        around: [0.1; 7],
        samples: vec![StaticSample::new(
            [0.2; 7].into(),
            [1.5; 7].into(),
            [-1.0; 7].into(),
        )],
        pattern_poses: Some(1),
        taken_unix_s: Some(1.8e9),
        targets: Some(vec![[0.2; 7]]),
        pattern: Some(fri_api::pattern::PatternKind::Centred),
        step_deg: Some(5.0),
        clock: Some(Clocks {
            service_s: 12.0,
            controller_s: 3600.5,
        }),
        session: Some(SessionMark {
            instance: 42,
            restarts: 3,
        }),
    };
    store.save_tare(Some(&tare)).unwrap();
    assert_eq!(store.load_tare().unwrap(), Some(tare));
}

#[test]
fn monitor_settings_round_trip_with_their_payload() {
    let dir = tempfile::tempdir().unwrap();
    let store = StateStore::open(dir.path()).unwrap();
    assert_eq!(store.load_monitor().unwrap(), None);
    let m = StoredMonitor {
        thresholds: [9.0, 9.0, 6.0, 6.0, 4.0, 2.0, 2.0],
        gains: [300.0; 7],
        reaction: fri_api::protocol::ReactionMode::Pause,
        pause_s: 1.5,
        set_for_payload: Some(AppliedPayload {
            mass: 3.028,
            com: [0.0, 0.0, 0.119],
        }),
        schedule: None,
        calibration: None,
    };
    store.save_monitor(Some(&m)).unwrap();
    let reopened = StateStore::open(dir.path()).unwrap();
    assert_eq!(reopened.load_monitor().unwrap(), Some(m));
    let text = fs::read_to_string(reopened.monitor_path()).unwrap();
    assert!(text.contains("\"reaction\": \"pause\""), "{text}");
    reopened.save_monitor(None).unwrap();
    assert_eq!(reopened.load_monitor().unwrap(), None);
}

#[test]
fn corrupt_file_is_reported_not_ignored() {
    let dir = tempfile::tempdir().unwrap();
    let store = StateStore::open(dir.path()).unwrap();
    fs::write(dir.path().join(PAYLOAD_FILE), "{\"mass\": 3.0").unwrap();
    assert!(matches!(
        store.load_payload(),
        Err(PersistError::Corrupt { .. })
    ));
}

#[test]
fn open_removes_temp_files_of_dead_writers_only() {
    let dir = tempfile::tempdir().unwrap();
    // Above the kernel's pid_max (at most 2^22): no such process can exist.
    let dead = dir.path().join(".payload.json.tmp.4999999");
    let dead_link = dir.path().join(".monitor.json.tmp.4999998");
    let outside = tempfile::NamedTempFile::new().unwrap();
    std::os::unix::fs::symlink(outside.path(), &dead_link).unwrap();
    let live = dir
        .path()
        .join(format!(".tare.json.tmp.{}", std::process::id()));
    let foreign = dir.path().join(".notes.txt.tmp.4999999");
    for f in [&dead, &live, &foreign] {
        fs::write(f, "partial").unwrap();
    }
    StateStore::open(dir.path()).unwrap();
    assert!(!dead.exists(), "a dead writer's temp file must be removed");
    assert!(live.exists(), "a running writer's temp file must stay");
    assert!(foreign.exists(), "files the store does not own must stay");
    assert!(
        fs::symlink_metadata(&dead_link).is_ok() && outside.path().exists(),
        "a symlink under a temporary name is neither removed nor followed"
    );
}

#[test]
fn atomic_write_leaves_no_temp_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("x.json");
    atomic_write(&path, b"one").unwrap();
    atomic_write(&path, b"two").unwrap();
    assert_eq!(fs::read(&path).unwrap(), b"two");
    let names: Vec<_> = fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names.len(), 1, "{names:?}");
}

fn monitor() -> StoredMonitor {
    StoredMonitor {
        thresholds: [6.0; 7],
        gains: [400.0; 7],
        reaction: fri_api::protocol::ReactionMode::Stop,
        pause_s: 2.0,
        set_for_payload: None,
        schedule: None,
        calibration: None,
    }
}

#[test]
fn a_symlink_planted_as_the_temporary_file_fails_the_write_and_is_not_followed() {
    // The attack: `.monitor.json.tmp.<pid>` -> a root-owned file outside the directory;
    // `collision configure` overwrote it.
    let tmp = tempfile::tempdir().unwrap();
    let state = tmp.path().join("state");
    let store = StateStore::open(&state).unwrap();
    store.save_monitor(Some(&monitor())).unwrap();
    let before = fs::read(store.monitor_path()).unwrap();
    let victim = tmp.path().join("passwd");
    fs::write(&victim, "root:x:0:0").unwrap();
    let planted = state.join(format!(".monitor.json.tmp.{}", std::process::id()));
    std::os::unix::fs::symlink(&victim, &planted).unwrap();
    let mut weaker = monitor();
    weaker.thresholds = [44.0; 7];
    let e = store.save_monitor(Some(&weaker)).unwrap_err();
    assert!(matches!(e, PersistError::Planted { .. }), "{e}");
    assert!(e.to_string().contains("symbolic link"), "{e}");
    assert_eq!(fs::read_to_string(&victim).unwrap(), "root:x:0:0");
    assert_eq!(fs::read(store.monitor_path()).unwrap(), before);
    // A dangling one is not created through either.
    fs::remove_file(&victim).unwrap();
    assert!(store.save_monitor(Some(&weaker)).is_err());
    assert!(!victim.exists());
}

#[test]
fn a_regular_file_left_under_this_processs_temporary_name_is_replaced() {
    let tmp = tempfile::tempdir().unwrap();
    let store = StateStore::open(tmp.path()).unwrap();
    let left = tmp
        .path()
        .join(format!(".payload.json.tmp.{}", std::process::id()));
    fs::write(&left, "partial").unwrap();
    let p = AppliedPayload {
        mass: 1.0,
        com: [0.0; 3],
    };
    store.save_payload(Some(&p)).unwrap();
    assert_eq!(store.load_payload().unwrap(), Some(p));
    assert!(!left.exists());
}

#[test]
fn planted_state_files_that_are_links_or_writable_by_others_are_not_restored() {
    let tmp = tempfile::tempdir().unwrap();
    let state = tmp.path().join("state");
    let store = StateStore::open(&state).unwrap();
    let elsewhere = tmp.path().join("payload.json");
    fs::write(&elsewhere, "{\"mass\": 6.9, \"com\": [0, 0, 0.1]}").unwrap();
    std::os::unix::fs::symlink(&elsewhere, state.join(PAYLOAD_FILE)).unwrap();
    let e = store.load_payload().unwrap_err().to_string();
    assert!(
        e.contains("payload.json") && e.contains("symbolic link"),
        "{e}"
    );
    fs::remove_file(state.join(PAYLOAD_FILE)).unwrap();
    fs::copy(&elsewhere, state.join(PAYLOAD_FILE)).unwrap();
    std::fs::set_permissions(
        state.join(PAYLOAD_FILE),
        std::os::unix::fs::PermissionsExt::from_mode(0o646),
    )
    .unwrap();
    let e = store.load_payload().unwrap_err().to_string();
    assert!(e.contains("writable by group or others"), "{e}");
}
