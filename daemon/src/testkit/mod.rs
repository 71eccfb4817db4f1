//! The whole daemon in-process, for tests of the service, of `fri-ctl` and of bridges: start it on
//! loopback with its operator socket in a directory the test owns, connect clients, stop it.
//!
//! Pair it with `mock_robot::spawn` (real UDP, lockstep or real time) as the controller:
//!
//! ```no_run
//! # async fn run() -> anyhow::Result<()> {
//! use fri_service::testkit::{InProcess, local_config};
//! use mock_robot::{ServerConfig, SimulationConfig, TimingMode};
//!
//! let dir = std::env::temp_dir().join("fri-testkit-doc");
//! let service = InProcess::start(local_config(&dir, "doc")).await?;
//! let mode = TimingMode::Lockstep { answer_timeout: std::time::Duration::from_millis(200) };
//! let robot = mock_robot::spawn_new(SimulationConfig::loaded(), ServerConfig::loopback(service.fri, mode))?;
//! let mut client = service.client().await?;
//! client.call(fri_api::protocol::Command::Status, |_, _| {}).await?;
//! drop(robot.join());
//! service.stop().await?;
//! # Ok(()) }
//! ```

pub mod log_lines;

use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::Duration;

use anyhow::{Context as _, bail};
use fri_api::client::Client;
use tokio::sync::watch;

use crate::config::Config;
use crate::service::RunningService;

/// Services started by this process so far (makes iceoryx2 prefixes unique).
static STARTED: AtomicU32 = AtomicU32::new(0);
/// Longest wait for the operator socket to appear after the start.
const SOCKET_WAIT: Duration = Duration::from_secs(5);

/// A configuration on loopback: FRI on an ephemeral port of 127.0.0.1, the operator socket and the
/// state directory inside `dir`, iceoryx2 under a prefix unique to this process and `name`.
pub fn local_config(dir: &Path, name: &str) -> Config {
    let mut c = Config::default();
    c.fri.bind = SocketAddr::from(([127, 0, 0, 1], 0));
    c.operator.socket = dir.join("op.sock");
    c.state.dir = dir.join("state");
    c.iceoryx2.service_prefix = name.to_owned();
    c.iceoryx2.global_prefix = Some(format!(
        "t{}x{}{name}_",
        std::process::id(),
        STARTED.fetch_add(1, Ordering::SeqCst)
    ));
    c
}

/// A running daemon with its operator server on a tokio task.
#[derive(Debug)]
pub struct InProcess {
    service: Option<Arc<RunningService>>,
    shutdown: watch::Sender<bool>,
    server: Option<tokio::task::JoinHandle<anyhow::Result<()>>>,
    /// The operator socket.
    pub socket: PathBuf,
    /// The FRI endpoint's address (where the controller sends).
    pub fri: SocketAddr,
}

impl InProcess {
    /// Starts the daemon and its operator server; returns once the socket accepts connections.
    pub async fn start(config: Config) -> anyhow::Result<Self> {
        let socket = config.operator.socket.clone();
        let service = Arc::new(RunningService::start(config)?);
        let fri = service
            .fri_addr()
            .context("the FRI endpoint has no address")?;
        let (shutdown, rx) = watch::channel(false);
        let serving = service.clone();
        let server = tokio::spawn(async move { serving.serve_operator(rx).await });
        let deadline = tokio::time::Instant::now() + SOCKET_WAIT;
        // Waits for the server's bind, not for a fixed time.
        while Client::connect(&socket).await.is_err() {
            if server.is_finished() || tokio::time::Instant::now() > deadline {
                bail!("the operator socket {} never accepted", socket.display());
            }
            tokio::task::yield_now().await;
            tokio::time::sleep(Duration::from_millis(2)).await;
        }
        Ok(Self {
            service: Some(service),
            shutdown,
            server: Some(server),
            socket,
            fri,
        })
    }

    /// A new client connection.
    pub async fn client(&self) -> anyhow::Result<Client> {
        Client::connect(&self.socket)
            .await
            .with_context(|| format!("connecting to {}", self.socket.display()))
    }

    /// The service (e.g. for its core).
    pub fn service(&self) -> Option<&RunningService> {
        self.service.as_deref()
    }

    /// Stops the operator server (answering pending requests) and the daemon.
    pub async fn stop(mut self) -> anyhow::Result<()> {
        let _ = self.shutdown.send(true);
        if let Some(s) = self.server.take() {
            s.await.context("operator server task")??;
        }
        if let Some(s) = self.service.take() {
            match Arc::try_unwrap(s) {
                Ok(s) => s.shutdown(),
                Err(_) => bail!("the service is still shared after its server stopped"),
            }
        }
        Ok(())
    }
}
