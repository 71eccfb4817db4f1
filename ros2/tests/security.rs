//! DDS Security: a keystore made by `tools/sros2_keystore.sh` (the SROS2 layout), the bridge in
//! its enclave `/lwr/fri_ros2` with `stop` enabled. A participant of the keystore (enclave
//! `/lwr/operator`, ros2-client with DDS Security) stops the arm and the service's audit trail
//! names it, authenticated; the rogue Cyclone participant (no security) calling the same service
//! gets nothing: no reply, no stop, no audit record.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod common;

use std::path::Path;
use std::time::Duration;

use fri_api::origin::Origin;
use fri_api::results::Change;
use fri_ros2::config::Ros2Config;
use fri_ros2::srv::{TriggerRequest, TriggerResponse};
use ros2_client::dds::rustdds::{
    DomainParticipantBuilder, DomainParticipantSecurityConfigFiles, RTPSEntity as _,
};
use ros2_client::{Context, Name, NodeName, NodeOptions, ServiceMapping, ServiceTypeName};

/// Runs the keystore script: the keystore in `dir` with the given enclaves.
fn keystore(dir: &Path, enclaves: &[&str]) {
    let status = std::process::Command::new("bash")
        .arg(common::workspace().join("tools/sros2_keystore.sh"))
        .arg(dir)
        .args(enclaves)
        .status()
        .unwrap();
    assert!(status.success(), "tools/sros2_keystore.sh: {status}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn only_a_participant_of_the_keystore_commands_the_arm() {
    common::loopback_multicast();
    let dir = tempfile::tempdir().unwrap();
    let ks = dir.path().join("keystore");
    keystore(&ks, &["/lwr/fri_ros2", "/lwr/operator"]);
    let mut config = common::service_config(dir.path(), "secure");
    config.observer.armed = true;
    let service = fri_service::testkit::InProcess::start(config.clone())
        .await
        .unwrap();
    let (robot, mut client) = common::unloaded_robot(&service).await;
    let audit = common::AuditWatch::start(service.client().await.unwrap()).await;
    let domain = 155;
    let bridge = common::Bridge::start_with(
        config,
        Ros2Config {
            domain_id: domain,
            joint_states_hz: 50,
            interface: Some("lo".into()),
            commands: vec!["stop".into()],
            security_enclave: Some(ks.join("enclaves/lwr/fri_ros2")),
            ..Ros2Config::default()
        },
    );

    // The rogue participant: no reader matches its requests, nothing answers.
    let rogue = common::JsonPeer::start(
        "rogue_peer.py",
        &[
            "trigger",
            "--service",
            "stop",
            "--domain",
            &domain.to_string(),
            "--wait-match",
            "10",
            "--quiet",
            "5",
        ]
        .map(String::from),
    );
    let rogue_guid = rogue.next_with("ready", 60).await["participant"]
        .as_str()
        .unwrap()
        .to_owned();
    assert_eq!(rogue.next_with("matched", 60).await["matched"], 0);
    assert_eq!(rogue.next_with("replies", 60).await["replies"], 0);
    assert!(!common::status(&mut client).await.stopped);

    // A participant of the keystore, with its own enclave.
    let participant = DomainParticipantBuilder::new(domain)
        .with_only_networks([std::net::IpAddr::from([127, 0, 0, 1])])
        .builtin_security(
            DomainParticipantSecurityConfigFiles::with_ros_default_names(
                ks.join("enclaves/lwr/operator"),
                String::new(),
            ),
        )
        .build()
        .unwrap();
    let guid = fri_ros2::rpc::participant_guid(&participant.guid().to_bytes());
    let context = Context::from_domain_participant(participant).unwrap();
    let mut node = context
        .new_node(
            NodeName::new("/test", "operator").unwrap(),
            NodeOptions::new(),
        )
        .unwrap();
    let qos = fri_ros2::dds::request_qos();
    let stop = node
        .create_client::<TriggerRequest, TriggerResponse>(
            ServiceMapping::Enhanced,
            &Name::new("/lwr", "stop").unwrap(),
            &ServiceTypeName::new("std_srvs", "Trigger"),
            qos.clone(),
            qos,
        )
        .unwrap();
    let spinner = node.spinner().unwrap();
    tokio::spawn(spinner.spin());
    let call = Duration::from_secs(60);
    tokio::time::timeout(call, stop.wait_for_service(&node))
        .await
        .expect("the authorised participant never discovered the bridge's stop service");
    let r = tokio::time::timeout(call, stop.async_call_service(TriggerRequest::default()))
        .await
        .unwrap()
        .unwrap();
    assert!(r.success, "{r:?}");
    assert!(common::status(&mut client).await.stopped);

    let records = audit.finish().await;
    assert!(
        records.iter().any(|r| r.change == Change::Stopped
            && matches!(&r.origin, Origin::Ros2 { participant: p, authenticated: true, .. } if *p == guid)),
        "{guid}: {records:?}"
    );
    assert!(
        !records
            .iter()
            .any(|r| matches!(&r.origin, Origin::Ros2 { participant: p, .. } if *p == rogue_guid)),
        "{records:?}"
    );
    drop(stop);
    drop(node);
    drop(context);
    bridge.stop().await;
    robot.stop();
    let _ = robot.join();
    service.stop().await.unwrap();
}
