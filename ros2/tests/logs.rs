//! The bridge's logs without `RUST_LOG` (issue 23 item 3: `fri-ros2` wrote 700 lines in about
//! 2.5 min — RustDDS's INFO "Update changes Locators in ReaderProxy" every 10 s, its WARN
//! "send_to_locator: Message size = 8436" for the robot description, ros2-client's "ROS_DISTRO
//! is not set"). The binary, bridging a running service to a subscriber for longer than RustDDS's
//! 10 s period, writes only its own lines below WARN and none of those three; with
//! `RUST_LOG=info` the same run shows the dependencies' INFO lines, so the test sees them when
//! they are there.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod common;

use std::process::{Command, Stdio};
use std::time::Duration;

use common::{TestNode, next_where};
use fri_ros_msgs::RosMessage;
use fri_ros_msgs::sensor_msgs::JointState;
use fri_ros_msgs::std_msgs;
use fri_ros2::dds::{latched_qos, stream_qos};
use fri_service::testkit::InProcess;
use fri_service::testkit::log_lines::{level_and_target, log_lines};

/// Lines the issue counted in the flood, by their text.
const NOISE: [&str; 3] = ["Update changes Locators", "Message size", "ROS_DISTRO"];

/// Runs `fri-ros2` over `service` with `filter` as `RUST_LOG` (unset: `None`) while a node
/// takes the joint states and the robot description for 12 s, then SIGTERM; its stderr lines.
async fn bridge_log(
    dir: &std::path::Path,
    config: &fri_service::config::Config,
    domain: u16,
    filter: Option<&str>,
) -> Vec<String> {
    let name = filter.unwrap_or("default");
    let file = dir.join(format!("{name}.toml"));
    std::fs::write(&file, toml::to_string(config).unwrap()).unwrap();
    let log = dir.join(format!("{name}.log"));
    let mut command = Command::new(env!("CARGO_BIN_EXE_fri-ros2"));
    command
        .arg("--config")
        .arg(&file)
        .env_remove("RUST_LOG")
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(&log).unwrap());
    if let Some(f) = filter {
        command.env("RUST_LOG", f);
    }
    let mut bridge = command.spawn().unwrap();
    let mut test = TestNode::new(domain, &format!("logs_{name}"));
    let joint_states =
        test.subscribe::<JointState>("/", "joint_states", JointState::TYPE, stream_qos());
    let descriptions = test.subscribe::<std_msgs::String>(
        "/",
        "robot_description",
        std_msgs::String::TYPE,
        latched_qos(),
    );
    let _ = next_where(&joint_states, "joint states from the bridge", |_| true).await;
    let d = next_where(&descriptions, "the robot description", |_| true).await;
    // the largest message the bridge sends (the URDF, 5 kB; the warning named 8436 B)
    assert!(d.data.contains("lwr_dh_frame_7"), "{}", d.data);
    // RustDDS's reader-proxy update comes every 10 s
    let until = tokio::time::Instant::now() + Duration::from_secs(12);
    while tokio::time::Instant::now() < until {
        while joint_states.take().unwrap().is_some() {}
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    // SAFETY: kill(2) on the child's own pid, which is still ours (not yet waited for).
    let pid = libc::pid_t::try_from(bridge.id()).unwrap();
    assert_eq!(unsafe { libc::kill(pid, libc::SIGTERM) }, 0);
    let status = bridge.wait().unwrap();
    let text = std::fs::read_to_string(&log).unwrap();
    assert!(status.success(), "{status}: {text}");
    log_lines(&text)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn without_rust_log_the_bridge_writes_no_dependency_line_below_warn() {
    common::loopback_multicast();
    let dir = tempfile::tempdir().unwrap();
    let mut config = common::service_config(dir.path(), "ros2logs");
    let domain = common::domain(0);
    config.ros2 = Some(
        toml::from_str(&format!(
            "domain_id = {domain}\ninterface = \"lo\"\njoint_states_hz = 50\n"
        ))
        .unwrap(),
    );
    let service = InProcess::start(config.clone()).await.unwrap();
    let robot = common::robot(mock_robot::SimulationConfig::loaded(), service.fri, None);
    common::wait_connected(&service).await;

    let lines = bridge_log(dir.path(), &config, domain, None).await;
    assert!(
        lines
            .iter()
            .any(|l| l.contains("INFO") && l.contains("starting the ROS 2 bridge")),
        "the bridge's own start line is missing: {lines:#?}"
    );
    let foreign: Vec<&String> = lines
        .iter()
        .filter(|l| match level_and_target(l) {
            Some((level, target)) => {
                !target.starts_with("fri_") && !matches!(level.as_str(), "WARN" | "ERROR")
            }
            // a line that is not a log line (e.g. a dependency printing on its own)
            None => true,
        })
        .collect();
    assert!(
        foreign.is_empty(),
        "lines below WARN from dependencies, or not from the logger: {foreign:#?}"
    );
    let noise: Vec<&String> = lines
        .iter()
        .filter(|l| NOISE.iter().any(|n| l.contains(n)))
        .collect();
    assert!(noise.is_empty(), "the issue's flood is back: {noise:#?}");

    // The same run at RUST_LOG=info: the dependencies' INFO lines are there to be seen.
    let loud = bridge_log(dir.path(), &config, domain, Some("info")).await;
    let dependencies = loud
        .iter()
        .filter(|l| {
            level_and_target(l).is_some_and(|(level, target)| {
                level == "INFO" && (target.starts_with("rustdds") || target.starts_with("ros2_"))
            })
        })
        .count();
    assert!(
        dependencies > 0,
        "RUST_LOG=info shows no dependency line: {loud:#?}"
    );

    robot.stop();
    let _ = robot.join();
    service.stop().await.unwrap();
}
