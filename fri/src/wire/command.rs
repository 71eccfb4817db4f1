//! Command datagram (`tFriCmdData`, remote → controller, 376 B, spec §1.4).

use serde::{Deserialize, Serialize};

use super::field::cmd;
use super::{
    CMD_DATAGRAM_ID, CMD_LEN, CMD_PACKET_SIZE, CommandFlags, Frame, Header, JOINTS, KRL_VALUES,
    KrlData, WireError, bytes, f32_array_accessors, f32_matrix_accessors, field,
    header_and_krl_accessors, header_and_krl_setters,
};

/// Zero-copy view over a command datagram.
///
/// Accessors index fixed offsets: build the view with [`CommandPacket::new_checked`] for outside
/// input; with [`CommandPacket::new_unchecked`] accessors panic when the buffer is shorter than
/// [`CMD_LEN`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CommandPacket<T: AsRef<[u8]>> {
    buffer: T,
}

impl<T: AsRef<[u8]>> CommandPacket<T> {
    /// Wraps a buffer without checking its length.
    pub const fn new_unchecked(buffer: T) -> Self {
        Self { buffer }
    }

    /// Wraps a buffer after checking that it is exactly [`CMD_LEN`] bytes long.
    pub fn new_checked(buffer: T) -> Result<Self, WireError> {
        super::error::check_len(buffer.as_ref().len(), CMD_LEN)?;
        Ok(Self { buffer })
    }

    /// Checks length, `packetSize` (376), `datagramId` (0x1005) and that no float is NaN/Inf.
    pub fn check(&self) -> Result<(), WireError> {
        super::validate(
            self.buffer.as_ref(),
            CMD_LEN,
            CMD_PACKET_SIZE,
            CMD_DATAGRAM_ID,
            &cmd::FLOAT_FIELDS,
        )
    }

    /// Returns the underlying buffer.
    pub fn into_inner(self) -> T {
        self.buffer
    }

    header_and_krl_accessors!();

    /// `cmd.cmdFlags`: which of the fields below the controller should use.
    pub fn cmd_flags(&self) -> CommandFlags {
        CommandFlags(bytes::read_u32(self.buffer.as_ref(), cmd::CMD_FLAGS))
    }

    f32_array_accessors!(
        jnt_pos,
        set_jnt_pos,
        cmd::JNT_POS,
        JOINTS,
        "`cmd.jntPos`: absolute joint set-point, rad."
    );
    f32_matrix_accessors!(
        cart_pos,
        set_cart_pos,
        cmd::CART_POS,
        3,
        4,
        "`cmd.cartPos`: TCP frame set-point, 3×4 row-major, translation in m."
    );
    f32_array_accessors!(
        add_jnt_trq,
        set_add_jnt_trq,
        cmd::ADD_JNT_TRQ,
        JOINTS,
        "`cmd.addJntTrq`: added joint torque, Nm."
    );
    f32_array_accessors!(
        add_tcp_ft,
        set_add_tcp_ft,
        cmd::ADD_TCP_FT,
        6,
        "`cmd.addTcpFT`: added TCP wrench Fx Fy Fz (N) Tz Ty Tx (Nm), task frame."
    );
    f32_array_accessors!(
        jnt_stiffness,
        set_jnt_stiffness,
        cmd::JNT_STIFFNESS,
        JOINTS,
        "`cmd.jntStiffness`: joint stiffness, Nm/rad."
    );
    f32_array_accessors!(
        jnt_damping,
        set_jnt_damping,
        cmd::JNT_DAMPING,
        JOINTS,
        "`cmd.jntDamping`: normalised joint damping, unitless (e.g. 0.7)."
    );
    f32_array_accessors!(
        cart_stiffness,
        set_cart_stiffness,
        cmd::CART_STIFFNESS,
        6,
        "`cmd.cartStiffness`: x y z (N/m) then a(Rz) b(Ry) c(Rx) (Nm/rad)."
    );
    f32_array_accessors!(
        cart_damping,
        set_cart_damping,
        cmd::CART_DAMPING,
        6,
        "`cmd.cartDamping`: normalised Cartesian damping, unitless, order x y z a b c."
    );
}

impl<T: AsRef<[u8]> + AsMut<[u8]>> CommandPacket<T> {
    header_and_krl_setters!();

    /// Sets `cmd.cmdFlags`.
    pub fn set_cmd_flags(&mut self, v: CommandFlags) {
        bytes::write_u32(self.buffer.as_mut(), cmd::CMD_FLAGS, v.bits())
    }
}

/// An owned, validated command datagram with f64 values in SI units.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Command {
    /// Our counter and the controller's counter we reflect.
    pub header: Header,
    /// Values read by the KRL program (the handshake lives in `int[13..16]`).
    pub krl: KrlData,
    /// Which of the fields below the controller should use.
    pub cmd_flags: CommandFlags,
    /// Absolute joint set-point, rad.
    pub jnt_pos: [f64; JOINTS],
    /// TCP frame set-point, 3×4 row-major, translation in m.
    pub cart_pos: Frame,
    /// Added joint torque, Nm.
    pub add_jnt_trq: [f64; JOINTS],
    /// Added TCP wrench Fx Fy Fz (N) then Tz Ty Tx (Nm), task frame.
    pub add_tcp_ft: [f64; 6],
    /// Joint stiffness, Nm/rad.
    pub jnt_stiffness: [f64; JOINTS],
    /// Normalised joint damping, unitless.
    pub jnt_damping: [f64; JOINTS],
    /// Cartesian stiffness x y z (N/m) then a b c (Nm/rad).
    pub cart_stiffness: [f64; 6],
    /// Normalised Cartesian damping, unitless, order x y z a b c.
    pub cart_damping: [f64; 6],
}

impl Command {
    /// Decodes and validates a command datagram: exact length 376, `packetSize` 376,
    /// `datagramId` 0x1005, every float finite.
    pub fn parse(datagram: &[u8]) -> Result<Self, WireError> {
        use bytes::{finite, finite_rows};
        let p = CommandPacket::new_checked(datagram)?;
        super::check_header(datagram, CMD_PACKET_SIZE, CMD_DATAGRAM_ID)?;
        // Fields are decoded in table order, so the first non-finite one is reported.
        Ok(Self {
            header: Header {
                send_seq_count: p.send_seq_count(),
                refl_seq_count: p.refl_seq_count(),
            },
            krl: super::parse_krl_checked(datagram)?,
            cmd_flags: p.cmd_flags(),
            jnt_pos: finite(p.jnt_pos(), "cmd.jntPos")?,
            cart_pos: finite_rows(p.cart_pos(), "cmd.cartPos")?,
            add_jnt_trq: finite(p.add_jnt_trq(), "cmd.addJntTrq")?,
            add_tcp_ft: finite(p.add_tcp_ft(), "cmd.addTcpFT")?,
            jnt_stiffness: finite(p.jnt_stiffness(), "cmd.jntStiffness")?,
            jnt_damping: finite(p.jnt_damping(), "cmd.jntDamping")?,
            cart_stiffness: finite(p.cart_stiffness(), "cmd.cartStiffness")?,
            cart_damping: finite(p.cart_damping(), "cmd.cartDamping")?,
        })
    }

    /// Encodes into a caller's buffer (no allocation), writing `packetSize` 376 and
    /// `datagramId` 0x1005. Fails when a value is or narrows to a non-finite f32; the buffer's
    /// content is then unspecified and must not be sent.
    pub fn emit(&self, out: &mut [u8; CMD_LEN]) -> Result<(), WireError> {
        use bytes::{to_wire_f32_rows, to_wire_f32s};
        super::emit_header_and_krl(
            out,
            &self.header,
            CMD_PACKET_SIZE,
            CMD_DATAGRAM_ID,
            &self.krl,
        )?;
        let mut p = CommandPacket::new_unchecked(&mut out[..]);
        p.set_cmd_flags(self.cmd_flags);
        p.set_jnt_pos(&to_wire_f32s(&self.jnt_pos, "cmd.jntPos")?);
        p.set_cart_pos(&to_wire_f32_rows(&self.cart_pos, "cmd.cartPos")?);
        p.set_add_jnt_trq(&to_wire_f32s(&self.add_jnt_trq, "cmd.addJntTrq")?);
        p.set_add_tcp_ft(&to_wire_f32s(&self.add_tcp_ft, "cmd.addTcpFT")?);
        p.set_jnt_stiffness(&to_wire_f32s(&self.jnt_stiffness, "cmd.jntStiffness")?);
        p.set_jnt_damping(&to_wire_f32s(&self.jnt_damping, "cmd.jntDamping")?);
        p.set_cart_stiffness(&to_wire_f32s(&self.cart_stiffness, "cmd.cartStiffness")?);
        p.set_cart_damping(&to_wire_f32s(&self.cart_damping, "cmd.cartDamping")?);
        Ok(())
    }
}

impl Default for Command {
    /// All zero, no flags.
    fn default() -> Self {
        Self {
            header: Header::default(),
            krl: KrlData::default(),
            cmd_flags: CommandFlags::EMPTY,
            jnt_pos: [0.0; JOINTS],
            cart_pos: [[0.0; 4]; 3],
            add_jnt_trq: [0.0; JOINTS],
            add_tcp_ft: [0.0; 6],
            jnt_stiffness: [0.0; JOINTS],
            jnt_damping: [0.0; JOINTS],
            cart_stiffness: [0.0; 6],
            cart_damping: [0.0; 6],
        }
    }
}

const _: () = assert!(KRL_VALUES == 16 && field::cmd::CMD_FLAGS.start == 140);
