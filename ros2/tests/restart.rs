//! The bridge outlives restarts. After the service stops and a new one starts on the same socket
//! and iceoryx2 names, `/joint_states` flows again (stamps from the new service's zero) and the
//! applied payload reaches `<ns>/payload` again. After the controller restarts under a running
//! service, `/joint_states` keeps flowing and a late subscriber still gets the transient-local
//! payload and robot description.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod common;

use common::{TestNode, next_where};
use fri_api::protocol::Command;
use fri_api::results::StatusResult;
use fri_ros_msgs::RosMessage;
use fri_ros_msgs::geometry_msgs::InertiaStamped;
use fri_ros_msgs::sensor_msgs::JointState;
use fri_ros_msgs::std_msgs;
use fri_ros2::dds::{latched_qos, stream_qos};

async fn apply_payload(client: &mut fri_api::client::Client, mass: f64, com: [f64; 3]) {
    let reply = client
        // Forced: these values test persistence across restarts, not the check (the
        // simulated flange carries no such payload).
        .call(
            Command::ApplyPayload {
                mass,
                com,
                force: Some(true),
            },
            |_, _| {},
        )
        .await
        .unwrap();
    assert!(reply.is_ok(), "{reply:?}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn joint_states_and_payload_come_back_after_the_service_restarts() {
    common::loopback_multicast();
    let dir = tempfile::tempdir().unwrap();
    let config = common::service_config(dir.path(), "ros2restart");
    let domain = common::domain(4);
    let mut test = TestNode::new(domain, "restart_test");
    let joint_states =
        test.subscribe::<JointState>("/", "joint_states", JointState::TYPE, stream_qos());
    let payloads =
        test.subscribe::<InertiaStamped>("/lwr", "payload", InertiaStamped::TYPE, latched_qos());

    let service = fri_service::testkit::InProcess::start(config.clone())
        .await
        .unwrap();
    let robot = common::robot(mock_robot::SimulationConfig::loaded(), service.fri, None);
    common::wait_connected(&service).await;
    let bridge = common::Bridge::start(config.clone(), domain, 100);
    // Past 1 s of the first service's time: every older sample has been taken, so a stamp
    // under 1 s later on can only come from the new service.
    let first = next_where(&joint_states, "joint state past 1 s", |m| {
        m.header.stamp.as_seconds() > 1.0
    })
    .await;
    assert_eq!(first.name.len(), 7);
    robot.stop();
    let _ = robot.join();
    service.stop().await.unwrap();

    // A new service on the same socket and iceoryx2 names, with a payload applied.
    let service = fri_service::testkit::InProcess::start(config.clone())
        .await
        .unwrap();
    let robot = common::robot(mock_robot::SimulationConfig::loaded(), service.fri, None);
    let mut client = common::wait_connected(&service).await;
    apply_payload(&mut client, 0.75, [0.0, 0.0, 0.05]).await;
    // Stamps of the new service start from zero again.
    let after = next_where(&joint_states, "joint state after the restart", |m| {
        m.header.stamp.as_seconds() < 1.0
    })
    .await;
    assert_eq!(after.name, first.name);
    let p = next_where(&payloads, "payload after the restart", |p| {
        p.inertia.m == 0.75
    })
    .await;
    assert_eq!(p.inertia.com.z, 0.05);

    bridge.stop().await;
    robot.stop();
    let _ = robot.join();
    service.stop().await.unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_bridge_keeps_publishing_through_a_controller_restart() {
    common::loopback_multicast();
    let dir = tempfile::tempdir().unwrap();
    let mut config = common::service_config(dir.path(), "ros2krcrestart");
    // The mock carries a payload the monitor is not told of: disarmed, it reports nothing.
    config.observer.armed = false;
    let domain = common::domain(5);
    let mut test = TestNode::new(domain, "controller_restart_test");
    let joint_states =
        test.subscribe::<JointState>("/", "joint_states", JointState::TYPE, stream_qos());

    let service = fri_service::testkit::InProcess::start(config.clone())
        .await
        .unwrap();
    // The controller restarts (sequence counter reset, statistics reset, back to MON) at 1.5 s.
    let sim = mock_robot::SimulationConfig {
        restarts_s: vec![1.5],
        ..mock_robot::SimulationConfig::loaded()
    };
    let robot = common::robot(sim, service.fri, None);
    let mut client = common::wait_connected(&service).await;
    let bridge = common::Bridge::start(config.clone(), domain, 100);
    apply_payload(&mut client, 1.25, [0.0, 0.01, 0.08]).await;
    let before = next_where(&joint_states, "joint state before the restart", |_| true).await;

    // The service takes the restart (after its resync time of silence) and answers again.
    let mut restarted_at = None;
    for _ in 0..1000 {
        let s = client
            .call_typed::<StatusResult>(Command::Status, |_| {})
            .await
            .unwrap()
            .unwrap();
        let restarts = s
            .fri
            .as_ref()
            .map_or(0, |f| f.statistics.sequence.restarted);
        if restarts >= 1 && s.connected {
            restarted_at = s.time_s;
            break;
        }
        tokio::time::sleep(std::time::Duration::from_millis(20)).await;
    }
    let restarted_at = restarted_at.expect("the service never saw the controller restart");
    assert!(restarted_at > before.header.stamp.as_seconds());
    // Joint states keep coming, stamped after the restart in the service's time base.
    let after = next_where(&joint_states, "joint state after the restart", |m| {
        m.header.stamp.as_seconds() > restarted_at + 0.2
    })
    .await;
    assert_eq!(after.name, before.name);

    // A subscriber that joins now gets the transient-local payload and description at once.
    let mut late = TestNode::new(domain, "late_subscriber");
    let payloads =
        late.subscribe::<InertiaStamped>("/lwr", "payload", InertiaStamped::TYPE, latched_qos());
    let descriptions = late.subscribe::<std_msgs::String>(
        "/",
        "robot_description",
        std_msgs::String::TYPE,
        latched_qos(),
    );
    let p = next_where(&payloads, "the applied payload, late", |p| {
        p.inertia.m == 1.25
    })
    .await;
    assert_eq!(p.inertia.com.y, 0.01);
    assert_eq!(p.header.frame_id, "lwr_dh_frame_7");
    let d = next_where(&descriptions, "the robot description, late", |_| true).await;
    assert!(d.data.contains("lwr_dh_frame_7"));

    bridge.stop().await;
    robot.stop();
    let _ = robot.join();
    service.stop().await.unwrap();
}
