//! A directory the service trusts, held open: every file in it is opened relative to the held
//! descriptor (`openat`) without following symbolic links, so nothing that happens to the path
//! after the check (a directory renamed, a symlink planted) redirects a read or a write.
//!
//! The rule, after OpenSSH's `StrictModes`: the directory itself is owned by the service's
//! effective user and is not writable by group or others ([`Rule::Owned`]); every parent is owned
//! by root or that user and is not writable by group or others, except a root-owned (or
//! own) sticky directory such as `/tmp`, where nobody else can rename or remove what the service
//! created ([`Rule::Trusted`]). The path's existing parents are resolved as `realpath` does (a
//! symlinked `/var/run` is followed, then every component of the real path is checked); the
//! directory itself must not be a symbolic link. Missing directories are created with mode 0755
//! and checked like the rest. ACLs are not inspected.

use std::ffi::OsString;
use std::fs::File;
use std::io::{self, Read};
use std::os::fd::{AsFd, AsRawFd, BorrowedFd, OwnedFd};
use std::path::{Component, Path, PathBuf};

pub(crate) use super::sys::{Stat, cstring, fstat, openat};
use super::sys::{lstat_at, names, single};

/// Mode of the directories the service creates (before the umask): no write for group or others.
const DIR_MODE: libc::mode_t = 0o755;

/// What a directory must satisfy.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Rule {
    /// Owned by the service's effective user, not writable by group or others (the state and
    /// recording directories).
    Owned,
    /// Owned by root or the service's user, not writable by group or others unless sticky (the
    /// parents, and the operator socket's directory).
    Trusted,
}

/// Errors of a checked directory.
#[derive(Debug, thiserror::Error)]
pub enum DirError {
    /// A file-system call failed.
    #[error("{key} {path}: cannot {action}: {source}")]
    Io {
        /// The configuration key the path comes from (e.g. `state.dir`).
        key: &'static str,
        /// What was being done.
        action: &'static str,
        /// The path involved.
        path: PathBuf,
        /// Underlying error.
        source: io::Error,
    },
    /// The directory, a parent or a file breaks the ownership and mode rule.
    #[error(
        "{key} {path}: refusing to trust it: {reason}. The service trusts only a directory its \
         own user (uid {euid}) owns and no other user can write, below parents owned by root or \
         that user that are not writable by group or others (root-owned sticky directories such \
         as /tmp excepted); files in it must be regular files owned by root or that user, not \
         writable by group or others. Fix the owner or mode (chown, chmod go-w), or choose \
         another directory"
    )]
    Untrusted {
        /// The configuration key the path comes from.
        key: &'static str,
        /// The offending path.
        path: PathBuf,
        /// Which part of the rule it breaks.
        reason: String,
        /// The service's effective user id.
        euid: u32,
    },
}

/// The service's effective user id.
pub fn euid() -> u32 {
    // SAFETY: geteuid has no preconditions and cannot fail.
    unsafe { libc::geteuid() }
}

/// Why `st` breaks `rule` for a directory (`None`: it holds).
fn breaks(rule: Rule, st: &Stat) -> Option<String> {
    let me = euid();
    let mode = st.mode & 0o7777;
    if !st.is_dir() {
        return Some(format!("it is a {}, not a directory", st.kind()));
    }
    match rule {
        Rule::Owned if st.uid != me => Some(format!(
            "it is owned by uid {}, not by the service's user",
            st.uid
        )),
        Rule::Owned if st.writable_by_others() => Some(format!(
            "it is writable by group or others (mode {mode:04o})"
        )),
        Rule::Trusted if st.uid != 0 && st.uid != me => Some(format!(
            "it is owned by uid {}, neither root nor the service's user",
            st.uid
        )),
        Rule::Trusted if st.writable_by_others() && !st.sticky() => Some(format!(
            "it is writable by group or others (mode {mode:04o}) and not sticky"
        )),
        _ => None,
    }
}

/// A checked directory, held open (see the module documentation).
#[derive(Debug)]
pub struct CheckedDir {
    key: &'static str,
    path: PathBuf,
    fd: OwnedFd,
}

impl CheckedDir {
    /// Opens `path` (creating it and its missing parents), checking the directory against
    /// `rule` and every parent against [`Rule::Trusted`]; `key` names the configuration key in
    /// errors.
    pub fn open(path: &Path, key: &'static str, rule: Rule) -> Result<Self, DirError> {
        let untrusted = |path: &Path, reason: String| DirError::Untrusted {
            key,
            path: path.to_owned(),
            reason,
            euid: euid(),
        };
        let io_err = |action, path: &Path| {
            let path = path.to_owned();
            move |source| DirError::Io {
                key,
                action,
                path,
                source,
            }
        };
        let Some(name) = path.file_name() else {
            return Err(untrusted(path, "it does not name a directory".into()));
        };
        let parent = match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            _ => Path::new("."),
        };
        let (real, missing) = resolve_existing(parent).map_err(|e| match e {
            Resolve::Io(source) => io_err("resolve", parent)(source),
            Resolve::Dots => untrusted(path, "`.` or `..` after a missing directory".into()),
        })?;
        let mut names: Vec<OsString> = real
            .components()
            .filter_map(|c| match c {
                Component::Normal(n) => Some(n.to_owned()),
                _ => None,
            })
            .collect();
        names.extend(missing);
        names.push(name.to_owned());

        let root = Path::new("/");
        let mut at = PathBuf::from("/");
        let mut fd: OwnedFd = File::open(root).map_err(io_err("open", root))?.into();
        let st = fstat(fd.as_fd()).map_err(io_err("inspect", root))?;
        if let Some(reason) = breaks(Rule::Trusted, &st) {
            return Err(untrusted(root, format!("parent: {reason}")));
        }
        let last = names.len() - 1;
        for (i, n) in names.iter().enumerate() {
            at.push(n);
            let c = cstring(n).map_err(io_err("open", &at))?;
            // Parents need only search permission (O_PATH); the directory itself is read
            // (listing, fsync).
            let access = if i == last {
                libc::O_RDONLY
            } else {
                libc::O_PATH
            };
            let flags = access | libc::O_DIRECTORY | libc::O_NOFOLLOW;
            let mut created = false;
            let next = match openat(fd.as_fd(), &c, flags, 0) {
                Err(e) if e.raw_os_error() == Some(libc::ENOENT) => {
                    // SAFETY: `fd` is open and `c` is NUL-terminated; mkdirat has no other
                    // preconditions.
                    let r = unsafe { libc::mkdirat(fd.as_raw_fd(), c.as_ptr(), DIR_MODE) };
                    if r != 0 {
                        let e = io::Error::last_os_error();
                        if e.raw_os_error() != Some(libc::EEXIST) {
                            return Err(io_err("create", &at)(e));
                        }
                    } else {
                        created = true;
                        tracing::info!(key, directory = %at.display(), "created directory");
                    }
                    openat(fd.as_fd(), &c, flags, 0)
                }
                r => r,
            };
            let next = match next {
                Ok(f) => f,
                Err(e) if matches!(e.raw_os_error(), Some(libc::ELOOP | libc::ENOTDIR)) => {
                    let what = lstat_at(fd.as_fd(), &c)
                        .map(|s| s.kind())
                        .unwrap_or("file that is not a directory");
                    return Err(untrusted(&at, format!("it is a {what}, not a directory")));
                }
                Err(e) => return Err(io_err("open", &at)(e)),
            };
            let st = fstat(next.as_fd()).map_err(io_err("inspect", &at))?;
            // A directory the service created is its own: held to the directory's rule.
            let rule_here = if i == last || created {
                rule
            } else {
                Rule::Trusted
            };
            if let Some(reason) = breaks(rule_here, &st) {
                let reason = if i == last {
                    reason
                } else {
                    format!("parent: {reason}")
                };
                return Err(untrusted(&at, reason));
            }
            fd = next;
        }
        Ok(Self { key, path: at, fd })
    }

    /// The directory's real path (its parents resolved).
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The held descriptor.
    pub(crate) fn fd(&self) -> BorrowedFd<'_> {
        self.fd.as_fd()
    }

    /// The full path of `name` in the directory (for messages).
    pub fn join(&self, name: &str) -> PathBuf {
        self.path.join(name)
    }

    /// An error for the file `name`.
    pub(crate) fn io_error(&self, action: &'static str, name: &str, source: io::Error) -> DirError {
        DirError::Io {
            key: self.key,
            action,
            path: self.join(name),
            source,
        }
    }

    /// An error for the directory itself.
    pub(crate) fn error(&self, action: &'static str, source: io::Error) -> DirError {
        DirError::Io {
            key: self.key,
            action,
            path: self.path.clone(),
            source,
        }
    }

    fn untrusted(&self, name: &str, reason: String) -> DirError {
        DirError::Untrusted {
            key: self.key,
            path: self.join(name),
            reason,
            euid: euid(),
        }
    }

    /// Reads the file `name` (at most `max_bytes`); `None` when it does not exist. A symbolic
    /// link, anything but a regular file, a file owned by another user than root or the
    /// service's, or one writable by group or others is refused.
    pub fn read(&self, name: &str, max_bytes: u64) -> Result<Option<Vec<u8>>, DirError> {
        let c = single(name).map_err(|e| self.io_error("open", name, e))?;
        // O_NONBLOCK: a named pipe planted under the name must not block the open.
        let flags = libc::O_RDONLY | libc::O_NOFOLLOW | libc::O_NONBLOCK | libc::O_NOCTTY;
        let fd = match openat(self.fd(), &c, flags, 0) {
            Ok(fd) => fd,
            Err(e) if e.raw_os_error() == Some(libc::ENOENT) => return Ok(None),
            Err(e) if e.raw_os_error() == Some(libc::ELOOP) => {
                return Err(self.untrusted(name, "it is a symbolic link".into()));
            }
            Err(e) => return Err(self.io_error("open", name, e)),
        };
        let st = fstat(fd.as_fd()).map_err(|e| self.io_error("inspect", name, e))?;
        if !st.is_file() {
            return Err(self.untrusted(name, format!("it is a {}", st.kind())));
        }
        if st.uid != 0 && st.uid != euid() {
            return Err(self.untrusted(
                name,
                format!(
                    "it is owned by uid {}, neither root nor the service's user",
                    st.uid
                ),
            ));
        }
        if st.writable_by_others() {
            return Err(self.untrusted(
                name,
                format!(
                    "it is writable by group or others (mode {:04o})",
                    st.mode & 0o7777
                ),
            ));
        }
        if st.size > max_bytes {
            return Err(self.untrusted(
                name,
                format!("it holds {} bytes, more than {max_bytes}", st.size),
            ));
        }
        let mut bytes = Vec::new();
        File::from(fd)
            .take(max_bytes + 1)
            .read_to_end(&mut bytes)
            .map_err(|e| self.io_error("read", name, e))?;
        if bytes.len() as u64 > max_bytes {
            return Err(self.untrusted(name, format!("it grew beyond {max_bytes} bytes")));
        }
        Ok(Some(bytes))
    }

    /// Creates the new file `name` (`O_CREAT | O_EXCL | O_NOFOLLOW`: anything under that name,
    /// a symbolic link included, makes it fail with `EEXIST` or `ELOOP`), open for writing.
    pub fn create_new(&self, name: &str, mode: libc::mode_t) -> io::Result<File> {
        let c = single(name)?;
        let flags = libc::O_WRONLY | libc::O_CREAT | libc::O_EXCL | libc::O_NOFOLLOW;
        openat(self.fd(), &c, flags, mode).map(File::from)
    }

    /// Renames `from` to `to` within the directory (replacing `to`'s entry, never following it).
    pub fn rename(&self, from: &str, to: &str) -> io::Result<()> {
        let (f, t) = (single(from)?, single(to)?);
        let d = self.fd.as_raw_fd();
        // SAFETY: the descriptor is open and both names are NUL-terminated.
        if unsafe { libc::renameat(d, f.as_ptr(), d, t.as_ptr()) } != 0 {
            return Err(io::Error::last_os_error());
        }
        Ok(())
    }

    /// Removes the entry `name` (a file or a symbolic link, never its target).
    pub fn remove(&self, name: &str) -> io::Result<()> {
        let c = single(name)?;
        // SAFETY: the descriptor is open and `c` is NUL-terminated.
        if unsafe { libc::unlinkat(self.fd.as_raw_fd(), c.as_ptr(), 0) } != 0 {
            return Err(io::Error::last_os_error());
        }
        Ok(())
    }

    /// What is under `name`, without following a symbolic link (`None`: nothing).
    pub(crate) fn entry(&self, name: &str) -> io::Result<Option<Stat>> {
        match lstat_at(self.fd(), &single(name)?) {
            Ok(s) => Ok(Some(s)),
            Err(e) if e.raw_os_error() == Some(libc::ENOENT) => Ok(None),
            Err(e) => Err(e),
        }
    }

    /// Flushes the directory's entries (a rename in it) to the disk.
    pub fn sync(&self) -> io::Result<()> {
        // SAFETY: the descriptor is open.
        if unsafe { libc::fsync(self.fd.as_raw_fd()) } != 0 {
            return Err(io::Error::last_os_error());
        }
        Ok(())
    }

    /// The names in the directory (without `.` and `..`).
    pub fn names(&self) -> io::Result<Vec<OsString>> {
        names(self.fd())
    }
}

enum Resolve {
    Io(io::Error),
    Dots,
}

/// Splits `dir` into its deepest existing ancestor, resolved like `realpath` (absolute, no
/// symbolic links), and the names below it that do not exist yet.
fn resolve_existing(dir: &Path) -> Result<(PathBuf, Vec<OsString>), Resolve> {
    let mut missing = Vec::new();
    let mut at = dir;
    loop {
        match at.canonicalize() {
            Ok(real) => {
                missing.reverse();
                return Ok((real, missing));
            }
            Err(e) if e.kind() == io::ErrorKind::NotFound => {}
            Err(e) => return Err(Resolve::Io(e)),
        }
        match at.components().next_back() {
            Some(Component::Normal(n)) => missing.push(n.to_owned()),
            _ => return Err(Resolve::Dots),
        }
        at = match at.parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            _ => Path::new("."),
        };
    }
}

#[cfg(test)]
#[path = "dir_tests.rs"]
mod tests;
