//! Creating the operator socket's listener, synchronously, so the service binds it before the
//! FRI endpoint answers anything (a start that cannot offer `stop` never drives the arm).
//!
//! The socket's directory is a checked directory (`persistence::dir`, [`Rule::Trusted`]: owned
//! by root or the service's user, not writable by group or others unless root-owned and sticky,
//! and so are its parents; created with mode 0755 if missing), so no other user can replace the
//! socket the operators' `stop` goes to. A socket file already at the path is removed only when
//! it is stale (connecting is refused: a crashed instance left it); a live server there, or
//! anything that is not a socket (checked without following symlinks), is an error.

use std::os::unix::fs::PermissionsExt;
use std::os::unix::net::{UnixListener, UnixStream};
use std::path::Path;

use crate::persistence::dir::{CheckedDir, Rule};

/// Binds the operator socket at `path` with mode 0660, non-blocking (ready for tokio's
/// `UnixListener::from_std`).
pub fn bind(path: &Path) -> Result<UnixListener, ServerError> {
    let err = |action: &'static str, at: &Path| {
        let path = at.to_owned();
        move |source| ServerError::Io {
            action,
            path,
            source,
        }
    };
    let Some(name) = path.file_name().and_then(|n| n.to_str()) else {
        return Err(err("bind", path)(std::io::ErrorKind::InvalidInput.into()));
    };
    let parent = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let dir = CheckedDir::open(parent, "operator.socket's directory", Rule::Trusted)
        .map_err(ServerError::Directory)?;
    let full = dir.join(name);
    match dir.entry(name).map_err(err("inspect", path))? {
        None => {}
        Some(st) if !st.is_socket() => {
            return Err(ServerError::NotASocket {
                path: path.to_owned(),
                found: st.kind(),
            });
        }
        Some(_) => match UnixStream::connect(&full) {
            Ok(_) => return Err(ServerError::InUse(path.to_owned())),
            Err(e) if e.kind() == std::io::ErrorKind::ConnectionRefused => {
                dir.remove(name).map_err(err("remove stale socket", path))?;
            }
            Err(source) => {
                return Err(ServerError::Unprobeable {
                    path: path.to_owned(),
                    source,
                });
            }
        },
    }
    // By path, in a directory nobody else may change.
    let listener = UnixListener::bind(&full).map_err(err("bind", path))?;
    std::fs::set_permissions(&full, std::fs::Permissions::from_mode(0o660))
        .map_err(err("set mode 0660 on", path))?;
    listener
        .set_nonblocking(true)
        .map_err(err("set non-blocking", path))?;
    Ok(listener)
}

/// The next client of `listener`, or `None` once `shutdown` turns true. An accept error (e.g.
/// out of file descriptors) is logged as `what`'s and retried after 10 ms, never spun on.
pub async fn next_client(
    listener: &tokio::net::UnixListener,
    shutdown: &mut tokio::sync::watch::Receiver<bool>,
    what: &str,
) -> Option<tokio::net::UnixStream> {
    loop {
        let accepted = tokio::select! {
            a = listener.accept() => a,
            _ = shutdown.wait_for(|s| *s) => return None,
        };
        match accepted {
            Ok((s, _)) => return Some(s),
            Err(e) => {
                tracing::warn!(error = %e, "{what} accept failed");
                tokio::time::sleep(std::time::Duration::from_millis(10)).await;
            }
        }
    }
}

/// Errors setting up the socket.
#[derive(Debug, thiserror::Error)]
pub enum ServerError {
    /// Creating the directory, binding or setting the mode failed.
    #[error("{action} {path}: {source}")]
    Io {
        /// What was being done.
        action: &'static str,
        /// The path.
        path: std::path::PathBuf,
        /// Underlying error.
        source: std::io::Error,
    },
    /// The socket's directory (or a parent) is not trusted, or cannot be created or opened.
    #[error("{0}")]
    Directory(crate::persistence::dir::DirError),
    /// Another server answers on the socket path.
    #[error("another service is already listening on {0}")]
    InUse(std::path::PathBuf),
    /// Something other than a socket exists at the path; it is never removed.
    #[error(
        "{path} is a {found}, not a socket; refusing to replace it (remove it or choose another \
         path)"
    )]
    NotASocket {
        /// The path.
        path: std::path::PathBuf,
        /// What was found there, e.g. `regular file`.
        found: &'static str,
    },
    /// A socket file exists but connecting failed for another reason than "nobody listens", so
    /// it cannot be called stale.
    #[error("{path}: cannot tell whether the existing socket is stale: {source}")]
    Unprobeable {
        /// The path.
        path: std::path::PathBuf,
        /// The connect error.
        source: std::io::Error,
    },
}
