//! Sensorless collision detection for the KUKA LWR 4+ with an estimated payload
//! (Gaz & De Luca, IROS 2017, Sec. VI-B, eq. 48).
//!
//! - [`observer::MomentumObserver`]: the generalised-momentum residual
//!   r = K_I(M q̇ − p(0) − ∫(τ_J + Cᵀq̇ − g_L + r)ds) with payload compensation, exact-ZOH or Euler
//!   discretisation, velocity from positions, fault monitoring; allocation-free `step`.
//! - [`detector::CollisionDetector`]: per-joint thresholds (6 Nm default), velocity scheduling,
//!   hysteresis, debounce, collision events with isolation.
//! - [`envelope`]: the motion features the residual's free-motion level depends on.
//! - [`calibration`]: the envelope and extreme-value fit that sets thresholds for a false-alarm
//!   budget, and the minimum detectable force at those thresholds.
//! - [`isolation`]: the contact fitted through each link's Jacobian (link, point, force,
//!   confidence) and damped least-squares contact wrench.
//! - [`reaction::ReactionSupervisor`]: stop / pause-then-resume / wait-for-operator requests.
//! - [`monitor::CollisionMonitor`]: all of the above in one per-cycle call.
//! - [`payload_tolerance::PayloadTolerance`]: detection against the predicted torque of a
//!   payload declared unknown (grasp and estimate with the monitor armed).
//!
//! Units: SI (rad, rad/s, Nm, N, kg, m, s). Joints and links are 0-based in code.

pub mod calibration;
pub mod config;
pub mod detector;
pub mod discretisation;
pub mod envelope;
pub mod error;
pub mod fault;
pub mod friction;
pub mod isolation;
pub mod monitor;
pub mod observer;
pub mod payload;
pub mod payload_tolerance;
pub mod reaction;
pub mod velocity;

pub use config::{DEFAULT_GAIN, GravitySource, ObserverConfig};
pub use detector::{
    CollisionDetector, CollisionEvent, DEFAULT_THRESHOLD_NM, Detection, DetectorConfig, JointSet,
    ThresholdSchedule,
};
pub use discretisation::{Discretisation, ResidualIntegrator};
pub use envelope::{FeatureTracker, MotionFeatures};
pub use error::ConfigError;
pub use fault::{Fault, FaultLog, Signal};
pub use friction::JointFriction;
pub use isolation::{ContactEstimate, ContactIsolator, LinkSurface, lwr4_link_surfaces};
pub use monitor::{CollisionMonitor, DEFAULT_WARMUP_S, MonitorConfig, MonitorOutput};
pub use observer::{MomentumObserver, ObserverInput, ObserverOutput, ObserverStatus};
pub use payload::PayloadCompensation;
pub use payload_tolerance::{
    FlangeLoadBounds, GraspTiming, LoadSample, ModeEnd, PayloadHypothesis, PayloadTolerance,
    PinSource, PinSummary, PinnedLoad, ToleranceStatus, fit_hypothesis,
};
pub use reaction::{ReactionPolicy, ReactionRequest, ReactionState, ReactionSupervisor, StopCause};
pub use velocity::{DEFAULT_VELOCITY_CUTOFF_HZ, MatchedLowPass, VelocityEstimator, VelocityFilter};
