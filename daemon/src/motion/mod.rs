//! Motion the service commands itself: the jerk-limited joint moves of the `trajectory` crate.

pub use trajectory::{JointMove, JointSetpoint, MotionError, MotionLimits};
