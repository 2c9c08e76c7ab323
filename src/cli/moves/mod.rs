//! `linterpd move`: ask the daemon for a move, then follow it (a progress bar from the move's
//! feed: upload, then motion) to a one-line summary. The target is one of `--to X,Y,Z[,A]` (a
//! line to a pose), `--to @NAME` (a line to a taught position), `--by DX,DY,DZ[,DA]` (a jog: a
//! line by an offset from where the move starts) or `--joints J1,J2,J3,J4` (a joint-space move).
//!
//! ```text
//!  stdout:  the summary (or the final report, --json); with --no-wait, the id (or the 202 body)
//!  stderr:  the progress bar on a terminal; a PLC link that goes down while it waits, once
//!  exit:    0 done; 2 bad arguments or a move the daemon refuses as impossible (400/404/422);
//!           3 refused for the robot's state (409: not-homed, faulted, ...), ended stopped,
//!           failed or cancelled, or --timeout ran out; 4 no daemon, or it cannot reach the
//!           PLC (503: link-down, stalled); 130 Ctrl-C, which stopped the robot first
//!           (`--detach`: Ctrl-C leaves the move running, exit 0)
//! ```

mod bars;
mod follow;
mod path;
mod wait;

pub use path::{RunArgs, run as run_path};

use std::fmt::Write as _;

use anyhow::{Context, anyhow};
use clap::Args;
use hyper::Method;
use serde::Serialize;
use serde_json::Value;

use super::args::{
    MethodArg, parse_duration, parse_joints, parse_length_mm, parse_offset, parse_pose, parse_ramp,
    parse_speed_mm_s,
};
use super::client::{Client, Received};
use super::interrupt::Interrupt;
use super::{DaemonArgs, Failure};
use crate::daemon::{MoveAccepted, MoveOrder, MoveReport, Stage};
use crate::order::OrderMotion;
use crate::robot::Ramp;

/// Arguments of `linterpd move`.
#[derive(Debug, Args)]
#[command(group(clap::ArgGroup::new("target").required(true).args(["to", "by", "joints"])))]
pub struct MoveArgs {
    /// Target pose: X,Y,Z or X,Y,Z,A in mm and degrees (without A the tool keeps its angle); or
    /// @NAME, a position taught with `linterpd pos save NAME`.
    #[arg(long, allow_hyphen_values = true)]
    pub to: Option<String>,
    /// A jog: a straight line by DX,DY,DZ or DX,DY,DZ,DA (mm and degrees) from where the move
    /// starts (where the move before it ends, or where the robot is).
    #[arg(long, allow_hyphen_values = true)]
    pub by: Option<String>,
    /// A joint-space move: J1,J2,J3,J4, every joint's target in the joints' order (degrees or
    /// mm); the joints move together on one trapezoid.
    #[arg(long, allow_hyphen_values = true)]
    pub joints: Option<String>,
    /// The robot (needed when the daemon runs several).
    #[arg(long, global = true)]
    pub robot: Option<String>,
    /// Speed, acceleration, method, period and tolerance.
    #[command(flatten)]
    pub motion: MotionFlags,
    /// How long to follow it, and what Ctrl-C does.
    #[command(flatten)]
    pub follow: FollowFlags,
    /// The daemon and output options.
    #[command(flatten)]
    pub daemon: DaemonArgs,
}

/// The following flags `move` and `run` share.
#[derive(Debug, Args)]
pub struct FollowFlags {
    /// The longest to wait for the move's end (a path's: each section's), e.g. `30s` (default:
    /// the daemon's deadline for the move, its planned duration and upload plus margins, and
    /// 2 s more). Running out exits 3 saying what the move waits for; the move is not stopped.
    #[arg(long, allow_hyphen_values = true, conflicts_with = "no_wait")]
    pub timeout: Option<String>,
    /// Return once the move (the path) is accepted, printing its id (its sections' ids).
    #[arg(long)]
    pub no_wait: bool,
    /// Ctrl-C stops following and leaves the move (the path) running (without it, Ctrl-C stops
    /// the robot).
    #[arg(long, conflicts_with = "no_wait")]
    pub detach: bool,
}

impl FollowFlags {
    /// `--timeout`, if given.
    fn timeout(&self) -> Result<Option<std::time::Duration>, Failure> {
        (self.timeout.as_deref())
            .map(|t| parse_duration(t).context("--timeout"))
            .transpose()
            .map_err(Failure::BadInput)
    }

    /// Ctrl-C caught (within the runtime), unless `--no-wait`.
    fn interrupt(&self) -> Result<Option<Interrupt>, Failure> {
        (!self.no_wait)
            .then(|| Interrupt::catch(self.detach))
            .transpose()
    }
}

/// The API's move order for the arguments; every value is checked here first, naming its flag.
fn order(args: &MoveArgs) -> anyhow::Result<MoveOrder> {
    Ok(MoveOrder {
        motion: args.motion.order_motion()?,
        permit: args.motion.permit.clone(),
        ..target(args)?
    })
}

/// The motion flags `move` and `run` share.
#[derive(Debug, Args)]
pub struct MotionFlags {
    /// Speed along the path, e.g. `240mm/s` or `240` (mm/s; default: the robot's). A joint move
    /// takes as long as a line as long as its tool path (or its tool turn, degrees as mm).
    #[arg(long, allow_hyphen_values = true)]
    pub speed: Option<String>,
    /// Acceleration time, e.g. `200ms` (default: the robot's).
    #[arg(long, allow_hyphen_values = true)]
    pub accel_time: Option<String>,
    /// Planning method (default: the robot's; `--tolerance` alone means bounded-error).
    #[arg(long, value_enum)]
    pub method: Option<MethodArg>,
    /// Interpolation period, e.g. `50ms` (default: the robot's).
    #[arg(long, allow_hyphen_values = true)]
    pub period: Option<String>,
    /// Path tolerance of a bounded-error move, e.g. `0.05mm` (a plain number is mm), against
    /// the path as planned (a path's blends included).
    #[arg(long, alias = "tolerance-mm", allow_hyphen_values = true)]
    pub tolerance: Option<String>,
    /// The ramps' shape: `trapezoid`, or `s-curve:JERK` with the path's jerk in mm/s^3, e.g.
    /// `s-curve:20000` (default: the robot's).
    #[arg(long, allow_hyphen_values = true)]
    pub profile: Option<String>,
    /// An interlock the PLC enforces, e.g. `"press_open & !press_moving"` or `"X5 & !X6"`:
    /// signal names or X / R bits of the input words, `!` for off, joined by `&`. The move
    /// starts only while it holds and is held (stopped) in the first scan it stops holding.
    #[arg(long)]
    pub permit: Option<String>,
}

impl MotionFlags {
    /// The motion the flags ask for, each checked here first, naming its flag (the permit
    /// is not a motion key: the caller takes it as it is).
    fn order_motion(&self) -> anyhow::Result<OrderMotion> {
        let speed_mm_s = self.speed.as_deref().map(parse_speed_mm_s);
        let speed_mm_s = speed_mm_s.transpose().context("--speed")?;
        let accel_time = checked_duration(self.accel_time.as_ref(), "--accel-time")?;
        let period = checked_duration(self.period.as_ref(), "--period")?;
        let tolerance_mm = self.tolerance.as_deref().map(parse_length_mm);
        let tolerance_mm = tolerance_mm.transpose().context("--tolerance")?;
        let ramp = self.profile.as_deref().map(parse_ramp);
        let (profile, jerk_mm_s3) = match ramp.transpose().context("--profile")? {
            None => (None, None),
            Some(Ramp::Trapezoid) => (Some("trapezoid"), None),
            Some(Ramp::SCurve { jerk_mm_s3 }) => (Some("s-curve"), Some(jerk_mm_s3)),
        };
        Ok(OrderMotion {
            speed_mm_s,
            accel_time,
            method: self.method.map(|m| m.name().to_owned()),
            period,
            tolerance_mm,
            profile: profile.map(str::to_owned),
            jerk_mm_s3,
        })
    }
}

/// A duration flag's text, once it reads as a duration (the daemon reads it again).
fn checked_duration(text: Option<&String>, flag: &'static str) -> anyhow::Result<Option<String>> {
    if let Some(text) = text {
        parse_duration(text).context(flag)?;
    }
    Ok(text.cloned())
}

/// The order's target, from whichever of `--to`, `--by` and `--joints` was given (clap lets
/// exactly one through).
fn target(args: &MoveArgs) -> anyhow::Result<MoveOrder> {
    let order = MoveOrder::default();
    if let Some(text) = &args.by {
        let by = parse_offset(text).context("--by")?;
        return Ok(MoveOrder {
            by: Some(by),
            ..order
        });
    }
    if let Some(text) = &args.joints {
        let joints = parse_joints(text).context("--joints")?;
        return Ok(MoveOrder {
            joints: Some(joints.to_vec()),
            ..order
        });
    }
    let text = args.to.as_deref().unwrap_or_default();
    if let Some(name) = text.strip_prefix('@') {
        return Ok(MoveOrder {
            position: Some(name.to_owned()),
            ..order
        });
    }
    let pose = parse_pose(text).context("--to")?;
    let mut to: Vec<f64> = pose.xyz_mm.to_vec();
    to.extend(pose.a_deg);
    Ok(MoveOrder {
        to: Some(to),
        ..order
    })
}

/// Runs `linterpd move`.
pub fn run(args: &MoveArgs, out: &mut dyn std::io::Write) -> Result<(), Failure> {
    let order = order(args).map_err(Failure::BadInput)?;
    let timeout = args.follow.timeout()?;
    args.daemon.block_on(async {
        let mut interrupt = args.follow.interrupt()?;
        let client = Client::new(&args.daemon.socket);
        let (robot, accepted) = post(&client, args.robot.as_deref(), "moves", &order).await?;
        let accepted: Received<MoveAccepted> =
            Received::read(accepted, "a move accepted").map_err(Failure::Runtime)?;
        let id = accepted.value.id;
        // A line cut where a joint reverses runs as several starts (an older
        // daemon gives only `id`).
        let ids = match accepted.value.ids.as_slice() {
            [] => vec![id],
            ids => ids.to_vec(),
        };
        if args.follow.no_wait {
            let line = accepted_line(id, &ids);
            return super::print(out, args.daemon.json, &accepted.json, &line);
        }
        let work = follow_starts(&client, &robot, &ids, timeout, args.daemon.json, out);
        let running = format!("move {id} goes on (`linterpd stop` stops it)");
        let stop = async || stop_robot(&client, &robot, &format!("move {id}")).await;
        match &mut interrupt {
            Some(interrupt) => interrupt.attached(work, &running, stop).await,
            None => work.await,
        }
    })
}

/// What `--no-wait` prints of move `id` accepted as the starts `ids`.
fn accepted_line(id: u64, ids: &[u64]) -> String {
    if ids.len() > 1 {
        let list: Vec<String> = ids.iter().map(u64::to_string).collect();
        format!(
            "move {id} accepted: a line cut into {} starts, moves {}",
            ids.len(),
            list.join(", ")
        )
    } else {
        format!("move {id} accepted")
    }
}

/// Follows a move's starts `ids` to their ends, a summary line each (the JSON: the last start's
/// report); done, or exit 3 with how the first one not done ended.
async fn follow_starts(
    client: &Client,
    robot: &str,
    ids: &[u64],
    timeout: Option<std::time::Duration>,
    json: bool,
    out: &mut dyn std::io::Write,
) -> Result<(), Failure> {
    let mut outcome = Ok(());
    for (n, &id) in ids.iter().enumerate() {
        let last = follow::to_end(client, robot, id, timeout, json).await?;
        let line = if ids.len() > 1 {
            format!("start {}/{}: {}", n + 1, ids.len(), summary(&last.value))
        } else {
            summary(&last.value)
        };
        // A start before the last is summed up in text only.
        let printed = if json && n + 1 < ids.len() {
            Ok(())
        } else {
            super::print(out, json, &last.json, &line)
        };
        // The verdict counts even when the summary cannot be written (a closed pipe).
        outcome = outcome.and(verdict(&last.value)).and(printed);
    }
    outcome
}

/// Stops the robot on Ctrl-C (its queued moves are cancelled with it); what was stopped.
async fn stop_robot(client: &Client, robot: &str, what: &str) -> Result<String, Failure> {
    client
        .expect(Method::POST, &format!("/v1/robots/{robot}/stop"), None)
        .await?;
    Ok(format!("{robot} stopped, {what} with it"))
}

/// Posts `order` to the robot's `endpoint` (`moves`, `paths`); the robot's name and the 202 body.
async fn post(
    client: &Client,
    robot: Option<&str>,
    endpoint: &str,
    order: &impl Serialize,
) -> Result<(String, Value), Failure> {
    let order = serde_json::to_value(order).map_err(|e| Failure::Runtime(e.into()))?;
    let robot = client.robot(robot).await.map_err(Failure::from_client)?;
    let accepted = client
        .expect(
            Method::POST,
            &format!("/v1/robots/{robot}/{endpoint}"),
            Some(&order),
        )
        .await?;
    Ok((robot, accepted))
}

/// Done, or exit 3 with how the move ended.
fn verdict(last: &MoveReport) -> Result<(), Failure> {
    if last.stage == Stage::Done {
        return Ok(());
    }
    let why = last
        .error
        .as_ref()
        .map(|e| format!(": {e}"))
        .unwrap_or_default();
    Err(Failure::NotDone(anyhow!(
        "move {} ended {}{why}",
        last.id,
        last.stage.name()
    )))
}

/// One line: what happened, how long it took, how far from the target it ended. Why a move did
/// not end done is not in it: the verdict says it once, on stderr.
fn summary(r: &MoveReport) -> String {
    let secs = |s: Option<f64>| s.map_or("-".to_owned(), |v| format!("{v:.3} s"));
    let mut line = format!(
        "move {} {}: upload {}, motion {}",
        r.id,
        r.stage.name(),
        secs(r.upload_s),
        secs(r.motion_s)
    );
    if let Some(e) = r.final_error_pulses {
        let pulses: Vec<String> = e.iter().map(i64::to_string).collect();
        let _ = write!(line, ", final error [{}] pulses", pulses.join(","));
    }
    if let Some(p) = &r.predicted {
        let _ = write!(
            line,
            ", predicted path deviation {:.4} mm",
            p.path_deviation_mm
        );
    }
    line
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;
    use serde_json::json;

    /// The order as the body posted.
    fn body(args: &MoveArgs) -> Value {
        serde_json::to_value(order(args).unwrap()).unwrap()
    }

    fn move_args(line: &[&str]) -> MoveArgs {
        let mut all = vec!["linterpd", "move"];
        all.extend(line);
        match crate::cli::Cli::try_parse_from(all).unwrap().command {
            crate::cli::Command::Move(args) => args,
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn order_takes_one_spelling_and_the_deprecated_one() {
        let args = move_args(&[
            "--to",
            "1,2,3,45",
            "--speed",
            "120mm/s",
            "--method",
            "bounded-error",
            "--tolerance",
            "0.05mm",
            "--accel-time",
            "200ms",
        ]);
        assert_eq!(
            body(&args),
            json!({"to": [1.0, 2.0, 3.0, 45.0], "speed_mm_s": 120.0,
                "method": "bounded-error", "tolerance_mm": 0.05, "accel_time": "200ms"})
        );
        let old = move_args(&["--to", "1,2,3", "--tolerance-mm", "0.1"]);
        assert_eq!(order(&old).unwrap().motion.tolerance_mm, Some(0.1));
    }

    #[test]
    fn a_jog_joints_or_a_taught_position_is_the_target() {
        assert_eq!(
            body(&move_args(&["--by", "0,-5,2"])),
            json!({"by": [0.0, -5.0, 2.0]})
        );
        assert_eq!(
            body(&move_args(&["--joints", "10,20,30,-45", "--speed", "50"])),
            json!({"joints": [10.0, 20.0, 30.0, -45.0], "speed_mm_s": 50.0})
        );
        assert_eq!(
            body(&move_args(&["--to", "@pick"])),
            json!({"position": "pick"})
        );
        let e = format!("{:#}", order(&move_args(&["--by", "1,2"])).unwrap_err());
        assert!(e.starts_with("--by: '1,2' has 2 values"), "{e}");
        for line in [
            &["linterpd", "move"][..],
            &["linterpd", "move", "--to", "1,2,3", "--by", "1,0,0"],
            &["linterpd", "move", "--joints", "1,2,3,4", "--by", "1,0,0"],
        ] {
            assert!(crate::cli::Cli::try_parse_from(line).is_err(), "{line:?}");
        }
    }

    #[test]
    fn bad_values_name_their_flag() {
        for (flag, value, named) in [
            (
                "--tolerance",
                "-1mm",
                "--tolerance: '-1mm' must be above 0 mm",
            ),
            ("--period", "50", "--period: duration \"50\": no unit"),
            ("--speed", "fast", "--speed: 'fast' is not a number"),
        ] {
            let e = format!(
                "{:#}",
                order(&move_args(&["--to", "1,2,3", flag, value])).unwrap_err()
            );
            assert!(e.contains(named), "{e}");
        }
        assert!(
            crate::cli::Cli::try_parse_from([
                "linterpd", "move", "--to", "1,2,3", "--method", "fast"
            ])
            .is_err()
        );
    }

    #[test]
    fn a_move_that_did_not_end_done_says_how_it_ended() {
        let report = |json| {
            Received::<MoveReport>::read(json, "a report")
                .unwrap()
                .value
        };
        assert!(verdict(&report(json!({"id": 3, "robot": "r", "stage": "done"}))).is_ok());
        let e = verdict(&report(json!({"id": 3, "robot": "r", "stage": "cancelled",
            "error": "cancelled by a stop"})))
        .unwrap_err();
        assert_eq!(e.exit_code(), crate::cli::EXIT_NOT_DONE);
        assert_eq!(e.to_string(), "move 3 ended cancelled: cancelled by a stop");
    }

    #[test]
    fn a_permit_refusal_is_said_once_by_the_verdict_not_by_the_summary_too() {
        let report = Received::<MoveReport>::read(
            json!({"id": 1, "robot": "r", "stage": "failed", "error": "not started: its permit \
                does not hold: X5 is off (the permit needs it on); nothing was written"}),
            "a report",
        )
        .unwrap()
        .value;
        assert_eq!(summary(&report), "move 1 failed: upload -, motion -");
        let e = verdict(&report).unwrap_err().to_string();
        assert_eq!(e.matches("its permit does not hold").count(), 1, "{e}");
    }

    #[test]
    fn a_summary_says_the_times_the_final_error_and_the_predicted_deviation() {
        let report = Received::<MoveReport>::read(
            json!({"id": 5, "robot": "r", "stage": "done", "upload_s": 0.0804,
                "motion_s": null, "final_error_pulses": [0, 1, -1, 0],
                "predicted": {"rows": 1, "words": 8, "duration_s": 1.0,
                    "path_deviation_mm": 0.012_34, "tracking_error_mm": 0.0}}),
            "a report",
        )
        .unwrap()
        .value;
        assert_eq!(
            summary(&report),
            "move 5 done: upload 0.080 s, motion -, final error [0,1,-1,0] pulses, predicted \
             path deviation 0.0123 mm"
        );
    }
}
