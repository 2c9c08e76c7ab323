//! PURE. Who may use the gateway's Modbus TCP face: client addresses as an allow-list entry
//! names them, one IP (`10.0.0.5`, `fd00::5`) or a network in CIDR form (`10.0.0.0/24`).

use std::fmt;
use std::net::IpAddr;
use std::str::FromStr;

use ipnet::IpNet;
use thiserror::Error;

/// An IP address or network an allow-list admits (one address: its full prefix).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ClientNet(IpNet);

/// An allow-list entry that is not an IP address or a CIDR network.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("{text:?} {reason}")]
pub struct ClientNetError {
    /// The text given.
    pub text: String,
    /// What is wrong with it.
    pub reason: String,
}

impl ClientNet {
    /// Whether `peer` is this address, or inside this network. An IPv4 client seen on an IPv6
    /// socket (`::ffff:10.0.0.5`) is matched as the IPv4 address it is.
    #[must_use]
    pub fn contains(&self, peer: IpAddr) -> bool {
        self.0.contains(&peer.to_canonical())
    }
}

impl FromStr for ClientNet {
    type Err = ClientNetError;

    fn from_str(text: &str) -> Result<Self, Self::Err> {
        let bad = |reason: &str| ClientNetError {
            text: text.to_owned(),
            reason: reason.to_owned(),
        };
        let trimmed = text.trim();
        let Some((ip, prefix)) = trimmed.split_once('/') else {
            let ip: IpAddr = trimmed.parse().map_err(|_| {
                bad("must be an IP address or a CIDR network, e.g. \"10.0.0.5\" or \"10.0.0.0/24\"")
            })?;
            return Ok(Self(IpNet::from(ip)));
        };
        let ip: IpAddr = ip.parse().map_err(|_| {
            bad("must be an IP address or a CIDR network, e.g. \"10.0.0.5\" or \"10.0.0.0/24\"")
        })?;
        let width = if ip.is_ipv4() { 32 } else { 128 };
        prefix
            .parse::<u8>()
            .ok()
            .and_then(|p| IpNet::new(ip, p).ok())
            .map(Self)
            .ok_or_else(|| bad(&format!("has a prefix length outside 0..={width}")))
    }
}

impl fmt::Display for ClientNet {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.0.prefix_len() == self.0.max_prefix_len() {
            write!(f, "{}", self.0.addr())
        } else {
            write!(f, "{}", self.0)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn net(text: &str) -> ClientNet {
        text.parse().unwrap()
    }

    fn ip(text: &str) -> IpAddr {
        text.parse().unwrap()
    }

    #[test]
    fn one_address_admits_only_itself() {
        let one = net("10.0.0.5");
        assert!(one.contains(ip("10.0.0.5")));
        assert!(!one.contains(ip("10.0.0.6")));
        assert!(
            one.contains(ip("::ffff:10.0.0.5")),
            "IPv4 seen on an IPv6 socket"
        );
        assert_eq!(one.to_string(), "10.0.0.5");
    }

    #[test]
    fn a_network_admits_its_addresses() {
        let lan = net("10.0.0.0/24");
        assert!(lan.contains(ip("10.0.0.1")) && lan.contains(ip("10.0.0.255")));
        assert!(!lan.contains(ip("10.0.1.1")));
        assert!(!lan.contains(ip("fd00::1")));
        assert!(net("0.0.0.0/0").contains(ip("192.168.1.1")));
        let v6 = net("fd00::/64");
        assert!(v6.contains(ip("fd00::5")) && !v6.contains(ip("fd01::5")));
        assert_eq!(lan.to_string(), "10.0.0.0/24");
    }

    #[test]
    fn bad_entries_name_the_text_and_the_limit() {
        let e = "10.0.0.0/33".parse::<ClientNet>().unwrap_err().to_string();
        assert_eq!(e, "\"10.0.0.0/33\" has a prefix length outside 0..=32");
        let e = "plc-hmi".parse::<ClientNet>().unwrap_err().to_string();
        assert!(e.contains("must be an IP address or a CIDR network"), "{e}");
        assert!("fd00::/129".parse::<ClientNet>().is_err());
    }
}
