//! Simulation configuration, readable from a scenario TOML file.
//!
//! Every section has documented defaults, so an empty TOML file is a valid scenario: the arm at
//! rest at the default pose with the paper's heavy payload, default sensors and model error.
//! Angles in scenario files are in degrees (`*_deg` keys); everything else is SI.

use serde::{Deserialize, Serialize};

mod controller;
mod payload;
mod physics;

pub use controller::{ControlSpec, ControllerSpec};
pub use payload::{
    DEFAULT_PAYLOAD_LENGTH_M, DEFAULT_PAYLOAD_RADIUS_M, PayloadAction, PayloadEvent, PayloadSpec,
};
pub use physics::{DEFAULT_TORQUE_QUANTUM_NM, FrictionSpec, ModelErrorSpec, SensorSpec};

pub use crate::arm_profile::{ArmProfile, ArmSpec};
use crate::contact::ContactSpec;
use crate::error::{SimError, ensure};
use crate::faults::NetworkFaultSpec;
use crate::motion::MotionSegment;

pub use fri::wire::JOINTS;

/// Default start pose: the paper's pick pose ([`dynamics::LWR4_PICK_POSE_DEG`]), deg.
pub const DEFAULT_INITIAL_Q_DEG: [f64; JOINTS] = dynamics::LWR4_PICK_POSE_DEG;

/// Complete configuration of one simulation run (a scenario).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct SimulationConfig {
    /// Free-form scenario name (goes into logs).
    pub name: String,
    /// Master seed of every random process (sensor noise, model perturbation, faults).
    pub seed: u64,
    /// Seed of what makes the arm itself (its torque sensors' offsets, the controller model's
    /// perturbation, a real profile's sensed terms), when another run of the same arm is meant
    /// (e.g. a calibration run before the task: the same arm, other noise); `None`: `seed`.
    pub arm_seed: Option<u64>,
    /// FRI cycle (friOpen argument), ms, 1..=100.
    pub cycle_ms: u32,
    /// Physics integration rate, Hz (≥ 5000); the substep count per cycle is rounded up.
    pub physics_rate_hz: f64,
    /// Scenario length, s; `None` runs until the motion script ends plus 1 s, or forever when
    /// there is no motion script.
    pub duration_s: Option<f64>,
    /// The arm the simulator is (`[arm] profile = "nominal"` or `"real-lwr4"`).
    pub arm: ArmSpec,
    /// Initial joint angles, deg; the arm starts at rest there.
    pub initial_q_deg: [f64; JOINTS],
    /// Joint angles given in rad (from the command line); overrides `initial_q_deg` when set.
    pub initial_q_rad: Option<[f64; JOINTS]>,
    /// The attached payload and its attach/detach timeline.
    pub payload: PayloadSpec,
    /// Joint torque sensor and encoder model.
    pub sensors: SensorSpec,
    /// Motor-side joint friction.
    pub friction: FrictionSpec,
    /// Perturbation of the controller's own dynamic model (lwr4-model.md §4).
    pub model: ModelErrorSpec,
    /// Controller gains of the position and joint impedance strategies.
    pub control: ControlSpec,
    /// Statistics and quality thresholds, command-mode rules of the controller.
    pub controller: ControllerSpec,
    /// KRL-side motion script executed in monitor mode (poses, dwells, sweeps).
    pub motion: Vec<MotionSegment>,
    /// External contacts (forces on links).
    pub contacts: Vec<ContactSpec>,
    /// Network faults on the command path.
    pub network: NetworkFaultSpec,
    /// Times of controller restarts (sequence counter reset, statistics reset, drop to MON), s.
    pub restarts_s: Vec<f64>,
    /// Times at which the operator stops command mode from the pendant (reason 8), s.
    pub operator_stops_s: Vec<f64>,
}

impl Default for SimulationConfig {
    fn default() -> Self {
        Self {
            name: "default".into(),
            seed: 1,
            arm_seed: None,
            cycle_ms: 1,
            physics_rate_hz: 5000.0,
            duration_s: None,
            arm: ArmSpec::default(),
            initial_q_deg: DEFAULT_INITIAL_Q_DEG,
            initial_q_rad: None,
            payload: PayloadSpec::default(),
            sensors: SensorSpec::default(),
            friction: FrictionSpec::default(),
            model: ModelErrorSpec::default(),
            control: ControlSpec::default(),
            controller: ControllerSpec::default(),
            motion: Vec::new(),
            contacts: Vec::new(),
            network: NetworkFaultSpec::default(),
            restarts_s: Vec::new(),
            operator_stops_s: Vec::new(),
        }
    }
}

impl SimulationConfig {
    /// The default simulation with the paper's payload (3.028 kg at (0, 0, 0.119) m) on the
    /// arm from the start; the plain default starts unloaded.
    pub fn loaded() -> Self {
        let mut config = Self::default();
        config.payload.attached_at_start = true;
        config
    }

    /// Parses a scenario from TOML text and validates it.
    pub fn from_toml_str(text: &str) -> Result<Self, SimError> {
        let config: Self = toml::from_str(text)?;
        config.validate()?;
        Ok(config)
    }

    /// Reads and parses a scenario TOML file.
    pub fn from_toml_file(path: &std::path::Path) -> Result<Self, SimError> {
        let text = std::fs::read_to_string(path)?;
        Self::from_toml_str(&text)
    }

    /// FRI cycle, s.
    pub fn cycle_s(&self) -> f64 {
        f64::from(self.cycle_ms) * 1e-3
    }

    /// Initial joint angles, rad.
    pub fn initial_q(&self) -> [f64; JOINTS] {
        self.initial_q_rad
            .unwrap_or_else(|| self.initial_q_deg.map(f64::to_radians))
    }

    /// Checks every range; returns the first violation.
    pub fn validate(&self) -> Result<(), SimError> {
        ensure((1..=100).contains(&self.cycle_ms), || {
            format!("cycle_ms must be 1..=100, got {}", self.cycle_ms)
        })?;
        ensure(
            self.physics_rate_hz.is_finite() && self.physics_rate_hz >= 5000.0,
            || {
                format!(
                    "physics_rate_hz must be >= 5000, got {}",
                    self.physics_rate_hz
                )
            },
        )?;
        if let Some(d) = self.duration_s {
            ensure(d.is_finite() && d > 0.0, || {
                format!("duration_s must be > 0, got {d}")
            })?;
        }
        ensure(self.initial_q().iter().all(|q| q.is_finite()), || {
            "initial joint angles must be finite".into()
        })?;
        self.payload.validate()?;
        self.sensors.validate()?;
        self.friction.validate()?;
        self.model.validate()?;
        self.control.validate()?;
        self.controller.validate()?;
        for segment in &self.motion {
            segment.validate()?;
        }
        for contact in &self.contacts {
            contact.validate()?;
        }
        self.network.validate()?;
        ensure(
            self.restarts_s
                .iter()
                .chain(&self.operator_stops_s)
                .all(|t| t.is_finite() && *t >= 0.0),
            || "restart and operator stop times must be finite and >= 0".into(),
        )?;
        Ok(())
    }
}
