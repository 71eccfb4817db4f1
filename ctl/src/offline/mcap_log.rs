//! Trajectory logs in MCAP files (`record --kind mcap`, or any ROS 2 bag in MCAP): the
//! `sensor_msgs/msg/JointState` messages on `/joint_states`, with time from their header stamps,
//! q from `position` (rad) and τ_J from `effort` (Nm).

use std::io::Read;
use std::path::Path;

use anyhow::{Context, bail};
use estimator::motion::Trajectory;
use fri_ros_msgs::sensor_msgs::JointState;
use nalgebra::SVector;

/// The first bytes of every MCAP file.
pub const MAGIC: &[u8; 8] = b"\x89MCAP0\r\n";
/// Largest MCAP file read, bytes (the file is read into memory; one hour at 1 kHz with the
/// service's three joint-state topics is about 1 GiB compressed at most).
pub const MAX_BYTES: u64 = 4 << 30;
/// The topic read.
pub const TOPIC: &str = "/joint_states";

/// Whether `path` starts with the MCAP magic.
pub fn is_mcap(path: &Path) -> anyhow::Result<bool> {
    let mut f = std::fs::File::open(path)
        .with_context(|| format!("cannot open trajectory log {}", path.display()))?;
    let mut head = [0u8; 8];
    let mut got = 0;
    while got < head.len() {
        match f.read(&mut head[got..]) {
            Ok(0) => break,
            Ok(n) => got += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e).with_context(|| format!("reading {}", path.display())),
        }
    }
    Ok(got == head.len() && &head == MAGIC)
}

/// Reads the joint states of an MCAP file as a trajectory of N joints.
pub fn read<const N: usize>(path: &Path) -> anyhow::Result<Trajectory<N>> {
    let size = std::fs::metadata(path)
        .with_context(|| format!("cannot open trajectory log {}", path.display()))?
        .len();
    if size > MAX_BYTES {
        bail!(
            "{}: {size} bytes, more than the {MAX_BYTES} bytes read into memory; cut it with \
             `mcap filter --start-secs/--end-secs` or record shorter runs",
            path.display()
        );
    }
    let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    from_bytes(&bytes)
}

/// Decodes the `/joint_states` messages of an MCAP file in memory.
pub fn from_bytes<const N: usize>(bytes: &[u8]) -> anyhow::Result<Trajectory<N>> {
    let mut tr = Trajectory {
        t: Vec::new(),
        q: Vec::new(),
        tau: Vec::new(),
    };
    let stream = mcap::MessageStream::new(bytes).context("not a readable MCAP file")?;
    for (k, m) in stream.enumerate() {
        let m = m.with_context(|| format!("MCAP record after {k} messages"))?;
        if m.channel.topic != TOPIC {
            continue;
        }
        let schema = m.channel.schema.as_ref().map(|s| s.name.as_str());
        if m.channel.message_encoding != "cdr"
            || !matches!(
                schema,
                Some("sensor_msgs/msg/JointState" | "sensor_msgs/JointState")
            )
        {
            bail!(
                "{TOPIC} holds {schema:?} messages in encoding `{}`; expected \
                 sensor_msgs/msg/JointState in `cdr` (ROS 2)",
                m.channel.message_encoding
            );
        }
        let row = tr.t.len() + 1;
        let js: JointState =
            fri_ros_msgs::decode_cdr(&m.data).with_context(|| format!("{TOPIC} message {row}"))?;
        if js.position.len() != N || js.effort.len() != N {
            bail!(
                "{TOPIC} message {row}: {} positions and {} efforts, the robot has {N} joints",
                js.position.len(),
                js.effort.len()
            );
        }
        let q = SVector::<f64, N>::from_column_slice(&js.position);
        let tau = SVector::<f64, N>::from_column_slice(&js.effort);
        if q.iter().chain(tau.iter()).any(|v| !v.is_finite()) {
            bail!("{TOPIC} message {row}: a position or effort is not finite");
        }
        tr.t.push(js.header.stamp.as_seconds());
        tr.q.push(q);
        tr.tau.push(tau);
    }
    if tr.t.is_empty() {
        bail!("no {TOPIC} messages (sensor_msgs/msg/JointState) in the MCAP file");
    }
    Ok(tr)
}
