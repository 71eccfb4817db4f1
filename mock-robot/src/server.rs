//! The simulated controller on a UDP socket: real-time (wall-clock paced) or lockstep timing.
//!
//! - Real time: measurement k leaves at t0 + k·T; answers arriving before t0 + (k+1)·T (at
//!   least T/2 after the actual send) count, with their measured round-trip latency; later ones
//!   are stale (missed).
//! - Lockstep: the next cycle starts as soon as the answer to the current measurement arrives,
//!   or after `answer_timeout` (counted as a miss). Latency counts as zero, so runs are
//!   deterministic given the remote's answers, and faster than real time.
//!
//! As on the real controller, the simulation sends first and talks to one remote (`client`): a
//! KRC talks to the one `FRIHOST` of its configuration, so datagrams from any other host are
//! ignored and counted (`RunSummary::foreign_datagrams`).
//! Any [`Controller`] runs here: the simulation, or a replayed log ([`crate::replay::Replay`]).
//! Changes of the controller's FRI state are logged as they happen (target
//! `mock_robot::controller`, INFO).

use std::io::{BufWriter, ErrorKind};
use std::net::{SocketAddr, UdpSocket};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use fri::wire::{Command, MSR_LEN};

use crate::config::SimulationConfig;
use crate::controller::Controller;
use crate::error::SimError;
use crate::simulation::Simulation;
use crate::truth::TruthLog;

/// Default lockstep answer timeout.
pub const DEFAULT_LOCKSTEP_TIMEOUT: Duration = Duration::from_millis(100);

/// How cycles are paced.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TimingMode {
    /// Wall-clock paced at the FRI cycle.
    RealTime,
    /// Next cycle when the answer arrives, or after the timeout (a miss).
    Lockstep {
        /// Longest wait for an answer.
        answer_timeout: Duration,
    },
}

/// Where and how to run the controller.
#[derive(Debug, Clone)]
pub struct ServerConfig {
    /// Local address of the controller's socket (port 0 = any free port).
    pub bind: SocketAddr,
    /// The remote (FRI client) address measurements are sent to.
    pub client: SocketAddr,
    /// Pacing.
    pub mode: TimingMode,
    /// Stop after this many cycles (None = until the scenario ends or a stop request).
    pub max_cycles: Option<u64>,
    /// Ground-truth CSV file to write, if any.
    pub truth_log: Option<PathBuf>,
}

impl ServerConfig {
    /// A controller on an ephemeral loopback port sending to `client`, run until stopped, without
    /// a truth log: what the demo and the service's end-to-end tests use.
    pub fn loopback(client: SocketAddr, mode: TimingMode) -> Self {
        Self {
            bind: SocketAddr::from(([127, 0, 0, 1], 0)),
            client,
            mode,
            max_cycles: None,
            truth_log: None,
        }
    }
}

/// Answer counts of a run so far.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct AnswerCounts {
    /// Measurements sent (cycles run).
    pub sent: u64,
    /// Measurements answered before the next one was due.
    pub answered: u64,
    /// Measurements not answered in time (the controller counts late answers as missed).
    pub missed: u64,
}

/// What a run did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RunSummary {
    /// Cycles run.
    pub cycles: u64,
    /// Simulated time, s.
    pub sim_time_s: f64,
    /// Wall-clock time, s.
    pub wall_time_s: f64,
    /// Measurements that could not be sent (socket errors).
    pub send_errors: u64,
    /// Real time: cycles that started more than one cycle late.
    pub late_cycles: u64,
    /// Real time: largest lateness of a cycle start, s.
    pub max_lateness_s: f64,
    /// Real time: mean |actual − scheduled| send time, s.
    pub mean_send_jitter_s: f64,
    /// Datagrams from hosts other than the configured remote's (ignored).
    pub foreign_datagrams: u64,
}

impl RunSummary {
    /// Simulated time per wall-clock time.
    pub fn speed_factor(&self) -> f64 {
        if self.wall_time_s > 0.0 {
            self.sim_time_s / self.wall_time_s
        } else {
            0.0
        }
    }
}

/// Round trips kept by [`RunCounters`] (10 min at 1 kHz).
const MAX_LATENCIES: usize = 600_000;

/// Live counters of a run, readable from other threads while it goes on.
#[derive(Debug)]
pub struct RunCounters {
    /// Cycles run.
    pub cycles: AtomicU64,
    /// Cycles whose measurement was answered in time (before the next one was due).
    pub answered: AtomicU64,
    /// Datagrams from hosts other than the configured remote's (ignored).
    pub foreign: AtomicU64,
    latencies: Mutex<Vec<f64>>,
}

impl Default for RunCounters {
    fn default() -> Self {
        Self {
            cycles: AtomicU64::new(0),
            answered: AtomicU64::new(0),
            foreign: AtomicU64::new(0),
            // Reserved up front: recording a round trip never allocates in the loop.
            latencies: Mutex::new(Vec::with_capacity(MAX_LATENCIES)),
        }
    }
}

impl RunCounters {
    /// Round trips (measurement sent → its answer received) so far, s; real time only, at
    /// most the first ten minutes.
    pub fn latencies(&self) -> Vec<f64> {
        self.latencies.lock().map(|l| l.clone()).unwrap_or_default()
    }

    /// Sent, answered and missed measurements so far.
    pub fn answer_counts(&self) -> AnswerCounts {
        let sent = self.cycles.load(Ordering::Relaxed);
        let answered = self.answered.load(Ordering::Relaxed);
        AnswerCounts {
            sent,
            answered,
            missed: sent.saturating_sub(answered),
        }
    }

    fn answered(&self, latency_s: f64) {
        self.answered.fetch_add(1, Ordering::Relaxed);
        if let Ok(mut l) = self.latencies.lock()
            && l.len() < l.capacity()
        {
            l.push(latency_s);
        }
    }
}

/// Waits until `socket` is readable or `timeout` passes; true when readable.
///
/// `ppoll` with a nanosecond timeout (high-resolution timer): `SO_RCVTIMEO` is rounded to the
/// kernel tick (up to 4 ms), far too coarse for a 1 ms cycle.
fn wait_readable(socket: &UdpSocket, timeout: Duration) -> bool {
    use std::os::fd::AsRawFd;
    let mut fd = libc::pollfd {
        fd: socket.as_raw_fd(),
        events: libc::POLLIN,
        revents: 0,
    };
    let ts = libc::timespec {
        tv_sec: libc::time_t::try_from(timeout.as_secs()).unwrap_or(libc::time_t::MAX),
        // subsec_nanos() < 1e9 fits every c_long.
        tv_nsec: timeout.subsec_nanos() as libc::c_long,
    };
    // SAFETY: `fd` is one valid pollfd and `ts` a valid timespec for the whole call; a null
    // signal mask keeps the current one.
    let ready = unsafe { libc::ppoll(&mut fd, 1, &ts, std::ptr::null()) };
    ready > 0 && fd.revents & libc::POLLIN != 0
}

/// Receives one datagram into `buf` before `deadline`; returns its length, arrival time and
/// source.
fn recv_until(
    socket: &UdpSocket,
    buf: &mut [u8],
    deadline: Instant,
) -> Option<(usize, Instant, SocketAddr)> {
    loop {
        let now = Instant::now();
        if now >= deadline {
            return None;
        }
        if !wait_readable(socket, deadline - now) {
            continue;
        }
        match socket.recv_from(buf) {
            Ok((n, from)) => return Some((n, Instant::now(), from)),
            // ICMP port unreachable from an earlier send (remote not up yet), or a spurious
            // wake-up: keep waiting.
            Err(e)
                if matches!(
                    e.kind(),
                    ErrorKind::WouldBlock
                        | ErrorKind::TimedOut
                        | ErrorKind::ConnectionRefused
                        | ErrorKind::Interrupted
                ) =>
            {
                continue;
            }
            Err(_) => return None,
        }
    }
}

/// Runs `sim` on `socket` until the controller ends (scenario or log over, FRI closed), `stop`
/// is set or `max_cycles` is reached; `counters` follow the run live.
pub fn run<C: Controller>(
    sim: &mut C,
    socket: &UdpSocket,
    config: &ServerConfig,
    stop: &AtomicBool,
    counters: &RunCounters,
) -> Result<RunSummary, SimError> {
    run_with(sim, socket, config, stop, counters, |_| {})
}

/// [`run`], calling `between(sim)` once per cycle before the controller advances: an operator's
/// requests are carried out there (the control socket's [`crate::control::ControlPort`]).
pub fn run_with<C: Controller>(
    sim: &mut C,
    socket: &UdpSocket,
    config: &ServerConfig,
    stop: &AtomicBool,
    counters: &RunCounters,
    mut between: impl FnMut(&mut C),
) -> Result<RunSummary, SimError> {
    let mut truth = match &config.truth_log {
        Some(_) if sim.simulation().is_none() => {
            return Err(SimError::InvalidConfig(
                "a truth log needs a simulation; a replayed log has no ground truth".into(),
            ));
        }
        Some(path) => Some(TruthLog::new(BufWriter::new(std::fs::File::create(path)?))?),
        None => None,
    };
    let cycle = Duration::from_secs_f64(sim.cycle_s());
    let mut summary = RunSummary::default();
    let mut msr_bytes = [0u8; MSR_LEN];
    let mut buf = [0u8; 2048];
    let start = Instant::now();
    let mut t0 = start;
    let mut k: u32 = 0;
    let mut jitter_sum = 0.0;
    while !stop.load(Ordering::Relaxed)
        && !sim.is_finished()
        && config.max_cycles.is_none_or(|m| summary.cycles < m)
    {
        if let TimingMode::RealTime = config.mode {
            let scheduled = t0 + cycle * k;
            let now = Instant::now();
            if now < scheduled {
                std::thread::sleep(scheduled - now);
            }
            let lateness = Instant::now()
                .saturating_duration_since(scheduled)
                .as_secs_f64();
            jitter_sum += lateness;
            summary.max_lateness_s = summary.max_lateness_s.max(lateness);
            if lateness > sim.cycle_s() {
                summary.late_cycles += 1;
                if lateness > 10.0 * sim.cycle_s() {
                    // Far behind (machine stalled): restart the schedule instead of bursting.
                    t0 = Instant::now();
                    k = 0;
                }
            }
        }
        let sent_at = Instant::now();
        let sent = sim.measurement().emit(&mut msr_bytes).is_ok()
            && socket.send_to(&msr_bytes, config.client).is_ok();
        if !sent {
            summary.send_errors += 1;
        }
        let msr_seq = sim.measurement().header.send_seq_count;
        match config.mode {
            TimingMode::RealTime => {
                // When this process was late to send (a non-real-time host), the remote still
                // gets at least half a cycle to answer: misses should be the remote's.
                let deadline = (t0 + cycle * (k + 1)).max(sent_at + cycle / 2);
                while let Some((n, at, from)) = recv_until(socket, &mut buf, deadline) {
                    if foreign(from, config, &mut summary, counters) {
                        continue;
                    }
                    let latency_s = (at - sent_at).as_secs_f64();
                    if answers(&buf[..n], msr_seq) {
                        counters.answered(latency_s);
                    }
                    sim.submit_datagram(&buf[..n], latency_s);
                }
            }
            TimingMode::Lockstep { answer_timeout } => {
                let deadline = sent_at + answer_timeout;
                if sent {
                    while let Some((n, _, from)) = recv_until(socket, &mut buf, deadline) {
                        if foreign(from, config, &mut summary, counters) {
                            continue;
                        }
                        sim.submit_datagram(&buf[..n], 0.0);
                        if answers(&buf[..n], msr_seq) {
                            counters.answered(0.0);
                            break;
                        }
                    }
                }
            }
        }
        between(sim);
        let msr = *sim.advance();
        while let Some(event) = sim.poll_event() {
            tracing::info!(target: "mock_robot::controller", "{event}");
        }
        if let (Some(log), Some(simulation)) = (truth.as_mut(), sim.simulation()) {
            log.record(simulation, &msr)?;
        }
        summary.cycles += 1;
        counters.cycles.fetch_add(1, Ordering::Relaxed);
        k = k.wrapping_add(1);
    }
    if let Some(log) = truth.as_mut() {
        log.flush()?;
    }
    summary.sim_time_s = summary.cycles as f64 * sim.cycle_s();
    summary.wall_time_s = start.elapsed().as_secs_f64();
    if summary.cycles > 0 {
        summary.mean_send_jitter_s = jitter_sum / summary.cycles as f64;
    }
    Ok(summary)
}

/// Whether `from` is another host than the configured remote's; such a datagram is counted and
/// ignored.
fn foreign(
    from: SocketAddr,
    config: &ServerConfig,
    summary: &mut RunSummary,
    counters: &RunCounters,
) -> bool {
    let foreign = from.ip() != config.client.ip();
    if foreign {
        summary.foreign_datagrams += 1;
        counters.foreign.fetch_add(1, Ordering::Relaxed);
    }
    foreign
}

/// Whether `datagram` is a command answering measurement `msr_seq`.
fn answers(datagram: &[u8], msr_seq: u16) -> bool {
    Command::parse(datagram).is_ok_and(|c| c.header.refl_seq_count == msr_seq)
}

/// A controller (by default a [`Simulation`]) running on its own thread.
#[derive(Debug)]
pub struct MockRobotHandle<C = Simulation> {
    local_addr: SocketAddr,
    stop: Arc<AtomicBool>,
    counters: Arc<RunCounters>,
    thread: JoinHandle<Result<(C, RunSummary), SimError>>,
}

impl<C> MockRobotHandle<C> {
    /// The controller's socket address (where its measurements come from).
    pub fn local_addr(&self) -> SocketAddr {
        self.local_addr
    }

    /// The run's live counters.
    pub fn counters(&self) -> &RunCounters {
        &self.counters
    }

    /// Asks the controller to stop after the current cycle.
    pub fn stop(&self) {
        self.stop.store(true, Ordering::Relaxed);
    }

    /// Whether the controller thread has ended (scenario over, or stopped).
    pub fn is_finished(&self) -> bool {
        self.thread.is_finished()
    }

    /// Stops the controller and returns it (a simulation, for ground truth) and the summary.
    pub fn join(self) -> Result<(C, RunSummary), SimError> {
        self.stop();
        self.thread
            .join()
            .map_err(|_| SimError::InvalidConfig("mock robot thread panicked".into()))?
    }
}

/// Builds the simulation from `config` and runs it on a new thread (see [`spawn`]).
pub fn spawn_new(
    config: SimulationConfig,
    server: ServerConfig,
) -> Result<MockRobotHandle, SimError> {
    spawn(Simulation::new(config)?, server)
}

/// Binds the socket and runs `sim` on a new thread; a simulation returned by
/// [`MockRobotHandle::join`] carries on where it stopped (time, sensor drift, noise).
pub fn spawn<C: Controller + Send + 'static>(
    mut sim: C,
    config: ServerConfig,
) -> Result<MockRobotHandle<C>, SimError> {
    let socket = UdpSocket::bind(config.bind)?;
    let local_addr = socket.local_addr()?;
    let stop = Arc::new(AtomicBool::new(false));
    let counters = Arc::new(RunCounters::default());
    let thread_stop = Arc::clone(&stop);
    let thread_counters = Arc::clone(&counters);
    let thread = std::thread::Builder::new()
        .name("mock-robot".into())
        .spawn(move || {
            if config.mode == TimingMode::RealTime
                && let Err(e) = realtime_priority()
            {
                tracing::debug!(
                    "mock controller: SCHED_FIFO not permitted ({e}); timing may suffer"
                );
            }
            let summary = run(&mut sim, &socket, &config, &thread_stop, &thread_counters)?;
            Ok((sim, summary))
        })?;
    Ok(MockRobotHandle {
        local_addr,
        stop,
        counters,
        thread,
    })
}

/// SCHED_FIFO priority of a real-time controller thread.
pub const REALTIME_PRIORITY: i32 = 80;

/// Puts the calling thread under SCHED_FIFO at [`REALTIME_PRIORITY`], for a real-time run: a
/// real controller is not preempted by the remote's host, so neither should the simulated one
/// be (its delays would count as misses). Fails without CAP_SYS_NICE or an rtprio limit.
pub fn realtime_priority() -> std::io::Result<()> {
    let param = libc::sched_param {
        sched_priority: REALTIME_PRIORITY,
    };
    // SAFETY: pthread_self() is valid for the calling thread; `param` outlives the call.
    let rc = unsafe { libc::pthread_setschedparam(libc::pthread_self(), libc::SCHED_FIFO, &param) };
    if rc == 0 {
        Ok(())
    } else {
        Err(std::io::Error::from_raw_os_error(rc))
    }
}
