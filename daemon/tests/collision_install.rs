//! `collision-install` through the operator socket of the whole daemon in-process: thresholds
//! calibrated elsewhere (`fri-ctl offline calibrate-thresholds`) are installed with their
//! schedule and gains, persisted and restored at the next start, audited with their origin;
//! thresholds fitted at another period or on another arm model, out-of-range schedules, a
//! hostile source name and thresholds above the ceiling are refused naming the field, and
//! nothing changes. The end-to-end route on real recordings is in
//! `ctl/tests/real_arm_service.rs`.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod common;

use common::collision_show as show;
use common::*;
use fri_api::cause::Cause;
use fri_api::protocol::{Command, ErrorCode, InstallThresholds, OperatorError};
use fri_api::results::{CalibrationInfo, CollisionResult, ThresholdSchedule};
use fri_service::testkit::{InProcess, local_config};
use serde_json::json;

fn schedule() -> ThresholdSchedule {
    ThresholdSchedule {
        thresholds: [1.8, 3.9, 1.4, 2.5, 1.6, 1.2, 1.1],
        speed: [0.5, 0.8, 0.3, 0.2, 0.1, 0.1, 0.05],
        velocity_noise: [0.0; 7],
        payload_dynamics: [0.0; 7],
        inertial: [0.1, 0.2, 0.1, 0.1, 0.0, 0.0, 0.0],
        gravity: [0.0, 0.01, 0.0, 0.01, 0.0, 0.0, 0.0],
        scale: [12.9, 8.0, 12.7, 9.0, 7.0, 5.0, 6.6],
        ceiling: [2.5, 4.5, 2.5, 3.0, 2.0, 1.5, 1.5],
    }
}

/// [`schedule`] as JSON with `field[index]` set to `value`.
fn schedule_with(field: &str, index: usize, value: f64) -> serde_json::Value {
    let mut s = serde_json::to_value(schedule()).unwrap();
    s[field][index] = json!(value);
    s
}

fn recording() -> CalibrationInfo {
    CalibrationInfo {
        budget_per_hour: 0.1,
        duration_s: 25.0,
        blocks: 24,
        block_s: 1.0,
        max_speed: [0.6, 0.1, 0.2, 0.3, 0.2, 0.2, 0.3],
        max_acceleration: [1.0; 7],
        installed_from: None,
    }
}

/// A valid request for this service (1 ms, nominal model), from `run1.json`.
fn install() -> Command {
    Command::CollisionInstall(Box::new(InstallThresholds {
        schedule: schedule(),
        recording: recording(),
        median_thresholds: [2.1, 4.5, 2.4, 3.0, 2.0, 1.5, 1.2],
        period_s: 0.001,
        gains: [200.0; 7],
        arm_offset: None,
        source: "run1.json".to_owned(),
        allow_weaker: None,
    }))
}

async fn settings(c: &mut fri_api::client::Client) -> CollisionResult {
    serde_json::from_value(call(c, show()).await.unwrap()).unwrap()
}

fn refused(r: Result<serde_json::Value, OperatorError>) -> OperatorError {
    match r {
        Ok(v) => panic!("installed: {v}"),
        Err(e) => e,
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn installed_thresholds_carry_their_schedule_and_gains_are_audited_and_survive_a_restart() {
    let dir = tempfile::tempdir().unwrap();
    let config = local_config(dir.path(), "install");
    let service = InProcess::start(config.clone()).await.unwrap();
    let mut c = service.client().await.unwrap();
    let events = collect_watch(service.client().await.unwrap(), None).await;
    let before = settings(&mut c).await;
    assert!(before.schedule.is_none(), "{before:?}");

    let m: CollisionResult =
        serde_json::from_value(call(&mut c, install()).await.unwrap()).unwrap();
    assert_eq!(m.thresholds, schedule().thresholds);
    assert_eq!(m.gains, [200.0; 7]);
    assert_eq!(m.schedule, Some(schedule()));
    let info = m.calibration.clone().unwrap();
    assert_eq!(info.installed_from.as_deref(), Some("run1.json"));
    assert_eq!(info.budget_per_hour, 0.1);
    assert!(m.persisted, "{m:?}");
    // The audit trail names who installed what.
    wait_event(&events, "calibration-installed audit", |e, d| {
        e == "audit"
            && d["change"]["what"] == "calibration-installed"
            && d["origin"]["kind"] == "operator"
    })
    .await;
    // A file written before caps (no `ceiling`) may reach a quarter of the torque limit in
    // motion: weaker than the configured 6 Nm, so it installs only with allow_weaker.
    let mut old = serde_json::to_value(install()).unwrap();
    old["schedule"].as_object_mut().unwrap().remove("ceiling");
    let e = refused(call(&mut c, serde_json::from_value(old.clone()).unwrap()).await);
    let Some(Cause::CalibrationAboveCeiling { joints }) = e.cause.as_deref() else {
        panic!("{e:?}");
    };
    assert_eq!(joints.len(), 7, "{e:?}");
    old["allow_weaker"] = json!(true);
    let m: CollisionResult = serde_json::from_value(
        call(&mut c, serde_json::from_value(old).unwrap())
            .await
            .unwrap(),
    )
    .unwrap();
    let ceiling = m.schedule.unwrap().ceiling;
    assert_eq!(ceiling, fri_api::schedule::quarter_of_the_torque_limits());
    assert_eq!(ceiling[0], 44.0, "{ceiling:?}");
    let m: CollisionResult =
        serde_json::from_value(call(&mut c, install()).await.unwrap()).unwrap();
    assert_eq!(m.schedule, Some(schedule()));
    service.stop().await.unwrap();

    // The next start restores the schedule, the gains and where they came from.
    let service = InProcess::start(config).await.unwrap();
    let mut c = service.client().await.unwrap();
    let restored = settings(&mut c).await;
    assert_eq!(restored.schedule, Some(schedule()), "{restored:?}");
    assert_eq!(restored.gains, [200.0; 7]);
    assert_eq!(
        restored.calibration.and_then(|i| i.installed_from),
        Some("run1.json".to_owned())
    );
    service.stop().await.unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn thresholds_for_another_setup_or_out_of_range_are_refused_and_nothing_changes() {
    let dir = tempfile::tempdir().unwrap();
    let mut config = local_config(dir.path(), "installbad");
    config.observer.calibration_ceiling_nm = [3.0; 7];
    let service = InProcess::start(config).await.unwrap();
    let mut c = service.client().await.unwrap();
    let before = settings(&mut c).await;
    // The valid request with one field of its JSON changed.
    let with = |field: &str, value: serde_json::Value| -> Command {
        let mut v = serde_json::to_value(install()).unwrap();
        v[field] = value;
        serde_json::from_value(v).unwrap()
    };

    // Fitted at 2 ms: another residual.
    let e = refused(call(&mut c, with("period_s", json!(0.002))).await);
    assert_eq!(e.code, ErrorCode::InvalidArguments, "{e:?}");
    assert!(
        matches!(e.cause.as_deref(), Some(Cause::ThresholdsForAnotherSetup { field, .. }) if field == "period_s"),
        "{e:?}"
    );
    // Fitted on an identified arm; this service runs the nominal model.
    let e = refused(
        call(
            &mut c,
            with("arm_offset", json!([0.9, 0.7, 0.0, -0.3, -0.7, 0.6, -0.1])),
        )
        .await,
    );
    assert!(
        matches!(e.cause.as_deref(), Some(Cause::ThresholdsForAnotherSetup { field, .. }) if field == "arm_offset"),
        "{e:?}"
    );
    assert!(e.message.contains("nominal model"), "{e:?}");
    // A negative schedule coefficient, a gain beyond the 1 ms bound, a median below the floor.
    let e = refused(call(&mut c, with("schedule", schedule_with("speed", 2, -1.0))).await);
    assert!(e.message.contains("schedule.speed[2]"), "{e:?}");
    // A cap beyond the wrist's quarter of its torque limit (9.5 Nm): detection off there.
    let e = refused(call(&mut c, with("schedule", schedule_with("ceiling", 6, 30.0))).await);
    assert!(e.message.contains("schedule.ceiling[6]"), "{e:?}");
    let e = refused(
        call(
            &mut c,
            with("gains", json!([200, 200, 200, 200, 200, 200, 900])),
        )
        .await,
    );
    assert!(e.message.contains("gains[6]"), "{e:?}");
    let e = refused(
        call(
            &mut c,
            with("median_thresholds", json!([0, 4.5, 2.4, 3, 2, 1.5, 1.2])),
        )
        .await,
    );
    assert!(e.message.contains("median_thresholds[0]"), "{e:?}");
    // A source name that would forge log lines.
    let e = refused(
        call(
            &mut c,
            with("source", json!("run1.json\nfri_service::audit: disarmed")),
        )
        .await,
    );
    assert!(e.message.contains("`source`"), "{e:?}");
    let e = refused(call(&mut c, with("source", json!(""))).await);
    assert!(e.message.contains("`source`"), "{e:?}");
    // θ0 and median under the ceiling of 3 Nm, but a cap above it (joint 1 may reach 5 Nm in
    // a faster motion): weaker than the configuration, refused.
    let e = refused(call(&mut c, with("schedule", schedule_with("ceiling", 0, 5.0))).await);
    let Some(Cause::CalibrationAboveCeiling { joints }) = e.cause.as_deref() else {
        panic!("{e:?}");
    };
    assert_eq!(joints[0].joint, 1, "{e:?}");
    assert_eq!(joints[0].threshold_max_nm, 5.0, "{e:?}");
    assert!(e.message.contains("up to 5.00 Nm in motion"), "{e:?}");
    // Above the ceiling of 3 Nm (joint 2, at rest, as median and as cap): only with allow_weaker.
    let e = refused(call(&mut c, install()).await);
    let Some(Cause::CalibrationAboveCeiling { joints }) = e.cause.as_deref() else {
        panic!("{e:?}");
    };
    let named: Vec<usize> = joints.iter().map(|j| j.joint).collect();
    assert_eq!(named, vec![2], "{e:?}");
    assert!(e.message.contains("allow_weaker"), "{e:?}");
    assert_eq!(
        settings(&mut c).await,
        before,
        "a refused install changed the monitor"
    );

    let m: CollisionResult = serde_json::from_value(
        call(&mut c, with("allow_weaker", json!(true)))
            .await
            .unwrap(),
    )
    .unwrap();
    assert_eq!(m.schedule, Some(schedule()));
    service.stop().await.unwrap();
}
