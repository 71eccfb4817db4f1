//! End-to-end workflows: tare, estimate, apply, arm, bad operator input and iceoryx2, the
//! service against the mock robot over UDP loopback through the operator socket.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod common;

use std::time::Duration;

use common::*;
use fri_api::protocol::Command;
use fri_service::config::Config;
use mock_robot::{ServerConfig, TimingMode};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn tare_then_estimate_through_the_socket_and_persist_after_restart() {
    let dir = tempfile::tempdir().unwrap();
    // Armed throughout: the payload is declared unknown before it is attached (it would trip the
    // monitor otherwise, the paper's point) and the estimate runs in the payload-tolerant mode.
    let config = test_config(dir.path());
    let h = Harness::start(config.clone(), dir).await;

    // Tare without payload.
    let driver =
        mock_robot::spawn_new(sim(false, 7), ServerConfig::loopback(h.fri, lockstep())).unwrap();
    let mut c = h.client().await;
    wait_connected(&mut c).await;
    let mut progress = 0;
    let tare = c
        .call(
            Command::Tare {
                around: None,
                poses: Some(6),
                step_deg: Some(7.0),
                pattern: None,
                replace_loaded: None,
            },
            |ev, _| {
                assert_eq!(ev, "progress");
                progress += 1;
            },
        )
        .await
        .unwrap()
        .unwrap();
    assert_eq!(tare["samples"], 6);
    assert!(progress >= 18, "progress events: {progress}");
    eprintln!(
        "tare: {} cycles, {:?}",
        driver.counters().answer_counts().sent,
        driver.counters().answer_counts()
    );
    // Payload attached to the same simulated robot: its model error, offsets and drift carry
    // on, and the estimate's noise is independent of the tare's. Declared first.
    let declared = call(&mut c, declare_payload_unknown()).await.unwrap();
    assert_eq!(declared["unknown_payload"]["samples"], 0, "{declared}");
    let mut robot = driver.join().unwrap().0;
    // Attaching takes 2 s of robot time with the arm off line: the service's clock cannot see
    // them, the controller's does, and the estimate must report them.
    const ATTACH_S: f64 = 2.0;
    for _ in 0..(ATTACH_S / robot.cycle_s()).round() as u64 {
        robot.step_cycle(None);
    }
    robot.set_payload_attached(true);
    let driver = mock_robot::spawn(robot, ServerConfig::loopback(h.fri, lockstep())).unwrap();
    // The resumed controller sends from a new port: the service binds it once the old one has
    // been silent for `fri.resync_after_s` (docs/fri.md, "Source binding and restarts").
    for _ in 0..500 {
        if driver.counters().answer_counts().answered > 50 {
            break;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    assert!(
        driver.counters().answer_counts().answered > 50,
        "{:?}",
        driver.counters().answer_counts()
    );
    let status = call(&mut c, Command::Status).await.unwrap();
    assert_eq!(
        status["fri"]["statistics"]["sequence"]["rebinds"], 1,
        "{status}"
    );
    // A pattern elsewhere than the tare's is refused before anything moves, naming both centres.
    let mut elsewhere: Vec<f64> = tare["around"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    elsewhere[0] += 0.02;
    let before = call(&mut c, Command::Status).await.unwrap()["q"].clone();
    let refused = call(
        &mut c,
        Command::EstimatePayload {
            around: Some(elsewhere.try_into().unwrap()),
            poses: Some(6),
            step_deg: Some(7.0),
            pattern: None,
            use_tare: None,
            apply: Some(true),
        },
    )
    .await
    .unwrap_err();
    assert_eq!(
        refused.code,
        fri_api::protocol::ErrorCode::InvalidArguments,
        "{refused:?}"
    );
    assert!(refused.message.contains("stored tare"), "{refused:?}");
    let after = call(&mut c, Command::Status).await.unwrap()["q"].clone();
    let moved = (0..7)
        .map(|j| (after[j].as_f64().unwrap() - before[j].as_f64().unwrap()).abs())
        .fold(0.0, f64::max);
    assert!(
        moved < 1e-3,
        "the refused estimate moved the arm by {moved} rad"
    );
    // Without `around`/`poses` the estimate runs at the tare's poses.
    let est = call(
        &mut c,
        Command::EstimatePayload {
            around: None,
            poses: None,
            step_deg: Some(7.0),
            pattern: None,
            use_tare: None,
            apply: Some(true),
        },
    )
    .await
    .unwrap();
    let sim_done = driver.join().unwrap().0;
    let truth = sim_done.true_payload().unwrap();
    let m_true = truth.mass;
    let c_true = truth.com().unwrap();
    let mass = est["mass"].as_f64().unwrap();
    let com: Vec<f64> = est["com"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    eprintln!("estimate {est}");
    assert_eq!(est["tare_used"], true);
    assert!(
        ((mass - m_true) / m_true).abs() < 0.005,
        "mass {mass} vs {m_true}"
    );
    for k in 0..3 {
        assert!(
            (com[k] - c_true[k]).abs() < 0.005,
            "com {com:?} vs {c_true:?}"
        );
    }
    assert!(est["mass_std"].as_f64().unwrap() > 0.0);
    let since_tare = est["uncertainty"]["since_tare_s"].as_f64().unwrap();
    assert!(
        (ATTACH_S..ATTACH_S + 5.0).contains(&since_tare),
        "since_tare_s {since_tare} for a {ATTACH_S} s pause: {est}"
    );
    let status = call(&mut c, Command::Status).await.unwrap();
    assert_eq!(status["payload"]["mass"].as_f64().unwrap(), mass);
    assert_eq!(status["monitor"]["armed"], true, "{status}");
    assert!(status["unknown_payload"].is_null(), "applied: {status}");
    assert_eq!(status["stopped"], false, "{status}");

    // Restart the service on the same state directory: the payload comes back.
    let dir = h.stop().await;
    let h = Harness::start(config, dir).await;
    let mut c = h.client().await;
    let status = call(&mut c, Command::Status).await.unwrap();
    assert_eq!(status["payload"]["mass"].as_f64().unwrap(), mass);
    assert_eq!(status["tare_samples"], 7, "six poses and the revisit");
    h.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn malformed_operator_input_never_disturbs_the_loop() {
    let dir = tempfile::tempdir().unwrap();
    let config = test_config(dir.path());
    let h = Harness::start(config, dir).await;
    let driver =
        mock_robot::spawn_new(sim(false, 9), ServerConfig::loopback(h.fri, lockstep())).unwrap();
    let mut c = h.client().await;
    let before = wait_connected(&mut c).await["cycle"].as_u64().unwrap();
    let mut raw = h.client().await;
    let mut junk: Vec<u8> = Vec::new();
    junk.extend_from_slice(b"{\"id\":1,\"cmd\":\"status\"\n"); // truncated JSON
    junk.extend_from_slice(b"\x00\x01\x02\n");
    junk.extend_from_slice(&vec![b'A'; 200_000]);
    junk.extend_from_slice(b"\n{\"id\":2,\"cmd\":\"apply-payload\",\"mass\":-5,\"com\":[0,0,0]}\n");
    junk.extend_from_slice(b"{\"id\":3,\"cmd\":\"collision\",\"action\":\"configure\",\"thresholds\":[1,1,1,1,1,1,-1]}\n");
    junk.extend_from_slice(b"{\"id\":4,\"cmd\":\"self-destruct\"}\n");
    raw.send_raw(&junk).await.unwrap();
    let mut codes = Vec::new();
    for _ in 0..6 {
        match raw.next_reply().await.unwrap() {
            fri_api::protocol::Reply::Err { error, .. } => codes.push(error.code),
            other => panic!("unexpected {other:?}"),
        }
    }
    use fri_api::protocol::ErrorCode as E;
    // Valid requests run concurrently, so replies may come in any order.
    let mut expected = vec![
        E::Malformed,
        E::Malformed,
        E::TooLarge,
        E::InvalidArguments,
        E::InvalidArguments,
        E::UnknownCommand,
    ];
    let key = |c: &E| format!("{c:?}");
    codes.sort_by_key(key);
    expected.sort_by_key(key);
    assert_eq!(codes, expected);
    // The loop kept running and the payload was not changed.
    let mut status = call(&mut c, Command::Status).await.unwrap();
    while status["cycle"].as_u64().unwrap() <= before {
        tokio::task::yield_now().await;
        status = call(&mut c, Command::Status).await.unwrap();
    }
    assert!(status["payload"].is_null());
    assert_eq!(status["monitor"]["thresholds"][6], 6.0);
    drop(driver.join());
    h.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn unbounded_pattern_centres_thresholds_and_gains_are_rejected_and_nothing_moves() {
    use fri_api::protocol::{CollisionAction, ErrorCode};
    let dir = tempfile::tempdir().unwrap();
    let config = test_config(dir.path());
    let h = Harness::start(config, dir).await;
    let driver =
        mock_robot::spawn_new(sim(false, 17), ServerConfig::loopback(h.fri, lockstep())).unwrap();
    let mut c = h.client().await;
    let q: Vec<f64> = wait_connected(&mut c).await["q"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    let q: [f64; 7] = q.try_into().unwrap();
    let estimate = |around: [f64; 7]| Command::EstimatePayload {
        around: Some(around),
        poses: Some(3),
        step_deg: Some(7.0),
        pattern: None,
        use_tare: None,
        apply: Some(true),
    };
    // Inside the joint limits but 0.6 rad from the measured pose on joint 4.
    let mut far = q;
    far[3] += 0.6;
    // Inside the limits and near enough, but joint 2 within 7° + 5° of its 120° limit.
    let mut near_limit = q;
    near_limit[1] = 115f64.to_radians();
    let configure = |thresholds, gains| Command::Collision {
        action: CollisionAction::Configure,
        thresholds,
        gains,
        reaction: None,
        pause_s: None,
    };
    let cases = [
        (estimate([1e300; 7]), "around[0] = 1e300 rad is outside"),
        (estimate(far), "around[3]"),
        (
            Command::Tare {
                around: Some(near_limit),
                poses: Some(3),
                step_deg: Some(7.0),
                pattern: None,
                replace_loaded: None,
            },
            "around[1]",
        ),
        (
            configure(Some([1e300; 7]), None),
            "thresholds[0] = 1e300 Nm",
        ),
        (configure(None, Some([1e308; 7])), "gains[0] = 1e308 1/s"),
    ];
    for (command, expected) in cases {
        let e = call(&mut c, command).await.unwrap_err();
        assert_eq!(e.code, ErrorCode::InvalidArguments, "{e:?}");
        assert!(e.message.starts_with(expected), "{}", e.message);
    }
    let e = call(&mut c, estimate(far)).await.unwrap_err();
    assert!(
        e.message
            .contains("motion.max_around_distance_rad = 0.5 rad"),
        "{}",
        e.message
    );
    // The monitor is unchanged and armed with its finite thresholds; the arm did not move.
    let status = call(&mut c, Command::Status).await.unwrap();
    assert_eq!(status["monitor"]["armed"], true);
    assert_eq!(status["monitor"]["thresholds"][0], 6.0);
    assert_eq!(status["monitor"]["gains"][0], 400.0);
    assert_eq!(status["command_mode"], false, "{status}");
    for j in 0..7 {
        let now = status["q"][j].as_f64().unwrap();
        assert!((now - q[j]).abs() < 1e-3, "joint {j}: {now} vs {}", q[j]);
    }
    drop(driver.join());
    h.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn iceoryx2_subscriber_receives_the_service_state() {
    use fri_service::ipc::publisher::open_service;
    use fri_service::ipc::{IpcNames, RobotState};
    let dir = tempfile::tempdir().unwrap();
    let config = test_config(dir.path());
    let names = IpcNames {
        service_prefix: config.iceoryx2.service_prefix.clone(),
        global_prefix: config.iceoryx2.global_prefix.clone(),
    };
    let h = Harness::start(config, dir).await;
    let driver =
        mock_robot::spawn_new(sim(false, 11), ServerConfig::loopback(h.fri, lockstep())).unwrap();
    let mut c = h.client().await;
    wait_connected(&mut c).await;
    // iceoryx2 ports are not Send: subscribe on a plain thread.
    let received = std::thread::spawn(move || {
        let node = names.node().unwrap();
        let sub = open_service::<RobotState>(&node, &names.state(), 1)
            .unwrap()
            .subscriber_builder()
            .create()
            .unwrap();
        let mut got = Vec::new();
        let t0 = std::time::Instant::now();
        while got.len() < 50 && t0.elapsed() < Duration::from_secs(20) {
            while let Some(s) = sub.receive().unwrap() {
                got.push(*s.payload());
            }
            std::thread::sleep(Duration::from_millis(1));
        }
        got
    })
    .join()
    .unwrap();
    assert!(received.len() >= 50, "received {}", received.len());
    assert!(received.windows(2).all(|w| w[1].cycle > w[0].cycle));
    let last = received.last().unwrap();
    // At rest at the mock's initial pose (the pick pose).
    assert!(
        (last.q[1] - dynamics::LWR4_PICK_POSE_RAD[1]).abs() < 0.01,
        "{:?}",
        last.q
    );
    assert_eq!(last.fri_state, 1);
    assert!(last.gravity[1].abs() > 1.0);
    drop(driver.join());
    h.stop().await;
}

/// The documented workflow on the running service in real time, armed throughout: declare the
/// payload unknown, grasp (the uncompensated payload is tolerated), apply the payload; a contact
/// during the next move stops the arm (issue 10, item 1: the reaction used to stay latched).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn declare_grasp_apply_and_a_contact_stops_the_arm() {
    let dir = tempfile::tempdir().unwrap();
    let mut config = armed_to_stop(test_config(dir.path()));
    // The default (paper-like) speeds: the applied payload compensates gravity only, so fast
    // moves would show its inertia as residual (issue 14's subject, not this test's).
    config.motion = Config::default().motion;
    let h = Harness::start(config, dir).await;
    let mut sim_config = sim(false, 23);
    sim_config.payload.events = vec![mock_robot::config::PayloadEvent {
        time_s: 1.0,
        action: mock_robot::config::PayloadAction::Attach,
    }];
    sim_config.contacts = vec![push_on_link_4(4.0)];
    let (mass, com) = (sim_config.payload.mass_kg, sim_config.payload.com_m);
    let driver = mock_robot::spawn_new(
        sim_config,
        ServerConfig::loopback(h.fri, TimingMode::RealTime),
    )
    .unwrap();
    let mut c = h.client().await;
    wait_connected(&mut c).await;
    let events = collect_watch(h.client().await, None).await;
    call(&mut c, declare_payload_unknown()).await.unwrap();
    // The payload is picked up at 1 s: far over the 6 Nm threshold, uncompensated, tolerated.
    while driver.counters().answer_counts().sent < 1500 {
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    // (A loaded host can pause the loop long enough for a monitor restart: its residual is
    // `null` during the 50 ms warm-up.)
    let mut status = call(&mut c, Command::Status).await.unwrap();
    for _ in 0..100 {
        if status["residual"][1].is_f64() {
            break;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
        status = call(&mut c, Command::Status).await.unwrap();
    }
    let r2 = status["residual"][1].as_f64().unwrap_or(0.0);
    assert!(r2.abs() > 6.0, "the uncompensated payload shows: {status}");
    assert_eq!(status["monitor"]["armed"], true, "{status}");
    assert_eq!(
        status["stopped"], false,
        "declared: the payload is tolerated"
    );
    // The payload applied: the mode ends in the same loop cycle.
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
    let e = call(
        &mut c,
        Command::EstimatePayload {
            around: None,
            poses: Some(6),
            step_deg: Some(7.0),
            pattern: None,
            use_tare: Some(false),
            apply: Some(false),
        },
    )
    .await
    .unwrap_err();
    assert!(
        matches!(
            e.cause.as_deref(),
            Some(fri_api::cause::Cause::Collision { .. })
        ),
        "{e:?}"
    );
    let status = call(&mut c, Command::Status).await.unwrap();
    assert_eq!(status["stopped"], true, "the arm is held: {status}");
    // The watch is another connection: its events are not ordered with this reply.
    wait_stopped_by_collision(&events).await;
    {
        let collisions = collision_times(&events);
        let evs = events.lock().unwrap();
        assert!(
            !collisions.is_empty() && collisions.iter().all(|t| *t > 3.9),
            "only the contact is a collision: {collisions:?}"
        );
        assert!(
            evs.iter()
                .any(|(k, d)| k == "stopped" && d["reason"] == "collision")
        );
    }
    drop(driver.join());
    h.stop().await;
}
