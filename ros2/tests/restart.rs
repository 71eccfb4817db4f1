//! The bridge outlives the service: after the service stops and a new one starts on the same
//! socket and iceoryx2 names, `/joint_states` flows again (stamps from the new service's zero)
//! and the applied payload reaches `<ns>/payload` again.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod common;

use std::time::Duration;

use fri_ros_msgs::RosMessage;
use fri_ros_msgs::geometry_msgs::InertiaStamped;
use fri_ros_msgs::sensor_msgs::JointState;
use ros2_client::dds::rustdds::DomainParticipantBuilder;
use ros2_client::{Context, MessageTypeName, Name, NodeName, NodeOptions, Subscription};

/// The next message on `sub` whose `pred` holds (bounded wait).
async fn next_where<M: 'static + serde::de::DeserializeOwned>(
    sub: &Subscription<M>,
    what: &str,
    pred: impl Fn(&M) -> bool,
) -> M {
    let deadline = tokio::time::Instant::now() + Duration::from_secs(30);
    loop {
        assert!(tokio::time::Instant::now() < deadline, "no {what}");
        match sub.take().unwrap() {
            Some((m, _)) if pred(&m) => return m,
            Some(_) => {}
            None => tokio::time::sleep(Duration::from_millis(5)).await,
        }
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn joint_states_and_payload_come_back_after_the_service_restarts() {
    common::loopback_multicast();
    let dir = tempfile::tempdir().unwrap();
    let config = common::service_config(dir.path(), "ros2restart");
    let domain = common::domain(4);

    let participant = DomainParticipantBuilder::new(domain)
        .with_only_networks([std::net::IpAddr::from([127, 0, 0, 1])])
        .build()
        .unwrap();
    let context = Context::from_domain_participant(participant).unwrap();
    let mut node = context
        .new_node(
            NodeName::new("/test", "restart_test").unwrap(),
            NodeOptions::new(),
        )
        .unwrap();
    let topic =
        |node: &mut ros2_client::Node, ns: &str, name: &str, t: &fri_ros_msgs::MessageType, qos| {
            node.create_topic(
                &Name::new(ns, name).unwrap(),
                MessageTypeName::new(t.package, t.name),
                &qos,
            )
            .unwrap()
        };
    let js = topic(
        &mut node,
        "/",
        "joint_states",
        JointState::TYPE,
        fri_ros2::dds::stream_qos(),
    );
    let joint_states = node.create_subscription::<JointState>(&js, None).unwrap();
    let pt = topic(
        &mut node,
        "/lwr",
        "payload",
        InertiaStamped::TYPE,
        fri_ros2::dds::latched_qos(),
    );
    let payloads = node
        .create_subscription::<InertiaStamped>(&pt, None)
        .unwrap();

    let service = fri_service::testkit::InProcess::start(config.clone())
        .await
        .unwrap();
    let robot = common::robot(mock_robot::SimulationConfig::default(), service.fri, None);
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
    let robot = common::robot(mock_robot::SimulationConfig::default(), service.fri, None);
    let mut client = common::wait_connected(&service).await;
    let reply = client
        .call(
            fri_api::protocol::Command::ApplyPayload {
                mass: 0.75,
                com: [0.0, 0.0, 0.05],
            },
            |_, _| {},
        )
        .await
        .unwrap();
    assert!(reply.is_ok(), "{reply:?}");
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
