//! Atomic replacement of a file in a checked directory, so a crash or power cut leaves the old or
//! the new file, never a torn one, and nothing planted in the directory is followed.
//!
//! Write protocol ([`write_atomic`]): create the temporary file `.<name>.tmp.<pid>` with
//! `O_CREAT | O_EXCL | O_NOFOLLOW` relative to the directory's descriptor, write and `fsync` it,
//! `renameat` it over the target (atomic on POSIX file systems; the target's entry is replaced,
//! never followed), then `fsync` the directory so the rename itself is durable. A writer killed
//! before the rename leaves its temporary file; [`remove_stale_temp_files`] removes those of
//! writers that no longer run.

use std::io::Write;
use std::path::Path;

use super::PersistError;
use super::dir::{CheckedDir, DirError, Rule};

/// Mode of the state files (before the umask): readable by everyone (they hold no secrets),
/// writable by the service only.
const FILE_MODE: libc::mode_t = 0o644;

/// Name of the temporary file a writer with process id `pid` uses for the file `name`.
pub(crate) fn temp_name(name: &str, pid: u32) -> String {
    format!(".{name}.tmp.{pid}")
}

/// Replaces `name` in `dir` with `bytes` atomically (see the module documentation). Something
/// other than a regular file under the temporary name (a planted symbolic link) makes the write
/// fail; a regular file there (left by an earlier process with this pid) is replaced.
pub fn write_atomic(dir: &CheckedDir, name: &str, bytes: &[u8]) -> Result<(), PersistError> {
    let tmp = temp_name(name, std::process::id());
    let fail = |action: &'static str, file: &str| {
        let file = file.to_owned();
        move |source| PersistError::Dir(dir.io_error(action, &file, source))
    };
    let mut file = match dir.create_new(&tmp, FILE_MODE) {
        Ok(f) => f,
        Err(e) if matches!(e.raw_os_error(), Some(libc::EEXIST | libc::ELOOP)) => {
            match dir.entry(&tmp).map_err(fail("inspect", &tmp))? {
                Some(st) if st.is_file() => {
                    dir.remove(&tmp)
                        .map_err(fail("remove stale temporary file", &tmp))?;
                    dir.create_new(&tmp, FILE_MODE)
                        .map_err(fail("create", &tmp))?
                }
                found => {
                    return Err(PersistError::Planted {
                        path: dir.join(&tmp),
                        found: found.map_or("file", |s| s.kind()),
                    });
                }
            }
        }
        Err(e) => return Err(fail("create", &tmp)(e)),
    };
    let written = file
        .write_all(bytes)
        .map_err(fail("write", &tmp))
        .and_then(|()| file.sync_all().map_err(fail("fsync", &tmp)))
        .and_then(|()| dir.rename(&tmp, name).map_err(fail("rename onto", name)));
    if written.is_err() {
        // Best effort: the error above is the one to report.
        let _ = dir.remove(&tmp);
    }
    written?;
    dir.sync()
        .map_err(|e| PersistError::Dir(dir.error("fsync", e)))
}

/// Replaces the file at `path` with `bytes` atomically; its directory is checked as the state
/// directory is ([`Rule::Owned`]) and created if missing.
pub fn atomic_write(path: &Path, bytes: &[u8]) -> Result<(), PersistError> {
    let (Some(parent), Some(name)) = (path.parent(), path.file_name().and_then(|n| n.to_str()))
    else {
        return Err(PersistError::Dir(DirError::Io {
            key: "file",
            action: "write",
            path: path.to_owned(),
            source: std::io::ErrorKind::InvalidInput.into(),
        }));
    };
    let parent = if parent.as_os_str().is_empty() {
        Path::new(".")
    } else {
        parent
    };
    let dir = CheckedDir::open(parent, "directory", Rule::Owned)?;
    write_atomic(&dir, name, bytes)
}

/// Removes `.<file>.tmp.<pid>` files of the state files `files` whose writer process no longer
/// exists. Files of a running process stay (it may be between write and rename); symbolic links
/// and anything else in the directory are not touched.
pub fn remove_stale_temp_files(dir: &CheckedDir, files: &[&str]) -> Result<(), PersistError> {
    let names = dir
        .names()
        .map_err(|e| PersistError::Dir(dir.error("list", e)))?;
    for name in names {
        let Some(name) = name.to_str() else { continue };
        let Some(pid) = temp_file_pid(name, files) else {
            continue;
        };
        let is_file = dir.entry(name).ok().flatten().is_some_and(|s| s.is_file());
        if is_file && !process_exists(pid) {
            match dir.remove(name) {
                Ok(()) => tracing::info!(
                    file = %dir.join(name).display(),
                    "removed stale temporary state file"
                ),
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                Err(e) => {
                    return Err(PersistError::Dir(dir.io_error(
                        "remove stale temporary file",
                        name,
                        e,
                    )));
                }
            }
        }
    }
    Ok(())
}

/// The writer's pid when `name` is a temporary file of one of `files`.
fn temp_file_pid(name: &str, files: &[&str]) -> Option<u32> {
    // The inverse of `temp_name`.
    let rest = name.strip_prefix('.')?;
    files
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
