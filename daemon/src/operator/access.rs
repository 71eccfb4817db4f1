//! Who may talk to the service: the [`AccessPolicy`] checked at `accept`, and the [`Peer`] the
//! kernel reported, which becomes each request's origin.

use fri_api::origin::Origin;
use fri_api::protocol::Ros2Caller;

/// Who may connect: root, the server's own uid, listed uids, or listed primary gids.
#[derive(Debug, Clone, Default)]
pub struct AccessPolicy {
    /// Additional allowed user ids.
    pub allowed_uids: Vec<u32>,
    /// Allowed group ids (the peer's primary gid as reported by SO_PEERCRED).
    pub allowed_gids: Vec<u32>,
}

impl AccessPolicy {
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
