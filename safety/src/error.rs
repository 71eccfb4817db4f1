//! Configuration errors (returned when building or reconfiguring; never from the hot path).

/// Why a configuration was refused.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum ConfigError {
    /// Sample period not finite or not positive.
    #[error("sample period {0} s must be finite and positive")]
    SamplePeriod(f64),
    /// Observer gain not finite or not positive.
    #[error("observer gain {gain} 1/s on joint {joint} (0-based) must be finite and positive")]
    Gain {
        /// Joint index, 0-based.
        joint: usize,
        /// Offending gain \[1/s\].
        gain: f64,
    },
    /// Euler form unstable at the largest accepted time step (K·T ≥ 2).
    #[error("Euler observer unstable on joint {joint}: gain {gain} 1/s × period {period} s ≥ 2")]
    UnstableEuler {
        /// Joint index, 0-based.
        joint: usize,
        /// Gain \[1/s\].
        gain: f64,
        /// Largest accepted period \[s\].
        period: f64,
    },
    /// Time-step acceptance band invalid.
    #[error("time-step band [{min}, {max}] × T invalid (need 0 < min ≤ 1 ≤ max)")]
    TimeStepBand {
        /// Lower factor.
        min: f64,
        /// Upper factor.
        max: f64,
    },
    /// Velocity filter cut-off not finite/positive.
    #[error("velocity filter cut-off must be finite and positive")]
    VelocityFilter,
    /// Joint torque terms (offset, friction) non-finite, or a smoothing velocity not positive.
    #[error(
        "joint torque terms (offset, friction) must be finite, with a positive smoothing velocity"
    )]
    Friction,
    /// Stale limit of zero samples.
    #[error("stale limit must be at least one sample")]
    StaleLimit,
    /// Threshold configuration invalid.
    #[error(
        "threshold on joint {joint} (0-based) must be finite and positive, velocity coefficient finite and non-negative"
    )]
    Threshold {
        /// Joint index, 0-based.
        joint: usize,
    },
    /// Threshold schedule coefficient negative or non-finite, or a ceiling not positive.
    #[error("threshold schedule coefficients must be finite and non-negative, ceilings positive")]
    Schedule,
    /// Threshold-to-noise ratio not finite or not positive.
    #[error("threshold-to-noise ratio on joint {joint} (0-based) must be finite and positive")]
    ThresholdToNoise {
        /// Joint index, 0-based.
        joint: usize,
    },
    /// Absolute isolation level not finite or not positive.
    #[error("isolation level on joint {joint} (0-based) must be finite and positive")]
    IsolationLevel {
        /// Joint index, 0-based.
        joint: usize,
    },
    /// Hysteresis ratio outside (0, 1] or zero debounce/release counts.
    #[error("release ratio must be in (0, 1] and debounce/release counts at least 1")]
    Hysteresis,
    /// Warm-up duration not finite or outside 0…10 s.
    #[error("monitor warm-up {0} s must be finite and within 0…10 s")]
    Warmup(f64),
    /// Pause duration not finite or negative.
    #[error("pause duration {0} s must be finite and non-negative")]
    Pause(f64),
    /// Wrench-estimation damping not finite or negative.
    #[error("damping {0} must be finite and non-negative")]
    Damping(f64),
    /// Bounds of a plausible flange load not finite or not positive.
    #[error(
        "flange-load bounds must be finite and positive: maximum mass {max_mass_kg} kg, radius {radius_m} m"
    )]
    FlangeLoad {
        /// Largest payload mass \[kg\].
        max_mass_kg: f64,
        /// Radius around the flange \[m\].
        radius_m: f64,
    },
    /// The timing of an unknown-payload declaration is not finite and non-negative (expiry
    /// positive).
    #[error(
        "unknown-payload timing must be finite and non-negative (expiry positive): grasp window {grasp_window_s} s, settle {settle_s} s, expiry {expire_s} s"
    )]
    GraspTiming {
        /// Grasp window \[s\].
        grasp_window_s: f64,
        /// Settle time \[s\].
        settle_s: f64,
        /// Expiry \[s\].
        expire_s: f64,
    },
    /// A declaration of an unknown payload while one is active: it would reopen the grasp
    /// window and forget the pin (a renewed declaration hid contacts for ever, issue 34), so it
    /// is refused and the active one kept with its pin and expiry.
    #[error(
        "the payload is already declared unknown (declaration {active}): a new declaration would reopen the grasp window; the active one keeps its pin and expiry"
    )]
    AlreadyDeclared {
        /// The active declaration's number.
        active: u32,
    },
}
