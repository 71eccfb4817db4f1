//! MCAP logs (the service's `record --kind mcap`, or any ROS 2 bag in MCAP): the
//! `sensor_msgs/msg/JointState` messages on `/joint_states`, stamped by their header, with
//! `position` (rad), `effort` (measured torques, Nm) and, when every message has it, `velocity`
//! (rad/s). Chunks are checked before anything is decompressed, so a chunk that claims a huge
//! uncompressed size is refused instead of allocated.

use std::path::Path;

use fri_ros_msgs::sensor_msgs::JointState;

use super::error::{Column, Location, ReplayError};
use super::log::{LogLimits, Quantity, RecordedLog, Row, check_value};
use crate::joints::{JOINTS, JointVector};

/// The first bytes of every MCAP file.
pub const MAGIC: &[u8; 8] = b"\x89MCAP0\r\n";
/// The topic replayed.
pub const TOPIC: &str = "/joint_states";
/// Largest uncompressed chunk accepted, bytes.
pub const MAX_CHUNK_BYTES: u64 = 64 << 20;

fn format_error(path: &Path, problem: String) -> ReplayError {
    ReplayError::Format {
        path: path.into(),
        problem,
    }
}

/// Refuses a file whose chunks claim more than [`MAX_CHUNK_BYTES`] uncompressed.
fn check_chunks(path: &Path, bytes: &[u8]) -> Result<(), ReplayError> {
    let reader = mcap::read::LinearReader::new(bytes)
        .map_err(|e| format_error(path, format!("not a readable MCAP file: {e}")))?;
    for (k, record) in reader.enumerate() {
        let record =
            record.map_err(|e| format_error(path, format!("MCAP record {}: {e}", k + 1)))?;
        if let mcap::records::Record::Chunk { header, .. } = record
            && header.uncompressed_size > MAX_CHUNK_BYTES
        {
            return Err(format_error(
                path,
                format!(
                    "MCAP record {} is a chunk of {} bytes uncompressed, more than the \
                     {MAX_CHUNK_BYTES} bytes a replay decompresses",
                    k + 1,
                    header.uncompressed_size
                ),
            ));
        }
    }
    Ok(())
}

/// Reads the joint states of an MCAP file held in `bytes`.
pub(super) fn read(
    path: &Path,
    bytes: &[u8],
    limits: &LogLimits,
) -> Result<RecordedLog, ReplayError> {
    check_chunks(path, bytes)?;
    let stream = mcap::MessageStream::new(bytes)
        .map_err(|e| format_error(path, format!("not a readable MCAP file: {e}")))?;
    let mut log = RecordedLog::empty();
    let stamp = Column {
        number: 0,
        name: "header.stamp".into(),
    };
    let mut with_velocity = None;
    for (k, message) in stream.enumerate() {
        let message = message
            .map_err(|e| format_error(path, format!("MCAP record after {k} messages: {e}")))?;
        if message.channel.topic != TOPIC {
            continue;
        }
        let schema = message.channel.schema.as_ref().map(|s| s.name.as_str());
        if message.channel.message_encoding != "cdr"
            || !matches!(
                schema,
                Some("sensor_msgs/msg/JointState" | "sensor_msgs/JointState")
            )
        {
            return Err(format_error(
                path,
                format!(
                    "{TOPIC} holds {schema:?} messages in encoding `{}`; expected \
                     sensor_msgs/msg/JointState in `cdr` (ROS 2)",
                    message.channel.message_encoding
                ),
            ));
        }
        let at = Location::Message(log.rows() + 1);
        let invalid = |field: String, problem: String| ReplayError::Invalid {
            path: path.into(),
            at,
            column: Some(Column {
                number: 0,
                name: field,
            }),
            problem,
        };
        let js: JointState =
            fri_ros_msgs::cdr::decode_cdr(&message.data).map_err(|e| ReplayError::Invalid {
                path: path.into(),
                at,
                column: None,
                problem: format!("not a CDR sensor_msgs/msg/JointState: {e}"),
            })?;
        let has_velocity = !js.velocity.is_empty();
        if *with_velocity.get_or_insert(has_velocity) != has_velocity {
            return Err(invalid(
                "velocity".into(),
                "present in some messages and not in others".into(),
            ));
        }
        let joints = |name: &str, values: &[f64], what: fn(usize) -> Quantity| {
            if values.len() != JOINTS {
                return Err(invalid(
                    name.into(),
                    format!("{} values, the robot has {JOINTS} joints", values.len()),
                ));
            }
            let mut v = JointVector::zeros();
            for (j, x) in values.iter().enumerate() {
                v[j] = check_value(what(j), *x).map_err(|p| invalid(format!("{name}[{j}]"), p))?;
            }
            Ok(v)
        };
        let t = check_value(Quantity::Time, js.header.stamp.as_seconds())
            .map_err(|p| invalid(stamp.name.clone(), p))?;
        let row = Row {
            t,
            q: joints("position", &js.position, Quantity::Position)?,
            tau: joints("effort", &js.effort, Quantity::Torque)?,
            qd: has_velocity
                .then(|| joints("velocity", &js.velocity, Quantity::Velocity))
                .transpose()?,
            qdd: None,
        };
        log.push(path, limits, at, &stamp, row)?;
    }
    log.finish(path)
}
