//! Simulation configuration, readable from a scenario TOML file.
//!
//! Every section has documented defaults, so an empty TOML file is a valid scenario: the arm at
//! rest at the default pose with the paper's heavy payload, default sensors and model error.
//! Angles in scenario files are in degrees (`*_deg` keys); everything else is SI.

use serde::{Deserialize, Serialize};

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
    /// FRI cycle (friOpen argument), ms, 1..=100.
    pub cycle_ms: u32,
    /// Physics integration rate, Hz (≥ 5000); the substep count per cycle is rounded up.
    pub physics_rate_hz: f64,
    /// Scenario length, s; `None` runs until the motion script ends plus 1 s, or forever when
    /// there is no motion script.
    pub duration_s: Option<f64>,
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
            cycle_ms: 1,
            physics_rate_hz: 5000.0,
            duration_s: None,
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

/// The rigid payload on the flange and when it is attached.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct PayloadSpec {
    /// Mass, kg (0 = no payload).
    pub mass_kg: f64,
    /// Centre of mass in DH frame 7 (wrist point), m.
    pub com_m: [f64; 3],
    /// Inertia about the CoM in frame-7 axes, kg·m², row-major 3×3; `None` = a solid cylinder of
    /// radius 0.04 m and length 0.08 m with the given mass, axis along z7.
    pub inertia_about_com: Option<[[f64; 3]; 3]>,
    /// Whether the payload is attached at t = 0.
    pub attached_at_start: bool,
    /// Attach/detach events.
    pub events: Vec<PayloadEvent>,
}

impl Default for PayloadSpec {
    fn default() -> Self {
        Self {
            mass_kg: 3.028,
            com_m: [0.0, 0.0, 0.119],
            inertia_about_com: None,
            attached_at_start: true,
            events: Vec::new(),
        }
    }
}

/// Radius of the default solid-cylinder payload, m.
pub const DEFAULT_PAYLOAD_RADIUS_M: f64 = 0.04;
/// Length of the default solid-cylinder payload along z7, m.
pub const DEFAULT_PAYLOAD_LENGTH_M: f64 = 0.08;

impl PayloadSpec {
    /// Inertia about the CoM, kg·m² (the given one or the default solid cylinder).
    pub fn inertia(&self) -> [[f64; 3]; 3] {
        self.inertia_about_com.unwrap_or_else(|| {
            let (r, l, m) = (
                DEFAULT_PAYLOAD_RADIUS_M,
                DEFAULT_PAYLOAD_LENGTH_M,
                self.mass_kg,
            );
            let transverse = m * (3.0 * r * r + l * l) / 12.0;
            let axial = 0.5 * m * r * r;
            [
                [transverse, 0.0, 0.0],
                [0.0, transverse, 0.0],
                [0.0, 0.0, axial],
            ]
        })
    }

    fn validate(&self) -> Result<(), SimError> {
        ensure(self.mass_kg.is_finite() && self.mass_kg >= 0.0, || {
            format!("payload mass must be >= 0 kg, got {}", self.mass_kg)
        })?;
        ensure(
            self.com_m.iter().all(|c| c.is_finite() && c.abs() < 1.0),
            || "payload CoM must be finite and within 1 m of frame 7".into(),
        )?;
        let i = self.inertia();
        let symmetric = (0..3).all(|r| (0..3).all(|c| (i[r][c] - i[c][r]).abs() <= 1e-12));
        let (a, b, c) = (i[0][0], i[1][1], i[2][2]);
        let triangle = a + b >= c && b + c >= a && a + c >= b;
        ensure(
            symmetric && a >= 0.0 && b >= 0.0 && c >= 0.0 && triangle,
            || {
                "payload inertia must be symmetric with non-negative principal moments obeying the triangle inequality".into()
            },
        )?;
        ensure(
            self.events
                .iter()
                .all(|e| e.time_s.is_finite() && e.time_s >= 0.0),
            || "payload event times must be >= 0 s".into(),
        )
    }
}

/// One payload attach or detach event.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PayloadEvent {
    /// Simulation time of the event, s.
    pub time_s: f64,
    /// What happens.
    pub action: PayloadAction,
}

/// Payload attach or detach.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum PayloadAction {
    /// The payload is rigidly attached to the flange.
    Attach,
    /// The payload is removed.
    Detach,
}

/// Default τ_J quantisation step per joint, Nm (Panda-like LSBs, lwr4-model.md §5).
pub const DEFAULT_TORQUE_QUANTUM_NM: [f64; JOINTS] =
    [0.0357, 0.0357, 0.0357, 0.0357, 0.0060, 0.0060, 0.0060];

/// Joint torque sensor and encoder model.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct SensorSpec {
    /// White noise σ of every τ_J reading, Nm.
    pub torque_noise_nm: f64,
    /// σ of the constant per-joint τ_J offset drawn at start, Nm.
    pub torque_offset_sigma_nm: f64,
    /// Random-walk intensity of the offset drift, Nm/√s (σ after t seconds = value·√t).
    pub torque_drift_nm_per_sqrt_s: f64,
    /// τ_J quantisation step per joint, Nm (0 = none).
    pub torque_quantum_nm: [f64; JOINTS],
    /// Encoder quantisation step of msrJntPos, rad (0 = none).
    pub encoder_quantum_rad: f64,
}

impl Default for SensorSpec {
    fn default() -> Self {
        Self {
            torque_noise_nm: 0.05,
            torque_offset_sigma_nm: 0.05,
            torque_drift_nm_per_sqrt_s: 0.002,
            torque_quantum_nm: DEFAULT_TORQUE_QUANTUM_NM,
            // 2π / 2^21: a 14-bit motor encoder behind a 1:128 reduction (order of magnitude).
            encoder_quantum_rad: std::f64::consts::TAU / 2_097_152.0,
        }
    }
}

impl SensorSpec {
    /// An ideal sensor set: no noise, offset, drift or quantisation.
    pub fn ideal() -> Self {
        Self {
            torque_noise_nm: 0.0,
            torque_offset_sigma_nm: 0.0,
            torque_drift_nm_per_sqrt_s: 0.0,
            torque_quantum_nm: [0.0; JOINTS],
            encoder_quantum_rad: 0.0,
        }
    }

    fn validate(&self) -> Result<(), SimError> {
        let all = [
            self.torque_noise_nm,
            self.torque_offset_sigma_nm,
            self.torque_drift_nm_per_sqrt_s,
            self.encoder_quantum_rad,
        ];
        ensure(
            all.iter()
                .chain(&self.torque_quantum_nm)
                .all(|v| v.is_finite() && *v >= 0.0),
            || "sensor noise, offset, drift and quantisation values must be finite and >= 0".into(),
        )
    }
}

/// Motor-side friction: τ_f = F_s·tanh(q̇/v_s) + F_v·q̇ (Jubien 2014, lwr4-model.md §5).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct FrictionSpec {
    /// Coulomb friction per joint, Nm.
    pub coulomb_nm: [f64; JOINTS],
    /// Viscous friction per joint, Nm·s/rad.
    pub viscous_nms_per_rad: [f64; JOINTS],
    /// Velocity scale of the smooth sign function, rad/s.
    pub smoothing_rad_per_s: f64,
    /// Reflected rotor inertia per joint, kg·m² (adds to the motor-side inertia; the link-side
    /// τ_J sensors do not see it).
    pub rotor_inertia_kgm2: [f64; JOINTS],
}

impl Default for FrictionSpec {
    fn default() -> Self {
        Self {
            coulomb_nm: [11.9, 11.5, 8.98, 8.35, 8.31, 4.72, 6.04],
            viscous_nms_per_rad: [14.4, 15.3, 6.55, 11.0, 4.29, 2.26, 1.6],
            smoothing_rad_per_s: 0.05,
            // Joints 3..7 from Jubien 2014; joints 1 and 2 are grouped there (ZZ1R = 3.20,
            // ZZ2R = 4.46 include link inertia), so 3.0 is an estimate of the rotor share.
            rotor_inertia_kgm2: [3.0, 3.0, 2.01, 1.92, 0.776, 0.391, 0.399],
        }
    }
}

impl FrictionSpec {
    /// No friction (rotor inertias kept: they keep the integration well conditioned).
    pub fn frictionless() -> Self {
        Self {
            coulomb_nm: [0.0; JOINTS],
            viscous_nms_per_rad: [0.0; JOINTS],
            ..Self::default()
        }
    }

    fn validate(&self) -> Result<(), SimError> {
        ensure(
            self.coulomb_nm
                .iter()
                .chain(&self.viscous_nms_per_rad)
                .chain(&self.rotor_inertia_kgm2)
                .all(|v| v.is_finite() && *v >= 0.0),
            || "friction values and rotor inertias must be finite and >= 0".into(),
        )?;
        ensure(
            self.smoothing_rad_per_s.is_finite() && self.smoothing_rad_per_s > 0.0,
            || "friction smoothing velocity must be > 0 rad/s".into(),
        )
    }
}

/// Gaussian perturbation of the controller's model (lwr4-model.md §4).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct ModelErrorSpec {
    /// σ of the per-link mass error, kg.
    pub mass_sigma_kg: f64,
    /// σ of each component of the per-link first-moment error m·c, kg·m.
    pub first_moment_sigma_kgm: f64,
}

impl Default for ModelErrorSpec {
    fn default() -> Self {
        Self {
            mass_sigma_kg: 0.02,
            first_moment_sigma_kgm: 0.005,
        }
    }
}

impl ModelErrorSpec {
    /// The controller knows the true arm parameters exactly (the payload is still undeclared).
    pub fn exact() -> Self {
        Self {
            mass_sigma_kg: 0.0,
            first_moment_sigma_kgm: 0.0,
        }
    }

    fn validate(&self) -> Result<(), SimError> {
        ensure(
            [self.mass_sigma_kg, self.first_moment_sigma_kgm]
                .iter()
                .all(|v| v.is_finite() && *v >= 0.0 && *v < 0.2),
            || "model perturbation sigmas must be in [0, 0.2)".into(),
        )
    }
}

/// Gains of the emulated joint controllers.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct ControlSpec {
    /// Natural frequency of the position controller, rad/s.
    pub position_bandwidth_rad_s: f64,
    /// Integral action rate of the position controller, 1/s (removes friction and payload sag).
    pub position_integral_per_s: f64,
    /// Joint stiffness used by joint impedance when the command carries none, Nm/rad.
    pub default_stiffness_nm_per_rad: [f64; JOINTS],
    /// Normalised damping used by joint impedance when the command carries none.
    pub default_damping: [f64; JOINTS],
}

impl Default for ControlSpec {
    fn default() -> Self {
        Self {
            position_bandwidth_rad_s: 100.0,
            position_integral_per_s: 20.0,
            default_stiffness_nm_per_rad: [1000.0; JOINTS],
            default_damping: [0.7; JOINTS],
        }
    }
}

impl ControlSpec {
    fn validate(&self) -> Result<(), SimError> {
        ensure(
            self.position_bandwidth_rad_s.is_finite()
                && (1.0..=300.0).contains(&self.position_bandwidth_rad_s)
                && self.position_integral_per_s.is_finite()
                && (0.0..=100.0).contains(&self.position_integral_per_s),
            || "position bandwidth must be 1..=300 rad/s and integral rate 0..=100 1/s".into(),
        )?;
        ensure(
            self.default_stiffness_nm_per_rad
                .iter()
                .all(|k| (0.0..=5000.0).contains(k))
                && self.default_damping.iter().all(|d| (0.0..=1.0).contains(d)),
            || "default stiffness must be 0..=5000 Nm/rad and damping 0..=1".into(),
        )
    }
}

/// Controller-side FRI parameters: quality thresholds and command-mode rules.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct ControllerSpec {
    /// Quality thresholds (over the last 100 cycles).
    pub quality: crate::stats::QualityThresholds,
    /// Consecutive missed answers bridged in CMD before dropping to MON (reason 2).
    pub max_consecutive_misses: u32,
    /// Largest allowed difference between `jntPos` and the mirrored set-point at CMD entry, rad.
    pub mirror_tolerance_rad: f64,
    /// Largest |addJntTrq| allowed at CMD entry, Nm.
    pub added_torque_tolerance_nm: f64,
    /// Set-point jump limit as a multiple of the joint velocity limit times the cycle.
    pub jump_velocity_factor: f64,
    /// Time the KRL program needs for `$stiffness` commit + friStart, s (one KRL interpolation
    /// cycle of 12 ms).
    pub start_delay_s: f64,
    /// Round-trip latency above which an answer counts as missed, as a fraction of the cycle.
    pub answer_deadline_cycles: f64,
    /// Start requests (distinct ids) the KRL program misses after each friOpen: it neither acts
    /// on nor acknowledges them, as a program that polls `$FRI_FRM_INT` at the wrong moment
    /// (the remote must send the request again with a new id). 0 = none.
    pub ignored_start_requests: u32,
}

impl Default for ControllerSpec {
    fn default() -> Self {
        Self {
            quality: crate::stats::QualityThresholds::default(),
            max_consecutive_misses: 5,
            mirror_tolerance_rad: 1e-4,
            added_torque_tolerance_nm: 0.01,
            jump_velocity_factor: 1.0,
            start_delay_s: 0.012,
            answer_deadline_cycles: 1.0,
            ignored_start_requests: 0,
        }
    }
}

impl ControllerSpec {
    fn validate(&self) -> Result<(), SimError> {
        self.quality.validate()?;
        ensure(
            self.mirror_tolerance_rad.is_finite()
                && self.mirror_tolerance_rad > 0.0
                && self.added_torque_tolerance_nm.is_finite()
                && self.added_torque_tolerance_nm >= 0.0
                && self.jump_velocity_factor.is_finite()
                && self.jump_velocity_factor > 0.0
                && self.start_delay_s.is_finite()
                && (0.0..=1.0).contains(&self.start_delay_s)
                && self.answer_deadline_cycles.is_finite()
                && self.answer_deadline_cycles > 0.0,
            || "controller tolerances must be positive and finite, start delay 0..=1 s".into(),
        )
    }
}
