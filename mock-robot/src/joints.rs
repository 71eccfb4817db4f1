//! Joint-space vectors of the seven-joint arm, shared by every part of the simulator.

use nalgebra::SVector;

pub use fri::wire::JOINTS;

/// Joint vector, f64 (one value per joint, units as documented where it is used).
pub type JointVector = SVector<f64, JOINTS>;
