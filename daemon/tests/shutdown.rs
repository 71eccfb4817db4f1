//! Shutdown (SIGINT/SIGTERM in the binary, `InProcess::stop` here, the same path): a request
//! still running is answered with the shutdown as its cause, the move is braked, and the
//! controller leaves command mode through the handshake (a regular friStop, not a drop for
//! missed answers). The service runs against the mock robot in lockstep over UDP loopback.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::time::Duration;

use fri_api::protocol::{Command, ErrorCode};
use fri_service::testkit::{InProcess, local_config};
use mock_robot::krl::KrlEvent;
use mock_robot::{ServerConfig, SimulationConfig, TimingMode};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn shutdown_during_a_move_answers_the_request_and_leaves_command_mode_by_handshake() {
    let dir = tempfile::tempdir().unwrap();
    let mut config = local_config(dir.path(), "shutdown");
    config.iceoryx2.enabled = false;
    config.observer.armed = false;
    let service = InProcess::start(config).await.unwrap();
    let mode = TimingMode::Lockstep {
        answer_timeout: Duration::from_millis(200),
    };
    let robot = mock_robot::spawn_new(
        SimulationConfig::loaded(),
        ServerConfig::loopback(service.fri, mode),
    )
    .unwrap();

    let mut status = service.client().await.unwrap();
    // Wait for the state a tare needs: the controller connected and the monitor live.
    while status
        .call(Command::Status, |_, _| {})
        .await
        .unwrap()
        .unwrap()["residual_valid"]
        != true
    {
        tokio::task::yield_now().await;
    }
    let mut client = service.client().await.unwrap();
    let (moving_tx, mut moving_rx) = tokio::sync::mpsc::unbounded_channel();
    let tare = tokio::spawn(async move {
        client
            .call(
                Command::Tare {
                    around: None,
                    poses: Some(6),
                    step_deg: Some(7.0),
                    pattern: None,
                    replace_loaded: None,
                },
                move |_, data| {
                    if data["phase"] == "moving" {
                        let _ = moving_tx.send(());
                    }
                },
            )
            .await
    });
    // The first pose's move has been requested; wait until the controller is in command mode.
    moving_rx
        .recv()
        .await
        .expect("the tare never started moving");
    loop {
        let s = status
            .call(Command::Status, |_, _| {})
            .await
            .unwrap()
            .unwrap();
        if s["command_mode"] == true {
            break;
        }
        tokio::task::yield_now().await;
    }

    service.stop().await.unwrap();
    let reply = tare.await.unwrap().unwrap();
    let e = reply.expect_err("the tare cannot complete across a shutdown");
    assert_eq!(e.code, ErrorCode::Aborted, "{e:?}");
    assert!(e.message.contains("shutting down"), "{e:?}");

    let (sim, _) = robot.join().unwrap();
    assert_eq!(
        sim.last_event(),
        Some(KrlEvent::Stopped),
        "command mode must end with the handshake's friStop, not a drop"
    );
}
