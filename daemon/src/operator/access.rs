//! Who may talk to the service: the [`AccessPolicy`] checked at `accept`, and the [`Peer`] the
//! kernel reported, which becomes each request's origin.

use fri_api::origin::Origin;
use fri_api::protocol::Ros2Caller;
use tokio::net::UnixStream;
use tracing::warn;

/// What a refused client is told.
pub const DENIED: &str = "permission denied: uid/gid not allowed by operator.allowed_uids/gids";

/// Why a connection was not admitted.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Refusal {
    /// Its credentials are not allowed: it is told [`DENIED`].
    Denied,
    /// The kernel did not report its credentials: it is closed without a word.
    Unknown,
}

/// Who may connect: root, the server's own uid, listed uids, or listed primary gids.
#[derive(Debug, Clone, Default)]
pub struct AccessPolicy {
    /// Additional allowed user ids.
    pub allowed_uids: Vec<u32>,
    /// Allowed group ids (the peer's primary gid as reported by SO_PEERCRED).
    pub allowed_gids: Vec<u32>,
}

impl AccessPolicy {
    /// The peer of an accepted connection on `what` (`operator socket`, `stop socket`), or
    /// why it is refused (logged here).
    pub fn admit(&self, stream: &UnixStream, what: &str) -> Result<Peer, Refusal> {
        match stream.peer_cred() {
            Ok(cred) if self.allows(cred.uid(), cred.gid()) => Ok(Peer {
                uid: cred.uid(),
                pid: cred.pid().unwrap_or(0),
            }),
            Ok(cred) => {
                warn!(
                    uid = cred.uid(),
                    gid = cred.gid(),
                    "{what} connection refused"
                );
                Err(Refusal::Denied)
            }
            Err(e) => {
                warn!(error = %e, "cannot read {what} peer credentials");
                Err(Refusal::Unknown)
            }
        }
    }

    /// Whether a peer with these credentials may talk to the service.
    pub fn allows(&self, uid: u32, gid: u32) -> bool {
        // SAFETY: geteuid has no preconditions and cannot fail.
        let own = unsafe { libc::geteuid() };
        uid == 0
            || uid == own
            || self.allowed_uids.contains(&uid)
            || self.allowed_gids.contains(&gid)
    }
}

/// The credentials of an operator-socket client, as the kernel reported them at `accept`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Peer {
    /// User id.
    pub uid: u32,
    /// Process id (0 when the kernel did not report it).
    pub pid: i32,
}

impl Peer {
    /// The origin of a request from this peer, forwarded for `ros2` when it says so.
    pub fn origin(self, ros2: Option<Ros2Caller>) -> Origin {
        match ros2 {
            None => Origin::Operator {
                uid: self.uid,
                pid: self.pid,
            },
            Some(c) => Origin::Ros2 {
                participant: c.participant,
                authenticated: c.authenticated,
                uid: self.uid,
                pid: self.pid,
            },
        }
    }
}
