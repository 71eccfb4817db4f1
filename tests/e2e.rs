//! End-to-end: the service against the mock robot in lockstep over UDP loopback, driven through
//! the operator socket.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::Duration;

use fri_service::config::Config;
use fri_service::demo::driver::{MockDriver, Pacing};
use fri_service::operator::client::Client;
use fri_service::operator::protocol::Command;
use fri_service::service::RunningService;
use mock_robot::SimulationConfig;
use serde_json::Value;
use tokio::sync::watch;

static NEXT: AtomicU32 = AtomicU32::new(0);

struct Harness {
    dir: tempfile::TempDir,
    service: Option<RunningService>,
    shutdown: watch::Sender<bool>,
    socket: PathBuf,
    fri: SocketAddr,
    server: Option<tokio::task::JoinHandle<()>>,
}

fn test_config(dir: &std::path::Path) -> Config {
    let mut c = Config::default();
    c.fri.bind = "127.0.0.1:0".parse().unwrap();
    c.operator.socket = dir.join("op.sock");
    c.state.dir = dir.join("state");
    c.iceoryx2.service_prefix = "e2e".into();
    c.iceoryx2.global_prefix = Some(format!(
        "fe2e{}x{}_",
        std::process::id(),
        NEXT.fetch_add(1, Ordering::SeqCst)
    ));
    // Faster moves than the conservative defaults keep the tests short.
    c.fri.max_joint_step = 1.0e-3;
    c.motion.max_velocity = [0.9; 7];
    c.motion.max_acceleration = [5.0; 7];
    c.motion.max_jerk = [100.0; 7];
    c.estimation.average_s = 0.2;
    c.estimation.settle_window_s = 0.05;
    c.estimation.settle_timeout_s = 0.5;
    c
}

impl Harness {
    async fn start(config: Config, dir: tempfile::TempDir) -> Self {
        let socket = config.operator.socket.clone();
        let service = RunningService::start(config).unwrap();
        let fri = service.fri_addr().unwrap();
        let (shutdown, rx) = watch::channel(false);
        let core_service = unsafe_static(&service);
        let server = tokio::spawn(async move {
            core_service.serve_operator(rx).await.unwrap();
        });
        // Wait for the socket.
        for _ in 0..200 {
            if socket.exists() {
                break;
            }
            tokio::time::sleep(Duration::from_millis(10)).await;
        }
        Self {
            dir,
            service: Some(service),
            shutdown,
            socket,
            fri,
            server: Some(server),
        }
    }

    async fn client(&self) -> Client {
        Client::connect(&self.socket).await.unwrap()
    }

    async fn stop(mut self) -> tempfile::TempDir {
        self.shutdown.send(true).unwrap();
        if let Some(s) = self.server.take() {
            s.await.unwrap();
        }
        if let Some(s) = self.service.take() {
            s.shutdown();
        }
        self.dir
    }
}

/// The operator server borrows the service for the test's lifetime.
fn unsafe_static(s: &RunningService) -> &'static RunningService {
    // SAFETY: every test awaits the server task (in `Harness::stop`) before dropping the
    // service, so the reference never outlives it.
    unsafe { &*(s as *const RunningService) }
}

fn sim(payload: bool, seed: u64) -> SimulationConfig {
    let mut c = SimulationConfig {
        seed,
        ..SimulationConfig::default()
    };
    c.payload.attached_at_start = payload;
    c
}

fn lockstep() -> Pacing {
    Pacing::Lockstep {
        timeout: Duration::from_millis(200),
    }
}

async fn call(
    c: &mut Client,
    cmd: Command,
) -> Result<Value, fri_service::operator::protocol::OperatorError> {
    c.call(cmd, |_, _| {}).await.unwrap()
}

async fn wait_connected(c: &mut Client) -> Value {
    for _ in 0..500 {
        let s = call(c, Command::Status).await.unwrap();
        if s["connected"].as_bool() == Some(true) {
            return s;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    panic!("service never saw the controller");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn tare_then_estimate_through_the_socket_and_persist_after_restart() {
    let dir = tempfile::tempdir().unwrap();
    let mut config = test_config(dir.path());
    // The uncompensated payload would trip the monitor: the paper's point. Estimation runs
    // with the monitor disarmed and contacts caught by the workflow's residual-change check.
    config.observer.armed = false;
    let h = Harness::start(config.clone(), dir).await;

    // Tare without payload.
    let driver = MockDriver::spawn(sim(false, 7), h.fri, lockstep()).unwrap();
    let mut c = h.client().await;
    wait_connected(&mut c).await;
    let mut progress = 0;
    let tare = c
        .call(
            Command::Tare {
                around: None,
                poses: Some(6),
                step_deg: Some(7.0),
            },
            |ev, _| {
                assert_eq!(ev, "progress");
                progress += 1;
            },
        )
        .await
        .unwrap()
        .unwrap();
    assert_eq!(tare["samples"], 6);
    assert!(progress >= 18, "progress events: {progress}");
    eprintln!("tare: {} cycles, {:?}", driver.cycles(), driver.stats());
    drop(driver.stop());

    // Payload attached (a new controller run, same seed: same sensor offsets and model error).
    let driver = MockDriver::spawn(sim(true, 7), h.fri, lockstep()).unwrap();
    tokio::time::sleep(Duration::from_millis(300)).await;
    let est = call(
        &mut c,
        Command::EstimatePayload {
            around: None,
            poses: Some(6),
            step_deg: Some(7.0),
            use_tare: None,
            apply: Some(true),
        },
    )
    .await
    .unwrap();
    let sim_done = driver.stop().unwrap();
    let truth = sim_done.true_payload().unwrap();
    let m_true = truth.mass;
    let c_true = truth.com().unwrap();
    let mass = est["mass"].as_f64().unwrap();
    let com: Vec<f64> = est["com"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    eprintln!("estimate {est}");
    assert_eq!(est["tare_used"], true);
    assert!(
        ((mass - m_true) / m_true).abs() < 0.005,
        "mass {mass} vs {m_true}"
    );
    for k in 0..3 {
        assert!(
            (com[k] - c_true[k]).abs() < 0.005,
            "com {com:?} vs {c_true:?}"
        );
    }
    assert!(est["mass_std"].as_f64().unwrap() > 0.0);
    let status = call(&mut c, Command::Status).await.unwrap();
    assert_eq!(status["payload"]["mass"].as_f64().unwrap(), mass);

    // Restart the service on the same state directory: the payload comes back.
    let dir = h.stop().await;
    let h = Harness::start(config, dir).await;
    let mut c = h.client().await;
    let status = call(&mut c, Command::Status).await.unwrap();
    assert_eq!(status["payload"]["mass"].as_f64().unwrap(), mass);
    assert_eq!(status["tare_samples"], 6);
    h.stop().await;
}
