//! Issue 34 item 8: the bridge's ROS 2 `stop` goes over the service's stop socket, which no
//! other client can occupy (docs/operator-protocol.md "Stop path"), as `fri-ctl stop` does;
//! every other command over the operator socket.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod common;

use fri_api::protocol::{Command, Ros2Caller};
use fri_api::results::StatusResult;
use fri_ros2::operator::{Operator, Trigger};

fn caller() -> Ros2Caller {
    Ros2Caller {
        participant: "010f2c4d.00001234.00000001.000001c1".into(),
        authenticated: false,
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_ros2_stop_goes_over_the_stop_socket() {
    let dir = tempfile::tempdir().unwrap();
    let mut config = common::service_config(dir.path(), "ros2stop");
    common::service_accepts_unauthenticated(&mut config);
    let stop_socket = config.operator.stop_socket_path();
    let service = fri_service::testkit::InProcess::start(config)
        .await
        .unwrap();
    let (robot, mut client) = common::unloaded_robot(&service).await;
    // An operator socket nobody serves: only the stop socket can take the stop.
    let nobody = dir.path().join("nobody.sock");
    let operator = Operator::new(nobody.clone(), stop_socket);
    let r = operator.trigger(Trigger::Stop, caller(), |_| {}).await;
    assert!(r.success, "{r:?}");
    let mut stopped = false;
    for _ in 0..500 {
        let status: StatusResult = client
            .call_typed(Command::Status, |_| {})
            .await
            .unwrap()
            .unwrap();
        if status.stopped {
            stopped = true;
            break;
        }
        tokio::time::sleep(std::time::Duration::from_millis(10)).await;
    }
    assert!(stopped, "the stop never held the arm");
    // Everything else goes over the operator socket (unreachable here, named in the answer).
    let r = operator.trigger(Trigger::Resume, caller(), |_| {}).await;
    assert!(!r.success && r.message.contains("nobody.sock"), "{r:?}");
    // Without a stop socket (a service older than it) the operator socket takes the stop.
    let socket = service.socket.clone();
    let old = Operator::new(socket, dir.path().join("absent.stop.sock"));
    let r = old.trigger(Trigger::Stop, caller(), |_| {}).await;
    assert!(r.success, "{r:?}");
    robot.stop();
    let _ = robot.join();
    service.stop().await.unwrap();
}
