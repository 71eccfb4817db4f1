//! Runs a `mock_robot::Simulation` as the FRI controller of a service over UDP loopback, either
//! in lockstep (the next measurement is sent as soon as the answer arrives, or after a timeout
//! counted as a miss: deterministic and faster than real time, for tests) or paced in real time
//! (for the demo and soak runs).

use std::net::{SocketAddr, UdpSocket};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use fri::wire::{CMD_LEN, Command, MSR_LEN};
use mock_robot::{SimError, Simulation, SimulationConfig};

/// How the simulated controller is paced.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pacing {
    /// Next cycle as soon as the answer arrived (or after `timeout`, counted as a miss).
    Lockstep {
        /// Longest wait for an answer.
        timeout: Duration,
    },
    /// One cycle per controller period of wall-clock time.
    RealTime,
}

/// Figures of a driver run.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct DriverStats {
    /// Measurements sent.
    pub sent: u64,
    /// Answers received in time.
    pub answered: u64,
    /// Cycles without an answer within the timeout.
    pub missed: u64,
    /// Answers received after the controller cycle had ended (real time only; the controller
    /// counts them as missed).
    pub late: u64,
}

/// Round trips kept for the latency figures (10 min at 1 kHz).
const MAX_LATENCIES: usize = 600_000;

/// Shared counters of a running driver.
#[derive(Debug, Default)]
struct Counters {
    sent: AtomicU64,
    answered: AtomicU64,
    missed: AtomicU64,
    late: AtomicU64,
    sim_cycles: AtomicU64,
}

/// A running simulated controller.
#[derive(Debug)]
pub struct MockDriver {
    stop: Arc<AtomicBool>,
    counters: Arc<Counters>,
    thread: Option<JoinHandle<Simulation>>,
    local: SocketAddr,
    latencies: Arc<Mutex<Vec<f64>>>,
}

impl MockDriver {
    /// Builds the simulation and starts sending to `service` from an ephemeral loopback port.
    pub fn spawn(
        config: SimulationConfig,
        service: SocketAddr,
        pacing: Pacing,
    ) -> Result<Self, SimError> {
        Self::resume(Simulation::new(config)?, service, pacing)
    }

    /// Carries on with an existing simulation (e.g. one returned by [`MockDriver::stop`] whose
    /// payload was attached since): time, sensor drift and noise continue where they stopped.
    pub fn resume(sim: Simulation, service: SocketAddr, pacing: Pacing) -> Result<Self, SimError> {
        let socket = UdpSocket::bind("127.0.0.1:0").map_err(SimError::from)?;
        let local = socket.local_addr().map_err(SimError::from)?;
        let stop = Arc::new(AtomicBool::new(false));
        let counters = Arc::new(Counters::default());
        let latencies = Arc::new(Mutex::new(Vec::new()));
        let (s, c, l) = (stop.clone(), counters.clone(), latencies.clone());
        let thread = std::thread::Builder::new()
            .name("mock-controller".into())
            .spawn(move || run(sim, socket, service, pacing, s, c, l))
            .map_err(SimError::from)?;
        Ok(Self {
            stop,
            counters,
            thread: Some(thread),
            local,
            latencies,
        })
    }

    /// The controller's local UDP address.
    pub fn local_addr(&self) -> SocketAddr {
        self.local
    }

    /// Counters so far.
    pub fn stats(&self) -> DriverStats {
        DriverStats {
            sent: self.counters.sent.load(Ordering::Relaxed),
            answered: self.counters.answered.load(Ordering::Relaxed),
            missed: self.counters.missed.load(Ordering::Relaxed),
            late: self.counters.late.load(Ordering::Relaxed),
        }
    }

    /// Measured round trips (measurement sent → answer received) so far, s.
    pub fn latencies(&self) -> Vec<f64> {
        self.latencies.lock().map(|l| l.clone()).unwrap_or_default()
    }

    /// Simulated time so far, in cycles.
    pub fn cycles(&self) -> u64 {
        self.counters.sim_cycles.load(Ordering::Relaxed)
    }

    /// Stops the controller and returns the simulation (for its truth and statistics).
    pub fn stop(mut self) -> Option<Simulation> {
        self.stop.store(true, Ordering::Release);
        self.thread.take().and_then(|t| t.join().ok())
    }
}

impl Drop for MockDriver {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Release);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn run(
    mut sim: Simulation,
    socket: UdpSocket,
    service: SocketAddr,
    pacing: Pacing,
    stop: Arc<AtomicBool>,
    counters: Arc<Counters>,
    latencies: Arc<Mutex<Vec<f64>>>,
) -> Simulation {
    if pacing == Pacing::RealTime {
        // Best effort, like the service's endpoint: a real controller does not get preempted.
        let param = libc::sched_param { sched_priority: 80 };
        // SAFETY: pthread_self() is valid for the calling thread; `param` outlives the call.
        let rc =
            unsafe { libc::pthread_setschedparam(libc::pthread_self(), libc::SCHED_FIFO, &param) };
        if rc != 0 {
            tracing::warn!(
                rc,
                "mock controller: SCHED_FIFO not permitted; timing may suffer"
            );
        }
    }
    let period = Duration::from_secs_f64(sim.cycle_s());
    let timeout = match pacing {
        Pacing::Lockstep { timeout } => timeout,
        // In real time the answer must come within the cycle.
        Pacing::RealTime => period,
    };
    let mut out = [0u8; MSR_LEN];
    let mut buf = [0u8; 2048];
    let mut next = Instant::now();
    while !stop.load(Ordering::Acquire) && !sim.is_finished() {
        let sent_at = Instant::now();
        let expected_seq = sim.measurement().header.send_seq_count;
        if sim.measurement().emit(&mut out).is_ok() {
            let _ = socket.send_to(&out, service);
            counters.sent.fetch_add(1, Ordering::Relaxed);
        }
        let deadline = sent_at + timeout;
        let mut answer: Option<Command> = None;
        let mut latency_s = 0.0;
        loop {
            let now = Instant::now();
            if now >= deadline {
                break;
            }
            let _ = socket.set_read_timeout(Some((deadline - now).max(Duration::from_micros(50))));
            match socket.recv_from(&mut buf) {
                Ok((n, from)) if from == service && n == CMD_LEN => {
                    // Only the answer to this measurement counts; a late answer to an earlier
                    // one is discarded (the controller would count it as stale).
                    if let Ok(c) = Command::parse(&buf[..n])
                        && c.header.refl_seq_count == expected_seq
                    {
                        latency_s = sent_at.elapsed().as_secs_f64();
                        answer = Some(c);
                        break;
                    }
                }
                Ok(_) => {}
                Err(_) => break,
            }
        }
        // In real time an answer later than the cycle is a miss for the controller too.
        let late = pacing == Pacing::RealTime && latency_s > sim.cycle_s();
        if late {
            counters.late.fetch_add(1, Ordering::Relaxed);
        }
        if let Some(cmd) = &answer {
            counters.answered.fetch_add(1, Ordering::Relaxed);
            if let Ok(mut l) = latencies.lock()
                && l.len() < MAX_LATENCIES
            {
                l.push(latency_s);
            }
            // Hand the answer over with its measured round trip, so the controller's
            // statistics (answer rate, latency, jitter) are those of the real exchange.
            let mut bytes = [0u8; CMD_LEN];
            if cmd.emit(&mut bytes).is_ok() {
                sim.submit_datagram(&bytes, latency_s);
            }
        } else {
            counters.missed.fetch_add(1, Ordering::Relaxed);
        }
        sim.advance();
        counters.sim_cycles.fetch_add(1, Ordering::Relaxed);
        if pacing == Pacing::RealTime {
            next += period;
            let now = Instant::now();
            if next > now {
                std::thread::sleep(next - now);
            } else if now - next > period * 100 {
                // Far behind (machine overloaded): re-anchor instead of bursting.
                next = now;
            }
        }
    }
    sim
}
