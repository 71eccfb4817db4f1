//! Measurement datagram (`tFriMsrData`, controller → remote, 916 B, spec §1.3).

use serde::{Deserialize, Serialize};

use super::field::msr;
use super::{
    CMD_LEN, ControlStrategy, Frame, Header, InterfaceState, JOINTS, KRL_VALUES, KrlData,
    MSR_DATAGRAM_ID, MSR_LEN, MSR_PACKET_SIZE, Quality, WireError, bytes, f32_array_accessors,
    f32_matrix_accessors, f32_scalar_accessors, field, header_and_krl_accessors,
    header_and_krl_setters,
};

/// Zero-copy view over a measurement datagram.
///
/// Accessors index fixed offsets: build the view with [`MeasurementPacket::new_checked`] for
/// outside input; with [`MeasurementPacket::new_unchecked`] accessors panic when the buffer is
/// shorter than [`MSR_LEN`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MeasurementPacket<T: AsRef<[u8]>> {
    buffer: T,
}

impl<T: AsRef<[u8]>> MeasurementPacket<T> {
    /// Wraps a buffer without checking its length.
    pub const fn new_unchecked(buffer: T) -> Self {
        Self { buffer }
    }

    /// Wraps a buffer after checking that it is exactly [`MSR_LEN`] bytes long.
    pub fn new_checked(buffer: T) -> Result<Self, WireError> {
        super::error::check_len(buffer.as_ref().len(), MSR_LEN)?;
        Ok(Self { buffer })
    }

    /// Checks length, `packetSize` (916), `datagramId` (0x2006) and that no float is NaN/Inf.
    pub fn check(&self) -> Result<(), WireError> {
        super::validate(
            self.buffer.as_ref(),
            MSR_LEN,
            MSR_PACKET_SIZE,
            MSR_DATAGRAM_ID,
            &msr::FLOAT_FIELDS,
        )
    }

    /// Returns the underlying buffer.
    pub fn into_inner(self) -> T {
        self.buffer
    }

    header_and_krl_accessors!();

    f32_scalar_accessors!(
        timestamp,
        set_timestamp,
        msr::TIMESTAMP,
        "`intf.timestamp`: controller time, s."
    );
    f32_scalar_accessors!(
        desired_msr_sample_time,
        set_desired_msr_sample_time,
        msr::DESIRED_MSR_SAMPLE_TIME,
        "`intf.desiredMsrSampleTime`: measurement period, s."
    );
    f32_scalar_accessors!(
        desired_cmd_sample_time,
        set_desired_cmd_sample_time,
        msr::DESIRED_CMD_SAMPLE_TIME,
        "`intf.desiredCmdSampleTime`: expected command period, s."
    );
    f32_scalar_accessors!(
        safety_limits,
        set_safety_limits,
        msr::SAFETY_LIMITS,
        "`intf.safetyLimits`: probably the `friStart` factor, unitless."
    );
    f32_scalar_accessors!(
        answer_rate,
        set_answer_rate,
        msr::ANSWER_RATE,
        "`intf.stat.answerRate`: share of answered datagrams over the last 100, 0…1."
    );
    f32_scalar_accessors!(
        latency,
        set_latency,
        msr::LATENCY,
        "`intf.stat.latency`: mean round-trip latency over the last 100 datagrams, s."
    );
    f32_scalar_accessors!(
        jitter,
        set_jitter,
        msr::JITTER,
        "`intf.stat.jitter`: mean jitter over the last 100 datagrams, s."
    );
    f32_scalar_accessors!(
        miss_rate,
        set_miss_rate,
        msr::MISS_RATE,
        "`intf.stat.missRate`: share of missed answers over the last 100, 0…1."
    );
    f32_array_accessors!(
        temperature,
        set_temperature,
        msr::TEMPERATURE,
        JOINTS,
        "`robot.temperature`: drive temperatures, °C (unit per one client; unverified)."
    );
    f32_array_accessors!(
        msr_jnt_pos,
        set_msr_jnt_pos,
        msr::MSR_JNT_POS,
        JOINTS,
        "`data.msrJntPos`: measured joint angles, rad."
    );
    f32_matrix_accessors!(
        msr_cart_pos,
        set_msr_cart_pos,
        msr::MSR_CART_POS,
        3,
        4,
        "`data.msrCartPos`: measured TCP frame, 3×4 row-major, translation in m."
    );
    f32_array_accessors!(
        cmd_jnt_pos,
        set_cmd_jnt_pos,
        msr::CMD_JNT_POS,
        JOINTS,
        "`data.cmdJntPos`: KRL joint command before FRI, rad."
    );
    f32_array_accessors!(
        cmd_jnt_pos_fri_offset,
        set_cmd_jnt_pos_fri_offset,
        msr::CMD_JNT_POS_FRI_OFFSET,
        JOINTS,
        "`data.cmdJntPosFriOffset`: offset added by FRI, rad."
    );
    f32_matrix_accessors!(
        cmd_cart_pos,
        set_cmd_cart_pos,
        msr::CMD_CART_POS,
        3,
        4,
        "`data.cmdCartPos`: KRL frame before FRI, 3×4 row-major, translation in m."
    );
    f32_matrix_accessors!(
        cmd_cart_pos_fri_offset,
        set_cmd_cart_pos_fri_offset,
        msr::CMD_CART_POS_FRI_OFFSET,
        3,
        4,
        "`data.cmdCartPosFriOffset`: frame offset due to FRI, 3×4 row-major, translation in m."
    );
    f32_array_accessors!(
        msr_jnt_trq,
        set_msr_jnt_trq,
        msr::MSR_JNT_TRQ,
        JOINTS,
        "`data.msrJntTrq`: measured joint torques, Nm."
    );
    f32_array_accessors!(
        est_ext_jnt_trq,
        set_est_ext_jnt_trq,
        msr::EST_EXT_JNT_TRQ,
        JOINTS,
        "`data.estExtJntTrq`: estimated external joint torques, Nm."
    );
    f32_array_accessors!(
        est_ext_tcp_ft,
        set_est_ext_tcp_ft,
        msr::EST_EXT_TCP_FT,
        6,
        "`data.estExtTcpFT`: estimated TCP wrench Fx Fy Fz (N) Tz Ty Tx (Nm), task frame."
    );
    f32_matrix_accessors!(
        jacobian,
        set_jacobian,
        msr::JACOBIAN,
        6,
        JOINTS,
        "`data.jacobian`: 6×7 row-major, rows X Y Z (m/rad) RZ RY RX (rad/rad), task frame."
    );
    f32_matrix_accessors!(
        mass_matrix,
        set_mass_matrix,
        msr::MASS_MATRIX,
        JOINTS,
        JOINTS,
        "`data.massMatrix`: 7×7 joint-space mass matrix, kg·m² (unit unverified)."
    );
    f32_array_accessors!(
        gravity,
        set_gravity,
        msr::GRAVITY,
        JOINTS,
        "`data.gravity`: per-joint gravity torque, Nm (spec §3)."
    );

    /// `intf.state`.
    pub fn state(&self) -> InterfaceState {
        InterfaceState::from_raw(bytes::read_u16(self.buffer.as_ref(), msr::STATE))
    }
    /// `intf.quality`.
    pub fn quality(&self) -> Quality {
        Quality::from_raw(bytes::read_u16(self.buffer.as_ref(), msr::QUALITY))
    }
    /// `intf.stat.missCounter`: total missed answers since `friOpen`.
    pub fn miss_counter(&self) -> u32 {
        bytes::read_u32(self.buffer.as_ref(), msr::MISS_COUNTER)
    }
    /// `robot.power`: drive power bitfield (bit i probably joint i+1).
    pub fn power(&self) -> u16 {
        bytes::read_u16(self.buffer.as_ref(), msr::POWER)
    }
    /// `robot.control`: active control strategy.
    pub fn control(&self) -> ControlStrategy {
        ControlStrategy::from_raw(bytes::read_u16(self.buffer.as_ref(), msr::CONTROL))
    }
    /// `robot.error`: drive error bitfield.
    pub fn error(&self) -> u16 {
        bytes::read_u16(self.buffer.as_ref(), msr::ERROR)
    }
    /// `robot.warning`: drive warning bitfield.
    pub fn warning(&self) -> u16 {
        bytes::read_u16(self.buffer.as_ref(), msr::WARNING)
    }
}

impl<T: AsRef<[u8]> + AsMut<[u8]>> MeasurementPacket<T> {
    header_and_krl_setters!();

    /// Sets `intf.state`.
    pub fn set_state(&mut self, v: InterfaceState) {
        bytes::write_u16(self.buffer.as_mut(), msr::STATE, v.to_raw())
    }
    /// Sets `intf.quality`.
    pub fn set_quality(&mut self, v: Quality) {
        bytes::write_u16(self.buffer.as_mut(), msr::QUALITY, v.to_raw())
    }
    /// Sets `intf.stat.missCounter`.
    pub fn set_miss_counter(&mut self, v: u32) {
        bytes::write_u32(self.buffer.as_mut(), msr::MISS_COUNTER, v)
    }
    /// Sets `robot.power`.
    pub fn set_power(&mut self, v: u16) {
        bytes::write_u16(self.buffer.as_mut(), msr::POWER, v)
    }
    /// Sets `robot.control`.
    pub fn set_control(&mut self, v: ControlStrategy) {
        bytes::write_u16(self.buffer.as_mut(), msr::CONTROL, v.to_raw())
    }
    /// Sets `robot.error`.
    pub fn set_error(&mut self, v: u16) {
        bytes::write_u16(self.buffer.as_mut(), msr::ERROR, v)
    }
    /// Sets `robot.warning`.
    pub fn set_warning(&mut self, v: u16) {
        bytes::write_u16(self.buffer.as_mut(), msr::WARNING, v)
    }
}

/// FRI interface statistics computed by the controller over the last 100 datagrams.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct InterfaceStatistics {
    /// Share of answered datagrams, 0…1 (ideally 1).
    pub answer_rate: f64,
    /// Mean round-trip latency, s.
    pub latency: f64,
    /// Mean jitter, s.
    pub jitter: f64,
    /// Mean share of missed answers, 0…1.
    pub miss_rate: f64,
    /// Total missed answers since `friOpen` (running count).
    pub miss_counter: u32,
}

/// Interface block of the measurement: state, quality, timing and statistics.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct InterfaceInfo {
    /// Controller time, s (coarse after long uptime: f32 on the wire).
    pub timestamp: f64,
    /// FRI state.
    pub state: InterfaceState,
    /// Communication quality.
    pub quality: Quality,
    /// Measurement period, s (e.g. 0.001 after `friOpen(1)`).
    pub desired_msr_sample_time: f64,
    /// Expected command period, s.
    pub desired_cmd_sample_time: f64,
    /// `safetyLimits`, probably the `friStart` factor, unitless (unverified).
    pub safety_limits: f64,
    /// The controller's statistics of our answers.
    pub statistics: InterfaceStatistics,
}

/// Robot state block: drive bitfields, active strategy, temperatures.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RobotStatus {
    /// Drive power bitfield, one bit per drive (0x7F = all 7 powered; bit order unverified).
    pub power: u16,
    /// Active control strategy.
    pub control: ControlStrategy,
    /// Drive error bitfield (errors switch the drives off).
    pub error: u16,
    /// Drive warning bitfield.
    pub warning: u16,
    /// Drive temperatures, °C (unit per one client; unverified).
    pub temperature: [f64; JOINTS],
}

/// Robot data block: positions, torques and the controller's model terms.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RobotData {
    /// Measured joint angles, rad (`$AXIS_ACT_MSR`).
    pub msr_jnt_pos: [f64; JOINTS],
    /// Measured TCP frame, 3×4 row-major, translation in m (`$POS_ACT_MSR`).
    pub msr_cart_pos: Frame,
    /// KRL joint command before FRI, rad (`$AXIS_ACT_CMD`).
    pub cmd_jnt_pos: [f64; JOINTS],
    /// Joint offset added by FRI, rad.
    pub cmd_jnt_pos_fri_offset: [f64; JOINTS],
    /// KRL TCP frame command before FRI, 3×4 row-major, m (`$POS_ACT_CMD`).
    pub cmd_cart_pos: Frame,
    /// Frame offset due to FRI, 3×4 row-major, m.
    pub cmd_cart_pos_fri_offset: Frame,
    /// Measured joint torques (torque sensors), Nm (`$TORQUE_AXIS_ACT`).
    pub msr_jnt_trq: [f64; JOINTS],
    /// Estimated external joint torques, Nm (`$TORQUE_AXIS_EST`; sign unverified).
    pub est_ext_jnt_trq: [f64; JOINTS],
    /// Estimated TCP wrench, Fx Fy Fz (N) then Tz Ty Tx (Nm), task frame (`$TORQUE_TCP_EST`).
    pub est_ext_tcp_ft: [f64; 6],
    /// Geometric Jacobian, 6×7 row-major, rows X Y Z (m/rad) then RZ RY RX (1), task frame.
    pub jacobian: [[f64; JOINTS]; 6],
    /// Joint-space mass matrix, 7×7 row-major, kg·m² (presumably; unit not stated by KUKA).
    pub mass_matrix: [[f64; JOINTS]; JOINTS],
    /// Per-joint gravity torque computed by the controller, Nm (spec §3).
    pub gravity: [f64; JOINTS],
}

/// An owned, validated measurement datagram with f64 values in SI units.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Measurement {
    /// Controller's counter and the counter it reflects from our last command.
    pub header: Header,
    /// Values written by the KRL program.
    pub krl: KrlData,
    /// Interface state, quality, timing and statistics.
    pub interface: InterfaceInfo,
    /// Drive bitfields, strategy and temperatures.
    pub robot: RobotStatus,
    /// Positions, torques and model terms.
    pub data: RobotData,
}

impl Measurement {
    /// Decodes and validates a measurement datagram: exact length 916, `packetSize` 916,
    /// `datagramId` 0x2006, every float finite. Unknown enum values are kept as `Unknown(raw)`.
    pub fn parse(datagram: &[u8]) -> Result<Self, WireError> {
        let p = MeasurementPacket::new_checked(datagram)?;
        super::check_header(datagram, MSR_PACKET_SIZE, MSR_DATAGRAM_ID)?;
        // Fields are decoded in table order, so the first non-finite one is reported.
        use bytes::{finite, finite_rows, finite_scalar as scalar};
        Ok(Self {
            header: Header {
                send_seq_count: p.send_seq_count(),
                refl_seq_count: p.refl_seq_count(),
            },
            krl: super::parse_krl_checked(datagram)?,
            interface: InterfaceInfo {
                timestamp: scalar(p.timestamp(), "intf.timestamp")?,
                state: p.state(),
                quality: p.quality(),
                desired_msr_sample_time: scalar(
                    p.desired_msr_sample_time(),
                    "intf.desiredMsrSampleTime",
                )?,
                desired_cmd_sample_time: scalar(
                    p.desired_cmd_sample_time(),
                    "intf.desiredCmdSampleTime",
                )?,
                safety_limits: scalar(p.safety_limits(), "intf.safetyLimits")?,
                statistics: InterfaceStatistics {
                    answer_rate: scalar(p.answer_rate(), "intf.stat.answerRate")?,
                    latency: scalar(p.latency(), "intf.stat.latency")?,
                    jitter: scalar(p.jitter(), "intf.stat.jitter")?,
                    miss_rate: scalar(p.miss_rate(), "intf.stat.missRate")?,
                    miss_counter: p.miss_counter(),
                },
            },
            robot: RobotStatus {
                power: p.power(),
                control: p.control(),
                error: p.error(),
                warning: p.warning(),
                temperature: finite(p.temperature(), "robot.temperature")?,
            },
            data: RobotData {
                msr_jnt_pos: finite(p.msr_jnt_pos(), "data.msrJntPos")?,
                msr_cart_pos: finite_rows(p.msr_cart_pos(), "data.msrCartPos")?,
                cmd_jnt_pos: finite(p.cmd_jnt_pos(), "data.cmdJntPos")?,
                cmd_jnt_pos_fri_offset: finite(
                    p.cmd_jnt_pos_fri_offset(),
                    "data.cmdJntPosFriOffset",
                )?,
                cmd_cart_pos: finite_rows(p.cmd_cart_pos(), "data.cmdCartPos")?,
                cmd_cart_pos_fri_offset: finite_rows(
                    p.cmd_cart_pos_fri_offset(),
                    "data.cmdCartPosFriOffset",
                )?,
                msr_jnt_trq: finite(p.msr_jnt_trq(), "data.msrJntTrq")?,
                est_ext_jnt_trq: finite(p.est_ext_jnt_trq(), "data.estExtJntTrq")?,
                est_ext_tcp_ft: finite(p.est_ext_tcp_ft(), "data.estExtTcpFT")?,
                jacobian: finite_rows(p.jacobian(), "data.jacobian")?,
                mass_matrix: finite_rows(p.mass_matrix(), "data.massMatrix")?,
                gravity: finite(p.gravity(), "data.gravity")?,
            },
        })
    }

    /// Encodes into a caller's buffer (no allocation), writing `packetSize` 916 and
    /// `datagramId` 0x2006. Fails when a value is or narrows to a non-finite f32; the buffer's
    /// content is then unspecified.
    pub fn emit(&self, out: &mut [u8; MSR_LEN]) -> Result<(), WireError> {
        use bytes::{to_wire_f32, to_wire_f32_rows, to_wire_f32s};
        super::emit_header_and_krl(
            out,
            &self.header,
            MSR_PACKET_SIZE,
            MSR_DATAGRAM_ID,
            &self.krl,
        )?;
        let mut p = MeasurementPacket::new_unchecked(&mut out[..]);
        let i = &self.interface;
        p.set_timestamp(to_wire_f32(i.timestamp, "intf.timestamp", 0)?);
        p.set_state(i.state);
        p.set_quality(i.quality);
        p.set_desired_msr_sample_time(to_wire_f32(
            i.desired_msr_sample_time,
            "intf.desiredMsrSampleTime",
            0,
        )?);
        p.set_desired_cmd_sample_time(to_wire_f32(
            i.desired_cmd_sample_time,
            "intf.desiredCmdSampleTime",
            0,
        )?);
        p.set_safety_limits(to_wire_f32(i.safety_limits, "intf.safetyLimits", 0)?);
        let s = &i.statistics;
        p.set_answer_rate(to_wire_f32(s.answer_rate, "intf.stat.answerRate", 0)?);
        p.set_latency(to_wire_f32(s.latency, "intf.stat.latency", 0)?);
        p.set_jitter(to_wire_f32(s.jitter, "intf.stat.jitter", 0)?);
        p.set_miss_rate(to_wire_f32(s.miss_rate, "intf.stat.missRate", 0)?);
        p.set_miss_counter(s.miss_counter);
        let r = &self.robot;
        p.set_power(r.power);
        p.set_control(r.control);
        p.set_error(r.error);
        p.set_warning(r.warning);
        p.set_temperature(&to_wire_f32s(&r.temperature, "robot.temperature")?);
        let d = &self.data;
        p.set_msr_jnt_pos(&to_wire_f32s(&d.msr_jnt_pos, "data.msrJntPos")?);
        p.set_msr_cart_pos(&to_wire_f32_rows(&d.msr_cart_pos, "data.msrCartPos")?);
        p.set_cmd_jnt_pos(&to_wire_f32s(&d.cmd_jnt_pos, "data.cmdJntPos")?);
        p.set_cmd_jnt_pos_fri_offset(&to_wire_f32s(
            &d.cmd_jnt_pos_fri_offset,
            "data.cmdJntPosFriOffset",
        )?);
        p.set_cmd_cart_pos(&to_wire_f32_rows(&d.cmd_cart_pos, "data.cmdCartPos")?);
        p.set_cmd_cart_pos_fri_offset(&to_wire_f32_rows(
            &d.cmd_cart_pos_fri_offset,
            "data.cmdCartPosFriOffset",
        )?);
        p.set_msr_jnt_trq(&to_wire_f32s(&d.msr_jnt_trq, "data.msrJntTrq")?);
        p.set_est_ext_jnt_trq(&to_wire_f32s(&d.est_ext_jnt_trq, "data.estExtJntTrq")?);
        p.set_est_ext_tcp_ft(&to_wire_f32s(&d.est_ext_tcp_ft, "data.estExtTcpFT")?);
        p.set_jacobian(&to_wire_f32_rows(&d.jacobian, "data.jacobian")?);
        p.set_mass_matrix(&to_wire_f32_rows(&d.mass_matrix, "data.massMatrix")?);
        p.set_gravity(&to_wire_f32s(&d.gravity, "data.gravity")?);
        Ok(())
    }

    /// The FRI joint set-point the controller currently uses, `cmdJntPos + cmdJntPosFriOffset`,
    /// rad: what the mirroring rule sends while not in command mode.
    pub fn mirrored_joint_position(&self) -> [f64; JOINTS] {
        core::array::from_fn(|i| self.data.cmd_jnt_pos[i] + self.data.cmd_jnt_pos_fri_offset[i])
    }

    /// True when any drive is powered (`robot.power != 0`, KUKA's sample rule).
    pub fn drives_powered(&self) -> bool {
        self.robot.power != 0
    }
}

impl Default for Measurement {
    /// An all-zero measurement with INVALID state and quality (no datagram received yet).
    fn default() -> Self {
        Self {
            header: Header::default(),
            krl: KrlData::default(),
            interface: InterfaceInfo {
                timestamp: 0.0,
                state: InterfaceState::Invalid,
                quality: Quality::Invalid,
                desired_msr_sample_time: 0.0,
                desired_cmd_sample_time: 0.0,
                safety_limits: 0.0,
                statistics: InterfaceStatistics::default(),
            },
            robot: RobotStatus {
                power: 0,
                control: ControlStrategy::Other,
                error: 0,
                warning: 0,
                temperature: [0.0; JOINTS],
            },
            data: RobotData {
                msr_jnt_pos: [0.0; JOINTS],
                msr_cart_pos: [[0.0; 4]; 3],
                cmd_jnt_pos: [0.0; JOINTS],
                cmd_jnt_pos_fri_offset: [0.0; JOINTS],
                cmd_cart_pos: [[0.0; 4]; 3],
                cmd_cart_pos_fri_offset: [[0.0; 4]; 3],
                msr_jnt_trq: [0.0; JOINTS],
                est_ext_jnt_trq: [0.0; JOINTS],
                est_ext_tcp_ft: [0.0; 6],
                jacobian: [[0.0; JOINTS]; 6],
                mass_matrix: [[0.0; JOINTS]; JOINTS],
                gravity: [0.0; JOINTS],
            },
        }
    }
}

// The two lengths must differ, so a datagram of one kind can never pass the other's check.
const _: () = assert!(MSR_LEN != CMD_LEN);
