//! The recording directory: where the operator's `record` command may write.
//!
//! The service runs as root next to the robot, and any allowed operator may send `record`, so a
//! request names only a file *in* the configured directory (`state.record_dir`): a plain name of
//! safe characters, no subdirectories, no `..`, no absolute paths. The directory is opened once
//! per request as a checked directory (`persistence::dir`: owned by the service's user, writable
//! by nobody else, below trusted parents, and not itself a symbolic link: a `recordings/`
//! replaced by a link is refused, not followed) and the file is created relative to that
//! descriptor with `O_CREAT | O_EXCL | O_NOFOLLOW`: a name that exists, including a planted
//! symlink, is refused, so a recording never overwrites anything.

use std::fs::File;
use std::path::{Path, PathBuf};

use crate::persistence::dir::{CheckedDir, DirError, Rule};

/// Longest file name, bytes (the usual `NAME_MAX`).
pub const MAX_NAME_BYTES: usize = 255;

/// Mode of new recordings (before the umask): readable by everyone, they hold no secrets.
const FILE_MODE: libc::mode_t = 0o644;

/// Errors of the recording directory.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    /// The requested name breaks the naming rule.
    #[error(
        "`path` {name:?} {rule}; give a file name for the recording directory {dir} \
         (state.record_dir): 1 to 255 characters of A-Z a-z 0-9 . _ -, not starting with . or -"
    )]
    InvalidName {
        /// The requested name.
        name: String,
        /// Which part of the rule it breaks.
        rule: &'static str,
        /// The recording directory.
        dir: PathBuf,
    },
    /// Something already exists under that name (file, directory or symlink).
    #[error("`path`: {path} already exists; recordings are never overwritten, choose another name")]
    Exists {
        /// The full path.
        path: PathBuf,
    },
    /// The directory cannot be created or opened, or is not trusted.
    #[error("recording directory: {0}")]
    Directory(#[from] DirError),
    /// Creating the file failed for another reason (permissions, disk full, ...).
    #[error("cannot create {path}: {source}")]
    Create {
        /// The full path.
        path: PathBuf,
        /// Underlying error.
        source: std::io::Error,
    },
}

impl RecordError {
    /// Whether the request is at fault (invalid arguments) rather than the system.
    pub fn is_request_error(&self) -> bool {
        matches!(self, Self::InvalidName { .. } | Self::Exists { .. })
    }
}

/// The opened recording directory.
#[derive(Debug)]
pub struct RecordDir {
    dir: CheckedDir,
}

impl RecordDir {
    /// Creates `dir` if missing and opens it, checked (see the module documentation).
    pub fn open(dir: &Path) -> Result<Self, RecordError> {
        Ok(Self {
            dir: CheckedDir::open(dir, "state.record_dir", Rule::Owned)?,
        })
    }

    /// The real path of the directory.
    pub fn path(&self) -> &Path {
        self.dir.path()
    }

    /// Checks `name` and that nothing exists under it yet; returns the full path. (The final
    /// word is [`RecordDir::create`]; this only lets a request fail before it does any work.)
    pub fn check_free(&self, name: &str) -> Result<PathBuf, RecordError> {
        let full = self.checked(name)?;
        match self.dir.entry(name) {
            Ok(None) => Ok(full),
            _ => Err(RecordError::Exists { path: full }),
        }
    }

    /// Creates the new file `name` in the directory; returns it and its full path.
    pub fn create(&self, name: &str) -> Result<(File, PathBuf), RecordError> {
        let full = self.checked(name)?;
        match self.dir.create_new(name, FILE_MODE) {
            Ok(file) => Ok((file, full)),
            // EEXIST: a file or a (possibly dangling) symlink; ELOOP: a symlink (O_NOFOLLOW).
            Err(e) if matches!(e.raw_os_error(), Some(libc::EEXIST | libc::ELOOP)) => {
                Err(RecordError::Exists { path: full })
            }
            Err(source) => Err(RecordError::Create { path: full, source }),
        }
    }

    fn invalid(&self, name: &str, rule: &'static str) -> RecordError {
        RecordError::InvalidName {
            name: name.to_owned(),
            rule,
            dir: self.dir.path().to_owned(),
        }
    }

    /// Applies the naming rule; returns the full path.
    fn checked(&self, name: &str) -> Result<PathBuf, RecordError> {
        let rule = if name.is_empty() {
            Some("is empty")
        } else if name.starts_with('/') {
            Some("is an absolute path")
        } else if name.contains('/') {
            Some("names a subdirectory or a parent (`/` and `..` are not allowed)")
        } else if name.len() > MAX_NAME_BYTES {
            Some("is longer than 255 bytes")
        } else if name.starts_with(['.', '-']) {
            Some("starts with `.` or `-`")
        } else if !name
            .bytes()
            .all(|b| b.is_ascii_alphanumeric() || b"._-".contains(&b))
        {
            Some("contains a character other than A-Z a-z 0-9 . _ -")
        } else {
            None
        };
        match rule {
            Some(rule) => Err(self.invalid(name, rule)),
            None => Ok(self.dir.join(name)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    #[test]
    fn names_outside_the_rule_are_refused_with_the_rule() {
        let dir = tempfile::tempdir().unwrap();
        let rec = RecordDir::open(&dir.path().join("rec")).unwrap();
        for (name, rule) in [
            ("", "empty"),
            ("/etc/passwd", "absolute"),
            ("../x.csv", "parent"),
            ("a/b.csv", "subdirectory"),
            ("..", "starts with"),
            ("-rf", "starts with"),
            ("a b.csv", "character"),
            ("x\0y", "character"),
        ] {
            let e = rec.create(name).unwrap_err();
            assert!(e.is_request_error(), "{name:?}: {e}");
            let text = e.to_string();
            assert!(
                text.contains("`path`") && text.contains(rule),
                "{name:?}: {text}"
            );
        }
        assert!(rec.create(&"a".repeat(256)).is_err());
        assert!(rec.create(&"a".repeat(255)).is_ok());
    }

    #[test]
    fn creates_new_files_only() {
        let dir = tempfile::tempdir().unwrap();
        let rec = RecordDir::open(&dir.path().join("rec")).unwrap();
        let (mut f, full) = rec.create("run.csv").unwrap();
        assert_eq!(full, rec.path().join("run.csv"));
        f.write_all(b"one").unwrap();
        assert!(matches!(
            rec.check_free("run.csv"),
            Err(RecordError::Exists { .. })
        ));
        assert!(matches!(
            rec.create("run.csv"),
            Err(RecordError::Exists { .. })
        ));
        assert_eq!(std::fs::read(&full).unwrap(), b"one");
        // A dangling symlink is refused too, and its target is not created.
        let target = dir.path().join("target");
        std::os::unix::fs::symlink(&target, rec.path().join("link.csv")).unwrap();
        assert!(matches!(
            rec.check_free("link.csv"),
            Err(RecordError::Exists { .. })
        ));
        assert!(matches!(
            rec.create("link.csv"),
            Err(RecordError::Exists { .. })
        ));
        assert!(!target.exists());
    }

    #[test]
    fn a_recordings_directory_replaced_by_a_symlink_is_refused_not_followed() {
        // The attack: `recordings/` replaced by a link made `record` write elsewhere.
        let dir = tempfile::tempdir().unwrap();
        let rec = dir.path().join("state/recordings");
        RecordDir::open(&rec).unwrap();
        std::fs::remove_dir(&rec).unwrap();
        let elsewhere = dir.path().join("elsewhere");
        std::fs::create_dir(&elsewhere).unwrap();
        std::os::unix::fs::symlink(&elsewhere, &rec).unwrap();
        let e = RecordDir::open(&rec).unwrap_err();
        assert!(!e.is_request_error());
        let text = e.to_string();
        assert!(
            text.contains("state.record_dir") && text.contains("symbolic link"),
            "{text}"
        );
        assert_eq!(std::fs::read_dir(&elsewhere).unwrap().count(), 0);
    }

    #[test]
    fn a_recordings_directory_another_user_owns_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let rec = dir.path().join("recordings");
        std::fs::create_dir(&rec).unwrap();
        std::os::unix::fs::chown(&rec, Some(65534), Some(65534)).unwrap();
        let text = RecordDir::open(&rec).unwrap_err().to_string();
        assert!(text.contains("owned by uid 65534"), "{text}");
    }
}
