//! Faults the observer detects in its inputs and configuration, and the log that reports them.
//!
//! A fault never produces a silent zero residual: the step that sees it reports it in its status,
//! the residual is held (not integrated), the momentum reference is re-anchored on the next good
//! sample, and the [`FaultLog`] keeps a count and the most recent fault for monitoring.

use serde::{Deserialize, Serialize};

/// Which input signal carried a bad value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Signal {
    /// Measured joint position q \[rad\].
    Position,
    /// Supplied joint velocity q̇ \[rad/s\].
    Velocity,
    /// Measured joint torque τ_J \[Nm\].
    Torque,
    /// Controller's gravity vector from the FRI packet \[Nm\].
    ControllerGravity,
}

/// One detected fault. `joint` is 0-based.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, thiserror::Error)]
pub enum Fault {
    /// A measurement was NaN or infinite.
    #[error("non-finite {signal:?} on joint {joint} (0-based)")]
    NonFiniteInput {
        /// The signal.
        signal: Signal,
        /// Joint index, 0-based.
        joint: usize,
    },
    /// Positions and torques were bit-identical for this many consecutive samples.
    #[error("stale measurements: {repeated_samples} identical consecutive samples")]
    StaleMeasurement {
        /// Number of consecutive identical samples.
        repeated_samples: u32,
    },
    /// The time step was zero, negative or not finite.
    #[error("invalid time step {dt_s} s")]
    InvalidTimeStep {
        /// Offending time step \[s\].
        dt_s: f64,
    },
    /// The time step lies outside the accepted band around the nominal period.
    #[error("time step {dt_s} s far off the nominal {nominal_s} s")]
    TimeStepOffNominal {
        /// Offending time step \[s\].
        dt_s: f64,
        /// Nominal controller period \[s\].
        nominal_s: f64,
    },
    /// The payload estimate is not physical; the previous payload stays in use.
    #[error("rejected payload estimate: mass {mass_kg} kg (negative or non-finite parameters)")]
    InvalidPayload {
        /// Mass of the rejected estimate \[kg\].
        mass_kg: f64,
    },
    /// Gravity source is the controller but the sample carried no gravity vector.
    #[error("controller gravity selected but missing from the sample")]
    MissingControllerGravity,
    /// The model terms (M, Cᵀq̇, g) or the residual came out non-finite.
    #[error("non-finite model terms or residual")]
    NonFiniteModelTerms,
}

/// Fault counters and the most recent fault, for monitoring.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct FaultLog {
    /// Number of samples rejected because of a fault since the last [`clear`](Self::clear).
    pub rejected_samples: u64,
    /// Most recent fault and the observer cycle it occurred in.
    pub last: Option<(u64, Fault)>,
    /// First fault since the last clear and its cycle.
    pub first: Option<(u64, Fault)>,
}

impl FaultLog {
    /// Records `fault` seen at `cycle`.
    pub fn record(&mut self, cycle: u64, fault: Fault) {
        self.rejected_samples += 1;
        self.last = Some((cycle, fault));
        if self.first.is_none() {
            self.first = Some((cycle, fault));
        }
    }

    /// Forgets all recorded faults.
    pub fn clear(&mut self) {
        *self = Self::default();
    }
}
