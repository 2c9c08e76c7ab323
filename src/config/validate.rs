//! The validation pass: raw robots, in file order, -> [`Robot`]s. Each section has its own module
//! (`kinematics`, `joints`, `motion`); this one only assembles them, so a new section is one more
//! call in [`robot`].

use toml::Spanned;

use super::check::At;
use super::raw::{RawConfig, RawRobot};
use std::collections::BTreeMap;

use super::{
    Config, ConfigError, cell, console, daemon, gateway, joints, kinematics, motion, pallets, plc,
};
use crate::plc::LinkSettings;
use crate::robot::Robot;

/// `area_words` when not given (CONTRACT.md).
pub(super) const DEFAULT_AREA_WORDS: i64 = 2000;
/// Smallest table area: the directory plus a few rows.
const MIN_AREA_WORDS: i64 = 64;
/// Largest table area.
const MAX_AREA_WORDS: i64 = 8000;

/// The robots of a parsed file, checked, in the order the file names them.
pub(super) fn config(text: &str, mut raw: RawConfig) -> Result<Config, ConfigError> {
    let mut entries: Vec<_> = std::mem::take(&mut raw.robots).into_iter().collect();
    entries.sort_by_key(|(name, _)| name.span().start);
    let mut robots = Robots::default();
    for (name, raw) in &entries {
        robots.add(text, name, raw)?;
    }
    if robots.checked.is_empty() {
        return Err(ConfigError::NoRobots);
    }
    let daemon = daemon::settings(&At::new(text, "daemon"), raw.daemon.as_ref())?;
    let console = raw
        .console
        .as_ref()
        .map(|c| console::settings(&At::new(text, "console"), c))
        .transpose()?;
    Ok(Config {
        robots: robots.checked,
        links: robots.links,
        gateways: robots.gateways,
        cells: robots.cells,
        daemon,
        console,
        robot_consoles: robots.consoles,
        pallets: robots.pallets,
    })
}

/// The robots checked so far and their sections, by robot name.
#[derive(Default)]
struct Robots {
    checked: Vec<Robot>,
    links: BTreeMap<String, LinkSettings>,
    gateways: BTreeMap<String, crate::gateway::GatewaySettings>,
    cells: BTreeMap<String, cell::CellSettings>,
    consoles: BTreeMap<String, super::RobotConsoleSettings>,
    pallets: BTreeMap<String, crate::pallet::RobotPallets>,
}

impl Robots {
    /// Checks the robot `name` and its sections, and adds them.
    fn add(
        &mut self,
        text: &str,
        name: &Spanned<String>,
        raw: &Spanned<RawRobot>,
    ) -> Result<(), ConfigError> {
        let robot = self::robot(text, name, raw)?;
        if let Some(set) = pallets::pallets(text, &robot, raw.get_ref())? {
            self.pallets.insert(robot.name.clone(), set);
        }
        if let Some(table) = &raw.get_ref().console {
            let at = At::new(text, "robots").child(&robot.name).child("console");
            self.consoles
                .insert(robot.name.clone(), console::robot(&at, table)?);
        }
        let link = self::link(text, &robot, raw)?;
        let gateway = self::gateway(text, &robot, raw, link.as_ref())?;
        let served = gateway.as_ref().is_some_and(|g| g.modbus.is_some());
        if let Some(g) = gateway {
            self.gateways.insert(robot.name.clone(), g);
        }
        let pallets = self.pallets.get(&robot.name);
        if let Some(settings) = self::cell(text, (&robot, pallets), raw, served, link.as_ref())? {
            self.cells.insert(robot.name.clone(), settings);
        }
        if let Some(link) = link {
            self.links.insert(robot.name.clone(), link);
        }
        self.checked.push(robot);
        Ok(())
    }
}

/// The robot's `[robots.NAME.cell]` table, if it has one (a face's pallet one of `pallets`): its face is `served` on the gateway's
/// Modbus face or mirrored in the PLC (over `link`), clear of the contract's words.
fn cell(
    text: &str,
    (robot, pallets): (&Robot, Option<&crate::pallet::RobotPallets>),
    raw: &Spanned<RawRobot>,
    served: bool,
    link: Option<&LinkSettings>,
) -> Result<Option<cell::CellSettings>, ConfigError> {
    let Some(table) = &raw.get_ref().cell else {
        return Ok(None);
    };
    let at = At::new(text, "robots").child(&robot.name).child("cell");
    let settings = cell::settings(&at, table)?;
    cell::face_pallet_known(&at.child("face"), table, pallets)?;
    let mirrored = settings.face.as_ref().and_then(|f| f.plc);
    if let (Some(face), false, None) = (&table.get_ref().face, served, mirrored) {
        let reason = format!(
            "the cell face is served on the gateway's Modbus face or mirrored in the \
             PLC: it needs [robots.{}.gateway.modbus], or `plc = \"DT...\"`",
            robot.name
        );
        return Err(at.child("face").missing(&face.span(), reason));
    }
    if let Some(first) = mirrored {
        cell::face_clear_of_contract(&at.child("face"), table, first, link)?;
    }
    Ok(Some(settings))
}

/// The robot's `[robots.NAME.gateway]` table, if it has one (it needs the plc table).
fn gateway(
    text: &str,
    robot: &Robot,
    raw: &Spanned<RawRobot>,
    link: Option<&LinkSettings>,
) -> Result<Option<crate::gateway::GatewaySettings>, ConfigError> {
    let Some(table) = &raw.get_ref().gateway else {
        return Ok(None);
    };
    let at = At::new(text, "robots").child(&robot.name).child("gateway");
    let Some(link) = link else {
        let reason = format!(
            "a gateway reaches the PLC through the robot's link: it needs [robots.{}.plc]",
            robot.name
        );
        return Err(at.missing(&table.span(), reason));
    };
    gateway::settings(&at, table, &link.layout).map(Some)
}

/// One robot.
fn robot(
    text: &str,
    name: &Spanned<String>,
    raw: &Spanned<RawRobot>,
) -> Result<Robot, ConfigError> {
    let at = At::new(text, "robots").child(name.get_ref());
    if name.get_ref().trim().is_empty() {
        return Err(At::new(text, "robots").invalid(name, "a robot needs a non-blank name"));
    }
    let r = raw.get_ref();
    let area_words = area_words(&at.child("area_words"), r.area_words.as_ref())?;
    let kinematics = kinematics::model(&at.child("kinematics"), &r.kinematics)?;
    let motion = motion::motion(&at.child("motion"), r.motion.get_ref())?;
    let max_speed_mm_s = motion::max_speed(&at.child("motion"), r.motion.get_ref(), &motion)?;
    let joints = joints::joints(&at.child("joints"), &r.joints, &kinematics)?;
    joints::jerk_needs_s_curve(&at.child("joints"), &r.joints, &joints, motion.ramp)?;
    let tool_mm = pallets::tool(&at.child("tool"), r.tool.as_ref())?.into();
    Ok(Robot {
        name: name.get_ref().clone(),
        kinematics: crate::kinematics::Arm {
            model: kinematics,
            tool_mm,
        },
        joints,
        motion,
        area_words,
        max_speed_mm_s,
    })
}

/// The robot's `[robots.NAME.plc]` table, if it has one.
fn link(
    text: &str,
    robot: &Robot,
    raw: &Spanned<RawRobot>,
) -> Result<Option<LinkSettings>, ConfigError> {
    let Some(plc) = &raw.get_ref().plc else {
        return Ok(None);
    };
    let at = At::new(text, "robots").child(&robot.name).child("plc");
    plc::link(&at, plc, robot).map(Some)
}

fn area_words(at: &At, raw: Option<&Spanned<i64>>) -> Result<usize, ConfigError> {
    raw.map_or(Ok(DEFAULT_AREA_WORDS), |v| {
        at.int_within(v, MIN_AREA_WORDS, MAX_AREA_WORDS)
    })
    .map(|v| v as usize)
}
