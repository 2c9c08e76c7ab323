//! PURE (but for [`Config::load`]). Strict TOML configuration, validated into
//! [`crate::robot::Robot`]s.
//!
//! Two passes: serde parses the text into the raw schema of `raw` (unknown keys and wrong types
//! are errors), then `validate` and its section modules (`kinematics`, `motion`, `joints`) check
//! every value and build the robots. Every error names the line, the key path and the value:
//! `config line 14: robots.press-loader.joints[2].max_freq_hz = 200000: channel 2 of an FP-X
//! C60T allows at most 20000 Hz`.
//!
//! ```toml
//! [robots.press-loader]
//! area_words = 2000                # optional, 64..=8000
//! [robots.press-loader.kinematics]
//! type = "cylindrical"             # cylindrical: l0_mm, min_axis_distance_mm (default 50)
//! l0_mm = 500.0                    # scara: l1_mm, l2_mm, elbow, reach_margin_mm (default 1)
//! [robots.press-loader.motion]     # cartesian: no keys
//! period = "50ms"
//! speed_mm_s = 240.0
//! accel_time = "200ms"             # method, frequency_model, over_speed optional
//! [[robots.press-loader.joints]]   # exactly 4, in the model's joint order
//! name = "theta1"
//! channel = 0
//! step_deg = 0.0025                # revolute: *_deg, prismatic: *_mm
//! min_deg = -170.0                 # offset_deg / offset_mm optional
//! max_deg = 170.0
//! max_freq_hz = 100000
//! output = "pulse-sign"
//! [robots.press-loader.plc]        # optional: how to reach the PLC (see `plc`)
//! protocol = "mewtocol"
//! serial = { path = "/dev/ttyUSB0" }
//! [daemon]                          # optional: the API of `linterpd serve` (see `daemon`)
//! socket = "/run/linterpd/api.sock"
//! [console]                         # optional: the operator's console (see `console`)
//! ```
//! `config/linterpd.toml` is the commented example.

mod cell;
mod check;
mod console;
mod daemon;
mod error;
pub mod files;
mod gateway;
mod joints;
mod kinematics;
mod locate;
mod motion;
mod pallets;
mod path_file;
mod plc;
mod raw;
pub mod suggest;
mod units;
mod validate;

use std::collections::BTreeMap;
use std::path::Path;

pub use cell::{CellSettings, FaceSettings};
pub use console::{
    ConsoleSettings, ConsoleUser, DEFAULT_CONSOLE_LISTEN, DEFAULT_MANUAL_SPEED_MM_S,
    MAX_MANUAL_SPEED_MM_S, RobotConsoleSettings, Role, Secret,
};
pub use daemon::{DEFAULT_SOCKET, DaemonSettings, JournalSettings};
pub use error::ConfigError;
pub use path_file::{ArcDoc, ElementDoc, PATH_FORMAT, PathDoc, PathFileError, Waypoint};
pub use units::{DurationError, DurationProblem, number_in, parse_duration_s};

use crate::plc::LinkSettings;
use crate::robot::Robot;

/// A checked config file: its robots and the links to their PLCs.
#[derive(Debug, Clone, PartialEq)]
pub struct Config {
    /// The robots, in the order the file defines them (never empty).
    pub robots: Vec<Robot>,
    /// The PLC link of each robot with a `[robots.NAME.plc]` table, by robot name.
    pub links: BTreeMap<String, LinkSettings>,
    /// The register gateway of each robot with a `[robots.NAME.gateway]` table, by robot name.
    pub gateways: BTreeMap<String, crate::gateway::GatewaySettings>,
    /// The cell of each robot with a `[robots.NAME.cell]` table, by robot name.
    pub cells: BTreeMap<String, CellSettings>,
    /// How `linterpd serve` offers its API (`[daemon]`; every default without one).
    pub daemon: DaemonSettings,
    /// The operator's console (`[console]`; none without one).
    pub console: Option<ConsoleSettings>,
    /// Each robot's `[robots.NAME.console]`, by robot name.
    pub robot_consoles: BTreeMap<String, RobotConsoleSettings>,
    /// Each robot's frames and pallets (`[robots.NAME.frames.NAME]`,
    /// `[robots.NAME.pallets.NAME]`), by robot name: checked; laid out by [`Config::patterns`].
    pub pallets: BTreeMap<String, crate::pallet::RobotPallets>,
}

impl Config {
    /// Parses and checks a config text.
    pub fn from_toml(text: &str) -> Result<Config, ConfigError> {
        let raw: raw::RawConfig = locate::parse(text)?;
        validate::config(text, raw)
    }

    /// Reads, parses and checks a config file; an error names the file. Relative paths (a
    /// cell's `programs`, `[daemon]`'s `socket`, `state_dir` and `token_file`) are taken from
    /// the file's directory.
    pub fn load(path: &Path) -> Result<Config, ConfigError> {
        let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Read {
            path: path.to_owned(),
            source,
        })?;
        Self::from_file_text(path, &text)
    }

    /// Parses and checks `text`, read from the file at `path`, as [`Config::load`] does: an
    /// error names the file, and relative paths are taken from its directory.
    pub fn from_file_text(path: &Path, text: &str) -> Result<Config, ConfigError> {
        let mut config = Self::from_toml(text).map_err(|e| ConfigError::InFile {
            path: path.to_owned(),
            error: Box::new(e),
        })?;
        let dir = path.parent().unwrap_or(Path::new("."));
        for cell in config.cells.values_mut() {
            if let Some(programs) = &mut cell.programs {
                *programs = dir.join(&*programs);
            }
        }
        let daemon = &mut config.daemon;
        daemon.socket = dir.join(&daemon.socket);
        daemon.state_dir = dir.join(&daemon.state_dir);
        if let Some(token) = &mut daemon.token_file {
            *token = dir.join(&*token);
        }
        for user in config.console.iter_mut().flat_map(|c| c.users.values_mut()) {
            if let Secret::TokenFile(file) = &mut user.secret {
                *file = dir.join(&*file);
            }
        }
        Ok(config)
    }

    /// The robot called `name`, or with `None` the only robot of the file.
    pub fn robot(&self, name: Option<&str>) -> Result<&Robot, ConfigError> {
        match (name, self.robots.as_slice()) {
            (_, []) => Err(ConfigError::NoRobots),
            (None, [only]) => Ok(only),
            (None, _) => Err(ConfigError::RobotNotChosen {
                known: self.names(),
            }),
            (Some(name), robots) => {
                robots
                    .iter()
                    .find(|r| r.name == name)
                    .ok_or_else(|| ConfigError::UnknownRobot {
                        name: name.to_owned(),
                        known: self.names(),
                    })
            }
        }
    }

    /// The PLC link of robot `name`, if its table has a `plc` section.
    #[must_use]
    pub fn link(&self, name: &str) -> Option<&LinkSettings> {
        self.links.get(name)
    }

    /// Robot `name`'s console settings (every default without a `[robots.NAME.console]`).
    #[must_use]
    pub fn robot_console(&self, name: &str) -> RobotConsoleSettings {
        self.robot_consoles.get(name).copied().unwrap_or_default()
    }

    /// The register gateway of robot `name`, if its table has a `gateway` section.
    #[must_use]
    pub fn gateway(&self, name: &str) -> Option<&crate::gateway::GatewaySettings> {
        self.gateways.get(name)
    }

    /// `robot`'s pallet patterns by pallet name, laid out with the taught positions `taught`
    /// (a frame's or corners' `"@name"` points) and every slot checked against the robot's reach
    /// and joint limits; empty for a robot without pallets. A pallet that names no taught
    /// position was already laid out and checked when the config was.
    ///
    /// # Errors
    /// A pallet that cannot be laid out or reached, naming the pallet and the slot.
    pub fn patterns(
        &self,
        robot: &Robot,
        taught: &BTreeMap<String, crate::robot::Position>,
    ) -> Result<BTreeMap<String, crate::pallet::Pattern>, crate::pallet::PalletError> {
        match self.pallets.get(&robot.name) {
            Some(set) => set.patterns(robot, taught),
            None => Ok(BTreeMap::new()),
        }
    }

    fn names(&self) -> String {
        let names: Vec<&str> = self.robots.iter().map(|r| r.name.as_str()).collect();
        names.join(", ")
    }
}

#[cfg(test)]
mod fixture;

#[cfg(test)]
#[allow(clippy::float_cmp)] // values parsed from TOML are exact
mod tests {
    use super::fixture::Says::{Is, StartsWith};
    use super::fixture::{MINIMAL, assert_refusals, edited, message};
    use super::*;
    use crate::kinematics::{JointKind, Model};
    use crate::robot::{Method, OverSpeed};
    use crate::table::{FrequencyModel, OutputMethod};

    const SHIPPED: &str = include_str!("../../config/linterpd.toml");
    const EXAMPLE: &str = include_str!("../../config/examples/gantry-and-scara.toml");

    #[test]
    fn shipped_file_describes_the_seed_press_loader() {
        let config = Config::from_toml(SHIPPED).unwrap();
        let robot = config.robot(Some("press-loader")).unwrap();
        let Model::Cylindrical(k) = &robot.kinematics.model else {
            panic!("press-loader is cylindrical")
        };
        assert_eq!((k.l0_mm, k.min_axis_distance_mm), (500.0, 50.0));
        assert_eq!(robot.area_words, 2000);
        let names: Vec<&str> = robot.joints.iter().map(|j| j.name.as_str()).collect();
        assert_eq!(names, ["theta1", "d2", "d3", "wrist"]);
        let channels: Vec<u8> = robot.joints.iter().map(|j| j.channel).collect();
        assert_eq!(channels, [0, 1, 2, 3]);
        let freqs: Vec<u32> = robot.joints.iter().map(|j| j.max_freq_hz).collect();
        assert_eq!(freqs, [100_000, 100_000, 20_000, 20_000]);
        assert!(
            robot
                .joints
                .iter()
                .all(|j| j.output == OutputMethod::PulseSign)
        );
    }

    #[test]
    fn shipped_file_reads_theta1_step_as_degrees_in_radians() {
        let config = Config::from_toml(SHIPPED).unwrap();
        let [theta1, d2, d3, wrist] = &config.robots[0].joints;
        assert_eq!(theta1.kind, JointKind::Revolute);
        assert!((theta1.step - 0.0025_f64.to_radians()).abs() < 1e-15);
        assert!((theta1.max - 170.0_f64.to_radians()).abs() < 1e-12);
        assert!((wrist.min + std::f64::consts::TAU).abs() < 1e-12);
        assert_eq!(
            (d2.kind, d2.step, d2.min, d2.max),
            (JointKind::Prismatic, 0.025, -50.0, 400.0)
        );
        assert_eq!((d3.step, d3.min, d3.max), (0.013, 0.0, 1000.0));
    }

    #[test]
    fn shipped_file_holds_the_seed_motion() {
        let config = Config::from_toml(SHIPPED).unwrap();
        let m = config.robots[0].motion;
        assert_eq!(m.method, Method::ConstantPeriod);
        assert!((m.period_s - 0.05).abs() < 1e-12);
        assert!((m.accel_s - 0.2).abs() < 1e-12);
        assert_eq!(m.speed_mm_s, 240.0);
        assert_eq!(m.frequency_model, FrequencyModel::FpxDivider);
        assert_eq!(m.over_speed, OverSpeed::Reject);
    }

    #[test]
    fn shipped_file_seed_move_lies_within_joint_limits() {
        let config = Config::from_toml(SHIPPED).unwrap();
        let robot = &config.robots[0];
        for (x, y, z) in [(-926.57, 535.03, 50.0), (-1144.43, 659.60, 186.60)] {
            let pose = robot.pose_with_wrist_at_zero(x, y, z).unwrap();
            let q = crate::kinematics::Kinematics::ik(&robot.kinematics, &pose, None).unwrap();
            for (joint, value) in robot.joints.iter().zip(q) {
                assert!(
                    joint.min < value && value < joint.max,
                    "{}: {value}",
                    joint.name
                );
            }
        }
    }

    #[test]
    fn robots_keep_file_order() {
        let config = Config::from_toml(EXAMPLE).unwrap();
        let names: Vec<&str> = config.robots.iter().map(|r| r.name.as_str()).collect();
        assert_eq!(names, ["gantry", "scara"]);
        assert_eq!(
            crate::kinematics::Kinematics::name(&config.robots[1].kinematics),
            "scara"
        );
    }

    #[test]
    fn defaults_fill_optional_keys() {
        let robot = &Config::from_toml(MINIMAL).unwrap().robots[0];
        assert_eq!(robot.area_words, 2000);
        assert_eq!(robot.motion.method, Method::ConstantPeriod);
        assert_eq!(robot.motion.frequency_model, FrequencyModel::FpxDivider);
        assert_eq!(robot.motion.over_speed, OverSpeed::Reject);
        assert!(robot.joints.iter().all(|j| j.offset == 0.0));
    }

    #[test]
    fn robot_without_name_needs_a_single_robot() {
        let config = Config::from_toml(EXAMPLE).unwrap();
        let e = config.robot(None).unwrap_err().to_string();
        assert_eq!(
            e,
            "config defines several robots (gantry, scara); name one of them"
        );
        let shipped = Config::from_toml(SHIPPED).unwrap();
        assert_eq!(shipped.robot(None).unwrap().name, "press-loader");
        let single = Config::from_toml(MINIMAL).unwrap();
        assert_eq!(single.robot(None).unwrap().name, "r");
    }

    #[test]
    fn unknown_robot_name_lists_known_names() {
        let config = Config::from_toml(SHIPPED).unwrap();
        let e = config.robot(Some("welder")).unwrap_err().to_string();
        assert_eq!(
            e,
            "config defines no robot \"welder\"; it defines press-loader"
        );
    }

    #[test]
    fn config_without_robots_is_an_error() {
        assert!(matches!(Config::from_toml(""), Err(ConfigError::NoRobots)));
        assert!(matches!(
            Config::from_toml("# nothing\n"),
            Err(ConfigError::NoRobots)
        ));
    }

    #[test]
    fn each_bad_edit_is_refused_naming_its_line_and_key() {
        assert_refusals(&[
            (
                7,
                "speed_mm_s = 240.0\ncolour = \"red\"",
                Is(
                    "config line 8: robots.r.motion.colour: unknown field `colour`, expected one \
                     of `method`, `period`, `speed_mm_s`, `accel_time`, `frequency_model`, \
                     `over_speed`, `tolerance_mm`, `max_speed_mm_s`, `profile`, `jerk_mm_s3`",
                ),
            ),
            (
                7,
                "speed_mm_s = \"fast\"",
                Is(
                    "config line 7: robots.r.motion.speed_mm_s: invalid type: string \"fast\", \
                     expected f64",
                ),
            ),
            (12, "step_deg = ", StartsWith("config line 12: ")),
            (
                7,
                "",
                Is("config line 5: robots.r.motion: missing field `speed_mm_s`"),
            ),
            (
                24,
                "",
                Is("config line 17: robots.r.joints[1]: missing field `output`"),
            ),
            (
                6,
                "method = \"spline\"\nperiod = \"50ms\"",
                StartsWith("config line 6: robots.r.motion.method: unknown variant"),
            ),
            (
                1,
                "[robots.r]\narea_words = 9000",
                Is("config line 2: robots.r.area_words = 9000: must be within 64..=8000"),
            ),
        ]);
    }

    #[test]
    fn unknown_top_level_key_is_an_error() {
        let text = format!("robot = 1\n{MINIMAL}");
        assert!(message(&text).starts_with("config line 1: robot: unknown field `robot`"));
    }

    #[test]
    fn config_parity_typo_inside_an_inline_table_names_parity_not_serial() {
        let text = SHIPPED.replace("parity = \"odd\"", "partiy = \"odd\"");
        let e = message(&text);
        assert!(
            e.contains(": robots.press-loader.plc.serial.partiy: unknown field `partiy`")
                && e.ends_with("did you mean `parity`?"),
            "{e}"
        );
    }

    #[test]
    fn config_error_of_a_file_names_the_file() {
        let dir = std::env::temp_dir().join(format!("linterpd-config-file-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("linterpd.toml");
        std::fs::write(&path, edited(&[(7, "sped_mm_s = 240.0")])).unwrap();
        let e = Config::load(&path).unwrap_err().to_string();
        assert!(
            e.starts_with(&format!(
                "{}: config line 7: robots.r.motion.sped_mm_s: unknown field `sped_mm_s`",
                path.display()
            )) && e.ends_with("did you mean `speed_mm_s`?"),
            "{e}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn relative_daemon_paths_are_taken_from_the_config_files_directory() {
        let dir = std::env::temp_dir().join(format!("linterpd-config-rel-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("try.toml");
        let text = format!("{MINIMAL}[daemon]\nsocket = \"run/api.sock\"\nstate_dir = \"/abs\"\n");
        std::fs::write(&path, text).unwrap();
        let d = Config::load(&path).unwrap().daemon;
        assert_eq!(d.socket, dir.join("run/api.sock"));
        assert_eq!(d.state_dir, Path::new("/abs"));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn load_reports_the_path_of_an_unreadable_file() {
        let path = Path::new("/nonexistent/linterpd.toml");
        let e = Config::load(path).unwrap_err();
        assert_eq!(
            e.to_string(),
            "cannot read config file /nonexistent/linterpd.toml"
        );
        assert!(std::error::Error::source(&e).is_some());
    }
}
