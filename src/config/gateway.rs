//! `[robots.NAME.gateway]` -> [`GatewaySettings`]: which of the PLC's registers the cell may
//! reach through linterpd.
//!
//! ```toml
//! [robots.press-loader.gateway]
//! read = ["DT0-DT999", "X0-X1F"]     # DT words, X / Y / R bits (X1F: word 1, bit F)
//! write = ["DT100-DT199", "R10-R1F"] # never X, never a word of the contract
//! modbus = { listen = "127.0.0.1:5020", allow = ["10.0.0.5"] }   # optional Modbus TCP face
//! ```
//! Without the table nothing is reachable. A writable range over the contract's status block,
//! command block or table areas is refused, naming the overlap (docs/CONTRACT.md).

use std::net::IpAddr;

use toml::Spanned;

use super::ConfigError;
use super::check::At;
use super::raw::{RawGateway, RawModbusFace};
use crate::contract::Layout;
use crate::gateway::{AccessList, GatewaySettings, ModbusFace, Range};

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

fn modbus_face(at: &At, raw: &Spanned<RawModbusFace>) -> Result<ModbusFace, ConfigError> {
    let r = raw.get_ref();
    let listen = r.listen.get_ref().parse().map_err(|_| {
        at.child("listen").invalid(
            &r.listen,
            "must be an IP address and port, e.g. \"127.0.0.1:5020\"",
        )
    })?;
    let mut allow = Vec::new();
    for (i, text) in r.allow.as_deref().unwrap_or_default().iter().enumerate() {
        let ip: IpAddr = text.get_ref().parse().map_err(|_| {
            at.child("allow")
                .index(i)
                .invalid(text, "must be an IP address, e.g. \"10.0.0.5\"")
        })?;
        allow.push(ip);
    }
    let face = ModbusFace { listen, allow };
    if !face.listen.ip().is_loopback() && face.allow.is_empty() {
        return Err(at.child("listen").invalid(
            &r.listen,
            "Modbus has no authentication: a listener beyond loopback needs gateway.modbus.allow, \
             the client addresses it serves",
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
        assert!(face.admits("127.0.0.1".parse().unwrap()));
        assert!(!face.admits("10.0.0.6".parse().unwrap()));
        assert!(Config::from_toml(MINIMAL).unwrap().gateway("r").is_none());
    }

    #[test]
    fn a_writable_contract_word_is_refused_naming_the_overlap() {
        let m = message(&with_gateway(
            "write = [\"DT100-DT199\", \"DT1030-DT1040\"]",
        ));
        assert!(
            m.contains("robots.r.gateway.write[1] = \"DT1030-DT1040\": DT1030-DT1040 overlaps the contract's command block (DT1032-DT1048)"),
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
        assert!(m.contains("needs gateway.modbus.allow"), "{m}");
    }

    #[test]
    fn a_gateway_needs_a_plc_table() {
        let text = format!("{MINIMAL}[robots.r.gateway]\nread = [\"DT0\"]\n");
        let m = message(&text);
        assert!(m.contains("needs [robots.r.plc]"), "{m}");
    }
}
