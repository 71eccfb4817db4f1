//! The joint limits of the LWR 4+ that motion scripts and the controller's rules respect.

use crate::joints::JOINTS;

/// Joint velocity limits of the LWR 4+, rad/s (from `dynamics`' lwr4-model.md §1.2 table).
pub const VELOCITY_LIMITS_RAD_S: [f64; JOINTS] =
    dynamics::degrees_to_radians(dynamics::LWR4_VELOCITY_LIMITS_DEG_S);

/// Joint position limits of the LWR 4+, ± rad (from `dynamics`' lwr4-model.md §1.2 table).
pub const POSITION_LIMITS_RAD: [f64; JOINTS] =
    dynamics::degrees_to_radians(dynamics::LWR4_POSITION_LIMITS_DEG);
