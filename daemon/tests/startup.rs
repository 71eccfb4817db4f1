//! Start-up failures (issue 20, items 2 and 7): every failure exits non-zero with the error
//! before the FRI endpoint answers anything — a probe plays the controller from before the start
//! and must receive nothing — and a second service on the same state directory or the same UDP
//! port fails while the first runs on undisturbed. The real binary, as root (as the service
//! runs next to the robot); `nobody` (uid 65534) plays the other local user.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod binary;

use std::os::unix::fs::{PermissionsExt, chown, symlink};
use std::time::Duration;

use binary::{Daemon, PATIENCE, config_in, failed_start, free_udp_port, write_config};
use fri_api::protocol::Command;
use fri_service::testkit::{InProcess, local_config};
use mock_robot::{ServerConfig, SimulationConfig, TimingMode};

#[test]
fn an_operator_socket_path_that_is_a_regular_file_stops_the_start_before_any_answer() {
    let dir = tempfile::tempdir().unwrap();
    let config = config_in(dir.path(), free_udp_port());
    std::fs::write(&config.operator.socket, "keep me").unwrap();
    let (status, stderr, answers) = failed_start(dir.path(), &config);
    assert!(!status.success(), "{stderr}");
    assert!(
        stderr.contains(&config.operator.socket.display().to_string())
            && stderr.contains("regular file"),
        "{stderr}"
    );
    assert_eq!(answers, 0, "the controller was answered: {stderr}");
    assert_eq!(
        std::fs::read_to_string(&config.operator.socket).unwrap(),
        "keep me"
    );
}

#[test]
fn an_operator_socket_path_that_is_a_symlink_stops_the_start_before_any_answer() {
    let dir = tempfile::tempdir().unwrap();
    let config = config_in(dir.path(), free_udp_port());
    let target = dir.path().join("target.sock");
    symlink(&target, &config.operator.socket).unwrap();
    let (status, stderr, answers) = failed_start(dir.path(), &config);
    assert!(!status.success(), "{stderr}");
    assert!(stderr.contains("symbolic link"), "{stderr}");
    assert_eq!(answers, 0, "the controller was answered: {stderr}");
    assert!(!target.exists(), "the symlink was followed");
}

#[test]
fn a_state_directory_another_user_owns_or_others_may_write_stops_the_start() {
    let dir = tempfile::tempdir().unwrap();
    let mut config = config_in(dir.path(), free_udp_port());
    // The set-up: the parent created by nobody before the service ran.
    let parent = dir.path().join("fri-service");
    std::fs::create_dir(&parent).unwrap();
    chown(&parent, Some(65534), Some(65534)).unwrap();
    config.state.dir = parent.join("state");
    let (status, stderr, answers) = failed_start(dir.path(), &config);
    assert!(!status.success(), "{stderr}");
    assert!(
        stderr.contains("state.dir")
            && stderr.contains(&parent.display().to_string())
            && stderr.contains("owned by uid 65534"),
        "{stderr}"
    );
    assert_eq!(answers, 0, "{stderr}");
    assert!(
        !config.state.dir.exists(),
        "created inside an untrusted parent"
    );

    let state = dir.path().join("open-state");
    std::fs::create_dir(&state).unwrap();
    std::fs::set_permissions(&state, std::fs::Permissions::from_mode(0o777)).unwrap();
    config.state.dir = state.clone();
    let (status, stderr, answers) = failed_start(dir.path(), &config);
    assert!(!status.success(), "{stderr}");
    assert!(
        stderr.contains(&state.display().to_string()) && stderr.contains("writable by group"),
        "{stderr}"
    );
    assert_eq!(answers, 0, "{stderr}");

    // The recording directory is held to the same rule.
    config.state.dir = dir.path().join("state");
    let rec = dir.path().join("rec");
    std::fs::create_dir(&rec).unwrap();
    chown(&rec, Some(65534), Some(65534)).unwrap();
    config.state.record_dir = Some(rec.clone());
    let (status, stderr, answers) = failed_start(dir.path(), &config);
    assert!(!status.success(), "{stderr}");
    assert!(
        stderr.contains("state.record_dir") && stderr.contains(&rec.display().to_string()),
        "{stderr}"
    );
    assert_eq!(answers, 0, "{stderr}");
}

/// The first service runs in this process against the mock controller in lockstep (a miss is an
/// answer later than 1 s); its cycle count and the controller's missed answers are compared
/// across the second service's attempt.
struct First {
    service: InProcess,
    robot: mock_robot::MockRobotHandle,
}

impl First {
    async fn start(dir: &std::path::Path) -> Self {
        let mut config = local_config(dir, "first");
        config.iceoryx2.enabled = false;
        let service = InProcess::start(config).await.unwrap();
        let mode = TimingMode::Lockstep {
            answer_timeout: Duration::from_secs(1),
        };
        let robot = mock_robot::spawn_new(
            SimulationConfig::default(),
            ServerConfig::loopback(service.fri, mode),
        )
        .unwrap();
        let first = Self { service, robot };
        first.wait_cycles(100).await;
        first
    }

    async fn cycles(&self) -> u64 {
        let mut c = self.service.client().await.unwrap();
        let s = c.call(Command::Status, |_, _| {}).await.unwrap().unwrap();
        s["fri"]["cycles"].as_u64().unwrap_or(0)
    }

    /// Waits until the service has run `n` more cycles.
    async fn wait_cycles(&self, n: u64) {
        let start = self.cycles().await;
        let deadline = tokio::time::Instant::now() + PATIENCE;
        while self.cycles().await < start + n {
            assert!(
                tokio::time::Instant::now() < deadline,
                "the first service stopped receiving the controller's datagrams"
            );
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
    }

    fn missed(&self) -> u64 {
        self.robot.counters().answer_counts().missed
    }

    async fn stop(self) {
        drop(self.robot.join());
        self.service.stop().await.unwrap();
    }
}

/// Runs a second `fri-service run` with `config`; it must fail on its own.
fn second_fails(dir: &std::path::Path, config: &fri_service::config::Config) -> String {
    let file = write_config(dir, "second.toml", config);
    let mut second = Daemon::spawn(&file, config, &dir.join("second.log"));
    let status = second.wait_exit();
    let stderr = second.stderr();
    let status = status.unwrap_or_else(|| panic!("the second service runs: {stderr}"));
    assert!(!status.success(), "{stderr}");
    stderr
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_second_service_on_the_same_configuration_fails_on_the_instance_lock() {
    let dir = tempfile::tempdir().unwrap();
    let first = First::start(dir.path()).await;
    let missed = first.missed();
    let mut config = first.service.service().unwrap().core.config().clone();
    config.fri.bind = first.service.fri;
    let stderr = second_fails(dir.path(), &config);
    assert!(
        stderr.contains("fri-service.lock")
            && stderr.contains(&format!("(pid {})", std::process::id())),
        "{stderr}"
    );
    first.wait_cycles(200).await;
    assert_eq!(first.missed(), missed, "the first service missed answers");
    first.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_second_service_on_the_same_udp_port_fails_and_the_first_keeps_the_controller() {
    let dir = tempfile::tempdir().unwrap();
    let first = First::start(dir.path()).await;
    let missed = first.missed();
    // Its own state directory and socket: only the port is shared.
    let other = dir.path().join("other");
    std::fs::create_dir(&other).unwrap();
    let config = config_in(&other, first.service.fri.port());
    let stderr = second_fails(&other, &config);
    assert!(
        stderr.contains("fri.bind") && stderr.contains("in use"),
        "{stderr}"
    );
    first.wait_cycles(200).await;
    assert_eq!(first.missed(), missed, "the first service missed answers");
    first.stop().await;
}
