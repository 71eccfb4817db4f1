//! Joint-space point-to-point profiles shared by the service, the simulated robot and the tests.
//!
//! - [`quintic`]: the rest-to-rest quintic s(τ) = 10τ³ − 15τ⁴ + 6τ⁵, its peak derivatives, the
//!   shortest duration within velocity/acceleration limits and a straight-line joint segment.
//! - [`joint_move`]: a jerk-limited straight-line move whose duration follows from per-joint
//!   limits, with a stop that brakes to rest on the line (evaluated once per cycle by the
//!   service's real-time thread; allocation-free).
//! - [`tour`]: the order of a set of targets with the least total move time (the pose
//!   patterns of tare and estimate are sets).

pub mod double_s;
pub mod joint_move;
pub mod quintic;
pub mod tour;

pub use joint_move::{JointMove, MotionError, MotionLimits};
pub use quintic::{JointSetpoint, QuinticSegment, quintic, rest_to_rest_duration};
