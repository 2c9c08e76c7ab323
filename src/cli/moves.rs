//! `linterpd move`: ask the daemon for a move, then follow it (a progress bar from the move's
//! feed: upload, then motion) to a one-line summary.

use std::fmt::Write as _;

use anyhow::anyhow;
use clap::Args;
use hyper::Method;
use indicatif::{ProgressBar, ProgressStyle};
use serde_json::{Value, json};

use super::args::parse_pose;
use super::client::Client;
use super::{DaemonArgs, Failure};

/// Arguments of `linterpd move`.
#[derive(Debug, Args)]
pub struct MoveArgs {
    /// Target pose: X,Y,Z or X,Y,Z,A in mm and degrees (without A the tool keeps its angle).
    #[arg(long, allow_hyphen_values = true)]
    pub to: String,
    /// The robot (needed when the daemon runs several).
    #[arg(long)]
    pub robot: Option<String>,
    /// Speed along the line, mm/s.
    #[arg(long, allow_hyphen_values = true)]
    pub speed: Option<f64>,
    /// Acceleration time, e.g. `200ms`.
    #[arg(long, allow_hyphen_values = true)]
    pub accel_time: Option<String>,
    /// `constant-period` or `bounded-error`.
    #[arg(long)]
    pub method: Option<String>,
    /// Interpolation period, e.g. `50ms`.
    #[arg(long, allow_hyphen_values = true)]
    pub period: Option<String>,
    /// Path tolerance of a bounded-error move, mm.
    #[arg(long, allow_hyphen_values = true)]
    pub tolerance_mm: Option<f64>,
    /// Return once the move is accepted, printing its id.
    #[arg(long)]
    pub no_wait: bool,
    /// The daemon and output options.
    #[command(flatten)]
    pub daemon: DaemonArgs,
}

fn order(args: &MoveArgs) -> anyhow::Result<Value> {
    let pose = parse_pose(&args.to).map_err(|e| e.context("--to"))?;
    let mut to: Vec<f64> = pose.xyz_mm.to_vec();
    to.extend(pose.a_deg);
    let mut order = json!({ "to": to });
    let fields = [
        ("speed_mm_s", args.speed.map(Value::from)),
        ("accel_time", args.accel_time.clone().map(Value::from)),
        ("method", args.method.clone().map(Value::from)),
        ("period", args.period.clone().map(Value::from)),
        ("tolerance_mm", args.tolerance_mm.map(Value::from)),
    ];
    for (key, value) in fields {
        if let Some(v) = value {
            order[key] = v;
        }
    }
    Ok(order)
}

/// Runs `linterpd move`.
pub fn run(args: &MoveArgs, out: &mut dyn std::io::Write) -> Result<(), Failure> {
    let order = order(args).map_err(Failure::BadInput)?;
    args.daemon.block_on(async {
        let client = Client::new(&args.daemon.socket);
        let robot = client
            .robot(args.robot.as_deref())
            .await
            .map_err(Failure::from_client)?;
        let accepted = client
            .expect(
                Method::POST,
                &format!("/v1/robots/{robot}/moves"),
                Some(&order),
            )
            .await?;
        let id = accepted["id"]
            .as_u64()
            .ok_or_else(|| Failure::Runtime(anyhow!("the daemon gave no move id")))?;
        if args.no_wait {
            return super::print(
                out,
                args.daemon.json,
                &accepted,
                &format!("move {id} accepted"),
            );
        }
        let last = follow(&client, &robot, id, args.daemon.json).await?;
        super::print(out, args.daemon.json, &last, &summary(&last))?;
        match last["stage"].as_str() {
            Some("done") => Ok(()),
            _ => Err(Failure::MoveEnded(anyhow!(
                "move {id} ended {}",
                last["stage"].as_str().unwrap_or("?")
            ))),
        }
    })
}

/// Follows a move's feed to its end, drawing the progress bar on a terminal.
async fn follow(client: &Client, robot: &str, id: u64, quiet: bool) -> Result<Value, Failure> {
    let bar = if quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(1_000)
    };
    bar.set_style(
        ProgressStyle::with_template("{msg:>10} [{bar:40}] {percent:>3}%")
            .expect("template")
            .progress_chars("=> "),
    );
    let mut last = Value::Null;
    client
        .feed(&format!("/v1/robots/{robot}/moves/{id}/events"), |report| {
            let stage = report["stage"].as_str().unwrap_or("?");
            let progress = report["progress"].as_f64().unwrap_or(0.0);
            bar.set_message(stage.to_owned());
            bar.set_position(if stage == "uploading" || stage == "queued" {
                0
            } else {
                (progress * 1_000.0) as u64
            });
            last = report.clone();
            !matches!(stage, "done" | "stopped" | "failed")
        })
        .await
        .map_err(Failure::from_client)?;
    bar.finish_and_clear();
    Ok(last)
}

/// One line: what happened, how long it took, how far from the target it ended.
fn summary(r: &Value) -> String {
    let num = |k: &str| {
        r[k].as_f64()
            .map_or("-".to_owned(), |v| format!("{v:.3} s"))
    };
    let mut line = format!(
        "move {} {}: upload {}, motion {}",
        r["id"],
        r["stage"].as_str().unwrap_or("?"),
        num("upload_s"),
        num("motion_s")
    );
    if let Some(e) = r["final_error_pulses"].as_array() {
        let _ = write!(line, ", final error {} pulses", Value::Array(e.clone()));
    }
    if let Some(d) = r["predicted"]["path_deviation_mm"].as_f64() {
        let _ = write!(line, ", predicted path deviation {d:.4} mm");
    }
    if let Some(e) = r["error"].as_str() {
        let _ = write!(line, ": {e}");
    }
    line
}
