//! `linterpd pos`: a robot's taught positions (`/v1/robots/{name}/positions`). `save NAME` takes
//! the robot's pose now (from the PLC's counts), `list`, `show NAME` and `delete NAME`; a taught
//! position is a move's target with `linterpd move --to @NAME`.
//!
//! ```text
//!  stdout:  a line per position (or the API's answer, --json)
//!  stderr:  the daemon's warning about its positions file (set aside as corrupt), if any
//!  exit:    0 done; 2 a bad name or no such position (400/404); 3 refused for the robot's state
//!           (409: not-homed, busy); 4 no daemon, or its PLC link is down (503); 1 the daemon
//!           could not write its positions file (500)
//! ```

use clap::{Args, Subcommand};
use hyper::Method;
use serde_json::Value;

use super::client::{Client, Received};
use super::{DaemonArgs, Failure};
use crate::daemon::api::{DeletedPosition, NamedPosition, PositionList, SavedPosition};
use crate::daemon::positions::check_name;

/// Arguments of `linterpd pos`.
#[derive(Debug, Args)]
pub struct PosArgs {
    /// What to do.
    #[command(subcommand)]
    pub action: PosAction,
    /// The robot and the daemon (before or after the action).
    #[command(flatten)]
    pub robot: Robot,
}

/// The `pos` subcommands.
#[derive(Debug, Subcommand)]
pub enum PosAction {
    /// Save the robot's pose now (from the PLC's counts) as NAME, replacing one of that name.
    Save(SaveArgs),
    /// List the robot's taught positions.
    List,
    /// Show one taught position.
    Show(Named),
    /// Delete a taught position.
    Delete(Named),
}

/// A position of a robot.
#[derive(Debug, Args)]
pub struct Named {
    /// The position's name: 1 to 32 letters, digits, '_' or '-', not starting with '-'.
    pub name: String,
}

/// `pos save`: the position, and the frame it is kept in.
#[derive(Debug, Args)]
pub struct SaveArgs {
    /// The position's name: 1 to 32 letters, digits, '_' or '-', not starting with '-'.
    pub name: String,
    /// Keep it in this frame (`[robots.NAME.frames.FRAME]`): re-teaching the frame's three
    /// points then moves it with them.
    #[arg(long)]
    pub frame: Option<String>,
}

/// A robot of the daemon.
#[derive(Debug, Args)]
pub struct Robot {
    /// The robot (needed when the daemon runs several).
    #[arg(long, global = true)]
    pub robot: Option<String>,
    /// The daemon and output options.
    #[command(flatten)]
    pub daemon: DaemonArgs,
}

/// Runs `linterpd pos`.
pub fn run(args: &PosArgs, out: &mut dyn std::io::Write) -> Result<(), Failure> {
    let (method, name) = match &args.action {
        PosAction::Save(s) => (Method::PUT, Some(s.name.as_str())),
        PosAction::List => (Method::GET, None),
        PosAction::Show(n) => (Method::GET, Some(n.name.as_str())),
        PosAction::Delete(n) => (Method::DELETE, Some(n.name.as_str())),
    };
    let target = &args.robot;
    if let Some(name) = name {
        check_name(name).map_err(super::bad_input)?;
    }
    let query = match &args.action {
        PosAction::Save(SaveArgs {
            frame: Some(frame), ..
        }) => format!("?frame={}", frame_query(frame)?),
        _ => String::new(),
    };
    let daemon = &target.daemon;
    daemon.block_on(async {
        let client = Client::new(&daemon.socket);
        let robot = client
            .robot(target.robot.as_deref())
            .await
            .map_err(Failure::from_client)?;
        let path = match name {
            Some(name) => format!("/v1/robots/{robot}/positions/{name}{query}"),
            None => format!("/v1/robots/{robot}/positions"),
        };
        let answer = client.expect(method, &path, None).await?;
        let text = text(&args.action, &robot, &answer).map_err(Failure::Runtime)?;
        super::print(out, daemon.json, &answer, &text)
    })
}

/// What the answer to `action` says, in words; the daemon's warning about its positions file,
/// if it gives one, on stderr.
fn text(action: &PosAction, robot: &str, answer: &Value) -> anyhow::Result<String> {
    let json = answer.clone();
    Ok(match action {
        PosAction::Save(_) => {
            let saved: SavedPosition = Received::read(json, "a position saved")?.value;
            warn(saved.warning.as_deref());
            saved_text(robot, &saved)
        }
        PosAction::List => {
            let list: PositionList = Received::read(json, "a list of positions")?.value;
            warn(list.warning.as_deref());
            list_text(robot, &list)
        }
        PosAction::Show(_) => position_text(&Received::read(json, "a position")?.value),
        PosAction::Delete(_) => {
            let gone: DeletedPosition = Received::read(json, "a position deleted")?.value;
            format!("{robot}: deleted {}", gone.deleted.name)
        }
    })
}

/// A frame's name as a query value: a TOML key of the config, so letters, digits, '_' or '-'.
fn frame_query(frame: &str) -> Result<&str, Failure> {
    let fits = |b: u8| b.is_ascii_alphanumeric() || b == b'_' || b == b'-';
    if frame.is_empty() || !frame.bytes().all(fits) {
        return Err(super::bad_input(anyhow::anyhow!(
            "--frame {frame:?}: a frame's name is letters, digits, '_' or '-' (as its \
             [robots.NAME.frames.NAME] table names it)"
        )));
    }
    Ok(frame)
}

fn warn(warning: Option<&str>) {
    if let Some(warning) = warning {
        eprintln!("warning: {warning}");
    }
}

/// `pick: x 0.000, y 520.000, z 20.000 mm, a 0.000 deg; joint counts [0, 800, 1538, 0]`.
fn position_text(p: &NamedPosition) -> String {
    let v = |i: usize| {
        let text = format!("{:.3}", p.position.pose[i]);
        // No "-0.000" for a value that rounds to zero.
        if text == "-0.000" {
            "0.000".to_owned()
        } else {
            text
        }
    };
    let counts: Vec<String> = p.position.joint_counts.iter().map(i64::to_string).collect();
    let frame = p
        .position
        .frame
        .as_ref()
        .map_or_else(String::new, |f| format!(" in frame {f}"));
    format!(
        "{}: x {}, y {}, z {} mm, a {} deg{frame}; joint counts [{}]",
        p.name,
        v(0),
        v(1),
        v(2),
        v(3),
        counts.join(",")
    )
}

fn saved_text(robot: &str, answer: &SavedPosition) -> String {
    let replaced = if answer.replaced {
        " (replacing the one of that name)"
    } else {
        ""
    };
    format!("{robot}: saved {}{replaced}", position_text(&answer.saved))
}

fn list_text(robot: &str, answer: &PositionList) -> String {
    if answer.positions.is_empty() {
        return format!("{robot}: no taught positions");
    }
    answer
        .positions
        .iter()
        .map(position_text)
        .collect::<Vec<_>>()
        .join("\n")
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;
    use serde_json::json;

    #[test]
    fn positions_print_one_line_each() {
        let p = json!({"name": "pick", "pose": [-0.0, 520.0, 20.0, -0.0001],
            "joint_counts": [0, 800, 1538, 0], "saved_unix_s": 1});
        let pick = Received::<NamedPosition>::read(p.clone(), "a position")
            .unwrap()
            .value;
        assert_eq!(
            position_text(&pick),
            "pick: x 0.000, y 520.000, z 20.000 mm, a 0.000 deg; joint counts [0,800,1538,0]"
        );
        let list = PositionList {
            positions: vec![pick.clone(), pick],
            warning: None,
        };
        assert_eq!(list_text("r", &list).lines().count(), 2);
        let list = |json| text(&PosAction::List, "r", &json);
        assert_eq!(
            list(json!({"positions": []})).unwrap(),
            "r: no taught positions"
        );
        assert_eq!(list(json!({"positions": [p]})).unwrap().lines().count(), 1);
        let e = format!("{:#}", list(json!({"list": []})).unwrap_err());
        assert!(
            e.starts_with("the daemon's answer is not a list of positions"),
            "{e}"
        );
    }

    #[test]
    fn subcommands_parse_and_a_bad_name_is_refused_before_asking() {
        let cli =
            crate::cli::Cli::try_parse_from(["linterpd", "pos", "save", "pick", "--json"]).unwrap();
        let crate::cli::Command::Pos(args) = cli.command else {
            panic!()
        };
        assert!(
            matches!(&args.action, PosAction::Save(n) if n.name == "pick" && n.frame.is_none())
                && args.robot.daemon.json
        );
        let cli = crate::cli::Cli::try_parse_from(["linterpd", "pos", "--json", "list"]).unwrap();
        let crate::cli::Command::Pos(args) = cli.command else {
            panic!()
        };
        assert!(matches!(args.action, PosAction::List) && args.robot.daemon.json);
        let cli = crate::cli::Cli::try_parse_from(["linterpd", "pos", "show", "a b"]).unwrap();
        let crate::cli::Command::Pos(args) = cli.command else {
            panic!()
        };
        let e = run(&args, &mut Vec::new()).unwrap_err();
        assert_eq!(e.exit_code(), crate::cli::EXIT_BAD_INPUT);
        assert!(e.to_string().contains("not starting with '-'"), "{e}");
    }

    #[test]
    fn a_position_in_a_frame_says_so_and_a_bad_frame_name_is_refused_before_asking() {
        let p = json!({"name": "grip", "pose": [30.0, 40.0, 20.0, 10.0],
            "joint_counts": [0, 800, 1538, 0], "saved_unix_s": 1, "frame": "station"});
        let grip = Received::<NamedPosition>::read(p, "a position")
            .unwrap()
            .value;
        assert_eq!(
            position_text(&grip),
            "grip: x 30.000, y 40.000, z 20.000 mm, a 10.000 deg in frame station; joint counts \
             [0,800,1538,0]"
        );
        let parse = |frame: &str| {
            let cli = crate::cli::Cli::try_parse_from([
                "linterpd", "pos", "save", "grip", "--frame", frame,
            ])
            .unwrap();
            let crate::cli::Command::Pos(args) = cli.command else {
                panic!()
            };
            args
        };
        let args = parse("station");
        assert!(
            matches!(&args.action, PosAction::Save(s) if s.frame.as_deref() == Some("station"))
        );
        let e = run(&parse("a&b=c"), &mut Vec::new()).unwrap_err();
        assert_eq!(e.exit_code(), crate::cli::EXIT_BAD_INPUT);
        assert!(e.to_string().contains("--frame \"a&b=c\""), "{e}");
    }
}
