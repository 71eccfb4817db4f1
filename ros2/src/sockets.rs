//! Pins the DDS participant's UDP sockets to the loopback interface.
//!
//! RustDDS 0.15 binds every socket of a participant to `0.0.0.0` whatever
//! `with_only_networks` says (`src/dds/participant.rs`, `DomainParticipantInner::new`: the SPDP
//! and user-traffic listeners, multicast and unicast, are `UDPListener::new_*("0.0.0.0", ..)`;
//! `src/network/udp_sender.rs`, `UDPSender::new_with_networks`: the unicast sender binds
//! `0.0.0.0:0`); `with_only_networks` only filters the advertised locators and the multicast
//! interfaces. The bridge cannot choose the address, so after the participant is built it finds
//! the sockets the participant created (the process's UDP sockets that were not there before)
//! and binds each to the interface's device (`SO_BINDTODEVICE`): the kernel then delivers to them
//! only datagrams that arrived on that interface (`ss -uanp` shows `0.0.0.0%lo:7400`).
//!
//! Only for a loopback interface: a socket bound to `eth0` no longer receives what processes of
//! the same host send to `eth0`'s address (the kernel delivers that through `lo`), which would cut
//! the robot PC's own nodes off. For other interfaces docs/ros2.md gives the firewall rule.

use std::collections::BTreeSet;
use std::os::fd::RawFd;

/// A socket of this process: its descriptor and the kernel's inode of the socket.
pub type SocketId = (RawFd, u64);

/// The UDP (IPv4 or IPv6) sockets open in this process.
pub fn udp_sockets() -> std::io::Result<BTreeSet<SocketId>> {
    let mut out = BTreeSet::new();
    for entry in std::fs::read_dir("/proc/self/fd")? {
        let entry = entry?;
        let Some(fd) = entry
            .file_name()
            .to_str()
            .and_then(|n| n.parse::<RawFd>().ok())
        else {
            continue;
        };
        // The descriptor may close between the listing and the look-up: then it is not ours.
        let Ok(target) = std::fs::read_link(entry.path()) else {
            continue;
        };
        let Some(inode) = target
            .to_str()
            .and_then(|t| t.strip_prefix("socket:["))
            .and_then(|t| t.strip_suffix(']'))
            .and_then(|t| t.parse::<u64>().ok())
        else {
            continue;
        };
        let domain = sockopt_int(fd, libc::SO_DOMAIN);
        let protocol = sockopt_int(fd, libc::SO_PROTOCOL);
        if matches!(domain, Some(libc::AF_INET | libc::AF_INET6))
            && protocol == Some(libc::IPPROTO_UDP)
        {
            out.insert((fd, inode));
        }
    }
    Ok(out)
}

fn sockopt_int(fd: RawFd, name: libc::c_int) -> Option<libc::c_int> {
    let mut value: libc::c_int = 0;
    let mut len = std::mem::size_of::<libc::c_int>() as libc::socklen_t;
    // SAFETY: `value` and `len` are valid for writes of an int; a descriptor that is not a
    // socket (or closed meanwhile) makes the call fail, which is handled.
    let r = unsafe {
        libc::getsockopt(
            fd,
            libc::SOL_SOCKET,
            name,
            (&raw mut value).cast(),
            &raw mut len,
        )
    };
    (r == 0).then_some(value)
}

/// The device a socket is bound to (`None`: none, or not a socket).
pub fn bound_device(fd: RawFd) -> Option<String> {
    let mut name = [0u8; libc::IFNAMSIZ];
    let mut len = name.len() as libc::socklen_t;
    // SAFETY: `name` is valid for `len` bytes of writes.
    let r = unsafe {
        libc::getsockopt(
            fd,
            libc::SOL_SOCKET,
            libc::SO_BINDTODEVICE,
            name.as_mut_ptr().cast(),
            &raw mut len,
        )
    };
    if r != 0 {
        return None;
    }
    let n = name.iter().position(|&b| b == 0).unwrap_or(0);
    (n > 0).then(|| String::from_utf8_lossy(&name[..n]).into_owned())
}

/// Binds the socket `fd` to the device `interface`.
fn bind_to_device(fd: RawFd, interface: &str) -> std::io::Result<()> {
    let name = interface.as_bytes();
    if name.is_empty() || name.len() >= libc::IFNAMSIZ {
        return Err(std::io::Error::other(format!(
            "interface name `{interface}` is not 1 to {} bytes",
            libc::IFNAMSIZ - 1
        )));
    }
    // SAFETY: `name` is valid for `name.len()` bytes of reads.
    let r = unsafe {
        libc::setsockopt(
            fd,
            libc::SOL_SOCKET,
            libc::SO_BINDTODEVICE,
            name.as_ptr().cast(),
            name.len() as libc::socklen_t,
        )
    };
    if r == 0 {
        Ok(())
    } else {
        Err(std::io::Error::last_os_error())
    }
}

/// Binds every UDP socket of `after` that is not in `before` (the sockets a participant created
/// in between) to `interface`; returns how many.
pub fn pin_new(
    before: &BTreeSet<SocketId>,
    after: &BTreeSet<SocketId>,
    interface: &str,
) -> std::io::Result<usize> {
    let mut pinned = 0;
    for &(fd, _) in after.difference(before) {
        bind_to_device(fd, interface)?;
        pinned += 1;
    }
    Ok(pinned)
}

/// Whether `interface` is a loopback interface.
pub fn is_loopback(interface: &str) -> bool {
    netdev::get_interfaces()
        .iter()
        .any(|i| i.name == interface && i.is_loopback())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::fd::AsRawFd as _;

    #[test]
    fn a_new_udp_socket_is_found_and_bound_to_loopback() {
        let before = udp_sockets().unwrap();
        let socket = std::net::UdpSocket::bind("0.0.0.0:0").unwrap();
        let tcp = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        let after = udp_sockets().unwrap();
        let fd = socket.as_raw_fd();
        assert!(after.iter().any(|&(f, _)| f == fd));
        assert!(!after.iter().any(|&(f, _)| f == tcp.as_raw_fd()));
        assert_eq!(bound_device(fd), None);
        // Other tests of this binary may open sockets meanwhile: pin ours alone.
        let ours: BTreeSet<SocketId> = after.iter().filter(|s| s.0 == fd).copied().collect();
        assert_eq!(pin_new(&before, &ours, "lo").unwrap(), 1);
        assert_eq!(bound_device(fd).as_deref(), Some("lo"));
        assert!(is_loopback("lo"));
        assert!(bind_to_device(fd, "").is_err());
    }
}
