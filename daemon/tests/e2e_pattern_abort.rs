//! Safe retries: a tare or estimate that aborts mid-pattern drives the arm back to where it
//! started when that is safe, and after a stop (or a contact) leaves it held where it stopped,
//! saying why it did not move and how to go on.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod common;

use std::time::Duration;

use common::*;
use fri_api::protocol::{Command, ErrorCode};
use mock_robot::ServerConfig;
use serde_json::Value;

fn q_of(status: &Value) -> [f64; 7] {
    std::array::from_fn(|j| status["q"][j].as_f64().unwrap())
}

fn distance(a: &[f64; 7], b: &[f64; 7]) -> f64 {
    (0..7).map(|j| (a[j] - b[j]).abs()).fold(0.0, f64::max)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_pattern_that_cannot_sample_returns_to_its_start_pose() {
    let dir = tempfile::tempdir().unwrap();
    let mut config = test_config(dir.path());
    config.observer.armed = false;
    // A torque bound far below the sensor noise (0.05 Nm): the arm never counts as settled, so
    // the first pose after a move fails, and no sample of a moving arm is ever taken.
    config.estimation.settle_torque_std = 0.001;
    config.estimation.settle_timeout_s = 0.3;
    let h = Harness::start(config, dir).await;
    let driver =
        mock_robot::spawn_new(sim(false, 11), ServerConfig::loopback(h.fri, lockstep())).unwrap();
    let mut c = h.client().await;
    let start = q_of(&wait_connected(&mut c).await);
    // A centre away from the start pose: the first sample needs a move.
    let mut around = start;
    around[1] += 0.05;
    let e = call(
        &mut c,
        Command::Tare {
            around: Some(around),
            poses: Some(3),
            step_deg: Some(3.0),
            pattern: None,
            replace_loaded: None,
        },
    )
    .await
    .unwrap_err();
    assert_eq!(e.code, ErrorCode::Failed, "{e:?}");
    assert!(e.message.contains("did not settle"), "{e:?}");
    assert!(e.message.contains("returned to its start pose"), "{e:?}");
    let status = call(&mut c, Command::Status).await.unwrap();
    assert_eq!(status["stopped"], false, "{status}");
    let back = q_of(&status);
    assert!(
        distance(&back, &start) < 2e-3,
        "the arm is {} rad from its start pose",
        distance(&back, &start)
    );
    assert!(status["tare_samples"].is_null() || status["tare_samples"] == 0);
    drop(driver.join());
    h.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_stop_mid_pattern_leaves_the_arm_held_and_says_how_to_go_on() {
    let dir = tempfile::tempdir().unwrap();
    let mut config = test_config(dir.path());
    config.observer.armed = false;
    let h = Harness::start(config, dir).await;
    let driver =
        mock_robot::spawn_new(sim(false, 12), ServerConfig::loopback(h.fri, lockstep())).unwrap();
    let mut c = h.client().await;
    wait_connected(&mut c).await;
    // The operator stops the arm while it moves to the second pose.
    let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel::<()>();
    let mut stopper = h.client().await;
    let stop = tokio::spawn(async move {
        rx.recv().await;
        call(&mut stopper, Command::Stop).await
    });
    let e = c
        .call(
            Command::Tare {
                around: None,
                poses: Some(4),
                step_deg: Some(5.0),
                pattern: None,
                replace_loaded: None,
            },
            |event, data| {
                if event == "progress" && data["phase"] == "moving" && data["step"] == 2 {
                    let _ = tx.send(());
                }
            },
        )
        .await
        .unwrap()
        .unwrap_err();
    stop.await.unwrap().unwrap();
    assert_eq!(e.code, ErrorCode::Aborted, "{e:?}");
    assert!(e.message.contains("was not driven back"), "{e:?}");
    assert!(e.message.contains("never moves by itself"), "{e:?}");
    assert!(e.message.contains("fri-ctl resume"), "{e:?}");
    assert!(e.message.contains("fri-ctl tare --around"), "{e:?}");
    // Held where it stopped: it does not move on its own.
    let held = call(&mut c, Command::Status).await.unwrap();
    assert_eq!(held["stopped"], true, "{held}");
    tokio::time::sleep(Duration::from_millis(200)).await;
    let later = call(&mut c, Command::Status).await.unwrap();
    assert!(later["cycle"].as_u64() > held["cycle"].as_u64());
    assert!(
        distance(&q_of(&held), &q_of(&later)) < 1e-4,
        "{held} vs {later}"
    );
    drop(driver.join());
    h.stop().await;
}
