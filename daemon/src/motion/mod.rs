//! Motion the service commands itself: jerk-limited joint interpolation.

pub mod interpolation;

pub use interpolation::{JointMove, JointSetpoint, MotionError, MotionLimits};
