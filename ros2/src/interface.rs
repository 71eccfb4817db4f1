//! The network interface DDS is pinned to: a name resolved to its addresses, or one address.

use std::net::IpAddr;

/// Errors resolving `ros2.interface`.
#[derive(Debug, thiserror::Error)]
pub enum InterfaceError {
    /// No interface has this name or address.
    #[error("no network interface or address `{name}` (interfaces: {known})")]
    Unknown {
        /// The configured value.
        name: String,
        /// The interfaces found, comma-separated.
        known: String,
    },
    /// The interface exists but has no IP address.
    #[error("network interface `{0}` has no IP address")]
    NoAddress(String),
}

/// The IP addresses of the interface named `name`, or `name` itself when it is an address of
/// one of the interfaces.
pub fn addresses(name: &str) -> Result<Vec<IpAddr>, InterfaceError> {
    resolve(name).map(|(_, a)| a)
}

/// The interface's name and the addresses DDS uses: every address of the interface named
/// `name`, or `name` alone when it is one interface's address.
pub fn resolve(name: &str) -> Result<(String, Vec<IpAddr>), InterfaceError> {
    let interfaces = netdev::get_interfaces();
    let of = |i: &netdev::Interface| -> Vec<IpAddr> {
        i.ipv4
            .iter()
            .map(|n| IpAddr::V4(n.addr()))
            .chain(i.ipv6.iter().map(|n| IpAddr::V6(n.addr())))
            .collect()
    };
    if let Ok(ip) = name.parse::<IpAddr>() {
        if let Some(i) = interfaces.iter().find(|i| of(i).contains(&ip)) {
            return Ok((i.name.clone(), vec![ip]));
        }
    } else if let Some(i) = interfaces.iter().find(|i| i.name == name) {
        let addrs = of(i);
        if addrs.is_empty() {
            return Err(InterfaceError::NoAddress(name.to_owned()));
        }
        return Ok((i.name.clone(), addrs));
    }
    Err(InterfaceError::Unknown {
        name: name.to_owned(),
        known: interfaces
            .iter()
            .map(|i| i.name.as_str())
            .collect::<Vec<_>>()
            .join(", "),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn loopback_resolves_by_name_and_by_address_and_unknown_names_fail() {
        let lo = addresses("lo").unwrap();
        assert!(lo.contains(&IpAddr::from([127, 0, 0, 1])));
        assert_eq!(
            addresses("127.0.0.1").unwrap(),
            vec![IpAddr::from([127, 0, 0, 1])]
        );
        let e = addresses("no-such-if0").unwrap_err().to_string();
        assert!(e.contains("no-such-if0") && e.contains("lo"), "{e}");
        assert!(addresses("192.0.2.77").is_err());
        assert_eq!(resolve("127.0.0.1").unwrap().0, "lo");
    }
}
