//! The real `fri-service` binary as a child process: its configuration file, its start (the
//! operator socket answers `status`) and its end, for the tests of start-up and restarts.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs, dead_code)]

use std::net::{SocketAddr, UdpSocket};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

use fri_api::client::Client;
use fri_service::config::Config;

/// Longest wait for a start or an exit: generous, the machine is shared; a test asserts the
/// outcome, never how long it took.
pub const PATIENCE: Duration = Duration::from_secs(30);

/// A loopback UDP port that was free a moment ago (the kernel's choice).
pub fn free_udp_port() -> u16 {
    let s = UdpSocket::bind("127.0.0.1:0").unwrap();
    s.local_addr().unwrap().port()
}

/// A configuration on loopback with everything inside `dir`, FRI on `port`, iceoryx2 off.
pub fn config_in(dir: &Path, port: u16) -> Config {
    let mut c = fri_service::testkit::local_config(dir, "bin");
    c.fri.bind = SocketAddr::from(([127, 0, 0, 1], port));
    c.iceoryx2.enabled = false;
    c
}

/// Writes `config` as `name` in `dir`; returns its path.
pub fn write_config(dir: &Path, name: &str, config: &Config) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, toml::to_string(config).unwrap()).unwrap();
    path
}

/// A running `fri-service run --config FILE`, its stderr going to a file.
pub struct Daemon {
    pub child: Child,
    pub log: PathBuf,
    pub socket: PathBuf,
}

impl Daemon {
    /// Spawns the binary with `RUST_LOG=info`; `log` receives its stderr.
    pub fn spawn(config_file: &Path, config: &Config, log: &Path) -> Self {
        Self::spawn_logging(config_file, config, log, Some("info"))
    }

    /// Spawns the binary with `RUST_LOG` set to `filter` (`None`: unset, the service's default
    /// filter); `log` receives its stderr.
    pub fn spawn_logging(
        config_file: &Path,
        config: &Config,
        log: &Path,
        filter: Option<&str>,
    ) -> Self {
        let err = std::fs::File::create(log).unwrap();
        let mut command = Command::new(env!("CARGO_BIN_EXE_fri-service"));
        command.args(["run", "--config"]).arg(config_file);
        match filter {
            Some(f) => command.env("RUST_LOG", f),
            None => command.env_remove("RUST_LOG"),
        };
        let child = command
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::from(err))
            .spawn()
            .unwrap();
        Self {
            child,
            log: log.to_owned(),
            socket: config.operator.socket.clone(),
        }
    }

    /// What the daemon wrote to stderr so far.
    pub fn stderr(&self) -> String {
        std::fs::read_to_string(&self.log).unwrap_or_default()
    }

    /// Waits until the operator socket answers `status`; `Err` with the daemon's stderr when it
    /// exited first or never answered.
    pub fn wait_running(&mut self) -> Result<serde_json::Value, String> {
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .unwrap();
        let deadline = Instant::now() + PATIENCE;
        loop {
            if let Some(status) = self.child.try_wait().unwrap() {
                return Err(format!("exited with {status}: {}", self.stderr()));
            }
            let answer = rt.block_on(async {
                let mut c = Client::connect(&self.socket).await.ok()?;
                c.call(fri_api::protocol::Command::Status, |_, _| {})
                    .await
                    .ok()?
                    .ok()
            });
            if let Some(status) = answer {
                return Ok(status);
            }
            if Instant::now() > deadline {
                return Err(format!("never answered `status`: {}", self.stderr()));
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    }

    /// Sends `signal` (SIGTERM, SIGKILL, ...).
    pub fn signal(&self, signal: libc::c_int) {
        let pid = libc::pid_t::try_from(self.child.id()).unwrap();
        // SAFETY: kill has no memory preconditions; the pid is our own child's.
        assert_eq!(unsafe { libc::kill(pid, signal) }, 0);
    }

    /// Waits for the exit; `None` when it is still running after [`PATIENCE`].
    pub fn wait_exit(&mut self) -> Option<ExitStatus> {
        let deadline = Instant::now() + PATIENCE;
        loop {
            if let Some(s) = self.child.try_wait().unwrap() {
                return Some(s);
            }
            if Instant::now() > deadline {
                return None;
            }
            std::thread::sleep(Duration::from_millis(5));
        }
    }
}

impl Drop for Daemon {
    fn drop(&mut self) {
        if self.child.try_wait().ok().flatten().is_none() {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

/// A stand-in controller on a thread: sends a valid measurement to `to` every millisecond and
/// counts every datagram that comes back, until stopped.
pub struct Probe {
    stop: std::sync::Arc<std::sync::atomic::AtomicBool>,
    thread: std::thread::JoinHandle<(u64, u64)>,
}

impl Probe {
    /// Starts probing `to`.
    pub fn start(to: SocketAddr) -> Self {
        use std::sync::atomic::Ordering;
        let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
        let flag = stop.clone();
        let socket = UdpSocket::bind("127.0.0.1:0").unwrap();
        socket
            .set_read_timeout(Some(Duration::from_millis(1)))
            .unwrap();
        let thread = std::thread::spawn(move || {
            let mut sim =
                mock_robot::Simulation::new(mock_robot::SimulationConfig::default()).unwrap();
            let mut bytes = [0u8; fri::wire::MSR_LEN];
            let mut buf = [0u8; 2048];
            let (mut sent, mut answers) = (0u64, 0u64);
            while !flag.load(Ordering::Relaxed) {
                sim.measurement().emit(&mut bytes).unwrap();
                if socket.send_to(&bytes, to).is_ok() {
                    sent += 1;
                }
                sim.advance();
                while socket.recv_from(&mut buf).is_ok() {
                    answers += 1;
                }
            }
            (sent, answers)
        });
        Self { stop, thread }
    }

    /// Stops; returns the measurements sent and the datagrams received.
    pub fn finish(self) -> (u64, u64) {
        self.stop.store(true, std::sync::atomic::Ordering::Relaxed);
        self.thread.join().unwrap()
    }
}

/// Runs the binary with `config` while a [`Probe`] plays the controller: the start must fail.
/// Returns the exit status, stderr, and the datagrams the probe received.
pub fn failed_start(dir: &Path, config: &Config) -> (ExitStatus, String, u64) {
    let file = write_config(dir, "failing.toml", config);
    let probe = Probe::start(config.fri.bind);
    let mut daemon = Daemon::spawn(&file, config, &dir.join("failing.log"));
    let status = daemon.wait_exit();
    // A little longer: a service that answered would keep answering.
    std::thread::sleep(Duration::from_millis(50));
    let (sent, answers) = probe.finish();
    let stderr = daemon.stderr();
    let status = status.unwrap_or_else(|| panic!("the start did not fail; it runs: {stderr}"));
    assert!(sent > 0, "the probe sent nothing");
    (status, stderr, answers)
}
