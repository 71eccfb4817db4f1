//! The bridge's ROS 2 services and its `apply_payload` subscription, called from a ros2-client
//! test node (RustDDS, a participant of its own), checked against the service's `status`.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod common;

use std::time::Duration;

use fri_api::client::Client;
use fri_api::protocol::Command;
use fri_api::results::StatusResult;
use fri_ros_msgs::RosMessage;
use fri_ros_msgs::geometry_msgs::{Inertia, InertiaStamped, Vector3};
use fri_ros2::srv::{SetBoolRequest, SetBoolResponse, TriggerRequest, TriggerResponse};
use ros2_client::dds::rustdds::DomainParticipantBuilder;
use ros2_client::{
    Context, MessageTypeName, Name, NodeName, NodeOptions, ServiceMapping, ServiceTypeName,
};

async fn status(c: &mut Client) -> StatusResult {
    c.call_typed::<StatusResult>(Command::Status, |_| {})
        .await
        .unwrap()
        .unwrap()
}

/// Waits (bounded) until the service's status satisfies `pred`.
async fn until(c: &mut Client, what: &str, pred: impl Fn(&StatusResult) -> bool) -> StatusResult {
    for _ in 0..1000 {
        let s = status(c).await;
        if pred(&s) {
            return s;
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    panic!("the service never reached: {what}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn stop_resume_arm_and_apply_payload_reach_the_service() {
    common::loopback_multicast();
    let dir = tempfile::tempdir().unwrap();
    let mut config = common::service_config(dir.path(), "ros2srv");
    config.observer.armed = true;
    common::service_accepts_unauthenticated(&mut config);
    let service = fri_service::testkit::InProcess::start(config.clone())
        .await
        .unwrap();
    // No payload on the arm: the armed monitor would hold it whatever the services do (the
    // resume is then rightly refused).
    let (robot, mut client) = common::unloaded_robot(&service).await;
    let domain = common::domain(1);
    let bridge = common::Bridge::start_with(
        config,
        common::unauthenticated(
            domain,
            &[
                "stop",
                "resume",
                "collision_arm",
                "expect_payload",
                "apply_payload",
            ],
        ),
    );

    let participant = DomainParticipantBuilder::new(domain)
        .with_only_networks([std::net::IpAddr::from([127, 0, 0, 1])])
        .build()
        .unwrap();
    let context = Context::from_domain_participant(participant).unwrap();
    let mut node = context
        .new_node(
            NodeName::new("/test", "services_test").unwrap(),
            NodeOptions::new(),
        )
        .unwrap();
    let qos = fri_ros2::dds::request_qos();
    let trigger = |node: &mut ros2_client::Node, name: &str| {
        node.create_client::<TriggerRequest, TriggerResponse>(
            ServiceMapping::Enhanced,
            &Name::new("/lwr", name).unwrap(),
            &ServiceTypeName::new("std_srvs", "Trigger"),
            qos.clone(),
            qos.clone(),
        )
        .unwrap()
    };
    let stop = trigger(&mut node, "stop");
    let expect = trigger(&mut node, "expect_payload");
    let resume = trigger(&mut node, "resume");
    let arm = node
        .create_client::<SetBoolRequest, SetBoolResponse>(
            ServiceMapping::Enhanced,
            &Name::new("/lwr", "collision_arm").unwrap(),
            &ServiceTypeName::new("std_srvs", "SetBool"),
            qos.clone(),
            qos.clone(),
        )
        .unwrap();
    let topic = node
        .create_topic(
            &Name::new("/lwr", "apply_payload").unwrap(),
            MessageTypeName::new(Inertia::TYPE.package, Inertia::TYPE.name),
            &qos,
        )
        .unwrap();
    let apply = node.create_publisher::<Inertia>(&topic, None).unwrap();
    let payload_topic = node
        .create_topic(
            &Name::new("/lwr", "payload").unwrap(),
            MessageTypeName::new(InertiaStamped::TYPE.package, InertiaStamped::TYPE.name),
            &fri_ros2::dds::latched_qos(),
        )
        .unwrap();
    let payloads = node
        .create_subscription::<InertiaStamped>(&payload_topic, None)
        .unwrap();
    let spinner = node.spinner().unwrap();
    tokio::spawn(spinner.spin());
    let call = Duration::from_secs(30);

    // Trigger on <ns>/stop: the arm is held.
    tokio::time::timeout(call, stop.wait_for_service(&node))
        .await
        .expect("the bridge's stop service was never discovered");
    let r = tokio::time::timeout(call, stop.async_call_service(TriggerRequest::default()))
        .await
        .unwrap()
        .unwrap();
    assert!(r.success, "{r:?}");
    assert!(r.message.contains("\"stopped\":true"), "{}", r.message);
    assert!(status(&mut client).await.stopped);
    let r = tokio::time::timeout(call, resume.async_call_service(TriggerRequest::default()))
        .await
        .unwrap()
        .unwrap();
    assert!(r.success, "{r:?}");
    assert!(r.message.contains("\"stopped\":false"), "{}", r.message);
    assert!(!status(&mut client).await.stopped);

    // SetBool on <ns>/collision_arm.
    tokio::time::timeout(call, arm.wait_for_service(&node))
        .await
        .unwrap();
    let r = tokio::time::timeout(call, arm.async_call_service(SetBoolRequest { data: false }))
        .await
        .unwrap()
        .unwrap();
    assert!(r.success, "{r:?}");
    assert!(!status(&mut client).await.monitor.armed);
    let r = tokio::time::timeout(call, arm.async_call_service(SetBoolRequest { data: true }))
        .await
        .unwrap()
        .unwrap();
    assert!(r.success, "{r:?}");
    assert!(status(&mut client).await.monitor.armed);

    // Trigger on <ns>/expect_payload: the unknown-payload mode, armed, until a payload is applied.
    tokio::time::timeout(call, expect.wait_for_service(&node))
        .await
        .unwrap();
    let r = tokio::time::timeout(call, expect.async_call_service(TriggerRequest::default()))
        .await
        .unwrap()
        .unwrap();
    assert!(r.success, "{r:?}");
    assert!(
        r.message.contains("\"declared_by\":\"operator\""),
        "{}",
        r.message
    );
    let s = status(&mut client).await;
    assert!(s.unknown_payload.is_some() && s.monitor.armed, "{s:?}");

    // apply_payload: NaN and negative masses are refused by the bridge, 1.25 kg on the empty
    // flange by the service's check against the measured torques (issue 34 item 5: the topic
    // cannot force), the empty flange's true payload is applied (ending the unknown-payload
    // mode); the payload topic never shows 1.25 kg.
    tokio::time::timeout(call, apply.wait_for_subscription(&node))
        .await
        .unwrap();
    let inertia = |m: f64| Inertia {
        m,
        com: Vector3::from_array([0.0, 0.0, 0.12]),
        ..Inertia::default()
    };
    apply.publish(inertia(f64::NAN)).unwrap();
    apply.publish(inertia(-1.0)).unwrap();
    apply.publish(inertia(1.25)).unwrap();
    apply.publish(inertia(0.0)).unwrap();
    let s = until(&mut client, "payload applied", |s| s.payload.is_some()).await;
    let p = s.payload.unwrap();
    assert_eq!(p.mass, 0.0, "1.25 kg on an empty flange is refused");
    assert_eq!(p.com, [0.0, 0.0, 0.12]);
    assert!(s.unknown_payload.is_none(), "applied: the mode ended");
    let mut seen = Vec::new();
    let deadline = tokio::time::Instant::now() + call;
    // The topic's payload after the apply (0 kg, transient-local), and never 1.25 kg.
    while seen.is_empty() {
        assert!(
            tokio::time::Instant::now() < deadline,
            "payload topic: {seen:?}"
        );
        match payloads.take().unwrap() {
            Some((m, _)) => seen.push(m.inertia.m),
            None => tokio::time::sleep(Duration::from_millis(20)).await,
        }
    }
    assert!(seen.iter().all(|&m| m == 0.0), "payload topic: {seen:?}");

    bridge.stop().await;
    robot.stop();
    let _ = robot.join();
    service.stop().await.unwrap();
}
