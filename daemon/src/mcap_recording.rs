//! `record --kind mcap`: the per-cycle state and the events as ROS 2 messages in an MCAP file.
//!
//! The file follows the MCAP `ros2` profile (schema encoding `ros2msg` with the definitions of
//! every type a schema uses concatenated, message encoding `cdr`), so Foxglove, `ros2 bag` and the
//! MCAP libraries read it as a ROS 2 bag. Messages are built by [`crate::ros_messages`], the same
//! functions the ROS 2 bridge publishes with: same topics, fields, units, frames and stamps.
//! Chunks are zstd-compressed and indexed (message indexes, chunk indexes, statistics and the
//! summary offsets), so a reader seeks by time without scanning the file.
//!
//! Time: every message's log time and publish time is its header stamp in nanoseconds, the
//! controller's time base (seconds since the service accepted its first measurement, counted from
//! the FRI sequence counter: consecutive states differ by whole cycles, lost cycles are gaps).
//! The host's wall clock at the first recorded state is in the metadata record `fri_service`.

use std::collections::BTreeMap;
use std::io::{Seek, Write};

use fri_api::JOINTS;
use fri_api::ipc::{CollisionMessage, RobotState};
use fri_ros_msgs::builtin_interfaces::Time;
use fri_ros_msgs::geometry_msgs::{InertiaStamped, WrenchStamped};
use fri_ros_msgs::names::in_namespace;
use fri_ros_msgs::{MessageType, RosMessage, encode_cdr};

use crate::ros_messages as ros;

/// Name of the MCAP profile of ROS 2 bags.
pub const PROFILE: &str = "ros2";
/// Schema encoding of the `ros2` profile: `.msg` text with its dependencies concatenated.
pub const SCHEMA_ENCODING: &str = "ros2msg";
/// Message encoding of the `ros2` profile: encapsulated CDR.
pub const MESSAGE_ENCODING: &str = "cdr";
/// Name of the metadata record that describes the recording.
pub const METADATA_NAME: &str = "fri_service";

/// Errors writing an MCAP recording.
#[derive(Debug, thiserror::Error)]
pub enum McapRecordingError {
    /// The MCAP writer failed (usually an I/O error of the file).
    #[error("MCAP: {0}")]
    Mcap(#[from] mcap::McapError),
    /// A message could not be encoded.
    #[error(transparent)]
    Cdr(#[from] fri_ros_msgs::CdrError),
}

/// What the recording holds besides the per-cycle state.
// Sent by value through the writer's preallocated queue once per cycle: boxing the state would
// allocate every cycle.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, PartialEq)]
pub enum Item {
    /// One cycle's state: `/joint_states`, `<ns>/external_torque`, `<ns>/controller_gravity`.
    State(RobotState),
    /// A collision onset: `<ns>/collision`.
    Collision(CollisionMessage),
    /// The applied payload (at the start and on every change): `<ns>/payload`.
    Payload(InertiaStamped),
    /// The contact wrench of a collision onset on the last link: `<ns>/contact_wrench`.
    ContactWrench(WrenchStamped),
}

/// Messages written per topic and the time span.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Written {
    /// States written (cycles).
    pub states: usize,
    /// Messages written on every topic together.
    pub messages: u64,
    /// Collision messages.
    pub collisions: u64,
    /// Payload messages.
    pub payloads: u64,
    /// Contact-wrench messages.
    pub contact_wrenches: u64,
}

/// One channel: its MCAP id and the sequence number of its next message.
#[derive(Debug, Clone, Copy)]
struct Channel {
    id: u16,
    sequence: u32,
}

/// Where the recording goes and what it names.
#[derive(Debug, Clone)]
pub struct McapSettings {
    /// Namespace of the service's topics (`ros2.namespace`, default `/lwr`).
    pub namespace: String,
    /// The controller cycle, s (for the metadata).
    pub cycle_s: f64,
}

/// An MCAP file being written (see the module documentation).
pub struct McapRecording<W: Write + Seek> {
    writer: mcap::Writer<W>,
    names: [String; JOINTS],
    settings: McapSettings,
    joint_states: Channel,
    external_torque: Channel,
    controller_gravity: Channel,
    payload: Channel,
    collision: Channel,
    contact_wrench: Channel,
    robot_description: Channel,
    written: Written,
}

impl<W: Write + Seek> std::fmt::Debug for McapRecording<W> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("McapRecording")
            .field("written", &self.written)
            .finish_non_exhaustive()
    }
}

/// Log time of a stamp, ns (the stamp's own seconds and nanoseconds: equal to the header).
pub fn log_time(stamp: Time) -> u64 {
    u64::try_from(stamp.sec).unwrap_or(0) * 1_000_000_000 + u64::from(stamp.nanosec)
}

impl<W: Write + Seek> McapRecording<W> {
    /// Starts the file: header, schemas and channels (written before the first message).
    pub fn create(out: W, settings: McapSettings) -> Result<Self, McapRecordingError> {
        let options = mcap::WriteOptions::new()
            .profile(PROFILE)
            .library(concat!("fri-service ", env!("CARGO_PKG_VERSION")))
            .compression(Some(mcap::Compression::Zstd))
            // Compress on this (non-real-time) thread: no pool of worker threads next to the loop.
            .compression_threads(0);
        let mut writer = options.create(out)?;
        let ns = settings.namespace.clone();
        let mut channel = |t: &MessageType, topic: &str| -> Result<Channel, McapRecordingError> {
            let schema = writer.add_schema(
                &t.ros_name(),
                SCHEMA_ENCODING,
                t.ros2msg_schema().as_bytes(),
            )?;
            let id = writer.add_channel(schema, topic, MESSAGE_ENCODING, &BTreeMap::new())?;
            Ok(Channel { id, sequence: 0 })
        };
        use fri_ros_msgs::{fri_msgs, sensor_msgs, std_msgs};
        let joint_state = sensor_msgs::JointState::TYPE;
        let joint_states = channel(joint_state, ros::JOINT_STATES_TOPIC)?;
        let external_torque = channel(joint_state, &in_namespace(&ns, "external_torque"))?;
        let controller_gravity = channel(joint_state, &in_namespace(&ns, "controller_gravity"))?;
        let payload = channel(InertiaStamped::TYPE, &in_namespace(&ns, "payload"))?;
        let collision = channel(fri_msgs::Collision::TYPE, &in_namespace(&ns, "collision"))?;
        let contact_wrench = channel(WrenchStamped::TYPE, &in_namespace(&ns, "contact_wrench"))?;
        let robot_description = channel(std_msgs::String::TYPE, ros::ROBOT_DESCRIPTION_TOPIC)?;
        Ok(Self {
            writer,
            names: ros::joint_names(),
            settings,
            joint_states,
            external_torque,
            controller_gravity,
            payload,
            collision,
            contact_wrench,
            robot_description,
            written: Written::default(),
        })
    }

    fn write<M: RosMessage>(
        &mut self,
        pick: fn(&mut Self) -> &mut Channel,
        stamp: Time,
        message: &M,
    ) -> Result<(), McapRecordingError> {
        let data = encode_cdr(message)?;
        let channel = pick(self);
        let header = mcap::records::MessageHeader {
            channel_id: channel.id,
            sequence: channel.sequence,
            log_time: log_time(stamp),
            publish_time: log_time(stamp),
        };
        channel.sequence = channel.sequence.wrapping_add(1);
        self.writer.write_to_known_channel(&header, &data)?;
        self.written.messages += 1;
        Ok(())
    }

    /// Writes one item (the first state also writes `/robot_description` and the metadata).
    pub fn item(&mut self, item: &Item) -> Result<(), McapRecordingError> {
        match item {
            Item::State(s) => self.state(s),
            Item::Collision(c) => {
                let m = ros::collision(c, &self.names);
                self.write(|r| &mut r.collision, m.header.stamp, &m)?;
                self.written.collisions += 1;
                Ok(())
            }
            Item::Payload(p) => {
                self.write(|r| &mut r.payload, p.header.stamp, p)?;
                self.written.payloads += 1;
                Ok(())
            }
            Item::ContactWrench(w) => {
                self.write(|r| &mut r.contact_wrench, w.header.stamp, w)?;
                self.written.contact_wrenches += 1;
                Ok(())
            }
        }
    }

    fn state(&mut self, s: &RobotState) -> Result<(), McapRecordingError> {
        let m = ros::joint_states(s, &self.names);
        let stamp = m.measured.header.stamp;
        if self.written.states == 0 {
            self.first(stamp)?;
        }
        self.write(|r| &mut r.joint_states, stamp, &m.measured)?;
        self.write(|r| &mut r.external_torque, stamp, &m.external_torque)?;
        self.write(|r| &mut r.controller_gravity, stamp, &m.controller_gravity)?;
        self.written.states += 1;
        Ok(())
    }

    /// What a late subscriber of the live topics gets at once (transient local): the URDF, and
    /// the metadata that maps the time base to the host clock.
    fn first(&mut self, stamp: Time) -> Result<(), McapRecordingError> {
        let description = fri_ros_msgs::std_msgs::String {
            data: ros::robot_description(),
        };
        self.write(|r| &mut r.robot_description, stamp, &description)?;
        let wall = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0.0, |d| d.as_secs_f64());
        let metadata = BTreeMap::from([
            (
                "time_base".to_owned(),
                "controller: s since the service accepted its first measurement, from the FRI \
                 sequence counter; log time = publish time = header stamp"
                    .to_owned(),
            ),
            ("cycle_s".to_owned(), format!("{}", self.settings.cycle_s)),
            (
                "first_stamp_s".to_owned(),
                format!("{:.9}", stamp.as_seconds()),
            ),
            ("first_stamp_host_unix_s".to_owned(), format!("{wall:.6}")),
            ("namespace".to_owned(), self.settings.namespace.clone()),
        ]);
        self.writer.write_metadata(&mcap::records::Metadata {
            name: METADATA_NAME.to_owned(),
            metadata,
        })?;
        Ok(())
    }

    /// Writes the summary (indexes, statistics) and flushes; returns what was written and the
    /// output.
    pub fn finish(mut self) -> Result<(Written, W), McapRecordingError> {
        self.writer.finish()?;
        Ok((self.written, self.writer.into_inner()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Cursor;

    fn state(cycle: u64) -> RobotState {
        let mut s = RobotState {
            cycle,
            time_s: cycle as f64 * 1e-3,
            ..RobotState::default()
        };
        s.q[2] = 0.5 + cycle as f64 * 1e-4;
        s.tau[1] = -12.0;
        s
    }

    #[test]
    fn a_recording_reads_back_as_ros2_messages_with_indexes_and_summary() {
        let settings = McapSettings {
            namespace: "/lwr".to_owned(),
            cycle_s: 1e-3,
        };
        let mut rec = McapRecording::create(Cursor::new(Vec::new()), settings).unwrap();
        for k in 1..=2000 {
            if k == 1500 {
                continue; // a lost cycle
            }
            rec.item(&Item::State(state(k))).unwrap();
        }
        rec.item(&Item::Collision(CollisionMessage {
            cycle: 2000,
            time_s: 2.0,
            link: 7,
            ..CollisionMessage::default()
        }))
        .unwrap();
        let (written, out) = rec.finish().unwrap();
        assert_eq!(written.states, 1999);
        assert_eq!(written.messages, 3 * 1999 + 2);
        let bytes = out.into_inner();

        let summary = mcap::Summary::read(&bytes).unwrap().unwrap();
        let stats = summary.stats.as_ref().unwrap();
        assert_eq!(stats.message_count, written.messages);
        assert_eq!(stats.message_start_time, 1_000_000);
        assert_eq!(stats.message_end_time, 2_000_000_000);
        assert!(!summary.chunk_indexes.is_empty());
        assert!(
            summary
                .chunk_indexes
                .iter()
                .all(|c| c.compression == "zstd" && !c.message_index_offsets.is_empty())
        );
        let header_profile = {
            let mut r = mcap::read::LinearReader::new(&bytes).unwrap();
            match r.next().unwrap().unwrap() {
                mcap::records::Record::Header(h) => h.profile,
                other => panic!("{other:?}"),
            }
        };
        assert_eq!(header_profile, "ros2");

        let mut js = Vec::new();
        let mut topics = std::collections::BTreeSet::new();
        for m in mcap::MessageStream::new(&bytes).unwrap() {
            let m = m.unwrap();
            topics.insert(m.channel.topic.clone());
            assert_eq!(m.channel.message_encoding, "cdr");
            let schema = m.channel.schema.as_ref().unwrap();
            assert_eq!(schema.encoding, "ros2msg");
            if m.channel.topic == "/joint_states" {
                assert_eq!(schema.name, "sensor_msgs/msg/JointState");
                assert!(String::from_utf8_lossy(&schema.data).contains("MSG: std_msgs/Header"));
                let j: fri_ros_msgs::sensor_msgs::JointState =
                    fri_ros_msgs::decode_cdr(&m.data).unwrap();
                assert_eq!(log_time(j.header.stamp), m.log_time);
                js.push(j);
            }
        }
        assert_eq!(
            topics.into_iter().collect::<Vec<_>>(),
            [
                "/joint_states",
                "/lwr/collision",
                "/lwr/controller_gravity",
                "/lwr/external_torque",
                "/robot_description",
            ]
        );
        assert_eq!(js.len(), 1999);
        assert_eq!(js[0].name[6], "lwr_joint_7");
        assert_eq!(js[9].position[2], state(10).q[2]);
        assert_eq!(js[9].effort[1], -12.0);
        // The lost cycle is a gap of two cycles between neighbouring stamps.
        assert_eq!(
            log_time(js[1499].header.stamp) - log_time(js[1498].header.stamp),
            2_000_000
        );
    }
}
