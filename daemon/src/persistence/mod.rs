//! Persistent service state: applied payload, tare samples, calibration and the collision
//! monitor's settings, each a JSON file in the state directory.
//!
//! The state directory is a [`dir::CheckedDir`]: owned by the service's user and writable by
//! nobody else, held open, every file opened relative to it without following symbolic links
//! (a planted link or a file writable by others is refused, never read or written through).
//! Files are replaced atomically ([`atomic`]), so a crash or power cut leaves the old or the new
//! file, never a torn one. The directory also holds the instance lock ([`lock`]).

pub mod atomic;
pub mod dir;
pub mod lock;
mod sys;

use std::path::{Path, PathBuf};
use std::sync::Arc;

use serde::{Deserialize, Serialize, de::DeserializeOwned};

pub use atomic::atomic_write;
use dir::{CheckedDir, DirError, Rule};

/// Largest state file read, bytes (a tare or calibration is a few kB).
pub const MAX_STATE_FILE_BYTES: u64 = 16 << 20;

/// Errors of the state store.
#[derive(Debug, thiserror::Error)]
pub enum PersistError {
    /// The directory or a file in it cannot be used (file-system error, or it breaks the
    /// ownership and mode rule).
    #[error(transparent)]
    Dir(#[from] DirError),
    /// Something other than a regular file is under a temporary file's name.
    #[error(
        "{path} is a {found}, not a temporary file of the service; refusing to write through it \
         (remove it)"
    )]
    Planted {
        /// The temporary file's path.
        path: PathBuf,
        /// What was found there.
        found: &'static str,
    },
    /// A state file exists but does not parse (edited by hand or from another version).
    #[error("state file {path} is not valid: {message}")]
    Corrupt {
        /// The file.
        path: PathBuf,
        /// Parser message.
        message: String,
    },
    /// Serialisation failed (should not happen for the service's own types).
    #[error("cannot serialise state for {path}: {message}")]
    Serialise {
        /// The file.
        path: PathBuf,
        /// Serialiser message.
        message: String,
    },
}

/// A payload applied to the observer, in the last DH frame of the model (frame 7 for the LWR).
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct AppliedPayload {
    /// Mass, kg.
    pub mass: f64,
    /// Centre of mass in frame 7, m.
    pub com: [f64; 3],
}

/// One static sample of the 7-joint LWR (`estimator`'s type): measured joint positions (rad),
/// measured joint torques (msrJntTrq, Nm) and the controller's gravity vector (Nm), each averaged
/// over the sample window; stored as `{"q": [..], "tau": [..], "gravity": [..]}`.
pub type StaticSample = estimator::samples::StaticSample<7>;

/// Unloaded samples at the estimation poses, subtracted from loaded samples (tare).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Tare {
    /// The pick pose around which the pattern was driven, rad.
    pub around: [f64; 7],
    /// One sample per pose, in the order driven (a revisit of the first pose last).
    pub samples: Vec<StaticSample>,
    /// Poses of the pattern (without the revisit); absent in files written before revisits:
    /// then every sample is a pattern pose.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pattern_poses: Option<usize>,
    /// When the tare ended, s since the Unix epoch (relates its controller times to a later
    /// estimate's after the controller restarted); absent in older files.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub taken_unix_s: Option<f64>,
    /// The commanded pose of every sample, in the order driven, rad: an estimate visits them
    /// in reverse (the tare's last samples and the estimate's first are nearest in time);
    /// absent in older files (then the estimate recomputes the pattern).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub targets: Option<Vec<[f64; 7]>>,
    /// The pattern and its increment (deg); absent in older files (paper, 7°).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pattern: Option<fri_api::pattern::PatternKind>,
    /// The pattern's increment, deg; absent in older files.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub step_deg: Option<f64>,
    /// The service's and the controller's clocks when the tare ended; absent in older files.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub clock: Option<Clocks>,
    /// The service instance and the controller restarts its session had counted when the tare
    /// ended (a later estimate tells a restart since); absent in older files.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub session: Option<SessionMark>,
}

/// Which controller session a stored tare belongs to: the service instance that took it and
/// the controller restarts (sequence counter reset after a silence) it had counted by then.
/// Counts of one instance are comparable; another instance's start from zero.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
#[serde(deny_unknown_fields)]
pub struct SessionMark {
    /// The service instance (`ServiceCore::instance`).
    pub instance: u64,
    /// Controller restarts its FRI session had counted.
    pub restarts: u64,
}

/// One instant on the service's clock (`time_s` of the states and samples, counted from the
/// controller's sequence, which restarts or skips unknown time across a controller restart or a
/// new source) and on the controller's own (`intf.timestamp`), s. Two of them tell how much
/// controller time passed between a tare and an estimate even when the service's clock could
/// not count it.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Clocks {
    /// The service's time, s.
    pub service_s: f64,
    /// The controller's timestamp, s.
    pub controller_s: f64,
}

impl Tare {
    /// Number of pattern poses the tare was taken at.
    pub fn pattern_len(&self) -> usize {
        self.pattern_poses.unwrap_or(self.samples.len())
    }
}

/// The collision monitor's settings set by `collision configure`, restored at the next start in
/// place of the configuration file's `[observer]` thresholds and gains and `[reaction]`. Arming
/// is not stored: a restarted service arms as its configuration says (default armed), so a
/// reboot never leaves the arm unprotected without anyone asking for it.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct StoredMonitor {
    /// Detection thresholds per joint, Nm.
    pub thresholds: [f64; 7],
    /// Observer gains K_I per joint, 1/s.
    pub gains: [f64; 7],
    /// Reaction to a detected contact.
    pub reaction: fri_api::protocol::ReactionMode,
    /// Pause of the `pause` reaction, s.
    pub pause_s: f64,
    /// The payload applied when the settings were configured (`null`: none): the thresholds
    /// fit the residual's free-motion level with that payload compensated.
    pub set_for_payload: Option<AppliedPayload>,
    /// The motion schedule of calibrated thresholds (`collision-calibrate`; absent: static
    /// thresholds).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub schedule: Option<fri_api::results::ThresholdSchedule>,
    /// How the calibrated settings were obtained (absent: not calibrated).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub calibration: Option<fri_api::results::CalibrationInfo>,
}

/// Directory holding the service's persistent state.
#[derive(Debug, Clone)]
pub struct StateStore {
    dir: Arc<CheckedDir>,
}

const PAYLOAD_FILE: &str = "payload.json";
const TARE_FILE: &str = "tare.json";
const MONITOR_FILE: &str = "monitor.json";
/// The state files (their temporary files are cleaned at open).
const STATE_FILES: [&str; 3] = [PAYLOAD_FILE, TARE_FILE, MONITOR_FILE];

impl StateStore {
    /// Opens (and creates if missing) the state directory, checking it and its parents
    /// ([`dir`]), and removes temporary files that killed writers left behind.
    pub fn open(dir: &Path) -> Result<Self, PersistError> {
        let dir = CheckedDir::open(dir, "state.dir", Rule::Owned)?;
        atomic::remove_stale_temp_files(&dir, &STATE_FILES)?;
        Ok(Self { dir: Arc::new(dir) })
    }

    /// The state directory's real path.
    pub fn dir(&self) -> &Path {
        self.dir.path()
    }

    /// The held state directory (for the instance lock).
    pub fn checked_dir(&self) -> &CheckedDir {
        &self.dir
    }

    /// Loads the applied payload; `None` when none was ever applied or it was cleared.
    pub fn load_payload(&self) -> Result<Option<AppliedPayload>, PersistError> {
        self.load(PAYLOAD_FILE)
    }

    /// Persists the applied payload (`None` clears it).
    pub fn save_payload(&self, payload: Option<&AppliedPayload>) -> Result<(), PersistError> {
        self.save(PAYLOAD_FILE, payload)
    }

    /// Loads the tare samples.
    pub fn load_tare(&self) -> Result<Option<Tare>, PersistError> {
        self.load(TARE_FILE)
    }

    /// Persists the tare samples (`None` clears them).
    pub fn save_tare(&self, tare: Option<&Tare>) -> Result<(), PersistError> {
        self.save(TARE_FILE, tare)
    }

    /// Loads the collision monitor's stored settings; `None` when never configured.
    pub fn load_monitor(&self) -> Result<Option<StoredMonitor>, PersistError> {
        self.load(MONITOR_FILE)
    }

    /// Persists the collision monitor's settings (`None` returns to the configuration file's).
    pub fn save_monitor(&self, monitor: Option<&StoredMonitor>) -> Result<(), PersistError> {
        self.save(MONITOR_FILE, monitor)
    }

    /// Path of the monitor settings file (for messages).
    pub fn monitor_path(&self) -> PathBuf {
        self.dir.join(MONITOR_FILE)
    }

    /// Path of the applied payload's file (for messages).
    pub fn payload_path(&self) -> PathBuf {
        self.dir.join(PAYLOAD_FILE)
    }

    /// Path of the tare's file (for messages).
    pub fn tare_path(&self) -> PathBuf {
        self.dir.join(TARE_FILE)
    }

    fn load<T: DeserializeOwned>(&self, name: &str) -> Result<Option<T>, PersistError> {
        let Some(bytes) = self.dir.read(name, MAX_STATE_FILE_BYTES)? else {
            return Ok(None);
        };
        // A cleared entry is stored as JSON `null`.
        serde_json::from_slice::<Option<T>>(&bytes).map_err(|e| PersistError::Corrupt {
            path: self.dir.join(name),
            message: e.to_string(),
        })
    }

    fn save<T: Serialize>(&self, name: &str, value: Option<&T>) -> Result<(), PersistError> {
        let mut text =
            serde_json::to_string_pretty(&value).map_err(|e| PersistError::Serialise {
                path: self.dir.join(name),
                message: e.to_string(),
            })?;
        text.push('\n');
        atomic::write_atomic(&self.dir, name, text.as_bytes())
    }
}

#[cfg(test)]
mod tests;
