//! The robot state snapshot and its read API (the getters of the Stanford FRI library, with
//! SI units, joints 0-based in code).

use serde::{Deserialize, Serialize};

use crate::handshake::{HandshakeRequest, HandshakeStatus};
use crate::session::{Arrival, PendingResync, SessionStatistics};
use crate::wire::{
    Command, ControlStrategy, Frame, InterfaceState, InterfaceStatistics, JOINTS, KRL_VALUES,
    Measurement, Quality,
};

/// Counters of the endpoint's I/O loop (outside the sans-IO session).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct EndpointCounters {
    /// Receive timeouts (no datagram within the configured timeout).
    pub receive_timeouts: u64,
    /// Receive calls that failed with an error other than a timeout.
    pub receive_errors: u64,
    /// Older datagrams found queued behind a newer one and passed to the session without being
    /// answered (the newest is answered).
    pub stale_drained: u64,
    /// Replies whose `send_to` failed or sent fewer bytes than the datagram.
    pub send_errors: u64,
    /// Messages taken from the command queue.
    pub queue_messages: u64,
}

/// Everything known after one cycle: the newest measurement, what we sent, and the counters.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct EndpointState {
    /// False until the first measurement was accepted; all values are then defaults.
    pub valid: bool,
    /// Newest accepted measurement.
    pub measurement: Measurement,
    /// How `measurement` follows the measurement the previous cycle (hook call) saw:
    /// `Continued { cycles }` with the controller cycles elapsed (1 in order, n + 1 after n lost
    /// or superseded measurements; multiply by the cycle time for dt), or the start of an epoch
    /// (`First`, `Restart`, `Rebind`: reset filters and differences). `None` before the first
    /// measurement. See [`Arrival`].
    pub arrival: Option<Arrival>,
    /// The reply we sent last (after mirroring and limits).
    pub last_reply: Command,
    /// The KRL program's handshake report.
    pub handshake: HandshakeStatus,
    /// The handshake request we currently send.
    pub request: HandshakeRequest,
    /// Session counters and our own timing figures.
    pub statistics: SessionStatistics,
    /// I/O loop counters.
    pub endpoint: EndpointCounters,
    /// Cycles completed by the endpoint (replies attempted).
    pub cycle: u64,
    /// How long the endpoint thread had waited since the newest accepted measurement when it
    /// published this state, s (0 before the first). Only this thread can tell a silent
    /// controller from a host that kept the service's own threads from running.
    pub silence_s: f64,
    /// Datagrams refused since the newest accepted one that the session accepts once the bound
    /// controller has been silent for `resync_after` (a restarted controller, or one on a new
    /// source), as of the publication; `None` when nothing waits.
    #[serde(default)]
    pub resync: Option<PendingResync>,
}

impl Default for EndpointState {
    fn default() -> Self {
        Self {
            valid: false,
            measurement: Measurement::default(),
            arrival: None,
            last_reply: Command::default(),
            handshake: HandshakeStatus::NOT_REPORTED,
            request: HandshakeRequest::NONE,
            statistics: SessionStatistics::default(),
            endpoint: EndpointCounters::default(),
            cycle: 0,
            silence_s: 0.0,
            resync: None,
        }
    }
}

impl EndpointState {
    /// Measured joint positions, rad.
    pub fn measured_joint_positions(&self) -> [f64; JOINTS] {
        self.measurement.data.msr_jnt_pos
    }
    /// Joint positions commanded by KRL before FRI (`cmdJntPos`), rad.
    pub fn commanded_joint_positions(&self) -> [f64; JOINTS] {
        self.measurement.data.cmd_jnt_pos
    }
    /// Joint offsets added by FRI (`cmdJntPosFriOffset`), rad.
    pub fn commanded_joint_position_offsets(&self) -> [f64; JOINTS] {
        self.measurement.data.cmd_jnt_pos_fri_offset
    }
    /// Joint set-point we sent last, rad.
    pub fn sent_joint_positions(&self) -> [f64; JOINTS] {
        self.last_reply.jnt_pos
    }
    /// Measured joint torques (torque sensors), Nm.
    pub fn measured_joint_torques(&self) -> [f64; JOINTS] {
        self.measurement.data.msr_jnt_trq
    }
    /// Estimated external joint torques, Nm.
    pub fn estimated_external_joint_torques(&self) -> [f64; JOINTS] {
        self.measurement.data.est_ext_jnt_trq
    }
    /// Estimated external TCP wrench Fx Fy Fz (N), Tz Ty Tx (Nm), task frame (wire order).
    pub fn estimated_external_tcp_wrench(&self) -> [f64; 6] {
        self.measurement.data.est_ext_tcp_ft
    }
    /// Per-joint gravity torque computed by the controller, Nm.
    pub fn gravity_torques(&self) -> [f64; JOINTS] {
        self.measurement.data.gravity
    }
    /// Joint-space mass matrix, 7×7 row-major, kg·m² (unit presumed).
    pub fn mass_matrix(&self) -> [[f64; JOINTS]; JOINTS] {
        self.measurement.data.mass_matrix
    }
    /// Jacobian 6×7 row-major, rows X Y Z (m/rad), RZ RY RX (rad/rad), task frame.
    pub fn jacobian(&self) -> [[f64; JOINTS]; 6] {
        self.measurement.data.jacobian
    }
    /// Measured TCP frame, 3×4 row-major `[R | p]`, p in m.
    pub fn measured_cartesian_pose(&self) -> Frame {
        self.measurement.data.msr_cart_pos
    }
    /// TCP frame commanded by KRL before FRI, 3×4 row-major, m.
    pub fn commanded_cartesian_pose(&self) -> Frame {
        self.measurement.data.cmd_cart_pos
    }
    /// TCP frame offset added by FRI, 3×4 row-major, m.
    pub fn commanded_cartesian_pose_offsets(&self) -> Frame {
        self.measurement.data.cmd_cart_pos_fri_offset
    }
    /// Drive temperatures, °C (unit unverified).
    pub fn drive_temperatures(&self) -> [f64; JOINTS] {
        self.measurement.robot.temperature
    }
    /// FRI state (MON / CMD / …).
    pub fn fri_state(&self) -> InterfaceState {
        self.measurement.interface.state
    }
    /// Communication quality.
    pub fn communication_quality(&self) -> Quality {
        self.measurement.interface.quality
    }
    /// Active control strategy (`robot.control`).
    pub fn control_strategy(&self) -> ControlStrategy {
        self.measurement.robot.control
    }
    /// Active control scheme in KRL numbers: 10 position, 20 Cartesian, 30 joint impedance, 0 other.
    pub fn control_scheme(&self) -> i32 {
        self.measurement.robot.control.krl_number()
    }
    /// Drive power bitfield (bit i probably joint i+1).
    pub fn drive_power(&self) -> u16 {
        self.measurement.robot.power
    }
    /// Drive error bitfield.
    pub fn drive_errors(&self) -> u16 {
        self.measurement.robot.error
    }
    /// Drive warning bitfield.
    pub fn drive_warnings(&self) -> u16 {
        self.measurement.robot.warning
    }
    /// True when any drive is powered.
    pub fn is_robot_armed(&self) -> bool {
        self.measurement.robot.power != 0
    }
    /// FRIL's "machine OK": command mode, drives powered, no drive error.
    pub fn is_machine_ok(&self) -> bool {
        self.valid
            && self.measurement.interface.state == InterfaceState::Command
            && self.measurement.robot.power != 0
            && self.measurement.robot.error == 0
    }
    /// The controller's UDP statistics (answer rate, latency (s), jitter (s), miss rate, misses).
    pub fn udp_statistics(&self) -> InterfaceStatistics {
        self.measurement.interface.statistics
    }
    /// KRL real values from the controller (`$FRI_TO_REA[1..16]`).
    pub fn krl_real_values(&self) -> [f64; KRL_VALUES] {
        self.measurement.krl.real
    }
    /// KRL integer values from the controller (`$FRI_TO_INT[1..16]`).
    pub fn krl_int_values(&self) -> [i32; KRL_VALUES] {
        self.measurement.krl.int
    }
    /// KRL bool values from the controller, bit i = `$FRI_TO_BOOL[i+1]`.
    pub fn krl_bool_values(&self) -> u16 {
        self.measurement.krl.bools
    }
    /// The controller's sequence counter (`sendSeqCount` of the newest measurement).
    pub fn krc_sequence_counter(&self) -> u16 {
        self.measurement.header.send_seq_count
    }
    /// FRI cycle time (`desiredCmdSampleTime`), s.
    pub fn fri_cycle_time(&self) -> f64 {
        self.measurement.interface.desired_cmd_sample_time
    }
    /// Controller timestamp of the newest measurement, s.
    pub fn controller_time(&self) -> f64 {
        self.measurement.interface.timestamp
    }
}
