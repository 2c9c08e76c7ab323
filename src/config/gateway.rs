//! `[robots.NAME.gateway]` -> [`GatewaySettings`]: which of the PLC's registers the cell may
//! reach through linterpd.
//!
//! ```toml
//! [robots.press-loader.gateway]
//! read = ["DT0-DT999", "X0-X1F"]     # DT words, X / Y / R bits (X1F: word 1, bit F)
//! write = ["DT100-DT199", "R10-R1F"] # never X, never a word of the contract
//! modbus = { listen = "0.0.0.0:5020", allow = ["10.0.0.5", "10.0.1.0/24"] }  # optional
//! ```
//! Without the table nothing is reachable. The Modbus TCP face listens on loopback
//! (`127.0.0.1:5020`) unless told otherwise, and beyond loopback only with `allow`, the IPs or
//! CIDR networks it serves (Modbus has no authentication); with `allow` it serves those and no
//! other client. A writable range over the contract's status block,
//! command block or table areas is refused, naming the overlap (docs/CONTRACT.md).

use std::net::{IpAddr, Ipv4Addr, SocketAddr};

use toml::Spanned;

use super::ConfigError;
use super::check::At;
use super::raw::{RawGateway, RawModbusFace};
use crate::contract::Layout;
use crate::gateway::{AccessList, ClientNet, GatewaySettings, ModbusFace, Range};

/// The gateway a table describes, for a robot whose contract sits at `layout`.
pub(super) fn settings(
    at: &At,
    raw: &Spanned<RawGateway>,
    layout: &Layout,
) -> Result<GatewaySettings, ConfigError> {
    let r = raw.get_ref();
    let read = ranges(&at.child("read"), r.read.as_deref())?;
    let write = ranges(&at.child("write"), r.write.as_deref())?;
    // Each writable range on its own, so an error names the entry to blame.
    for (i, range) in write.iter().enumerate() {
        if let Err(e) = AccessList::new(Vec::new(), vec![*range], layout) {
            let entry = &r.write.as_deref().unwrap_or_default()[i];
            return Err(at.child("write").index(i).invalid(entry, e.to_string()));
        }
    }
    let access = AccessList::new(read, write, layout).map_err(|e| {
        at.child("write")
            .missing(&raw.span(), format!("cannot be used: {e}"))
    })?;
    let modbus = r
        .modbus
        .as_ref()
        .map(|m| modbus_face(&at.child("modbus"), m))
        .transpose()?;
    Ok(GatewaySettings { access, modbus })
}

/// Where the Modbus TCP face listens unless `listen` says: loopback, port 5020 (502 needs
/// privileges the service does not have).
pub(super) const DEFAULT_MODBUS_LISTEN: SocketAddr =
    SocketAddr::new(IpAddr::V4(Ipv4Addr::LOCALHOST), 5020);

fn ranges(at: &At, raw: Option<&[Spanned<String>]>) -> Result<Vec<Range>, ConfigError> {
    raw.unwrap_or_default()
        .iter()
        .enumerate()
        .map(|(i, text)| {
            text.get_ref()
                .parse::<Range>()
                .map_err(|e| at.index(i).invalid(text, e.reason))
        })
        .collect()
}

/// A server's `listen` (`default` when not given; `example` in the message when it does not
/// parse) and `allow`, the client networks it serves.
pub(super) fn listen_allow(
    at: &At,
    (listen, allow): (Option<&Spanned<String>>, Option<&[Spanned<String>]>),
    default: SocketAddr,
    example: &str,
) -> Result<(SocketAddr, Vec<ClientNet>), ConfigError> {
    let listen = match listen {
        None => default,
        Some(text) => text.get_ref().parse().map_err(|_| {
            at.child("listen").invalid(
                text,
                format!("must be an IP address and port, e.g. \"{example}\""),
            )
        })?,
    };
    let allow = allow
        .unwrap_or_default()
        .iter()
        .enumerate()
        .map(|(i, text)| {
            text.get_ref()
                .parse()
                .map_err(|e: crate::gateway::ClientNetError| {
                    at.child("allow").index(i).invalid(text, e.reason)
                })
        })
        .collect::<Result<_, _>>()?;
    Ok((listen, allow))
}

fn modbus_face(at: &At, raw: &Spanned<RawModbusFace>) -> Result<ModbusFace, ConfigError> {
    let r = raw.get_ref();
    let (listen, allow) = listen_allow(
        at,
        (r.listen.as_ref(), r.allow.as_deref()),
        DEFAULT_MODBUS_LISTEN,
        "127.0.0.1:5020",
    )?;
    let face = ModbusFace { listen, allow };
    if let Some(text) = &r.listen
        && face.allow.is_empty()
        && !face.listen.ip().to_canonical().is_loopback()
    {
        return Err(at.child("listen").invalid(
            text,
            format!(
                "{} is beyond loopback and Modbus has no authentication: it needs \
                 gateway.modbus.allow, the client IPs or CIDR networks it serves",
                face.listen.ip()
            ),
        ));
    }
    Ok(face)
}

#[cfg(test)]
mod tests {
    use super::super::Config;
    use super::super::fixture::{MINIMAL, message};
    use crate::gateway::Range;

    const PLC: &str =
        "[robots.r.plc]\nprotocol = \"mewtocol\"\nserial = { path = \"/dev/ttyS0\" }\n";

    fn with_gateway(table: &str) -> String {
        format!("{MINIMAL}{PLC}[robots.r.gateway]\n{table}\n")
    }

    #[test]
    fn lists_and_the_modbus_face_are_read() {
        let text = with_gateway(
            "read = [\"DT0-DT999\", \"X0-X1F\"]\nwrite = [\"DT100-DT199\", \"R10-R1F\"]\n\
             modbus = { listen = \"0.0.0.0:5020\", allow = [\"10.0.0.5\"] }",
        );
        let config = Config::from_toml(&text).unwrap();
        let g = config.gateway("r").unwrap();
        let dt = |t: &str| t.parse::<Range>().unwrap();
        assert!(g.access.check_write(&dt("DT150")).is_ok());
        assert!(g.access.check_read(&dt("X3")).is_ok());
        assert!(g.access.check_write(&dt("DT200")).is_err());
        let face = g.modbus.as_ref().unwrap();
        assert!(face.admits("10.0.0.5".parse().unwrap()));
        assert!(
            !face.admits("127.0.0.1".parse().unwrap()),
            "with an allow-list, only whom it lists"
        );
        assert!(!face.admits("10.0.0.6".parse().unwrap()));
        assert!(Config::from_toml(MINIMAL).unwrap().gateway("r").is_none());
    }

    #[test]
    fn a_writable_contract_word_is_refused_naming_the_overlap() {
        let m = message(&with_gateway(
            "write = [\"DT100-DT199\", \"DT1030-DT1040\"]",
        ));
        assert!(
            m.contains("robots.r.gateway.write[1] = \"DT1030-DT1040\": DT1030-DT1040 overlaps the contract's command block (DT1032-DT1056)"),
            "{m}"
        );
        let m = message(&with_gateway("write = [\"X0-X7\"]"));
        assert!(m.contains("X0-X7 is in X, the inputs"), "{m}");
        let m = message(&with_gateway("read = [\"DT5-X3\"]"));
        assert!(
            m.contains("gateway.read[0] = \"DT5-X3\": spans two areas"),
            "{m}"
        );
    }

    #[test]
    fn a_modbus_face_beyond_loopback_needs_an_allow_list() {
        let m = message(&with_gateway("modbus = { listen = \"0.0.0.0:5020\" }"));
        assert!(
            m.contains("gateway.modbus.listen = \"0.0.0.0:5020\": 0.0.0.0 is beyond loopback")
                && m.contains("needs gateway.modbus.allow"),
            "{m}"
        );
        let m = message(&with_gateway(
            "modbus = { listen = \"0.0.0.0:5020\", allow = [\"10.0.0.0/33\"] }",
        ));
        assert!(
            m.contains("allow[0] = \"10.0.0.0/33\": has a prefix length outside 0..=32"),
            "{m}"
        );
    }

    #[test]
    fn a_modbus_face_listens_on_loopback_unless_told() {
        let config = Config::from_toml(&with_gateway("read = [\"DT0\"]\nmodbus = {}")).unwrap();
        let face = config.gateway("r").unwrap().modbus.clone().unwrap();
        assert_eq!(face.listen, super::DEFAULT_MODBUS_LISTEN);
        assert!(face.admits("127.0.0.1".parse().unwrap()));
        assert!(!face.admits("10.0.0.5".parse().unwrap()));
        let text = with_gateway(
            "modbus = { listen = \"0.0.0.0:5020\", allow = [\"10.0.1.0/24\", \"127.0.0.1\"] }",
        );
        let config = Config::from_toml(&text).unwrap();
        let face = config.gateway("r").unwrap().modbus.clone().unwrap();
        assert!(face.admits("10.0.1.77".parse().unwrap()));
        assert!(face.admits("127.0.0.1".parse().unwrap()));
        assert!(!face.admits("10.0.2.1".parse().unwrap()));
    }

    #[test]
    fn a_gateway_needs_a_plc_table() {
        let text = format!("{MINIMAL}[robots.r.gateway]\nread = [\"DT0\"]\n");
        let m = message(&text);
        assert!(m.contains("needs [robots.r.plc]"), "{m}");
    }
}
