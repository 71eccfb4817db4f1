//! A recorded log held for replay: time stamps, joint angles, measured joint torques, and joint
//! velocities and accelerations (recorded, or differentiated from the angles when the log has
//! none), every row validated on the way in; sampled at any time by linear interpolation.

use std::io::Read;
use std::os::unix::fs::OpenOptionsExt;
use std::path::Path;

use super::error::{Column, Location, ReplayError};
use crate::joints::{JOINTS, JointVector};
use crate::motion::{POSITION_LIMITS_RAD, VELOCITY_LIMITS_RAD_S};
use crate::simulation::TORQUE_LIMITS_NM;
use estimator::motion::{Trajectory, time_base};
use estimator::replay::Spline;

/// Largest log file read, bytes (2 GiB: about an hour of the service's 1 kHz log).
pub const MAX_LOG_BYTES: u64 = 2 << 30;
/// Most rows (or `/joint_states` messages) held, rows (33 min at 1 kHz, 2.8 h at 200 Hz; about
/// 460 MB in memory).
pub const MAX_ROWS: usize = 2_000_000;
/// Longest time between two consecutive stamps, s: a longer gap is a hole in the recording, and
/// interpolating across it would replay a motion that never happened.
pub const MAX_GAP_S: f64 = 0.1;
/// Margin allowed beyond the joint position limits, rad (5°: encoders read past the software
/// limits).
pub const POSITION_MARGIN_RAD: f64 = 5.0 * std::f64::consts::PI / 180.0;
/// Measured torques may reach this multiple of the joint torque limits (sensor range).
pub const TORQUE_RANGE_FACTOR: f64 = 2.0;
/// Velocities may reach this multiple of the joint velocity limits.
pub const VELOCITY_RANGE_FACTOR: f64 = 2.0;
/// Largest joint acceleration accepted, rad/s².
pub const MAX_ACCELERATION_RAD_S2: f64 = 1000.0;

/// The bounds a log must keep (the defaults are the constants above).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LogLimits {
    /// Largest file, bytes.
    pub max_bytes: u64,
    /// Most rows.
    pub max_rows: usize,
    /// Longest gap between stamps, s.
    pub max_gap_s: f64,
}

impl Default for LogLimits {
    fn default() -> Self {
        Self {
            max_bytes: MAX_LOG_BYTES,
            max_rows: MAX_ROWS,
            max_gap_s: MAX_GAP_S,
        }
    }
}

/// What a row carries besides the stamp, angles and torques.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Derivatives {
    /// Velocities and accelerations recorded (the real LWR 4+ recordings).
    Recorded,
    /// Velocities recorded, accelerations differentiated (the service's `record --kind log`).
    VelocityRecorded,
    /// Both differentiated from the angles (central differences over the stamps).
    Differentiated,
}

/// The joint state of a log at one time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Joint angles, rad.
    pub q: JointVector,
    /// Joint velocities, rad/s.
    pub qd: JointVector,
    /// Joint accelerations, rad/s².
    pub qdd: JointVector,
    /// Measured joint torques, Nm.
    pub tau: JointVector,
}

/// A validated log (at least two rows, stamps increasing).
#[derive(Debug, Clone)]
pub struct RecordedLog {
    t: Vec<f64>,
    q: Vec<JointVector>,
    qd: Vec<JointVector>,
    qdd: Vec<JointVector>,
    tau: Vec<JointVector>,
    derivatives: Option<Derivatives>,
    /// The natural cubic spline through the positions (set by `finish`).
    spline: Option<Spline<JOINTS>>,
}

/// One row as a reader found it.
#[derive(Debug, Clone, Copy)]
pub(super) struct Row {
    pub t: f64,
    pub q: JointVector,
    pub tau: JointVector,
    pub qd: Option<JointVector>,
    pub qdd: Option<JointVector>,
}

/// The quantity a value is, for its range check.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Quantity {
    Time,
    Position(usize),
    Velocity(usize),
    Acceleration(usize),
    Torque(usize),
}

/// Checks that `v` is finite and within the range of `what`; the problem, with the range, when
/// it is not.
pub(super) fn check_value(what: Quantity, v: f64) -> Result<f64, String> {
    if !v.is_finite() {
        return Err(format!("{v} is not a finite number"));
    }
    let (limit, unit) = match what {
        Quantity::Time => (1e9, "s"),
        Quantity::Position(j) => (POSITION_LIMITS_RAD[j] + POSITION_MARGIN_RAD, "rad"),
        Quantity::Velocity(j) => (VELOCITY_RANGE_FACTOR * VELOCITY_LIMITS_RAD_S[j], "rad/s"),
        Quantity::Acceleration(_) => (MAX_ACCELERATION_RAD_S2, "rad/s²"),
        Quantity::Torque(j) => (TORQUE_RANGE_FACTOR * TORQUE_LIMITS_NM[j], "Nm"),
    };
    if v.abs() > limit {
        return Err(format!(
            "{v} {unit} is outside -{limit:.4}..={limit:.4} {unit}"
        ));
    }
    Ok(v)
}

/// Opens `path` for reading: not through a symbolic link, a regular file, at most
/// `limits.max_bytes`; returns the file and its size.
pub(super) fn open(path: &Path, limits: &LogLimits) -> Result<(std::fs::File, u64), ReplayError> {
    let file = std::fs::OpenOptions::new()
        .read(true)
        // No FIFO may block the open; no symlink is followed at the last component.
        .custom_flags(libc::O_NOFOLLOW | libc::O_NONBLOCK | libc::O_CLOEXEC)
        .open(path)
        .map_err(|source| match source.raw_os_error() {
            Some(libc::ELOOP) => ReplayError::Symlink { path: path.into() },
            _ => ReplayError::Open {
                path: path.into(),
                source,
            },
        })?;
    let meta = file.metadata().map_err(|source| ReplayError::Open {
        path: path.into(),
        source,
    })?;
    if !meta.is_file() {
        return Err(ReplayError::NotAFile { path: path.into() });
    }
    if meta.len() > limits.max_bytes {
        return Err(ReplayError::TooLarge {
            path: path.into(),
            bytes: meta.len(),
            limit: limits.max_bytes,
        });
    }
    Ok((file, meta.len()))
}

/// Reads at most `limits.max_bytes` of `file` (a file that grows past them is refused).
pub(super) fn read_bounded(
    path: &Path,
    file: std::fs::File,
    size: u64,
    limits: &LogLimits,
) -> Result<Vec<u8>, ReplayError> {
    let mut bytes = Vec::with_capacity(usize::try_from(size).unwrap_or(0));
    file.take(limits.max_bytes + 1)
        .read_to_end(&mut bytes)
        .map_err(|source| ReplayError::Read {
            path: path.into(),
            source,
        })?;
    if bytes.len() as u64 > limits.max_bytes {
        return Err(ReplayError::TooLarge {
            path: path.into(),
            bytes: bytes.len() as u64,
            limit: limits.max_bytes,
        });
    }
    Ok(bytes)
}

impl RecordedLog {
    /// An empty log to [`push`](Self::push) rows into, then [`finish`](Self::finish).
    pub(super) fn empty() -> Self {
        Self {
            t: Vec::new(),
            q: Vec::new(),
            qd: Vec::new(),
            qdd: Vec::new(),
            tau: Vec::new(),
            derivatives: None,
            spline: None,
        }
    }

    /// Appends a row found at `at`: its stamp must follow the previous one by more than 0 and at
    /// most `limits.max_gap_s`; `time` names the stamp's column.
    pub(super) fn push(
        &mut self,
        path: &Path,
        limits: &LogLimits,
        at: Location,
        time: &Column,
        row: Row,
    ) -> Result<(), ReplayError> {
        let invalid = |problem: String| ReplayError::Invalid {
            path: path.into(),
            at,
            column: Some(time.clone()),
            problem,
        };
        if let Some(&previous) = self.t.last() {
            if row.t <= previous {
                return Err(invalid(format!(
                    "stamp {} s is not after the previous one, {previous} s: stamps must increase",
                    row.t
                )));
            }
            if row.t - previous > limits.max_gap_s {
                return Err(invalid(format!(
                    "stamp {} s is {:.4} s after the previous one, more than the {} s a replay \
                     bridges: cut the log at the gap",
                    row.t,
                    row.t - previous,
                    limits.max_gap_s
                )));
            }
        }
        if self.t.len() >= limits.max_rows {
            return Err(ReplayError::TooManyRows {
                path: path.into(),
                limit: limits.max_rows,
            });
        }
        let derivatives = match (row.qd.is_some(), row.qdd.is_some()) {
            (true, true) => Derivatives::Recorded,
            (true, false) => Derivatives::VelocityRecorded,
            _ => Derivatives::Differentiated,
        };
        self.derivatives = Some(derivatives);
        self.t.push(row.t);
        self.q.push(row.q);
        self.tau.push(row.tau);
        self.qd.push(row.qd.unwrap_or_default());
        self.qdd.push(row.qdd.unwrap_or_default());
        Ok(())
    }

    /// Completes the log: at least two rows; velocities and accelerations the rows lacked are
    /// differentiated.
    pub(super) fn finish(mut self, path: &Path) -> Result<Self, ReplayError> {
        if self.t.len() < 2 {
            return Err(ReplayError::TooShort {
                path: path.into(),
                rows: self.t.len(),
            });
        }
        // The rows' own clock, as the offline tools play them (`estimator::replay`): a recorder
        // that samples on a regular clock but stamps with jitter (8 of the 5026 steps of each
        // real LWR run) would otherwise make a late-then-early stamp a velocity spike of tens
        // of Nm in the 1 kHz momentum residual.
        let trajectory = Trajectory {
            t: std::mem::take(&mut self.t),
            q: std::mem::take(&mut self.q),
            tau: Vec::new(),
        };
        self.t = time_base(&trajectory).0;
        self.q = trajectory.q;
        self.spline = Some(Spline::new(&self.t, &self.q));
        match self.derivatives {
            Some(Derivatives::Recorded) => {}
            Some(Derivatives::VelocityRecorded) => self.qdd = differentiate(&self.t, &self.qd),
            _ => {
                self.qd = differentiate(&self.t, &self.q);
                self.qdd = differentiate(&self.t, &self.qd);
            }
        }
        Ok(self)
    }

    /// The rows' stamps as recorded, s.
    pub fn stamps(&self) -> &[f64] {
        &self.t
    }

    /// Rows held.
    pub fn rows(&self) -> usize {
        self.t.len()
    }

    /// The first stamp, s (the replay's time 0).
    pub fn start_s(&self) -> f64 {
        self.t.first().copied().unwrap_or(0.0)
    }

    /// Time from the first to the last stamp, s.
    pub fn duration_s(&self) -> f64 {
        self.t.last().copied().unwrap_or(0.0) - self.start_s()
    }

    /// Where the velocities and accelerations come from.
    pub fn derivatives(&self) -> Derivatives {
        self.derivatives.unwrap_or(Derivatives::Differentiated)
    }

    /// The joint state `t_s` (s) after the first stamp, between the rows around it (the first or
    /// last row outside the log): positions on the natural cubic spline through the rows'
    /// positions (exact at every row, its velocity continuous: the motion the arm made, with no
    /// step at the rows for a 1 kHz observer to see), the recorded velocities, accelerations
    /// and torques linearly. `cursor` is the row index to start searching from: replaying
    /// forward keeps the search O(1) and allocation-free.
    pub fn sample(&self, t_s: f64, cursor: &mut usize) -> Sample {
        let t = self.start_s() + t_s;
        let last = self.t.len().saturating_sub(1);
        if *cursor > last || self.t.get(*cursor).is_none_or(|&c| c > t) {
            *cursor = 0;
        }
        while *cursor + 1 < last && self.t[*cursor + 1] <= t {
            *cursor += 1;
        }
        let i = (*cursor).min(last.saturating_sub(1));
        let (t0, t1) = (self.t[i], self.t[i + 1]);
        let s = ((t - t0) / (t1 - t0)).clamp(0.0, 1.0);
        let lerp = |v: &[JointVector]| v[i] + (v[i + 1] - v[i]) * s;
        let q = match &self.spline {
            Some(spline) => spline.at(&self.t, &self.q, i, t0 + s * (t1 - t0)).0,
            None => lerp(&self.q),
        };
        Sample {
            q,
            qd: lerp(&self.qd),
            qdd: lerp(&self.qdd),
            tau: lerp(&self.tau),
        }
    }
}

/// Central differences of `x` over the stamps `t` (one-sided at both ends).
fn differentiate(t: &[f64], x: &[JointVector]) -> Vec<JointVector> {
    let n = t.len();
    (0..n)
        .map(|i| {
            let (a, b) = (i.saturating_sub(1), (i + 1).min(n - 1));
            (x[b] - x[a]) / (t[b] - t[a])
        })
        .collect()
}

/// The column names of joint `j`'s values in a header: `{prefix}{j + 1}`.
pub(super) fn joint_names(prefix: &str) -> [String; JOINTS] {
    std::array::from_fn(|j| format!("{prefix}{}", j + 1))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(t: f64, q0: f64) -> Row {
        Row {
            t,
            q: JointVector::from_element(q0),
            tau: JointVector::from_element(2.0 * q0),
            qd: None,
            qdd: None,
        }
    }

    fn time() -> Column {
        Column {
            number: 1,
            name: "t".into(),
        }
    }

    #[test]
    fn samples_interpolate_between_rows_and_derivatives_are_differentiated() {
        let (path, limits) = (Path::new("x.csv"), LogLimits::default());
        let mut log = RecordedLog::empty();
        for (k, (t, q)) in [(10.0, 0.0), (10.004, 0.4), (10.010, 1.0)]
            .iter()
            .enumerate()
        {
            log.push(path, &limits, Location::Line(k + 2), &time(), row(*t, *q))
                .unwrap();
        }
        let log = log.finish(path).unwrap();
        assert_eq!(log.derivatives(), Derivatives::Differentiated);
        let mut cursor = 0;
        let s = log.sample(0.002, &mut cursor);
        assert!((s.q[3] - 0.2).abs() < 1e-12 && (s.tau[3] - 0.4).abs() < 1e-12);
        assert!((s.qd[0] - 100.0).abs() < 1e-9, "{}", s.qd[0]);
        let s = log.sample(0.007, &mut cursor);
        assert!((s.q[0] - 0.7).abs() < 1e-12);
        // Past the end: the last row; and back to the start: the search restarts.
        assert!((log.sample(1.0, &mut cursor).q[0] - 1.0).abs() < 1e-12);
        assert!((log.sample(0.0, &mut cursor).q[0]).abs() < 1e-12);
    }

    #[test]
    fn stamps_must_increase_without_long_gaps() {
        let (path, limits) = (Path::new("x.csv"), LogLimits::default());
        let mut log = RecordedLog::empty();
        log.push(path, &limits, Location::Line(2), &time(), row(1.0, 0.0))
            .unwrap();
        let e = log
            .push(path, &limits, Location::Line(3), &time(), row(1.0, 0.0))
            .unwrap_err();
        assert!(
            e.to_string()
                .starts_with("x.csv: line 3, column 1 (`t`): stamp 1 s is not after")
        );
        let e = log
            .push(path, &limits, Location::Line(3), &time(), row(1.5, 0.0))
            .unwrap_err();
        assert!(
            e.to_string()
                .contains("more than the 0.1 s a replay bridges"),
            "{e}"
        );
        assert!(matches!(
            RecordedLog::empty().finish(path),
            Err(ReplayError::TooShort { rows: 0, .. })
        ));
    }

    #[test]
    fn values_outside_their_range_name_it() {
        assert!(check_value(Quantity::Position(3), 2.0).is_ok());
        let e = check_value(Quantity::Position(3), 2.5).unwrap_err();
        assert_eq!(e, "2.5 rad is outside -2.1817..=2.1817 rad");
        let e = check_value(Quantity::Torque(5), f64::NAN).unwrap_err();
        assert_eq!(e, "NaN is not a finite number");
        assert!(check_value(Quantity::Torque(0), 352.0).is_ok());
        assert!(check_value(Quantity::Torque(0), 352.1).is_err());
    }
}
