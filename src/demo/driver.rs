//! Runs a `mock_robot::Simulation` as the FRI controller of a service over UDP loopback, either
//! in lockstep (the next measurement is sent as soon as the answer arrives, or after a timeout
//! counted as a miss: deterministic and faster than real time, for tests) or paced in real time
//! (for the demo and soak runs).
//!
//! A thin handle on `mock_robot::spawn`: the simulated controller's own loop keeps its schedule
//! (sends at t0 + k·T, waits with a high-resolution timer, gives every answer until the next
//! measurement is due), so its host's delays are not charged to the service as missed answers.

use std::net::SocketAddr;
use std::sync::atomic::Ordering;
use std::time::Duration;

use mock_robot::server::{MockRobotHandle, ServerConfig, TimingMode};
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
    /// Measurements sent (cycles run).
    pub sent: u64,
    /// Measurements answered before the next one was due.
    pub answered: u64,
    /// Measurements not answered in time (the controller counts late answers as missed).
    pub missed: u64,
}

/// A running simulated controller.
#[derive(Debug)]
pub struct MockDriver {
    handle: MockRobotHandle,
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
        let mode = match pacing {
            Pacing::Lockstep { timeout } => TimingMode::Lockstep {
                answer_timeout: timeout,
            },
            Pacing::RealTime => TimingMode::RealTime,
        };
        let config = ServerConfig {
            bind: SocketAddr::from(([127, 0, 0, 1], 0)),
            client: service,
            mode,
            max_cycles: None,
            truth_log: None,
        };
        Ok(Self {
            handle: mock_robot::spawn(sim, config)?,
        })
    }

    /// The controller's local UDP address.
    pub fn local_addr(&self) -> SocketAddr {
        self.handle.local_addr()
    }

    /// Counters so far.
    pub fn stats(&self) -> DriverStats {
        let c = self.handle.counters();
        let sent = c.cycles.load(Ordering::Relaxed);
        let answered = c.answered.load(Ordering::Relaxed);
        DriverStats {
            sent,
            answered,
            missed: sent.saturating_sub(answered),
        }
    }

    /// Measured round trips (measurement sent → answer received) so far, s.
    pub fn latencies(&self) -> Vec<f64> {
        self.handle.counters().latencies()
    }

    /// Simulated time so far, in cycles.
    pub fn cycles(&self) -> u64 {
        self.handle.counters().cycles.load(Ordering::Relaxed)
    }

    /// Stops the controller and returns the simulation (for its truth and statistics).
    pub fn stop(self) -> Option<Simulation> {
        match self.handle.join() {
            Ok((sim, _)) => Some(sim),
            Err(e) => {
                tracing::warn!(error = %e, "simulated controller failed");
                None
            }
        }
    }
}
