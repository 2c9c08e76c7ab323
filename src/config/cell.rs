//! `[robots.NAME.cell]` -> [`CellSettings`]: the robot's place in its cell: the names of the
//! cell's signals and where its cycle programs are.
//!
//! ```toml
//! [robots.press-loader.cell]
//! signals = { press_open = "X5", press_moving = "X6", part_present = "X2", press_go = "Y0" }
//! programs = "cycles"            # a directory of cycle programs (*.toml), relative to this file
//! require_wait_timeout = true    # refuse a program whose `wait` has no `timeout` (default false)
//!
//! [robots.press-loader.cell.face]   # the register face the line's PLC or HMI drives
//! registers = 50000              # its first register on the gateway's Modbus face (23 words)
//! # plc = "DT3000"               # or: mirrored in the robot PLC's DT3000..DT3017, polled
//! pallet = "out"                 # the pallet the status block's +18..+22 show (mirrored: to
//!                                # DT3022); a pallet of the robot
//! home = "home"                  # the taught position `home` moves to (default "home")
//! positions = ["home", "pick", "press"]   # numbered from 1 in the status block's +16
//! mode = "local"                 # the mode at start-up: local (default) or remote
//! ```
//! A signal is an X, Y or R bit (`X5`, `X1A`, `R10A`); an input the PLC program copies into the
//! status block (`[robots.NAME.plc.contract] inputs`) is read at no cost with every status read.

use std::collections::BTreeMap;
use std::path::PathBuf;

use toml::Spanned;

use super::ConfigError;
use super::check::At;
use super::raw::{RawCell, RawCellFace};
use crate::cell::Mode;
use crate::cell::face::{BLOCK_WORDS, BLOCK_WORDS_NO_PALLET};
use crate::contract::DT_LAST;
use crate::gateway::Address;

/// A robot's cell: its signals' names and its cycle programs' directory.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CellSettings {
    /// Signal name -> its bit.
    pub signals: BTreeMap<String, Address>,
    /// The directory of the cycle programs, as the file gives it (relative to the config
    /// file's directory once [`super::Config::load`] read it).
    pub programs: Option<PathBuf>,
    /// Whether every `wait` of a program must have a `timeout`.
    pub require_wait_timeout: bool,
    /// The register face the line drives, if it has one.
    pub face: Option<FaceSettings>,
}

/// `[robots.NAME.cell.face]`: where the cell face is served and what it shows.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FaceSettings {
    /// Its first register on the gateway's Modbus face: above the DT words, so it hides none.
    pub registers: u16,
    /// Its first DT word in the robot's PLC, when it is mirrored there (for a press PLC wired
    /// to the robot's PLC): the daemon reads the command words and writes the status words.
    /// A mirrored face is not served on the Modbus face (one writer of its command words).
    pub plc: Option<u32>,
    /// The taught position the `home` command moves to and `in-home` compares with.
    pub home: String,
    /// The taught positions the status block numbers (from 1).
    pub positions: Vec<String>,
    /// The mode at start-up.
    pub mode: Mode,
    /// The pallet the status block shows (`[robots.NAME.pallets.NAME]`), and whose redo and
    /// go-on the command bits give.
    pub pallet: Option<String>,
}

impl FaceSettings {
    /// The block's words: without a pallet shown, the 18 before the pallet's.
    #[must_use]
    pub fn block_words(&self) -> usize {
        face_words(self.pallet.is_some())
    }
}

fn face_words(pallet: bool) -> usize {
    if pallet {
        BLOCK_WORDS
    } else {
        BLOCK_WORDS_NO_PALLET
    }
}

/// The face's default first register.
pub(super) const FACE_REGISTERS: u16 = 50_000;

/// The cell a table describes.
pub(super) fn settings(at: &At, raw: &Spanned<RawCell>) -> Result<CellSettings, ConfigError> {
    let r = raw.get_ref();
    let mut signals = BTreeMap::new();
    for (name, bit) in r.signals.iter().flatten() {
        let at = at.child("signals").child(name.get_ref());
        check_name(&at, name)?;
        let address: Address = bit
            .get_ref()
            .parse()
            .map_err(|e: crate::gateway::AddressError| at.invalid(bit, e.reason))?;
        if !address.area.is_bits() {
            return Err(at.invalid(bit, "a signal is an X, Y or R bit, not a DT word"));
        }
        signals.insert(name.get_ref().clone(), address);
    }
    let programs = r.programs.as_ref().map(|p| PathBuf::from(p.get_ref()));
    let face = r
        .face
        .as_ref()
        .map(|f| face(&at.child("face"), f.get_ref()))
        .transpose()?;
    Ok(CellSettings {
        signals,
        programs,
        require_wait_timeout: r
            .require_wait_timeout
            .as_ref()
            .is_some_and(|b| *b.get_ref()),
        face,
    })
}

/// The face a table describes.
fn face(at: &At, raw: &RawCellFace) -> Result<FaceSettings, ConfigError> {
    let words = face_words(raw.pallet.is_some());
    let registers = face_registers(at, raw, words)?;
    let plc = face_plc_word(at, raw, words)?;
    if let (Some(_), Some(r)) = (&plc, &raw.registers) {
        return Err(at.child("registers").invalid(
            r,
            "the face is either served on the Modbus face (`registers`) or mirrored in the PLC \
             (`plc`), not both: its command words have one writer",
        ));
    }
    let home = raw
        .home
        .as_ref()
        .map_or_else(|| Ok("home".to_owned()), |h| position_name(at, "home", h))?;
    let positions = face_positions(at, raw)?;
    let mode = match &raw.mode {
        Some(m) => m
            .get_ref()
            .parse()
            .map_err(|e: crate::cell::ModeError| at.child("mode").invalid(m, e.to_string()))?,
        None => Mode::Local,
    };
    let pallet = raw.pallet.as_ref().map(|p| p.get_ref().clone());
    Ok(FaceSettings {
        registers,
        plc,
        home,
        positions,
        mode,
        pallet,
    })
}

/// The first Modbus register the face is served at.
fn face_registers(at: &At, raw: &RawCellFace, words: usize) -> Result<u16, ConfigError> {
    let first = i64::from(DT_LAST) + 1;
    let last = i64::from(u16::MAX) + 1 - words as i64;
    Ok(match &raw.registers {
        Some(r) => {
            let v = at.child("registers").int_within(r, first, last)?;
            u16::try_from(v).unwrap_or(FACE_REGISTERS)
        }
        None => FACE_REGISTERS,
    })
}

/// The first DT word the face is mirrored at in the PLC, when it is.
fn face_plc_word(at: &At, raw: &RawCellFace, words: usize) -> Result<Option<u32>, ConfigError> {
    let Some(p) = &raw.plc else {
        return Ok(None);
    };
    let at = at.child("plc");
    let address: Address = p
        .get_ref()
        .parse()
        .map_err(|e: crate::gateway::AddressError| at.invalid(p, e.reason))?;
    let last = address.index + words as u32 - 1;
    if address.area != crate::gateway::Area::Dt || last > u32::from(DT_LAST) {
        return Err(at.invalid(
            p,
            format!("the face's {words} words are DT words, within DT0-DT{DT_LAST}"),
        ));
    }
    Ok(Some(address.index))
}

/// A position name under `key`, checked against the rule.
fn position_name(at: &At, key: &str, value: &Spanned<String>) -> Result<String, ConfigError> {
    if crate::robot::is_position_name(value.get_ref()) {
        Ok(value.get_ref().clone())
    } else {
        Err(at
            .child(key)
            .invalid(value, crate::robot::POSITION_NAME_RULE))
    }
}

/// The positions the face offers, each named once.
fn face_positions(at: &At, raw: &RawCellFace) -> Result<Vec<String>, ConfigError> {
    let mut positions = Vec::new();
    for p in raw.positions.iter().flatten() {
        let n = position_name(at, "positions", p)?;
        if positions.contains(&n) {
            return Err(at.child("positions").invalid(p, "is named twice"));
        }
        positions.push(n);
    }
    Ok(positions)
}

/// The mirrored face's words must not touch the contract's (the PLC program owns those), and
/// the robot needs a link to mirror it over.
pub(super) fn face_clear_of_contract(
    at: &At,
    raw: &Spanned<RawCell>,
    first: u32,
    link: Option<&crate::plc::LinkSettings>,
) -> Result<(), ConfigError> {
    let face = raw.get_ref().face.as_ref().map(Spanned::get_ref);
    let Some(plc) = face.and_then(|f| f.plc.as_ref()) else {
        return Ok(());
    };
    let shows_pallet = face.is_some_and(|f| f.pallet.is_some());
    let at = at.child("plc");
    let Some(link) = link else {
        return Err(at.invalid(
            plc,
            "a face mirrored in the PLC needs the robot's [plc] link",
        ));
    };
    let block = crate::gateway::Range {
        area: crate::gateway::Area::Dt,
        first,
        last: first + face_words(shows_pallet) as u32 - 1,
    };
    for (what, words) in crate::gateway::contract_regions(&link.layout) {
        if block.overlaps(&words) {
            return Err(at.invalid(plc, format!("{block} overlaps {what} ({words})")));
        }
    }
    Ok(())
}

/// The face's `pallet` must name a pallet of the robot.
pub(super) fn face_pallet_known(
    at: &At,
    raw: &Spanned<RawCell>,
    pallets: Option<&crate::pallet::RobotPallets>,
) -> Result<(), ConfigError> {
    let face = raw.get_ref().face.as_ref().map(Spanned::get_ref);
    let Some(pallet) = face.and_then(|f| f.pallet.as_ref()) else {
        return Ok(());
    };
    let known: Vec<&str> = pallets
        .iter()
        .flat_map(|p| p.layouts.keys())
        .map(String::as_str)
        .collect();
    if known.contains(&pallet.get_ref().as_str()) {
        return Ok(());
    }
    let reason = if known.is_empty() {
        "the robot has no pallet: add [robots.NAME.pallets.NAME]".to_owned()
    } else {
        format!("the robot's pallets are {}", known.join(", "))
    };
    Err(at.child("pallet").invalid(pallet, reason))
}

/// A signal's name: a letter, then letters, digits, `_` or `-`; never one that reads as an
/// address (a program could not tell them apart).
fn check_name(at: &At, name: &Spanned<String>) -> Result<(), ConfigError> {
    let text = name.get_ref();
    let mut chars = text.chars();
    let well_formed = chars.next().is_some_and(|c| c.is_ascii_alphabetic())
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
    if !well_formed {
        return Err(at.invalid(
            name,
            "a signal's name starts with a letter, then letters, digits, `_` or `-`",
        ));
    }
    if text.parse::<Address>().is_ok() {
        return Err(at.invalid(name, "reads as a PLC address: name it otherwise"));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use crate::config::Config;
    use crate::config::fixture::MINIMAL;
    use crate::gateway::Address;

    fn with_cell(cell: &str) -> String {
        format!("{MINIMAL}\n[robots.r.cell]\n{cell}\n")
    }

    #[test]
    fn signals_name_bits_and_the_programs_directory_is_kept() {
        let text = with_cell(
            "signals = { press_open = \"X5\", press_go = \"Y0\", part = \"R10A\" }\n\
             programs = \"cycles\"\nrequire_wait_timeout = true",
        );
        let config = Config::from_toml(&text).unwrap();
        let cell = &config.cells["r"];
        assert_eq!(cell.signals["press_open"], "X5".parse::<Address>().unwrap());
        assert_eq!(cell.signals["part"], "R10A".parse::<Address>().unwrap());
        assert_eq!(
            cell.programs.as_deref(),
            Some(std::path::Path::new("cycles"))
        );
        assert!(cell.require_wait_timeout);
    }

    #[test]
    fn a_bad_signal_is_refused_naming_the_key_and_the_value() {
        for (cell, key, words) in [
            (
                "signals = { open = \"DT100\" }",
                "signals.open",
                "not a DT word",
            ),
            ("signals = { open = \"Q5\" }", "signals.open", "Q5"),
            (
                "signals = { X5 = \"X5\" }",
                "signals.X5",
                "reads as a PLC address",
            ),
            (
                "signals = { \"5open\" = \"X5\" }",
                "signals.5open",
                "starts with a letter",
            ),
        ] {
            let e = Config::from_toml(&with_cell(cell)).unwrap_err().to_string();
            assert!(e.contains(key) && e.contains(words), "{cell}: {e}");
        }
    }

    #[test]
    fn the_face_takes_its_defaults_and_checks_every_key() {
        let config = Config::from_toml(&with_face("")).unwrap();
        let face = config.cells["r"].face.clone().unwrap();
        assert_eq!(face.registers, super::FACE_REGISTERS);
        assert_eq!(face.home, "home");
        assert_eq!(face.mode, crate::cell::Mode::Local);
        let config = Config::from_toml(&with_face(
            "registers = 40000\nhome = \"rest\"\npositions = [\"rest\", \"pick\"]\nmode = \"remote\"",
        ))
        .unwrap();
        let face = config.cells["r"].face.clone().unwrap();
        assert_eq!(
            (face.registers, face.home.as_str(), face.positions.len()),
            (40_000, "rest", 2)
        );
        assert_eq!(face.mode, crate::cell::Mode::Remote);
        for (table, key, words) in [
            ("registers = 100", "face.registers", "32765..=65518"),
            ("registers = 65530", "face.registers", "32765..=65518"),
            ("mode = \"auto\"", "face.mode", "`local` or `remote`"),
            (
                "positions = [\"a\", \"a\"]",
                "face.positions",
                "named twice",
            ),
            ("home = \"\"", "face.home", "\"\""),
            ("strobe = 1", "strobe", "unknown field"),
            ("plc = \"X10\"", "face.plc", "DT words"),
            ("plc = \"DT32760\"", "face.plc", "DT words"),
            (
                "plc = \"DT1010\"",
                "face.plc",
                "overlaps the contract's status block",
            ),
            (
                "plc = \"DT3000\"\nregisters = 40000",
                "face.registers",
                "not both",
            ),
        ] {
            let e = Config::from_toml(&with_face(table))
                .unwrap_err()
                .to_string();
            assert!(e.contains(key) && e.contains(words), "{table}: {e}");
        }
    }

    fn with_face(face: &str) -> String {
        format!(
            "{MINIMAL}\n[robots.r.plc]\nprotocol = \"mewtocol\"\nserial = {{ path = \"/dev/ttyS0\" }}\n\
             [robots.r.gateway.modbus]\nlisten = \"127.0.0.1:1502\"\n\
             [robots.r.cell.face]\n{face}\n"
        )
    }

    #[test]
    fn the_faces_pallet_names_a_pallet_of_the_robot_and_adds_its_five_words() {
        const OUT: &str = "[robots.r.pallets.out]\norigin_mm = [700, 0, 100]\nrows = 2\n\
                           columns = 3\npitch_mm = [300, 200]\nlayer_height_mm = 80\nlayers = 2\n";
        let config = Config::from_toml(&format!("{}{OUT}", with_face("pallet = \"out\""))).unwrap();
        let face = config.cells["r"].face.clone().unwrap();
        assert_eq!(
            (face.pallet.as_deref(), face.block_words()),
            (Some("out"), 23)
        );
        assert_eq!(with_face_words(""), 18);
        let refused = |text: String| Config::from_toml(&text).unwrap_err().to_string();
        let e = refused(format!("{}{OUT}", with_face("pallet = \"top\"")));
        assert!(
            e.contains("face.pallet")
                && e.contains("\"top\"")
                && e.contains("the robot's pallets are out"),
            "{e}"
        );
        let e = refused(with_face("pallet = \"out\""));
        assert!(
            e.contains("face.pallet") && e.contains("the robot has no pallet"),
            "{e}"
        );
        // The block's last word must fit: 23 words with a pallet, 18 without.
        let e = refused(format!(
            "{}{OUT}",
            with_face("pallet = \"out\"\nregisters = 65518")
        ));
        assert!(e.contains("32765..=65513"), "{e}");
        let mirrored = "plc = \"DT32745\"";
        assert!(Config::from_toml(&with_face(mirrored)).is_ok());
        let e = refused(format!(
            "{}{OUT}",
            with_face(&format!("{mirrored}\npallet = \"out\""))
        ));
        assert!(e.contains("the face's 23 words are DT words"), "{e}");
    }

    fn with_face_words(face: &str) -> usize {
        let config = Config::from_toml(&with_face(face)).unwrap();
        config.cells["r"].face.clone().unwrap().block_words()
    }

    #[test]
    fn a_face_without_the_gateways_modbus_face_is_refused() {
        let e = Config::from_toml(&with_cell("[robots.r.cell.face]"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("gateway.modbus"), "{e}");
    }

    #[test]
    fn an_unknown_key_in_the_cell_table_is_refused() {
        let e = Config::from_toml(&with_cell("signal = {}"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("signal"), "{e}");
    }
}
