//! socket2 setup and the two I/O calls of the loop.

use std::io;
use std::mem::MaybeUninit;
use std::net::{Ipv4Addr, SocketAddr};
use std::time::Duration;

use serde::{Deserialize, Serialize};
use socket2::{Domain, Protocol, SockAddr, Socket, Type};

use super::EndpointError;
use crate::wire::DEFAULT_PORT;

/// Socket settings of the endpoint.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct SocketConfig {
    /// Local address to bind (default 0.0.0.0:49938, the FRI default port).
    pub bind: SocketAddr,
    /// Receive timeout of the blocking receive; bounds shutdown latency.
    pub receive_timeout: Duration,
    /// Kernel receive buffer, bytes: small, so a stall cannot queue many stale datagrams
    /// (the kernel may round it up).
    pub receive_buffer: usize,
    /// DSCP code point for our replies (46 = expedited forwarding), `None` to leave it.
    pub dscp: Option<u8>,
}

impl Default for SocketConfig {
    fn default() -> Self {
        Self {
            bind: SocketAddr::from((Ipv4Addr::UNSPECIFIED, DEFAULT_PORT)),
            receive_timeout: Duration::from_millis(100),
            receive_buffer: 4096,
            dscp: Some(46),
        }
    }
}

/// Creates, configures and binds the socket. The bind is exclusive: neither `SO_REUSEADDR`
/// nor `SO_REUSEPORT` is set, so a second program binding the same port (a second service with
/// the same configuration) fails with "address in use" instead of sharing, and taking, the
/// controller's datagrams. The buffer size and DSCP are best effort (warning on failure).
pub(crate) fn open(config: &SocketConfig) -> Result<Socket, EndpointError> {
    let addr = config.bind;
    let err = |source| EndpointError::Socket { addr, source };
    let socket =
        Socket::new(Domain::for_address(addr), Type::DGRAM, Some(Protocol::UDP)).map_err(err)?;
    if let Err(e) = socket.set_recv_buffer_size(config.receive_buffer) {
        tracing::warn!(error = %e, "receive buffer size not applied");
    }
    if let Some(dscp) = config.dscp
        && addr.is_ipv4()
        && let Err(e) = socket.set_tos_v4(u32::from(dscp) << 2)
    {
        tracing::warn!(dscp, error = %e, "DSCP not applied");
    }
    socket.bind(&SockAddr::from(addr)).map_err(err)?;
    // A zero timeout would mean "block forever" to the OS; keep at least 1 ms.
    let timeout = config.receive_timeout.max(Duration::from_millis(1));
    socket.set_read_timeout(Some(timeout)).map_err(err)?;
    Ok(socket)
}

/// Receives one datagram into `buf`: `Ok(None)` on timeout (blocking) or when nothing is
/// queued (non-blocking). A datagram longer than `buf` is cut to `buf.len()` bytes by the
/// kernel; `buf` is larger than any valid datagram, so it is still rejected as oversized.
pub(crate) fn receive(
    socket: &Socket,
    buf: &mut [u8],
    blocking: bool,
) -> io::Result<Option<(usize, SocketAddr)>> {
    // SAFETY: `MaybeUninit<u8>` has the layout of `u8`, and the kernel only writes initialised
    // bytes into the buffer, so viewing initialised bytes as possibly-uninitialised is sound.
    let uninit = unsafe { &mut *(buf as *mut [u8] as *mut [MaybeUninit<u8>]) };
    let flags = if blocking { 0 } else { libc::MSG_DONTWAIT };
    match socket.recv_from_with_flags(uninit, flags) {
        Ok((n, from)) => match from.as_socket() {
            Some(source) => Ok(Some((n.min(buf.len()), source))),
            None => Err(io::Error::new(
                io::ErrorKind::InvalidData,
                "non-IP source address",
            )),
        },
        Err(e)
            if matches!(
                e.kind(),
                io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
            ) =>
        {
            Ok(None)
        }
        Err(e) => Err(e),
    }
}

/// Sends one datagram; returns the number of bytes sent.
pub(crate) fn send(socket: &Socket, datagram: &[u8], to: SocketAddr) -> io::Result<usize> {
    socket.send_to(datagram, &SockAddr::from(to))
}
