//! `linterpd status`: each robot's link, PLC state, counts and moves, from the daemon.

use clap::Args;
use hyper::Method;
use serde_json::Value;

use super::client::Client;
use super::{DaemonArgs, Failure};

/// Arguments of `linterpd status`.
#[derive(Debug, Args)]
pub struct StatusArgs {
    /// One robot only.
    #[arg(long)]
    pub robot: Option<String>,
    /// The daemon and output options.
    #[command(flatten)]
    pub daemon: DaemonArgs,
}

fn line(r: &Value) -> String {
    let link = if r["link"]["connected"].as_bool() == Some(true) {
        "connected".to_owned()
    } else {
        format!(
            "link down ({})",
            r["link"]["error"].as_str().unwrap_or("not connected yet")
        )
    };
    let pose = r["pose"].as_array().map_or("-".to_owned(), |p| {
        let v: Vec<String> = p
            .iter()
            .map(|x| format!("{:.3}", x.as_f64().unwrap_or(f64::NAN)))
            .collect();
        format!("({})", v.join(", "))
    });
    format!(
        "{}: {link}, PLC {} / {}, heartbeat {} ms, pose {pose}, moving {}, queued {}",
        r["name"].as_str().unwrap_or("?"),
        r["plc_mode"].as_str().unwrap_or("?"),
        r["state"].as_str().unwrap_or("?"),
        r["heartbeat_age_ms"],
        r["current_move"],
        r["queued"]
    )
}

/// Runs `linterpd status`.
pub fn run(args: &StatusArgs, out: &mut dyn std::io::Write) -> Result<(), Failure> {
    args.daemon.block_on(async {
        let client = Client::new(&args.daemon.socket);
        let path = args
            .robot
            .as_ref()
            .map_or("/v1/robots".to_owned(), |r| format!("/v1/robots/{r}"));
        let answer = client.expect(Method::GET, &path, None).await?;
        let robots = match &answer {
            Value::Array(list) => list.clone(),
            one => vec![one.clone()],
        };
        let text: Vec<String> = robots.iter().map(line).collect();
        super::print(out, args.daemon.json, &answer, &text.join("\n"))
    })
}
