//! The collision monitor as the service runs it, built in one place: by the service on the
//! controller's measurements, and by `fri-ctl offline monitor` and `calibrate-thresholds` on a
//! recorded log (a second copy of these settings would drift from the service's).

use dynamics::Model;
use nalgebra::SVector;
use safety::{
    CollisionMonitor, ConfigError, GravitySource, JointFriction, MonitorConfig, ReactionPolicy,
};

use crate::bounds;
use crate::results::JointFit;
use crate::schedule::ThresholdSchedule;

type V7 = SVector<f64, 7>;

/// What the service's monitor is built from besides the arm model.
#[derive(Debug, Clone, Copy)]
pub struct MonitorSetup<'a> {
    /// Controller period, s.
    pub period_s: f64,
    /// Observer gains K_I, 1/s.
    pub gains: [f64; 7],
    /// Thresholds at rest θ0, Nm (a calibrated schedule's own replace them).
    pub thresholds: [f64; 7],
    /// The motion schedule of a calibration (`collision-calibrate`, `collision-install`).
    pub schedule: Option<&'a ThresholdSchedule>,
    /// Reaction to a collision.
    pub reaction: ReactionPolicy,
}

/// The service's collision monitor on `model` (the observer's model: nominal, or an identified
/// arm's corrected one) subtracting `joint_terms` (an identified arm's offset and friction) at
/// its own velocity, with model gravity, the LWR's link surfaces for the contact fit, and a
/// calibrated schedule capped at its own cap, at most the thresholds' upper bound. Matched
/// torque filtering starts off: the service's cycle switches it on where the torque steps
/// (collision-detection.md §3), which a recorded log does not show.
pub fn build_monitor(
    model: Model<7>,
    joint_terms: Option<JointFriction<7>>,
    setup: &MonitorSetup<'_>,
) -> Result<CollisionMonitor<7>, ConfigError> {
    let mut mc = MonitorConfig::<7>::new(setup.period_s, safety::DEFAULT_GAIN);
    mc.observer.gains = V7::from(setup.gains);
    mc.observer.gravity_source = GravitySource::Model;
    mc.observer.matched_torque_filter = false;
    mc.observer.friction = joint_terms;
    mc.detector.thresholds_nm = V7::from(setup.thresholds);
    mc.link_surfaces = Some(safety::lwr4_link_surfaces());
    if let Some(s) = setup.schedule {
        mc.detector.thresholds_nm = V7::from(s.thresholds);
        mc.detector.velocity_coefficients = V7::from(s.speed);
        mc.detector.schedule = safety::ThresholdSchedule {
            velocity_noise: V7::from(s.velocity_noise),
            payload_dynamics: V7::from(s.payload_dynamics),
            inertial: V7::from(s.inertial),
            gravity: V7::from(s.gravity),
            ceiling_nm: V7::from_fn(|j, _| s.ceiling[j].min(bounds::threshold(j).max)),
        };
        mc.threshold_to_noise = V7::from(s.scale);
    }
    mc.reaction = setup.reaction;
    CollisionMonitor::new(model, mc)
}

/// A calibration's schedule as the service stores and installs it.
pub fn schedule_of(fit: &safety::calibration::Calibration<7>) -> ThresholdSchedule {
    let array = |v: &V7| -> [f64; 7] { std::array::from_fn(|j| v[j]) };
    ThresholdSchedule {
        thresholds: array(&fit.thresholds_nm),
        speed: array(&fit.velocity_coefficients),
        velocity_noise: array(&fit.schedule.velocity_noise),
        payload_dynamics: array(&fit.schedule.payload_dynamics),
        inertial: array(&fit.schedule.inertial),
        gravity: array(&fit.schedule.gravity),
        scale: array(&fit.scale),
        ceiling: array(&fit.schedule.ceiling_nm),
    }
}

/// A calibration's per-joint report as `collision calibrate` and the thresholds file give it.
pub fn joint_fits(fit: &safety::calibration::Calibration<7>) -> Vec<JointFit> {
    fit.joints
        .iter()
        .map(|j| JointFit {
            threshold_at_rest: j.threshold_at_rest_nm,
            threshold_median: j.threshold_median_nm,
            threshold_max: j.threshold_max_nm,
            envelope: j.envelope,
            model: j.tail.name().to_owned(),
            shape_interval: j.shape_interval,
            scale: j.scale,
            scale_point: j.scale_point,
            scale_std: j.scale_std,
            scale_interval: j.scale_interval,
            peak: j.peak_nm,
            exceedances: j.exceedances,
            cap: Some(j.cap.nm),
            cap_fitted: j.cap.fitted_nm.is_finite().then_some(j.cap.fitted_nm),
            cap_source: Some(j.cap.source.name().to_owned()),
        })
        .collect()
}
