//! Persistent service state: applied payload, tare samples, calibration and the collision
//! monitor's settings, each a JSON file in
//! the state directory, written atomically so a crash or power cut leaves the old or the new file,
//! never a torn one.
//!
//! Write protocol ([`atomic_write`]): write a temporary file in the same directory, `fsync` it,
//! `rename` it over the target (atomic on POSIX file systems), then `fsync` the directory so the
//! rename itself is durable. A writer killed before the rename leaves its temporary file; the
//! next [`StateStore::open`] removes those of writers that no longer run.

use std::fs::{self, File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize, de::DeserializeOwned};

/// Errors of the state store.
#[derive(Debug, thiserror::Error)]
pub enum PersistError {
    /// File-system operation failed.
    #[error("{action} {path}: {source}")]
    Io {
        /// What was being done.
        action: &'static str,
        /// The file or directory involved.
        path: PathBuf,
        /// Underlying error.
        source: std::io::Error,
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

fn io(action: &'static str, path: &Path) -> impl FnOnce(std::io::Error) -> PersistError {
    let path = path.to_owned();
    move |source| PersistError::Io {
        action,
        path,
        source,
    }
}

/// Name of the temporary file a writer with process id `pid` uses for the file `name`.
fn temp_name(name: &str, pid: u32) -> String {
    format!(".{name}.tmp.{pid}")
}

/// Replaces `path` with `bytes` atomically: temp file in the same directory, fsync, rename,
/// fsync of the directory.
pub fn atomic_write(path: &Path, bytes: &[u8]) -> Result<(), PersistError> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_owned(),
        _ => PathBuf::from("."),
    };
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "state".to_owned());
    // The pid keeps two writers from sharing a temp file; a killed writer's leftover is removed
    // by the next `StateStore::open` (see `remove_stale_temp_files`).
    let tmp = dir.join(temp_name(&name, std::process::id()));
    {
        let mut file = OpenOptions::new()
            .write(true)
            .create(true)
            .truncate(true)
            .open(&tmp)
            .map_err(io("create", &tmp))?;
        file.write_all(bytes).map_err(io("write", &tmp))?;
        file.sync_all().map_err(io("fsync", &tmp))?;
    }
    fs::rename(&tmp, path).map_err(io("rename onto", path))?;
    File::open(&dir)
        .and_then(|d| d.sync_all())
        .map_err(io("fsync directory", &dir))?;
    Ok(())
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
    dir: PathBuf,
}

const PAYLOAD_FILE: &str = "payload.json";
const TARE_FILE: &str = "tare.json";
const CALIBRATION_FILE: &str = "calibration.json";
const MONITOR_FILE: &str = "monitor.json";

impl StateStore {
    /// Opens (and creates if missing) the state directory and removes temporary files that
    /// killed writers left behind.
    pub fn open(dir: &Path) -> Result<Self, PersistError> {
        fs::create_dir_all(dir).map_err(io("create directory", dir))?;
        remove_stale_temp_files(dir)?;
        Ok(Self {
            dir: dir.to_owned(),
        })
    }

    /// The state directory.
    pub fn dir(&self) -> &Path {
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

    /// Loads the controller-model calibration (opaque JSON produced by the estimator).
    pub fn load_calibration(&self) -> Result<Option<serde_json::Value>, PersistError> {
        self.load(CALIBRATION_FILE)
    }

    /// Persists the calibration (`None` clears it).
    pub fn save_calibration(
        &self,
        calibration: Option<&serde_json::Value>,
    ) -> Result<(), PersistError> {
        self.save(CALIBRATION_FILE, calibration)
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

    fn load<T: DeserializeOwned>(&self, name: &str) -> Result<Option<T>, PersistError> {
        let path = self.dir.join(name);
        let text = match fs::read_to_string(&path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(io("read", &path)(e)),
        };
        // A cleared entry is stored as JSON `null`.
        serde_json::from_str::<Option<T>>(&text).map_err(|e| PersistError::Corrupt {
            path,
            message: e.to_string(),
        })
    }

    fn save<T: Serialize>(&self, name: &str, value: Option<&T>) -> Result<(), PersistError> {
        let path = self.dir.join(name);
        let mut text =
            serde_json::to_string_pretty(&value).map_err(|e| PersistError::Serialise {
                path: path.clone(),
                message: e.to_string(),
            })?;
        text.push('\n');
        atomic_write(&path, text.as_bytes())
    }
}

/// Removes `.<state file>.tmp.<pid>` files of the store's own state files whose writer process
/// no longer exists. Files of a running process stay (it may be between write and rename), and
/// nothing else in the directory is touched.
fn remove_stale_temp_files(dir: &Path) -> Result<(), PersistError> {
    for entry in fs::read_dir(dir).map_err(io("list directory", dir))? {
        let entry = entry.map_err(io("list directory", dir))?;
        let Some(pid) = entry.file_name().to_str().and_then(temp_file_pid) else {
            continue;
        };
        let path = entry.path();
        // Only regular files: a symlink or directory with that name is not ours.
        let is_file = fs::symlink_metadata(&path).is_ok_and(|m| m.file_type().is_file());
        if is_file && !process_exists(pid) {
            match fs::remove_file(&path) {
                Ok(()) => {
                    tracing::info!(file = %path.display(), "removed stale temporary state file")
                }
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                Err(e) => return Err(io("remove stale temporary file", &path)(e)),
            }
        }
    }
    Ok(())
}

/// The writer's pid when `name` is a temporary file of one of the store's state files.
fn temp_file_pid(name: &str) -> Option<u32> {
    // The inverse of `temp_name`.
    let rest = name.strip_prefix('.')?;
    [PAYLOAD_FILE, TARE_FILE, CALIBRATION_FILE, MONITOR_FILE]
        .iter()
        .find_map(|f| rest.strip_prefix(f)?.strip_prefix(".tmp."))
        .filter(|pid| !pid.is_empty() && pid.bytes().all(|b| b.is_ascii_digit()))
        .and_then(|pid| pid.parse().ok())
}

/// Whether a process with this pid exists (signal 0 checks without sending anything).
fn process_exists(pid: u32) -> bool {
    let Ok(pid) = libc::pid_t::try_from(pid) else {
        return false;
    };
    if pid <= 0 {
        // 0 and negative values address process groups, not a writer.
        return true;
    }
    // SAFETY: kill with signal 0 performs only the permission and existence checks.
    let r = unsafe { libc::kill(pid, 0) };
    // EPERM: the process exists but belongs to someone else.
    r == 0 || std::io::Error::last_os_error().raw_os_error() != Some(libc::ESRCH)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn payload_round_trips_and_clears() {
        let dir = tempfile::tempdir().unwrap();
        let store = StateStore::open(dir.path()).unwrap();
        assert_eq!(store.load_payload().unwrap(), None);
        let p = AppliedPayload {
            mass: 3.028,
            com: [0.0, 0.0, 0.119],
        };
        store.save_payload(Some(&p)).unwrap();
        let reopened = StateStore::open(dir.path()).unwrap();
        assert_eq!(reopened.load_payload().unwrap(), Some(p));
        reopened.save_payload(None).unwrap();
        assert_eq!(reopened.load_payload().unwrap(), None);
    }

    #[test]
    fn tare_and_calibration_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let store = StateStore::open(&dir.path().join("nested/state")).unwrap();
        let tare = Tare {
            around: [0.1; 7],
            samples: vec![StaticSample::new(
                [0.2; 7].into(),
                [1.5; 7].into(),
                [-1.0; 7].into(),
            )],
            pattern_poses: Some(1),
            taken_unix_s: Some(1.8e9),
            targets: Some(vec![[0.2; 7]]),
            pattern: Some(fri_api::pattern::PatternKind::Centred),
            step_deg: Some(5.0),
            clock: Some(Clocks {
                service_s: 12.0,
                controller_s: 3600.5,
            }),
            session: Some(SessionMark {
                instance: 42,
                restarts: 3,
            }),
        };
        store.save_tare(Some(&tare)).unwrap();
        assert_eq!(store.load_tare().unwrap(), Some(tare));
        let cal = serde_json::json!({"delta": [1.0, 2.0]});
        store.save_calibration(Some(&cal)).unwrap();
        assert_eq!(store.load_calibration().unwrap(), Some(cal));
    }

    #[test]
    fn monitor_settings_round_trip_with_their_payload() {
        let dir = tempfile::tempdir().unwrap();
        let store = StateStore::open(dir.path()).unwrap();
        assert_eq!(store.load_monitor().unwrap(), None);
        let m = StoredMonitor {
            thresholds: [9.0, 9.0, 6.0, 6.0, 4.0, 2.0, 2.0],
            gains: [300.0; 7],
            reaction: fri_api::protocol::ReactionMode::Pause,
            pause_s: 1.5,
            set_for_payload: Some(AppliedPayload {
                mass: 3.028,
                com: [0.0, 0.0, 0.119],
            }),
            schedule: None,
            calibration: None,
        };
        store.save_monitor(Some(&m)).unwrap();
        let reopened = StateStore::open(dir.path()).unwrap();
        assert_eq!(reopened.load_monitor().unwrap(), Some(m));
        let text = fs::read_to_string(reopened.monitor_path()).unwrap();
        assert!(text.contains("\"reaction\": \"pause\""), "{text}");
        reopened.save_monitor(None).unwrap();
        assert_eq!(reopened.load_monitor().unwrap(), None);
    }

    #[test]
    fn corrupt_file_is_reported_not_ignored() {
        let dir = tempfile::tempdir().unwrap();
        let store = StateStore::open(dir.path()).unwrap();
        fs::write(dir.path().join(PAYLOAD_FILE), "{\"mass\": 3.0").unwrap();
        assert!(matches!(
            store.load_payload(),
            Err(PersistError::Corrupt { .. })
        ));
    }

    #[test]
    fn open_removes_temp_files_of_dead_writers_only() {
        let dir = tempfile::tempdir().unwrap();
        // Above the kernel's pid_max (at most 2^22): no such process can exist.
        let dead = dir.path().join(".payload.json.tmp.4999999");
        let live = dir
            .path()
            .join(format!(".tare.json.tmp.{}", std::process::id()));
        let foreign = dir.path().join(".notes.txt.tmp.4999999");
        for f in [&dead, &live, &foreign] {
            fs::write(f, "partial").unwrap();
        }
        StateStore::open(dir.path()).unwrap();
        assert!(!dead.exists(), "a dead writer's temp file must be removed");
        assert!(live.exists(), "a running writer's temp file must stay");
        assert!(foreign.exists(), "files the store does not own must stay");
    }

    #[test]
    fn atomic_write_leaves_no_temp_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.json");
        atomic_write(&path, b"one").unwrap();
        atomic_write(&path, b"two").unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"two");
        let names: Vec<_> = fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names.len(), 1, "{names:?}");
    }
}
