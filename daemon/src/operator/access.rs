//! Who may talk to the service: the [`AccessPolicy`] checked at `accept`, and the [`Peer`] the
//! kernel reported, which becomes each request's origin.

use fri_api::origin::Origin;
use fri_api::protocol::{ErrorCode, OperatorError, Ros2Caller};
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
    /// User ids whose requests may say they forward a ROS 2 caller (the bridge's user),
    /// besides the service's own.
    pub ros2_bridge_uids: Vec<u32>,
}

impl AccessPolicy {
    /// The peer of an accepted connection on `what` (`operator socket`, `stop socket`), or
    /// why it is refused (logged here).
    pub fn admit(&self, stream: &UnixStream, what: &str) -> Result<Peer, Refusal> {
        match stream.peer_cred() {
            Ok(cred) if self.allows(cred.uid(), cred.gid()) => Ok(Peer {
                uid: cred.uid(),
                pid: cred.pid().unwrap_or(0),
                ros2_bridge: self.may_claim_ros2(cred.uid()),
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

    /// Whether a peer of user `uid` may claim to forward a ROS 2 caller: the service's own
    /// user or one of `ros2_bridge_uids` (root is not implied: an origin in the audit log is
    /// only as good as who may write it).
    pub fn may_claim_ros2(&self, uid: u32) -> bool {
        // SAFETY: geteuid has no preconditions and cannot fail.
        let own = unsafe { libc::geteuid() };
        uid == own || self.ros2_bridge_uids.contains(&uid)
    }
}

/// The credentials of an operator-socket client, as the kernel reported them at `accept`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Peer {
    /// User id.
    pub uid: u32,
    /// Process id (0 when the kernel did not report it).
    pub pid: i32,
    /// Its requests may claim a ROS 2 caller ([`AccessPolicy::may_claim_ros2`]).
    pub ros2_bridge: bool,
}

impl Peer {
    /// Err, naming the field and the setting, when a request claims the ROS 2 caller `ros2`
    /// and this peer is not the bridge's user: its requests are refused, its `stop` is
    /// honoured with its own origin ([`Peer::origin`]).
    pub fn check_claim(self, ros2: Option<&Ros2Caller>) -> Result<(), OperatorError> {
        if ros2.is_none() || self.ros2_bridge {
            return Ok(());
        }
        Err(OperatorError::new(
            ErrorCode::InvalidArguments,
            format!(
                "ros2: uid {} may not forward a ROS 2 caller; only the bridge's user may \
                 (the service's own, or operator.ros2_bridge_uids)",
                self.uid
            ),
        ))
    }

    /// The origin of a request from this peer, forwarded for `ros2` when it says so and may
    /// ([`Peer::check_claim`]); a claim it may not make is dropped: the peer's own origin.
    pub fn origin(self, ros2: Option<Ros2Caller>) -> Origin {
        match ros2.filter(|_| self.ros2_bridge) {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_the_bridges_user_may_claim_a_ros2_caller() {
        // SAFETY: no preconditions.
        let own = unsafe { libc::geteuid() };
        let stranger = if own == 4242 { 4243 } else { 4242 };
        let p = AccessPolicy {
            allowed_uids: vec![stranger],
            allowed_gids: Vec::new(),
            ros2_bridge_uids: Vec::new(),
        };
        assert!(p.may_claim_ros2(own));
        assert!(!p.may_claim_ros2(stranger));
        // root may connect, not speak for the bridge
        assert!(own == 0 || !p.may_claim_ros2(0));
        let caller = Ros2Caller {
            participant: "01.02.03".into(),
            authenticated: true,
        };
        let forged = Peer {
            uid: stranger,
            pid: 7,
            ros2_bridge: p.may_claim_ros2(stranger),
        };
        let e = forged.check_claim(Some(&caller)).unwrap_err();
        assert_eq!(e.code, ErrorCode::InvalidArguments);
        assert!(
            e.message.starts_with("ros2:") && e.message.contains("operator.ros2_bridge_uids"),
            "{e:?}"
        );
        // its stop still counts, as its own
        assert!(matches!(
            forged.origin(Some(caller.clone())),
            Origin::Operator { uid, pid: 7 } if uid == stranger
        ));
        assert!(forged.check_claim(None).is_ok());
        let listed = AccessPolicy {
            ros2_bridge_uids: vec![stranger],
            ..p
        };
        let bridge = Peer {
            uid: stranger,
            pid: 7,
            ros2_bridge: listed.may_claim_ros2(stranger),
        };
        assert!(bridge.check_claim(Some(&caller)).is_ok());
        assert!(matches!(
            bridge.origin(Some(caller)),
            Origin::Ros2 {
                authenticated: true,
                ..
            }
        ));
    }
}
