//! The instance lock: one service per state directory. Two services on one state directory
//! would overwrite each other's state and, with one configuration, fight over the controller;
//! the second one's start fails instead, naming the lock and the holder's pid.
//!
//! The lock is `flock(LOCK_EX | LOCK_NB)` on `fri-service.lock` in the state directory, opened
//! relative to the checked directory with `O_NOFOLLOW`; the kernel releases it when the holder
//! exits, however it ends, so a killed service never leaves a stale lock. The file holds the
//! holder's pid for the message (informational: the lock is the `flock`, not the file).

use std::io::{Read, Seek, Write};
use std::os::fd::AsRawFd;
use std::path::PathBuf;

use super::dir::{CheckedDir, cstring, fstat, openat};

/// Name of the lock file in the state directory.
pub const LOCK_FILE: &str = "fri-service.lock";

/// Longest pid text read from a lock file, bytes.
const PID_BYTES: u64 = 32;

/// Errors taking the instance lock.
#[derive(Debug, thiserror::Error)]
pub enum LockError {
    /// Another process holds the lock.
    #[error(
        "another fri-service{holder} holds the instance lock {path}: one service per state \
         directory (state.dir); stop it, or give this one its own state.dir"
    )]
    Held {
        /// The lock file.
        path: PathBuf,
        /// " (pid N)" when the file names the holder, else empty.
        holder: String,
    },
    /// The lock file cannot be opened or locked.
    #[error("instance lock {path}: {action}: {source}")]
    Io {
        /// The lock file.
        path: PathBuf,
        /// What was being done.
        action: &'static str,
        /// Underlying error.
        source: std::io::Error,
    },
    /// Something other than a regular file is under the lock's name.
    #[error(
        "instance lock {path} is a {found}, not a regular file; refusing to use it (remove it)"
    )]
    NotAFile {
        /// The lock file.
        path: PathBuf,
        /// What was found.
        found: &'static str,
    },
}

/// The held instance lock (released when dropped, or when the process ends).
#[derive(Debug)]
pub struct InstanceLock {
    _file: std::fs::File,
    path: PathBuf,
}

impl InstanceLock {
    /// Takes the lock of the state directory `dir`, or fails at once when it is held.
    pub fn acquire(dir: &CheckedDir) -> Result<Self, LockError> {
        let path = dir.join(LOCK_FILE);
        let io = |action| {
            let path = path.clone();
            move |source| LockError::Io {
                path,
                action,
                source,
            }
        };
        let name = cstring(LOCK_FILE.as_ref()).map_err(io("open"))?;
        let flags = libc::O_RDWR | libc::O_CREAT | libc::O_NOFOLLOW | libc::O_NONBLOCK;
        let fd = match openat(dir.fd(), &name, flags, 0o644) {
            Err(e) if e.raw_os_error() == Some(libc::ELOOP) => {
                return Err(LockError::NotAFile {
                    path,
                    found: "symbolic link",
                });
            }
            r => r.map_err(io("open"))?,
        };
        let st = fstat(std::os::fd::AsFd::as_fd(&fd)).map_err(io("inspect"))?;
        if !st.is_file() {
            return Err(LockError::NotAFile {
                path,
                found: st.kind(),
            });
        }
        let mut file = std::fs::File::from(fd);
        // SAFETY: the descriptor is open; flock has no memory preconditions.
        if unsafe { libc::flock(file.as_raw_fd(), libc::LOCK_EX | libc::LOCK_NB) } != 0 {
            let e = std::io::Error::last_os_error();
            if e.raw_os_error() != Some(libc::EWOULDBLOCK) {
                return Err(io("lock")(e));
            }
            let mut text = String::new();
            let _ = (&mut file).take(PID_BYTES).read_to_string(&mut text);
            let holder = text
                .trim()
                .parse::<u32>()
                .map_or(String::new(), |pid| format!(" (pid {pid})"));
            return Err(LockError::Held { path, holder });
        }
        file.set_len(0).map_err(io("truncate"))?;
        file.rewind().map_err(io("write"))?;
        writeln!(file, "{}", std::process::id()).map_err(io("write"))?;
        Ok(Self { _file: file, path })
    }

    /// The lock file.
    pub fn path(&self) -> &std::path::Path {
        &self.path
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::persistence::dir::Rule;

    #[test]
    fn a_second_holder_fails_naming_the_lock_and_the_pid_and_takes_it_after_release() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = CheckedDir::open(&tmp.path().join("state"), "state.dir", Rule::Owned).unwrap();
        let first = InstanceLock::acquire(&dir).unwrap();
        // flock belongs to the open file: a second open in this very process conflicts too.
        let e = InstanceLock::acquire(&dir).unwrap_err().to_string();
        assert!(e.contains(LOCK_FILE), "{e}");
        assert!(e.contains(&format!("(pid {})", std::process::id())), "{e}");
        drop(first);
        let again = InstanceLock::acquire(&dir).unwrap();
        assert_eq!(again.path(), dir.join(LOCK_FILE));
    }

    #[test]
    fn a_symlink_under_the_lock_name_is_refused_and_not_followed() {
        let tmp = tempfile::tempdir().unwrap();
        let state = tmp.path().join("state");
        let dir = CheckedDir::open(&state, "state.dir", Rule::Owned).unwrap();
        let target = tmp.path().join("elsewhere");
        std::os::unix::fs::symlink(&target, state.join(LOCK_FILE)).unwrap();
        let e = InstanceLock::acquire(&dir).unwrap_err();
        assert!(matches!(e, LockError::NotAFile { .. }), "{e}");
        assert!(!target.exists(), "the symlink was followed");
    }
}
