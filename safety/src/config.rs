//! Observer configuration and its validation.

use nalgebra::SVector;
use serde::{Deserialize, Serialize};

use crate::discretisation::Discretisation;
use crate::error::ConfigError;
use crate::friction::JointFriction;
use crate::velocity::VelocityFilter;

/// Where the unloaded-robot gravity vector g(q) of g_L comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum GravitySource {
    /// Computed from the observer's dynamic model.
    #[default]
    Model,
    /// Taken from the sample (the controller's `data.gravity` of the FRI packet \[Nm\]); it must be
    /// the gravity of the robot *without* the undeclared payload.
    Controller,
}

/// Default observer gain K_I \[1/s\] (collision-detection.md §10 target 3). With the velocity
/// filter of that time (200 Hz) and debounce 1 it met the delay targets (median ≤ 5 ms, p95
/// ≤ 10 ms for 50 N impulsive contacts on links 4–7) with zero false alarms in 1 h of simulated
/// free motion at 6 Nm (BENCHMARKS.md, `collision_eval --sweep`); lower gains are slower
/// (K = 100: 8.8 ms). With calibrated thresholds and the 50 Hz filter: 2.8 ms.
pub const DEFAULT_GAIN: f64 = 400.0;

/// Configuration of the momentum observer for N joints.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ObserverConfig<const N: usize> {
    /// Controller's nominal sample period T \[s\] (FRI `desiredMsrSampleTime`), e.g. 0.001.
    pub sample_period_s: f64,
    /// Per-joint observer gains K_I \[1/s\]; each joint's residual is K_I/(s + K_I) of τ_ext.
    pub gains: SVector<f64, N>,
    /// Discretisation (default exact ZOH).
    pub discretisation: Discretisation,
    /// Velocity filter used when a sample carries no velocity.
    pub velocity_filter: VelocityFilter,
    /// Source of the unloaded gravity vector.
    pub gravity_source: GravitySource,
    /// Optional joint torque terms (offset, friction) subtracted from the torque input at the
    /// observer's velocity (an identified arm's, or motor-side friction).
    pub friction: Option<JointFriction<N>>,
    /// Smallest accepted time step as a fraction of the nominal period (default 0.5).
    pub min_dt_factor: f64,
    /// Largest accepted time step as a multiple of the nominal period (default 3: up to two lost
    /// packets are bridged exactly by the ZOH update).
    pub max_dt_factor: f64,
    /// Consecutive bit-identical samples (q and τ on all joints) after which the stream counts
    /// as stale; `None` disables the check (needed for noise-free simulations at rest).
    pub stale_limit: Option<u32>,
    /// Pass the torque terms (τ − g + Cᵀq̇) through the velocity filter's low-pass stages, so
    /// that they lag exactly as the momentum does (default false: the paper's eq. 48). With it,
    /// the residual of a fast deceleration that is no contact (M·q̈ times the filter's delay) is
    /// about 8× smaller (`daemon/tests/cycle_faults.rs`); the residual noise is unchanged. The
    /// service switches it on only while the controller brakes (collision-detection.md §3).
    #[serde(default)]
    pub matched_torque_filter: bool,
}

impl<const N: usize> ObserverConfig<N> {
    /// Defaults: gain `gain` \[1/s\] on every joint, period `sample_period_s` \[s\], exact ZOH,
    /// first-order velocity filter at [`crate::DEFAULT_VELOCITY_CUTOFF_HZ`], model gravity, no friction, dt accepted in
    /// \[0.5T, 3T\], stale after 100 identical samples.
    pub fn new(sample_period_s: f64, gain: f64) -> Self {
        Self {
            sample_period_s,
            gains: SVector::repeat(gain),
            discretisation: Discretisation::default(),
            velocity_filter: VelocityFilter::default(),
            gravity_source: GravitySource::default(),
            friction: None,
            min_dt_factor: 0.5,
            max_dt_factor: 3.0,
            stale_limit: Some(100),
            matched_torque_filter: false,
        }
    }

    /// Checks every field; the observer refuses an invalid configuration.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let t = self.sample_period_s;
        if !(t.is_finite() && t > 0.0) {
            return Err(ConfigError::SamplePeriod(t));
        }
        if !(self.min_dt_factor > 0.0
            && self.min_dt_factor <= 1.0
            && self.max_dt_factor >= 1.0
            && self.max_dt_factor.is_finite())
        {
            return Err(ConfigError::TimeStepBand {
                min: self.min_dt_factor,
                max: self.max_dt_factor,
            });
        }
        let limit = self.discretisation.max_stable_gain_period_product();
        for (joint, &k) in self.gains.iter().enumerate() {
            if !(k.is_finite() && k > 0.0) {
                return Err(ConfigError::Gain { joint, gain: k });
            }
            if k * t * self.max_dt_factor >= limit {
                return Err(ConfigError::UnstableEuler {
                    joint,
                    gain: k,
                    period: t * self.max_dt_factor,
                });
            }
        }
        if !self.velocity_filter.is_valid() {
            return Err(ConfigError::VelocityFilter);
        }
        if let Some(f) = &self.friction
            && !f.is_valid()
        {
            return Err(ConfigError::Friction);
        }
        if self.stale_limit == Some(0) {
            return Err(ConfigError::StaleLimit);
        }
        Ok(())
    }
}
