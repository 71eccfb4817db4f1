//! What the bridge's tests share: the service in-process against the mock robot, the bridge on
//! loopback, the Python DDS peers' virtual environment.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs, dead_code)]

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Mutex;
use std::time::Duration;

use fri_api::client::Client;
use fri_ros_msgs::MessageType;
use fri_ros2::BridgeConfig;
use fri_ros2::config::Ros2Config;
use fri_service::config::Config;
use fri_service::testkit::{InProcess, local_config};
use mock_robot::{MockRobotHandle, ServerConfig, SimulationConfig, TimingMode};
use ros2_client::dds::rustdds::DomainParticipantBuilder;
use ros2_client::{
    Context, MessageTypeName, Name, Node, NodeName, NodeOptions, QosProfile, Subscription,
};
use tokio::sync::oneshot;

/// The workspace root.
pub fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_owned()
}

static VENV: Mutex<()> = Mutex::new(());

/// The Python of the peers' virtual environment (`target/python-peers`), created (or completed)
/// with `tools/python_peers.sh` when it is missing or lacks a peer package (a fresh checkout, an
/// older list), so `cargo test` needs only `python3` on the machine.
pub fn peers_python() -> PathBuf {
    let _one_at_a_time = VENV.lock().unwrap_or_else(|e| e.into_inner());
    let root = workspace();
    let venv = root.join("target").join("python-peers");
    let python = venv.join("bin").join("python");
    let ready = python.exists()
        && Command::new(&python)
            .args(["-c", "import cyclonedds, mcap, mcap_ros2.decoder"])
            .status()
            .is_ok_and(|s| s.success());
    if !ready {
        let status = Command::new("bash")
            .arg(root.join("tools").join("python_peers.sh"))
            .arg(&venv)
            .status()
            .expect("running tools/python_peers.sh (needs bash and python3)");
        assert!(status.success(), "tools/python_peers.sh failed: {status}");
    }
    python
}

/// Loopback carries multicast only with the flag set (DDS discovery); as root the tests set it.
pub fn loopback_multicast() {
    let on = std::fs::read_to_string("/sys/class/net/lo/flags")
        .ok()
        .and_then(|f| u32::from_str_radix(f.trim().trim_start_matches("0x"), 16).ok())
        .is_some_and(|f| f & 0x1000 != 0); // IFF_MULTICAST
    if !on {
        let s = Command::new("ip")
            .args(["link", "set", "lo", "multicast", "on"])
            .status();
        eprintln!("ip link set lo multicast on: {s:?}");
    }
}

/// A DDS domain of this test process alone (tests in one process use different `index`es).
pub fn domain(index: u16) -> u16 {
    let pid = u16::try_from(std::process::id() % 50).unwrap();
    100 + pid * 2 + index
}

/// The service in-process on loopback with the e2e tests' faster motion limits.
pub fn service_config(dir: &Path, name: &str) -> Config {
    let mut c = local_config(dir, name);
    c.fri.max_joint_step = 1.0e-3;
    c.motion.max_velocity = [0.9; 7];
    c.motion.max_acceleration = [5.0; 7];
    c.motion.max_jerk = [100.0; 7];
    c
}

/// The mock robot in real time (1 ms cycles, as a KRC), optionally writing its truth log.
pub fn robot(
    sim: SimulationConfig,
    fri: std::net::SocketAddr,
    truth: Option<PathBuf>,
) -> MockRobotHandle {
    let mut server = ServerConfig::loopback(fri, TimingMode::RealTime);
    server.truth_log = truth;
    mock_robot::spawn_new(sim, server).unwrap()
}

/// The bridge on loopback in `domain`, stopped by sending on the returned channel.
pub struct Bridge {
    stop: Option<oneshot::Sender<()>>,
    task: tokio::task::JoinHandle<Result<(), fri_ros2::BridgeError>>,
}

impl Bridge {
    pub fn start(service: Config, domain_id: u16, joint_states_hz: u32) -> Self {
        let ros2 = Ros2Config {
            domain_id,
            joint_states_hz,
            interface: Some("lo".into()),
            ..Ros2Config::default()
        };
        Self::start_with(service, ros2)
    }

    /// The bridge with `ros2` as its `[ros2]` table.
    pub fn start_with(service: Config, ros2: Ros2Config) -> Self {
        let config = BridgeConfig::new(service, ros2).unwrap();
        let (stop, rx) = oneshot::channel();
        let task = tokio::spawn(fri_ros2::run(config, async {
            let _ = rx.await;
        }));
        Self {
            stop: Some(stop),
            task,
        }
    }

    pub async fn stop(mut self) {
        if let Some(s) = self.stop.take() {
            let _ = s.send(());
        }
        tokio::time::timeout(Duration::from_secs(10), self.task)
            .await
            .expect("the bridge did not stop")
            .unwrap()
            .unwrap();
    }
}

/// The simulated arm in real time, with no payload on it (an undeclared one is a contact to an
/// armed monitor), once the service hears it: the robot and a client of the service.
pub async fn unloaded_robot(service: &InProcess) -> (MockRobotHandle, Client) {
    let mut sim = SimulationConfig::default();
    sim.payload.attached_at_start = false;
    let robot = robot(sim, service.fri, None);
    (robot, wait_connected(service).await)
}

/// Waits until the service sees the controller.
pub async fn wait_connected(service: &InProcess) -> Client {
    let mut c = service.client().await.unwrap();
    for _ in 0..1000 {
        let s = c
            .call(fri_api::protocol::Command::Status, |_, _| {})
            .await
            .unwrap()
            .unwrap();
        if s["connected"].as_bool() == Some(true) {
            return c;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    panic!("the service never saw the controller");
}

/// A ros2-client node of a DDS participant of its own on loopback (the test's ROS 2 side).
pub struct TestNode {
    /// The node.
    pub node: Node,
    _context: Context,
}

impl TestNode {
    /// A node `/test/<name>` in `domain`, restricted to 127.0.0.1.
    pub fn new(domain: u16, name: &str) -> Self {
        let participant = DomainParticipantBuilder::new(domain)
            .with_only_networks([std::net::IpAddr::from([127, 0, 0, 1])])
            .build()
            .unwrap();
        let context = Context::from_domain_participant(participant).unwrap();
        let node = context
            .new_node(NodeName::new("/test", name).unwrap(), NodeOptions::new())
            .unwrap();
        Self {
            node,
            _context: context,
        }
    }

    /// A subscription to `namespace`/`name` of type `t` with `qos`.
    pub fn subscribe<M: 'static>(
        &mut self,
        namespace: &str,
        name: &str,
        t: &MessageType,
        qos: QosProfile,
    ) -> Subscription<M> {
        let topic = self
            .node
            .create_topic(
                &Name::new(namespace, name).unwrap(),
                MessageTypeName::new(t.package, t.name),
                &qos,
            )
            .unwrap();
        self.node.create_subscription::<M>(&topic, None).unwrap()
    }
}

/// The next message on `sub` for which `pred` holds (waits at most 30 s).
pub async fn next_where<M: 'static + serde::de::DeserializeOwned>(
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

/// The `[ros2]` table on loopback in `domain_id` with `commands` served to ANY participant
/// (`allow_unauthenticated_commands`), disarm, resume and motion allowed as the commands need.
pub fn unauthenticated(domain_id: u16, commands: &[&str]) -> Ros2Config {
    let has = |c: &str| commands.contains(&c);
    Ros2Config {
        domain_id,
        joint_states_hz: 50,
        interface: Some("lo".into()),
        commands: commands.iter().map(|c| (*c).to_owned()).collect(),
        allow_disarm: has("collision_arm"),
        allow_resume: has("resume"),
        allow_motion: has("tare") || has("estimate_payload"),
        allow_unauthenticated_commands: true,
        ..Ros2Config::default()
    }
}

/// The service's own `[ros2]` table accepting unauthenticated ROS 2 commands.
pub fn service_accepts_unauthenticated(config: &mut Config) {
    config.ros2 = Some(toml::from_str("allow_unauthenticated_commands = true").unwrap());
}

/// CYCLONEDDS_URI pinning a Cyclone peer to loopback.
pub const CYCLONE_ON_LO: &str = "<CycloneDDS><Domain id=\"any\"><General><Interfaces>\
     <NetworkInterface name=\"lo\"/></Interfaces></General></Domain></CycloneDDS>";

/// A Python peer printing one JSON object per line.
pub struct JsonPeer {
    child: std::process::Child,
    lines: std::sync::mpsc::Receiver<serde_json::Value>,
}

impl JsonPeer {
    /// Runs `ros2/tests/peers/<script>` with `args` on loopback.
    pub fn start(script: &str, args: &[String]) -> Self {
        use std::io::BufRead as _;
        let mut child = Command::new(peers_python())
            .arg(workspace().join("ros2/tests/peers").join(script))
            .args(args)
            .env("CYCLONEDDS_URI", CYCLONE_ON_LO)
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::inherit())
            .spawn()
            .unwrap();
        let stdout = child.stdout.take().unwrap();
        let (tx, lines) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            for line in std::io::BufReader::new(stdout).lines() {
                let Ok(line) = line else { break };
                match serde_json::from_str::<serde_json::Value>(&line) {
                    Ok(v) => {
                        if tx.send(v).is_err() {
                            break;
                        }
                    }
                    Err(e) => eprintln!("peer printed a non-JSON line ({e}): {line}"),
                }
            }
        });
        Self { child, lines }
    }

    /// The next line with `key`, waiting at most `timeout_s` in all.
    pub async fn next_with(&self, key: &str, timeout_s: u64) -> serde_json::Value {
        let deadline = std::time::Instant::now() + Duration::from_secs(timeout_s);
        loop {
            let left = deadline.saturating_duration_since(std::time::Instant::now());
            assert!(
                !left.is_zero(),
                "the peer printed no `{key}` in {timeout_s} s"
            );
            match self.lines.try_recv() {
                Ok(v) if v.get(key).is_some() => return v,
                Ok(_) => {}
                Err(std::sync::mpsc::TryRecvError::Empty) => {
                    tokio::time::sleep(Duration::from_millis(20)).await;
                }
                Err(e) => panic!("the peer ended before printing `{key}`: {e}"),
            }
        }
    }
}

impl Drop for JsonPeer {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// A `watch` of the service collecting its audit records.
pub struct AuditWatch {
    stop: oneshot::Sender<()>,
    task: tokio::task::JoinHandle<Vec<fri_api::results::AuditRecord>>,
}

impl AuditWatch {
    /// Starts a `watch` on `c`; returns once it is live.
    pub async fn start(mut c: Client) -> Self {
        use fri_api::results::Event;
        let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel();
        let (live_tx, live_rx) = oneshot::channel();
        let watcher = tokio::spawn(async move {
            let mut live = Some(live_tx);
            let _ = c
                .call_typed::<serde_json::Value>(
                    fri_api::protocol::Command::Watch { state_every: None },
                    |e| match e {
                        Ok(Event::Watching(_)) => {
                            if let Some(l) = live.take() {
                                let _ = l.send(());
                            }
                        }
                        Ok(Event::Audit(a)) => {
                            let _ = tx.send(a);
                        }
                        _ => {}
                    },
                )
                .await;
        });
        live_rx.await.unwrap();
        let (stop, mut stopped) = oneshot::channel::<()>();
        let task = tokio::spawn(async move {
            let mut seen = Vec::new();
            loop {
                tokio::select! {
                    a = rx.recv() => match a {
                        Some(a) => seen.push(a),
                        None => break,
                    },
                    _ = &mut stopped => break,
                }
            }
            // What was already sent.
            while let Ok(a) = rx.try_recv() {
                seen.push(a);
            }
            watcher.abort();
            seen
        });
        Self { stop, task }
    }

    /// The records seen so far (after a short grace for events in flight).
    pub async fn finish(self) -> Vec<fri_api::results::AuditRecord> {
        tokio::time::sleep(Duration::from_millis(500)).await;
        let _ = self.stop.send(());
        self.task.await.unwrap()
    }
}

/// The service's status.
pub async fn status(c: &mut Client) -> fri_api::results::StatusResult {
    c.call_typed::<fri_api::results::StatusResult>(fri_api::protocol::Command::Status, |_| {})
        .await
        .unwrap()
        .unwrap()
}
