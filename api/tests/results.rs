//! Golden JSON of every operator result and event, built as the daemon builds it
//! (`daemon/src/service/core.rs`, `core/watch.rs`, `events.rs`): each decodes into its typed
//! struct in `fri_api::results` and serialises back to the same JSON.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use fri::session::SessionStatistics;
use fri::wire::{InterfaceStatistics, Measurement};
use fri_api::cause::Cause;
use fri_api::fri_context::FriContext;
use fri_api::protocol::{ErrorCode, OperatorError, Reply};
use fri_api::results::*;
use serde::Serialize;
use serde::de::DeserializeOwned;
use serde_json::{Value, json};

/// Decodes `v` into `T`, checks that it serialises back to `v`, and returns it.
fn round_trip<T: DeserializeOwned + Serialize>(v: Value) -> T {
    let t: T = serde_json::from_value(v.clone())
        .unwrap_or_else(|e| panic!("{}: {e}\n{v:#}", std::any::type_name::<T>()));
    assert_eq!(
        serde_json::to_value(&t).unwrap(),
        v,
        "{}",
        std::any::type_name::<T>()
    );
    t
}

/// An event line's `event`/`data` decoded into [`Event`], and back.
fn event(name: &str, data: Value) -> Event {
    let e = Event::decode(name, &data).unwrap_or_else(|e| panic!("{name}: {e}\n{data:#}"));
    assert_eq!(e.name(), name);
    assert_eq!(
        serde_json::to_value(&e).unwrap(),
        json!({"event": name, "data": data})
    );
    e
}

fn fri() -> Value {
    serde_json::to_value(FriContext::of(&Measurement::default())).unwrap()
}

const Q: [f64; 7] = [0.1, 0.5, -0.2, -1.2, 0.0, 0.5, 0.3];

#[test]
fn status_connected_and_disconnected() {
    // core.rs `status`, with an endpoint snapshot and a state.
    let fri_status = json!({
        "valid": true,
        "state": "Command",
        "quality": "Perfect",
        "krl_status": "CommandActive",
        "drop_reason": "None",
        "cycles": 1234u64,
        "statistics": serde_json::to_value(SessionStatistics::default()).unwrap(),
        "controller_statistics": serde_json::to_value(InterfaceStatistics::default()).unwrap(),
    });
    let connected = json!({
        "connected": true,
        "residual_valid": true,
        "fri": fri_status,
        "cycle": 1234u64,
        "time_s": 1.234,
        "q": Q, "qd": ([0.0; 7]), "tau": ([1.5; 7]), "gravity": ([1.4; 7]), "tau_ext": ([0.1; 7]),
        "residual": ([0.01; 7]),
        "command_mode": true, "stopped": false, "collision": false, "observer_fault": false,
        "moving": false,
        "payload": json!({"mass": 1.5, "com": [0.0, 0.01, -0.02], "frame": "7"}),
        "payload_origin": {"kind": "ros2", "participant": "010f2c4d.00001234.00000001.000001c1",
                           "authenticated": true, "uid": 1000, "pid": 4242},
        "tare_samples": 6,
        "weaker_than_configuration": ["joint 2 threshold 9.000 Nm above the configuration's 6.000 Nm"],
        "monitor": {"armed": true, "thresholds": ([6.0; 7]), "gains": ([400.0; 7]),
                    "reaction": "stop", "pause_s": 2.0, "persisted": false,
                    "set_for_payload": null, "payload_changed": false},
        "ros2_unauthenticated_commands": true,
        "state": {"kind": "commanding"},
        "unknown_payload": null,
        "robot": {"model": "lwr4", "calibration": {
            "path": "/etc/fri-service/arm.toml", "logs": ["run1.csv"], "duration_s": 25.1,
            "residual_rms_nominal": ([1.0; 7]), "heldout_rms": ([0.3; 7]), "offset": ([0.5; 7])}},
        "dropped": {"loop_events": 3, "ipc_messages": null},
    });
    let s: StatusResult = round_trip(connected.clone());
    assert_eq!(s.dropped.unwrap().loop_events, 3);
    assert_eq!(s.robot.as_ref().unwrap().model, "lwr4");
    assert_eq!(s.fri.unwrap().cycles, 1234);
    assert!(matches!(
        s.payload_origin,
        Some(fri_api::origin::Origin::Ros2 { uid: 1000, .. })
    ));
    assert_eq!(s.payload.unwrap().mass, 1.5);
    assert!(s.ros2_unauthenticated_commands);
    // Before the first measurement and without an endpoint snapshot.
    let empty = json!({
        "connected": false, "residual_valid": false, "fri": null,
        "cycle": null, "time_s": null, "q": null, "qd": null, "tau": null, "gravity": null,
        "tau_ext": null, "residual": null,
        "command_mode": false, "stopped": false, "collision": false, "observer_fault": false,
        "moving": false, "payload": null, "payload_origin": null, "tare_samples": null,
        "weaker_than_configuration": [],
        "monitor": {"armed": false, "thresholds": ([6.0; 7]), "gains": ([400.0; 7]),
                    "reaction": "stop", "pause_s": 2.0, "persisted": false,
                    "set_for_payload": null, "payload_changed": false},
        "ros2_unauthenticated_commands": false,
        "state": null,
        "unknown_payload": null,
        "robot": null,
        "dropped": null,
    });
    // Held by a collision: the state names the cause and the controller's view.
    let mut held = connected.clone();
    held["state"] = json!({"kind": "stopped", "cause": {"kind": "collision", "link": 4, "time_s": 2.5, "residual": ([7.0; 7])}, "fri": fri()});
    let s: StatusResult = round_trip(held);
    assert_eq!(s.state.map(|s| s.word()), Some("stopped"));
    let s: StatusResult = round_trip(empty.clone());
    assert!(s.q.is_none() && s.fri.is_none());
    // While the monitor warms up the residual is NaN, which JSON writes as null.
    let mut warming = empty;
    warming["q"] = json!(Q);
    warming["residual"] = json!([null, null, null, null, null, null, null]);
    let s: StatusResult = round_trip(warming);
    assert!(s.residual.unwrap()[0].is_nan());
    // Right after a controller restart: not connected, resynchronising (`fri.resync`).
    let mut resync = connected.clone();
    resync["connected"] = json!(false);
    resync["fri"]["resync"] = json!({"kind": "restart", "source": "192.168.0.20:49938",
                                     "refused": 420u64, "remaining_s": 0.58, "resync_after_s": 1.0});
    let s: StatusResult = round_trip(resync);
    let r = s.fri.unwrap().resync.unwrap();
    assert_eq!((r.kind, r.refused), (ResyncKind::Restart, 420));
    // The payload declared unknown, three static samples fitted.
    let mut grasping = connected;
    grasping["unknown_payload"] = json!({
        "declared_by": "operator", "origin": {"kind": "operator", "uid": 0, "pid": 17},
        "max_mass": 7.0, "max_radius": 0.3, "samples": 3,
        "mass": 3.03, "com": [0.0, 0.0, 0.119], "consistent": true,
        "declared_at_s": 12.5, "grasp_window_end_s": 22.5, "expires_at_s": 150.0,
        "expires_in_s": 120.25,
        "pinned": {
            "mass": 3.03, "com": [0.0, 0.0, 0.119], "mass_tolerance": 0.94,
            "com_tolerance": 0.05, "com_height_open": false, "by": "samples", "samples": 3,
            "at_s": 29.75,
        },
    });
    let s: StatusResult = round_trip(grasping);
    let u = s.unknown_payload.unwrap();
    assert_eq!(u.samples, 3);
    assert_eq!(u.pinned.map(|p| p.by), Some(PinnedBy::Samples));
}

#[test]
fn expect_payload_results() {
    let declared: ExpectPayloadResult = round_trip(json!({"unknown_payload": {
        "declared_by": "estimate-payload", "origin": {"kind": "configuration"},
        "max_mass": 2.0, "max_radius": 0.25, "samples": 0,
        "mass": null, "com": null, "consistent": true,
        "declared_at_s": null, "grasp_window_end_s": null, "expires_at_s": null,
        "expires_in_s": null, "pinned": null,
    }}));
    assert_eq!(
        declared.unknown_payload.unwrap().declared_by,
        DeclaredBy::EstimatePayload
    );
    let ended: ExpectPayloadResult = round_trip(json!({"unknown_payload": null}));
    assert!(ended.unknown_payload.is_none());
}

#[test]
fn sample_tare_and_payload_results() {
    round_trip::<SampleResult>(json!({
        "q": Q, "tau": ([1.0; 7]), "gravity": ([0.9; 7]),
        "velocity_max": 0.0002, "torque_std": ([0.01; 7]), "drift": 0.00001,
        "cycles": 500, "settle_s": 0.35,
    }));
    round_trip::<TareResult>(json!({"samples": 6, "around": Q}));
    round_trip::<PayloadResult>(
        json!({"payload": {"mass": 3.028, "com": [0.0, 0.0, 0.119], "frame": "7"}}),
    );
    let cleared: PayloadResult = round_trip(json!({"payload": null}));
    assert!(cleared.payload.is_none());
    let m: CollisionResult = round_trip(json!({
        "armed": true, "thresholds": [9.0, 9.0, 6.0, 6.0, 4.0, 2.0, 2.0], "gains": ([400.0; 7]),
        "reaction": "pause", "pause_s": 1.5, "persisted": true,
        "set_for_payload": {"mass": 3.028, "com": [0.0, 0.0, 0.119], "frame": "7"},
        "payload_changed": true,
    }));
    assert_eq!(m.reaction, fri_api::protocol::ReactionMode::Pause);
    // An older daemon's reply (no reaction or persistence fields) still decodes.
    let old: CollisionResult = serde_json::from_value(
        json!({"armed": true, "thresholds": [6.0, 6.0, 6.0, 6.0, 6.0, 6.0, 5.0], "gains": ([400.0; 7])}),
    )
    .unwrap();
    assert_eq!(old.reaction, fri_api::protocol::ReactionMode::Stop);
    assert!(!old.persisted && !old.payload_changed);
}

#[test]
fn estimate_result_mirrors_the_estimator_plus_the_service_fields() {
    let estimate = estimator::estimate::PayloadEstimate {
        method: estimator::estimate::Method::Direct,
        correction: estimator::estimate::Correction::None,
        mass: 3.0281,
        mass_std: 0.0004,
        com: [0.0001, -0.0002, 0.1190],
        com_std: ([0.0003; 3]),
        com_flange: [0.0001, -0.0002, 0.0400],
        com_flange_std: ([0.0003; 3]),
        first_moment: [0.0003, -0.0006, 0.3603],
        first_moment_std: ([0.0009; 3]),
        covariance: [[1e-8; 4]; 4],
        residual_rms: vec![0.01; 7],
        residual_std: 0.012,
        condition_number: 12.5,
        samples: 6,
        joints_used: vec![1, 2, 3, 4, 5, 6, 7],
    };
    // core.rs `estimate_payload`: the estimator's JSON plus the service's fields.
    let mut v = serde_json::to_value(&estimate).unwrap();
    v["tare_used"] = json!(true);
    v["correction"] = json!("tare");
    v["frame"] = json!("7");
    v["around"] = json!(Q);
    v["applied"] = json!(false);
    let r: EstimateResult = round_trip(v.clone());
    assert_eq!(r.correction, Correction::Tare);
    assert_eq!(r.method, EstimateMethod::Direct);
    // A CoM component the poses cannot determine is NaN, written as null.
    v["com"][0] = Value::Null;
    let r: EstimateResult = serde_json::from_value(v).unwrap();
    assert!(r.com[0].is_nan());
}

#[test]
fn stop_resume_record_watch_results() {
    let s: StopResult = round_trip(json!({"stopped": true, "controller": "connected"}));
    assert_eq!(s.controller, ControllerLink::Connected);
    let s: StopResult = round_trip(json!({
        "stopped": true, "controller": "silent",
        "note": "the controller is silent: …; nothing is commanded while the controller is silent, and the stop holds the arm when it returns",
    }));
    assert!(s.note.is_some());
    round_trip::<ResumeResult>(json!({"stopped": false, "waiting_for_release": false}));
    round_trip::<ResumeResult>(
        json!({"stopped": true, "waiting_for_release": true, "note": "the contact is still detected"}),
    );
    round_trip::<RecordResult>(json!({"rows": 3, "path": "/var/lib/fri/rec/s.csv"}));
    let r: RecordResult = round_trip(json!({"rows": 50, "path": "/rec/l.csv", "lost": 0}));
    assert_eq!(r.lost, Some(0));
    round_trip::<WatchResult>(json!({"watch": "ended"}));
}

#[test]
fn progress_events_of_every_phase() {
    // core.rs `run_pattern`, `estimate_payload` and `record`.
    for phase in ["moving", "settling"] {
        event(
            "progress",
            json!({"phase": phase, "step": 1, "of": 6, "workflow": "tare", "pose": Q}),
        );
    }
    let e = event(
        "progress",
        json!({"phase": "sampled", "step": 2, "of": 6, "workflow": "estimate", "pose": Q,
               "settle_s": 0.4, "max_speed": 0.0001}),
    );
    assert!(matches!(
        e,
        Event::Progress(Progress {
            phase: Phase::Sampled,
            settle_s: Some(_),
            ..
        })
    ));
    event(
        "progress",
        json!({"phase": "returning", "workflow": "tare", "step": 6, "of": 6}),
    );
    event(
        "progress",
        json!({"phase": "estimating", "workflow": "estimate"}),
    );
    event("progress", json!({"phase": "sampled", "step": 1, "of": 3}));
}

#[test]
fn watch_events_with_their_causes() {
    // workflow/watch.rs, with the reasons as output.rs serialises them.
    assert_eq!(
        event("watching", json!({"cycle": 5})),
        Event::Watching(fri_api::results::Watching { cycle: Some(5) })
    );
    event("watching", json!({"cycle": null}));
    // The audit trail (daemon/src/audit.rs): who changed what.
    let audit = event(
        "audit",
        json!({"time_unix_s": 1.7e9, "origin": {"kind": "operator", "uid": 1000, "pid": 42},
               "change": {"what": "disarmed"}}),
    );
    assert!(matches!(
        audit,
        Event::Audit(AuditRecord {
            change: Change::Disarmed,
            ..
        })
    ));
    event(
        "audit",
        json!({"time_unix_s": 1.7e9, "origin": {"kind": "restored"},
               "change": {"what": "restored", "file": "monitor.json",
                          "weaker_than_configuration": ["report-only reaction (the configuration's is `stop`)"]},
               "suppressed_before": 3}),
    );
    event(
        "collision",
        json!({"time_s": 12.5, "cycle": 12500u64, "link": 4, "joints": [3, 4], "residual": ([0.5; 7])}),
    );
    for (reason, cause) in [
        ("operator", json!({"kind": "operator"})),
        (
            "collision",
            json!({"kind": "collision", "link": 4, "time_s": 12.5, "residual": ([0.5; 7])}),
        ),
        (
            "observer-fault",
            json!({"kind": "observer-fault", "fault": {"StaleMeasurement": {"repeated_samples": 50}}}),
        ),
    ] {
        let e = event(
            "stopped",
            json!({"cycle": 7u64, "reason": reason, "detail": "stopped by …", "cause": cause, "fri": fri()}),
        );
        assert!(matches!(e, Event::Stopped(_)));
    }
    event("resumed", json!({"cycle": 9u64}));
    for kind in [
        "held",
        "command-mode-lost",
        "controller-restarted",
        "unplannable",
        "braked",
    ] {
        event(
            "move-aborted",
            json!({"cycle": 3u64, "reason": {"kind": kind}, "detail": "…", "fri": fri()}),
        );
    }
    for reason in [
        json!({"kind": "controller-restarted"}),
        json!({"kind": "gap", "cycles": 12}),
        json!({"kind": "stopped-in-gap", "cycles": 3}),
    ] {
        event(
            "monitor-restarted",
            json!({"cycle": 3u64, "reason": reason, "detail": "…", "fri": fri()}),
        );
    }
    event(
        "state",
        json!({"cycle": 100u64, "time_s": 0.1, "q": Q, "tau": ([1.0; 7]), "residual": ([0.0; 7]), "flags": 5}),
    );
    event(
        "state",
        json!({"cycle": 101u64, "time_s": 0.101, "q": Q, "tau": ([1.0; 7]), "flags": 128,
               "residual": [null, null, null, null, null, null, null]}),
    );
    assert!(Event::decode("fireworks", &json!({})).is_err());
}

#[test]
fn a_never_heard_controller_error_decodes() {
    // core.rs `latest`: silent "since forever" is +∞, which JSON writes as null.
    let e = OperatorError::new(
        ErrorCode::NotReady,
        "no measurement from the controller yet",
    )
    .with_cause(Cause::ControllerSilent {
        silent_s: f64::INFINITY,
        fri: None,
    });
    let line = Reply::err(Some(1), e).to_line();
    let Reply::Err { error, .. } = serde_json::from_str(&line).unwrap() else {
        panic!("not an error reply: {line}");
    };
    assert!(matches!(
        error.cause.as_deref(),
        Some(Cause::ControllerSilent { silent_s, fri: None }) if silent_s.is_infinite()
    ));
}

#[test]
fn a_not_settled_error_decodes_before_a_full_window() {
    // acquire.rs `not_settled`: before a full settle window the speed is NaN, which JSON writes as
    // null.
    let e = OperatorError::new(ErrorCode::Failed, "the arm did not settle within 2 s").with_cause(
        Cause::NotSettled {
            speed_rad_s: f64::NAN,
            limit_rad_s: 2e-4,
            waited_s: 2.0,
        },
    );
    let line = Reply::err(Some(1), e).to_line();
    let Reply::Err { error, .. } = serde_json::from_str(&line).unwrap() else {
        panic!("not an error reply: {line}");
    };
    assert!(matches!(
        error.cause.as_deref(),
        Some(Cause::NotSettled { speed_rad_s, limit_rad_s, waited_s })
            if speed_rad_s.is_nan() && *limit_rad_s == 2e-4 && *waited_s == 2.0
    ));
}
