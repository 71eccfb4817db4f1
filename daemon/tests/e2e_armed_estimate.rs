//! Grasping and estimating an unknown payload with the collision monitor armed throughout
//! (issue 12): the service against the real-time mock robot through the operator socket.
//!
//! The tare runs in lockstep (fast); the same simulated robot then restarts in real time, the
//! operator declares the payload unknown (`expect-payload`), the payload is picked up at a fixed
//! controller time, and `estimate-payload --apply` runs armed. Outcomes only: no
//! collision event for the payload itself, the estimate applied and the mode ended; a contact
//! during the estimate is caught, holds the arm and aborts with the collision cause.
//!
//! On a host that stalls the real-time pair (this shared VM does, at times for more than half of
//! the cycles) the controller may end command mode for good. That outcome is asserted too — the
//! typed cause, no collision, the arm not held — and the scenario is tried again, at most
//! [`ATTEMPTS`] times. A run the host stalled proves nothing about the workflow: when every
//! attempt stalled the test fails, saying so with the evidence; it never passes on stalls. A
//! collision before the scenario's own contact is a false contact and fails the test, stalled
//! host or not (issue 34 item 6).
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod common;

use std::future::Future;
use std::time::Duration;

use common::*;
use fri_api::cause::Cause;
use fri_api::client::Client;
use fri_api::protocol::{Command, ErrorCode, OperatorError};
use mock_robot::contact::{ContactProfile, ContactSpec};
use mock_robot::{MockRobotHandle, ServerConfig, TimingMode};

/// Controller time of the real-time session at which the payload is picked up, s (the operator
/// declares it unknown before).
const GRASP_S: f64 = 2.0;

/// One real-time controller and service at a time: on this 2-core machine three pairs of
/// real-time threads in parallel miss answers on their own (the controller then drops command
/// mode), which is not what these tests are about.
static REAL_TIME: tokio::sync::Mutex<()> = tokio::sync::Mutex::const_new(());

/// Attempts of a scenario while the host's stalls end command mode before it completes.
const ATTEMPTS: usize = 5;

/// Lateness of a controller cycle start beyond which the controller's own thread stalled, s
/// (the service's connection timeout is 0.1 s).
const CONTROLLER_STALL_S: f64 = 0.05;

/// How one attempt of a scenario ended.
enum Attempt {
    /// The scenario ran to its end; every assertion held.
    Done,
    /// The host's stalls ended command mode first (the outcome asserted), as described.
    HostStalled(String),
}

/// Runs `scenario` one real-time pair at a time until an attempt is done, at most
/// [`ATTEMPTS`] times.
async fn in_attempts<F: Future<Output = Attempt>>(scenario: impl Fn() -> F) {
    let _one_at_a_time = REAL_TIME.lock().await;
    let mut stalled = Vec::new();
    for _ in 0..ATTEMPTS {
        match scenario().await {
            Attempt::Done => return,
            Attempt::HostStalled(why) => stalled.push(why),
        }
    }
    panic!(
        "no conclusion: the host stalled the real-time pair in all {ATTEMPTS} attempts (the \
         outcome under the stalls held each time, but the workflow never ran): {stalled:#?}"
    );
}

/// An attempt whose workflow failed with `e`: asserts that it is the outcome of a stalled
/// host and ends the attempt. The host stalled when the controller missed more than 2 % of our
/// answers (an idle host: about 0.4 %) or its own thread started a cycle more than
/// [`CONTROLLER_STALL_S`] late. Accepted outcomes: command mode lost or never entered, the
/// controller silent; and the contact of the scenario (onset `contact_onset_s`) taking place
/// before the stalled test host could start the estimate (the arm then held by it). A
/// collision before that onset is a false contact: the test fails with its evidence, whatever
/// the host did (the one cause found so far, a stall across the grasp, is fixed and reproduced
/// cycle by cycle in `unknown_payload_pin.rs`).
async fn host_stalled(
    e: OperatorError,
    c: &mut Client,
    driver: MockRobotHandle,
    events: &Collected,
    h: Harness,
    contact_onset_s: Option<f64>,
) -> Attempt {
    let answers = driver.counters().answer_counts();
    let (_, summary) = driver.join().unwrap();
    let stalled = answers.missed * 50 > answers.sent || summary.max_lateness_s > CONTROLLER_STALL_S;
    let evidence = format!(
        "{answers:?}, controller thread: {} late cycles, latest by {:.3} s",
        summary.late_cycles, summary.max_lateness_s
    );
    assert!(
        stalled,
        "failed on a host that kept time ({evidence}): {e:?}"
    );
    let times = collision_times(events);
    let onset = contact_onset_s.unwrap_or(f64::INFINITY);
    let status = call(c, Command::Status).await.unwrap();
    match e.cause.as_deref() {
        Some(
            Cause::CommandModeLost { .. }
            | Cause::CommandModeNotEntered { .. }
            | Cause::ControllerSilent { .. },
        ) => {
            assert!(
                times.iter().all(|t| *t >= onset),
                "a collision before any contact: {times:?} (the workflow: {e:?}; events: {:?})",
                events.lock().unwrap()
            );
            if times.is_empty() {
                assert_eq!(status["stopped"], false, "nothing holds the arm: {status}");
            }
        }
        Some(Cause::Held) if contact_onset_s.is_some() => {
            assert_eq!(status["stopped"], true, "{status}");
            assert!(!times.is_empty(), "held without a collision: {status}");
        }
        Some(Cause::Collision { .. }) => panic!(
            "FALSE CONTACT under host stalls ({evidence}): collisions at {times:?} s, the \
             scenario's contact at {onset} s: {e:?} (events: {:?})",
            events.lock().unwrap()
        ),
        _ => panic!("not the outcome of a stalled host ({evidence}): {e:?}"),
    }
    h.stop().await;
    Attempt::HostStalled(format!("{evidence}: {}", e.message))
}

/// The status once the residual is valid again (the monitor restarts after a gap the host
/// causes, and its residual is undefined until it has run).
async fn status_with_residual(c: &mut Client) -> serde_json::Value {
    for _ in 0..200 {
        let status = call(c, Command::Status).await.unwrap();
        if status["residual_valid"] == true {
            return status;
        }
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    panic!("the residual never became valid");
}

fn three_pose_tare() -> Command {
    Command::Tare {
        around: None,
        poses: Some(3),
        step_deg: Some(7.0),
        pattern: None,
        replace_loaded: None,
    }
}

fn estimate_and_apply() -> Command {
    Command::EstimatePayload {
        around: None,
        poses: None,
        step_deg: Some(7.0),
        pattern: None,
        use_tare: None,
        apply: Some(true),
    }
}

/// The service armed (reaction: stop), its state in `dir`, after a three-pose tare in lockstep;
/// then the same simulated robot (same seed: same model error and sensor offsets) restarted in
/// real time with the grasp at `GRASP_S` and `contacts` in its scenario, its controller
/// tolerant of host stalls (see `tolerant_of_host_stalls`).
async fn tared_and_restarted(
    dir: tempfile::TempDir,
    seed: u64,
    contacts: Vec<ContactSpec>,
    payload_kg: f64,
) -> (Harness, fri_api::client::Client, MockRobotHandle, Collected) {
    let mut config = armed_to_stop(test_config(dir.path()));
    // The real-time session comes from a new port: bind it soon after the lockstep one ends.
    config.fri.resync_after_s = 0.1;
    let h = Harness::start(config, dir).await;
    let driver =
        mock_robot::spawn_new(sim(false, seed), ServerConfig::loopback(h.fri, lockstep())).unwrap();
    let mut c = h.client().await;
    wait_connected(&mut c).await;
    let tare = call(&mut c, three_pose_tare()).await.unwrap();
    assert_eq!(tare["samples"], 3, "{tare}");
    drop(driver.join());
    let mut restarted = tolerant_of_host_stalls(sim(false, seed));
    restarted.payload.mass_kg = payload_kg;
    restarted.payload.events = vec![mock_robot::config::PayloadEvent {
        time_s: GRASP_S,
        action: mock_robot::config::PayloadAction::Attach,
    }];
    restarted.contacts = contacts;
    let driver = mock_robot::spawn_new(
        restarted,
        ServerConfig::loopback(h.fri, TimingMode::RealTime),
    )
    .unwrap();
    for _ in 0..500 {
        if driver.counters().answer_counts().answered > 50 {
            break;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    let events = collect_watch(h.client().await, None).await;
    (h, c, driver, events)
}

/// Waits until the real-time controller is `after_s` past the grasp.
async fn until_after_grasp(driver: &MockRobotHandle, after_s: f64) {
    let cycles = ((GRASP_S + after_s) * 1000.0) as u64;
    while driver.counters().answer_counts().sent < cycles {
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
}

fn count(events: &Collected, name: &str) -> usize {
    events
        .lock()
        .unwrap()
        .iter()
        .filter(|(e, _)| e == name)
        .count()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn tare_declare_grasp_and_estimate_with_the_monitor_armed_throughout() {
    in_attempts(|| async {
        let dir = tempfile::tempdir().unwrap();
        let (h, mut c, driver, events) = tared_and_restarted(dir, 31, Vec::new(), 3.028).await;
        let declared = call(&mut c, declare_payload_unknown()).await.unwrap();
        assert_eq!(
            declared["unknown_payload"]["declared_by"], "operator",
            "{declared}"
        );
        assert_eq!(declared["unknown_payload"]["samples"], 0);
        until_after_grasp(&driver, 0.5).await;
        let status = status_with_residual(&mut c).await;
        assert_eq!(status["monitor"]["armed"], true, "{status}");
        assert_eq!(
            status["stopped"], false,
            "the payload is tolerated: {status}"
        );
        assert!(status["unknown_payload"].is_object(), "{status}");
        // The uncompensated payload is in the residual (far over 6 Nm) and tolerated.
        let r2 = status["residual"][1].as_f64().unwrap_or(0.0);
        assert!(
            r2.abs() > 6.0,
            "the payload shows in the residual: {status}"
        );
        let est = match call(&mut c, estimate_and_apply()).await {
            Ok(est) => est,
            Err(e) => return host_stalled(e, &mut c, driver, &events, h, None).await,
        };
        let (robot, _) = driver.join().unwrap();
        let truth = robot.true_payload().unwrap();
        let mass = est["mass"].as_f64().unwrap();
        eprintln!("estimate {est}");
        assert_eq!(est["applied"], true);
        assert_eq!(est["tare_used"], true);
        assert!(
            ((mass - truth.mass) / truth.mass).abs() < 0.01,
            "mass {mass} vs {}",
            truth.mass
        );
        let status = call(&mut c, Command::Status).await.unwrap();
        assert_eq!(status["monitor"]["armed"], true, "{status}");
        assert!(
            status["unknown_payload"].is_null(),
            "applied: the mode ended: {status}"
        );
        assert_eq!(status["payload"]["mass"].as_f64().unwrap(), mass);
        assert_eq!(status["stopped"], false, "{status}");
        assert_eq!(
            count(&events, "collision"),
            0,
            "{:?}",
            events.lock().unwrap()
        );
        assert_eq!(count(&events, "stopped"), 0, "{:?}", events.lock().unwrap());
        h.stop().await;
        Attempt::Done
    })
    .await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_contact_during_the_armed_estimate_is_caught_holds_the_arm_and_aborts_it() {
    in_attempts(|| async {
        let dir = tempfile::tempdir().unwrap();
        // An 80 N half-sine on link 5 well inside the estimate (it starts 0.5 s after the grasp
        // and takes seconds of controller time).
        let contact = ContactSpec {
            link: 5,
            point_m: [0.0, -0.05, 0.0],
            onset_s: GRASP_S + 2.0,
            profile: ContactProfile::HalfSine {
                peak_force_n: [80.0, 0.0, 0.0],
                duration_s: 0.3,
            },
        };
        let (h, mut c, driver, events) = tared_and_restarted(dir, 37, vec![contact], 3.028).await;
        call(&mut c, declare_payload_unknown()).await.unwrap();
        until_after_grasp(&driver, 0.5).await;
        let e = call(&mut c, estimate_and_apply()).await.unwrap_err();
        if !matches!(e.cause.as_deref(), Some(Cause::Collision { .. })) {
            return host_stalled(e, &mut c, driver, &events, h, Some(GRASP_S + 2.0)).await;
        }
        assert_eq!(e.code, ErrorCode::Aborted, "{e:?}");
        let status = call(&mut c, Command::Status).await.unwrap();
        assert_eq!(status["stopped"], true, "the arm is held: {status}");
        assert_eq!(status["state"]["cause"]["kind"], "collision", "{status}");
        assert_eq!(status["monitor"]["armed"], true);
        assert!(
            status["unknown_payload"].is_object(),
            "nothing was applied: the payload is still unknown: {status}"
        );
        wait_stopped_by_collision(&events).await;
        // Only the contact is a collision, not the grasp.
        let times = collision_times(&events);
        assert_eq!(times.len(), 1, "{times:?}");
        drop(driver.join());
        h.stop().await;
        Attempt::Done
    })
    .await;
}

/// A light payload grasped without a declaration stays under the thresholds, so nothing trips;
/// `estimate-payload` sees that the applied payload (none) does not explain the residual and
/// runs in the unknown-payload mode by itself; without `--apply` the mode stays on until the
/// operator applies the estimate.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn estimate_payload_enters_the_mode_itself_when_the_residual_is_unexplained() {
    in_attempts(|| async {
        let dir = tempfile::tempdir().unwrap();
        let (h, mut c, driver, events) = tared_and_restarted(dir, 41, Vec::new(), 0.5).await;
        until_after_grasp(&driver, 0.5).await;
        let status = status_with_residual(&mut c).await;
        assert_eq!(status["stopped"], false, "{status}");
        assert!(
            status["unknown_payload"].is_null(),
            "not declared: {status}"
        );
        let largest = (0..7)
            .map(|j| status["residual"][j].as_f64().unwrap_or(0.0).abs())
            .fold(0.0, f64::max);
        assert!(
            largest > 2.0 && largest < 6.0,
            "between a third of the threshold and the threshold: {status}"
        );
        let mut estimate = estimate_and_apply();
        if let Command::EstimatePayload { apply, .. } = &mut estimate {
            *apply = Some(false);
        }
        let est = match call(&mut c, estimate).await {
            Ok(est) => est,
            Err(e) => return host_stalled(e, &mut c, driver, &events, h, None).await,
        };
        let status = call(&mut c, Command::Status).await.unwrap();
        let mode = &status["unknown_payload"];
        assert_eq!(mode["declared_by"], "estimate-payload", "{status}");
        assert_eq!(mode["samples"], 4, "three poses and the revisit: {status}");
        assert_eq!(mode["consistent"], true);
        assert!(
            (mode["mass"].as_f64().unwrap() - 0.5).abs() < 0.02,
            "{status}"
        );
        let com: [f64; 3] = serde_json::from_value(est["com"].clone()).unwrap();
        let mass = est["mass"].as_f64().unwrap();
        call(
            &mut c,
            Command::ApplyPayload {
                mass,
                com,
                force: None,
            },
        )
        .await
        .unwrap();
        let status = call(&mut c, Command::Status).await.unwrap();
        assert!(status["unknown_payload"].is_null(), "{status}");
        assert_eq!(status["stopped"], false, "{status}");
        assert_eq!(
            count(&events, "collision"),
            0,
            "{:?}",
            events.lock().unwrap()
        );
        drop(driver.join());
        h.stop().await;
        Attempt::Done
    })
    .await;
}
