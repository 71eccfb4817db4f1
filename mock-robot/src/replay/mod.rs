//! A recorded log played as the controller: `mock-robot --replay FILE`, or [`Replay`] in process
//! (with the test kit or [`crate::spawn`]).
//!
//! Measurement k reports the log `k · cycle` after its first stamp: joint angles and measured
//! torques interpolated linearly between the rows around that time, and what the KRC computes
//! from its own model at those angles — here the nominal model (`dynamics::lwr4()`): gravity,
//! mass matrix, Jacobian, frames and `estExtJntTrq = rnea(q, q̇, q̈) − τ_msr` (velocities and
//! accelerations from the log, differentiated when it has none). The controller runs the FRI
//! link as the simulation does (statistics, quality, misses) and the KRL program in monitor mode
//! only: a start of command mode is acknowledged and refused with reason 7 (strategy not
//! supported). The last row ends the controller.

mod csv;
mod error;
mod log;
mod mcap;

use std::path::Path;

use dynamics::{Data, Model};
use fri::wire::{InterfaceState, KrlData, Measurement};

pub use self::csv::{MAX_COLUMNS, MAX_LINE_BYTES};
pub use self::mcap::{MAX_CHUNK_BYTES, TOPIC};
pub use error::{Column, Location, ReplayError};
pub use log::{
    Derivatives, LogLimits, MAX_ACCELERATION_RAD_S2, MAX_GAP_S, MAX_LOG_BYTES, MAX_ROWS,
    POSITION_MARGIN_RAD, RecordedLog, Sample, TORQUE_RANGE_FACTOR, VELOCITY_RANGE_FACTOR,
};

use crate::config::ControllerSpec;
use crate::controller::{Controller, ControllerEvent, EventKind, EventQueue};
use crate::joints::JointVector;
use crate::krl::{FriState, KrlEvent, KrlProgram};
use crate::link::{FriLink, ReceiveCounters};
use crate::report::{Reading, write_robot_data};
use crate::simulation::Simulation;
use crate::stats::{Quality, Statistics};

/// Reads a log: MCAP when the file starts with the MCAP magic, CSV otherwise; bounded by
/// `limits`, a symbolic link refused.
pub fn read_log(path: &Path, limits: &LogLimits) -> Result<RecordedLog, ReplayError> {
    let (file, size) = log::open(path, limits)?;
    let bytes = log::read_bounded(path, file, size, limits)?;
    if bytes.starts_with(self::mcap::MAGIC) {
        self::mcap::read(path, &bytes, limits)
    } else {
        self::csv::read(path, bytes.as_slice(), limits)
    }
}

/// The controller that plays a [`RecordedLog`].
#[derive(Debug, Clone)]
pub struct Replay {
    log: RecordedLog,
    cycle_s: f64,
    last_cycle: u64,
    cycle: u64,
    time_s: f64,
    cursor: usize,
    sample: Sample,
    link: FriLink,
    krl: KrlProgram,
    model: Model<7>,
    data: Data<7>,
    mirrored: JointVector,
    events: EventQueue,
    measurement: Measurement,
}

impl Replay {
    /// Reads `path` with the default limits and plays it at a cycle of `cycle_ms` (1..=100 ms).
    pub fn from_file(path: &Path, cycle_ms: u32) -> Result<Self, ReplayError> {
        Self::new(read_log(path, &LogLimits::default())?, cycle_ms)
    }

    /// Plays `log` at a cycle of `cycle_ms` (1..=100 ms) with the default FRI rules.
    pub fn new(log: RecordedLog, cycle_ms: u32) -> Result<Self, ReplayError> {
        if !(1..=100).contains(&cycle_ms) {
            return Err(ReplayError::Cycle { cycle_ms });
        }
        let cycle_s = f64::from(cycle_ms) * 1e-3;
        let spec = ControllerSpec::default();
        let model = dynamics::lwr4();
        let mut cursor = 0;
        let sample = log.sample(0.0, &mut cursor);
        // The last measurement is the last one within the log (its end to a nanosecond).
        let last_cycle = ((log.duration_s() + 1e-9) / cycle_s).floor() as u64;
        let mut replay = Self {
            cycle_s,
            last_cycle,
            cycle: 0,
            time_s: 0.0,
            cursor,
            sample,
            link: FriLink::new(&spec, &Default::default(), 0, cycle_s),
            krl: KrlProgram::monitor_only(&spec, cycle_s),
            data: Data::new(&model),
            model,
            mirrored: sample.q,
            events: EventQueue::new(),
            measurement: crate::report::initial_measurement(cycle_s),
            log,
        };
        replay.build_measurement();
        Ok(replay)
    }

    /// The log played.
    pub fn log(&self) -> &RecordedLog {
        &self.log
    }

    /// The joint state the current measurement reports (interpolated from the log).
    pub fn sample(&self) -> &Sample {
        &self.sample
    }

    /// Cycles played so far.
    pub fn cycles(&self) -> u64 {
        self.cycle
    }

    /// Measurements the whole log gives (the last one at its last stamp or just before).
    pub fn total_cycles(&self) -> u64 {
        self.last_cycle + 1
    }

    /// FRI state (monitor mode, or off after the remote closed FRI).
    pub fn fri_state(&self) -> FriState {
        if self.krl.is_closed() {
            FriState::Off
        } else {
            FriState::Monitor
        }
    }

    /// Current quality level.
    pub fn quality(&self) -> Quality {
        self.link.quality()
    }

    /// Statistics over the last 100 cycles.
    pub fn statistics(&self) -> Statistics {
        self.link.statistics()
    }

    /// What the controller received so far.
    pub fn receive_counters(&self) -> ReceiveCounters {
        self.link.counters()
    }

    /// Code of the last refusal reason (`msr.krl.intData[12]`; 7 after a start request).
    pub fn drop_reason_code(&self) -> i32 {
        self.krl.reason_code()
    }

    /// Events dropped because nobody took them.
    pub fn events_dropped(&self) -> u64 {
        self.events.dropped()
    }

    fn build_measurement(&mut self) {
        self.sample = self.log.sample(self.time_s, &mut self.cursor);
        let s = &self.sample;
        let reading = Reading {
            q_msr: &s.q,
            qd: &s.qd,
            qdd: &s.qdd,
            tau_msr: &s.tau,
            // Monitor mode: the KRC holds where the arm is.
            cmd_pos: &s.q,
            fri_setpoint: None,
        };
        self.mirrored = write_robot_data(
            &self.model,
            &mut self.data,
            &reading,
            &mut self.measurement.data,
        );
        let mut krl = KrlData::default();
        self.krl.write_status(&mut krl.int);
        let state = self.fri_state();
        let m = &mut self.measurement;
        self.link.stamp(m, self.time_s);
        m.krl = krl;
        m.interface.state = InterfaceState::from_raw(state.wire_value());
    }
}

impl Controller for Replay {
    fn measurement(&self) -> &Measurement {
        &self.measurement
    }

    fn submit_datagram(&mut self, bytes: &[u8], latency_s: f64) {
        self.link.submit(bytes, latency_s);
    }

    fn advance(&mut self) -> &Measurement {
        let view = self.link.receive();
        let event = self
            .krl
            .step(view.as_ref(), self.link.quality(), &self.mirrored);
        let kind = match event {
            Some(KrlEvent::Dropped(reason)) => Some(EventKind::StartRefused {
                reason,
                monitor_only: true,
            }),
            Some(KrlEvent::Closed) => Some(EventKind::Closed),
            // Monitor mode only: no entry, no stop.
            Some(KrlEvent::EnteredCommand(_) | KrlEvent::Stopped) | None => None,
        };
        self.cycle += 1;
        if let Some(kind) = kind {
            // Stamped with the first measurement that shows it.
            self.events.push(ControllerEvent {
                time_s: self.cycle as f64 * self.cycle_s,
                kind,
            });
        }
        self.time_s = self.cycle as f64 * self.cycle_s;
        self.build_measurement();
        &self.measurement
    }

    fn is_finished(&self) -> bool {
        self.krl.is_closed() || self.cycle > self.last_cycle
    }

    fn cycle_s(&self) -> f64 {
        self.cycle_s
    }

    fn time_s(&self) -> f64 {
        self.time_s
    }

    fn poll_event(&mut self) -> Option<ControllerEvent> {
        self.events.pop()
    }

    fn simulation(&self) -> Option<&Simulation> {
        None
    }
}
