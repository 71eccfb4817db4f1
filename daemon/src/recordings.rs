//! The recording directory: where the operator's `record` command may write.
//!
//! The service runs as root next to the robot, and any allowed operator may send `record`, so a
//! request names only a file *in* the configured directory (`state.record_dir`): a plain name of
//! safe characters, no subdirectories, no `..`, no absolute paths. The directory is opened once
//! per request (its canonical path resolved, then opened with `O_DIRECTORY | O_NOFOLLOW`) and the
//! file is created relative to that descriptor with `O_CREAT | O_EXCL | O_NOFOLLOW`: a name that
//! exists, including a planted symlink, is refused, so a recording never overwrites anything.

use std::ffi::CString;
use std::fs::{File, OpenOptions};
use std::os::fd::{AsRawFd, FromRawFd, OwnedFd};
use std::os::unix::fs::OpenOptionsExt;
use std::path::{Path, PathBuf};

/// Longest file name, bytes (the usual `NAME_MAX`).
pub const MAX_NAME_BYTES: usize = 255;

/// Mode of new recordings (before the umask): readable by everyone, they hold no secrets.
const FILE_MODE: libc::c_uint = 0o644;

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
    /// The directory cannot be created or opened.
    #[error("recording directory {dir} (state.record_dir): {action}: {source}")]
    Directory {
        /// The configured directory.
        dir: PathBuf,
        /// What was being done.
        action: &'static str,
        /// Underlying error.
        source: std::io::Error,
    },
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
    path: PathBuf,
    fd: OwnedFd,
}

impl RecordDir {
    /// Creates `dir` if missing and opens it (its canonical path, without following a symlink
    /// at the last component).
    pub fn open(dir: &Path) -> Result<Self, RecordError> {
        let fail = |action| {
            move |source| RecordError::Directory {
                dir: dir.to_owned(),
                action,
                source,
            }
        };
        std::fs::create_dir_all(dir).map_err(fail("create"))?;
        let path = dir.canonicalize().map_err(fail("resolve"))?;
        let file = OpenOptions::new()
            .read(true)
            .custom_flags(libc::O_DIRECTORY | libc::O_NOFOLLOW | libc::O_CLOEXEC)
            .open(&path)
            .map_err(fail("open"))?;
        Ok(Self {
            path,
            fd: file.into(),
        })
    }

    /// The canonical path of the directory.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Checks `name` and that nothing exists under it yet; returns the full path. (The final
    /// word is [`RecordDir::create`]; this only lets a request fail before it does any work.)
    pub fn check_free(&self, name: &str) -> Result<PathBuf, RecordError> {
        let full = self.checked(name)?;
        match std::fs::symlink_metadata(&full) {
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(full),
            _ => Err(RecordError::Exists { path: full }),
        }
    }

    /// Creates the new file `name` in the directory; returns it and its full path.
    pub fn create(&self, name: &str) -> Result<(File, PathBuf), RecordError> {
        let full = self.checked(name)?;
        // `checked` allows no NUL byte.
        let c_name = CString::new(name).map_err(|_| self.invalid(name, "contains a NUL byte"))?;
        let flags =
            libc::O_WRONLY | libc::O_CREAT | libc::O_EXCL | libc::O_NOFOLLOW | libc::O_CLOEXEC;
        // SAFETY: the directory descriptor is open for the lifetime of `self`, `c_name` is a
        // NUL-terminated string that outlives the call, and openat has no other preconditions.
        let fd = unsafe { libc::openat(self.fd.as_raw_fd(), c_name.as_ptr(), flags, FILE_MODE) };
        if fd < 0 {
            let source = std::io::Error::last_os_error();
            // EEXIST: a file or a (possibly dangling) symlink; ELOOP: a symlink (O_NOFOLLOW).
            return Err(match source.raw_os_error() {
                Some(libc::EEXIST) | Some(libc::ELOOP) => RecordError::Exists { path: full },
                _ => RecordError::Create { path: full, source },
            });
        }
        // SAFETY: openat just returned this descriptor; nothing else owns it.
        let file = unsafe { File::from_raw_fd(fd) };
        Ok((file, full))
    }

    fn invalid(&self, name: &str, rule: &'static str) -> RecordError {
        RecordError::InvalidName {
            name: name.to_owned(),
            rule,
            dir: self.path.clone(),
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
            None => Ok(self.path.join(name)),
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
    fn a_symlinked_directory_is_resolved_once_and_reported_canonically() {
        let dir = tempfile::tempdir().unwrap();
        let real = dir.path().join("real");
        std::fs::create_dir(&real).unwrap();
        let link = dir.path().join("link");
        std::os::unix::fs::symlink(&real, &link).unwrap();
        let rec = RecordDir::open(&link).unwrap();
        assert_eq!(rec.path(), real.canonicalize().unwrap());
        let (_, full) = rec.create("x.csv").unwrap();
        assert!(real.join("x.csv").exists() && full.starts_with(real.canonicalize().unwrap()));
    }
}
