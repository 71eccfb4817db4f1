//! Messages the service publishes over iceoryx2: plain `#[repr(C)]` structs other processes can
//! map directly from shared memory. This module depends on nothing but iceoryx2's derive, so a
//! subscriber can copy it verbatim (or depend on this crate) without pulling in the service.
//!
//! Joint arrays hold joints 1..7 at indices 0..6. Units are SI (rad, rad/s, Nm, kg, m, s).

#[cfg(feature = "iceoryx2")]
use iceoryx2::prelude::ZeroCopySend;

pub use crate::JOINTS;

/// Bits of [`RobotState::flags`].
pub mod flags {
    /// The controller is in command mode (FRI state CMD).
    pub const COMMAND_MODE: u32 = 1 << 0;
    /// The collision monitor is armed.
    pub const MONITOR_ARMED: u32 = 1 << 1;
    /// A collision is currently detected (residual over threshold on some joint).
    pub const COLLISION: u32 = 1 << 2;
    /// The service holds the arm after a stop or a collision reaction.
    pub const STOPPED: u32 = 1 << 3;
    /// A payload estimate is applied to the observer.
    pub const PAYLOAD_APPLIED: u32 = 1 << 4;
    /// The observer flagged a fault (NaN input, bad time step): the residual is not valid.
    pub const OBSERVER_FAULT: u32 = 1 << 5;
    /// The service is driving a commanded move (estimation poses, brake).
    pub const MOVING: u32 = 1 << 6;
    /// The collision monitor is warming up after a (re)start or waits for the arm to come to
    /// rest: `residual` is NaN and no collision can be detected.
    pub const RESIDUAL_INVALID: u32 = 1 << 7;
    /// The service wants command mode (a move is pending or running): with [`COMMAND_MODE`]
    /// clear, the controller has not entered it yet.
    pub const COMMAND_REQUESTED: u32 = 1 << 8;
}

/// Robot state, published once per FRI cycle on `<prefix>/state`.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(
    feature = "iceoryx2",
    derive(ZeroCopySend),
    type_name("fri_service::RobotState")
)]
#[repr(C)]
pub struct RobotState {
    /// Cycles answered by the service since start.
    pub cycle: u64,
    /// Time since the service started, s.
    pub time_s: f64,
    /// Measured joint positions, rad.
    pub q: [f64; JOINTS],
    /// Joint velocities (filtered difference of q), rad/s.
    pub qd: [f64; JOINTS],
    /// Measured joint torques τ_J (msrJntTrq), Nm.
    pub tau: [f64; JOINTS],
    /// The controller's gravity vector g(q) (without payload), Nm.
    pub gravity: [f64; JOINTS],
    /// The controller's estimated external joint torques (estExtJntTrq), Nm.
    pub tau_ext: [f64; JOINTS],
    /// The service's momentum-observer residual (payload-compensated when one is applied), Nm;
    /// NaN while [`flags::RESIDUAL_INVALID`] is set.
    pub residual: [f64; JOINTS],
    /// Combination of [`flags`] bits.
    pub flags: u32,
    /// FRI interface state: 0 off, 1 monitor, 2 command.
    pub fri_state: u32,
    /// FRI quality: 0 unacceptable, 1 bad, 2 ok, 3 perfect.
    pub quality: u32,
    /// Reserved, zero.
    pub reserved: u32,
}

impl Default for RobotState {
    fn default() -> Self {
        Self {
            cycle: 0,
            time_s: 0.0,
            q: [0.0; JOINTS],
            qd: [0.0; JOINTS],
            tau: [0.0; JOINTS],
            gravity: [0.0; JOINTS],
            tau_ext: [0.0; JOINTS],
            residual: [0.0; JOINTS],
            flags: 0,
            fri_state: 0,
            quality: 0,
            reserved: 0,
        }
    }
}

/// The iceoryx2 message of a detected collision, published on `<prefix>/collision` at the onset of
/// each detection (its wire type name stays `fri_service::CollisionEvent` for existing subscribers).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(
    feature = "iceoryx2",
    derive(ZeroCopySend),
    type_name("fri_service::CollisionEvent")
)]
#[repr(C)]
pub struct CollisionMessage {
    /// Cycle of the detection.
    pub cycle: u64,
    /// Time since the service started, s.
    pub time_s: f64,
    /// Residual at detection, Nm.
    pub residual: [f64; JOINTS],
    /// Joints over threshold: bit i set for joint i+1.
    pub joints_mask: u32,
    /// Isolated link (1..7, the most distal joint over threshold); 0 when unknown.
    pub link: u32,
    /// Estimated contact wrench for a contact isolated on the last link (`link` 7): force (N)
    /// then moment about the assumed contact point, the flange origin (Nm), both in the base
    /// frame, from the residual at the onset; zero when [`Self::wrench_valid`] is 0.
    pub contact_wrench: [f64; 6],
    /// 1 when [`Self::contact_wrench`] holds an estimate, 0 otherwise (another link, or the
    /// estimate's system was singular).
    pub wrench_valid: u32,
    /// Reserved, zero.
    pub reserved: u32,
}

/// A payload estimate (published after `estimate-payload`, and on apply/clear), on
/// `<prefix>/payload`. Frame 7 = last DH frame of the LWR, as in the paper.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(
    feature = "iceoryx2",
    derive(ZeroCopySend),
    type_name("fri_service::PayloadEstimate")
)]
#[repr(C)]
pub struct PayloadEstimate {
    /// Time since the service started, s.
    pub time_s: f64,
    /// Mass, kg.
    pub mass: f64,
    /// Centre of mass in frame 7, m.
    pub com: [f64; 3],
    /// Standard deviation of the mass, kg (0 when applied by hand).
    pub mass_std: f64,
    /// Standard deviation of each CoM coordinate, m (0 when applied by hand).
    pub com_std: [f64; 3],
    /// Number of static samples behind the estimate (0 when applied by hand).
    pub samples: u32,
    /// 1 when this payload is now applied to the observer, 0 otherwise (a cleared payload is
    /// published with `applied = 0` and `mass = 0`).
    pub applied: u32,
}
