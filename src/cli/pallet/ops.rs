//! `linterpd pallet status|set|reset|redo|go-on`: a robot's pallets' counts in the daemon
//! (`/v1/robots/{name}/pallets`), and the operator's changes of them.
//!
//! ```text
//!  stdout:  a line per pallet (or the API's answer, --json)
//!  stderr:  the daemon's warning about its pallets file (lost or unreadable), if any
//!  exit:    0 done; 2 no such pallet, an index past its slots (400/404); 3 refused for the
//!           cycle's state or nothing to choose (409); 4 no daemon (503); 1 the daemon could
//!           not write its pallets file (500)
//! ```

use clap::{Args, Subcommand};
use hyper::Method;
use serde_json::{Value, json};

use super::PalletArgs;
use crate::cli::Failure;
use crate::cli::client::{Client, Received};
use crate::wire::{PalletList, PalletStatus};

/// `linterpd pallet` actions on the daemon's counts.
#[derive(Debug, Subcommand)]
pub enum CountAction {
    /// Each pallet's count in the daemon: the slot to fill next, the layer, full, parts and
    /// pallets done, and what to do when a slot was interrupted.
    Status(StatusArgs),
    /// Set the slot to fill next (a partly built pallet put in); the counts stay.
    Set(SetArgs),
    /// Begin a new pallet at slot 0 (a full one is counted as done).
    Reset(Named),
    /// An interrupted slot's part was not placed: place at that slot again.
    Redo(Named),
    /// An interrupted slot's part was placed: count it and go on at the next slot.
    GoOn(Named),
}

/// Arguments of `linterpd pallet status`.
#[derive(Debug, Args)]
pub struct StatusArgs {
    /// One pallet (all of the robot's without).
    pub name: Option<String>,
}

/// Arguments of `linterpd pallet set`.
#[derive(Debug, Args)]
pub struct SetArgs {
    /// The pallet.
    pub name: String,
    /// The slot to fill next, from 0 as `pallet show` numbers them (the pallet's slots: full).
    pub index: usize,
}

/// A pallet of the robot.
#[derive(Debug, Args)]
pub struct Named {
    /// The pallet.
    pub name: String,
}

/// What an action asks of the daemon: the method, the path under the robot, the body.
fn request(action: &CountAction) -> (Method, String, Option<Value>) {
    let post =
        |name: &str, command: &str, body| (Method::POST, format!("pallets/{name}/{command}"), body);
    match action {
        CountAction::Status(s) => match &s.name {
            Some(name) => (Method::GET, format!("pallets/{name}"), None),
            None => (Method::GET, "pallets".to_owned(), None),
        },
        CountAction::Set(s) => post(&s.name, "set", Some(json!({ "index": s.index }))),
        CountAction::Reset(n) => post(&n.name, "reset", None),
        CountAction::Redo(n) => post(&n.name, "redo", None),
        CountAction::GoOn(n) => post(&n.name, "go-on", None),
    }
}

/// Runs an action that asks the daemon.
pub(super) fn run(
    args: &PalletArgs,
    action: &CountAction,
    out: &mut dyn std::io::Write,
) -> Result<(), Failure> {
    let daemon = &args.daemon;
    daemon.block_on(async {
        let client = Client::new(&daemon.socket);
        let robot = client
            .robot(args.robot.as_deref())
            .await
            .map_err(Failure::from_client)?;
        let (method, path, body) = request(action);
        let answer = client
            .expect(method, &format!("/v1/robots/{robot}/{path}"), body.as_ref())
            .await?;
        let hint = args
            .robot
            .as_ref()
            .map_or_else(String::new, |r| format!(" --robot {r}"));
        let text = text(&robot, &hint, answer.clone()).map_err(Failure::Runtime)?;
        crate::cli::print(out, daemon.json, &answer, &text)
    })
}

/// The answer in words: a line per pallet; the file's warning on stderr.
fn text(robot: &str, hint: &str, answer: Value) -> anyhow::Result<String> {
    if answer.get("pallets").is_some_and(Value::is_array) {
        let list: PalletList = Received::read(answer, "a list of pallets")?.value;
        if let Some(warning) = &list.warning {
            eprintln!("warning: {warning}");
        }
        if list.pallets.is_empty() {
            return Ok(format!(
                "{robot}: no pallets ([robots.{robot}.pallets.NAME])"
            ));
        }
        let lines: Vec<String> = list.pallets.iter().map(|p| line(robot, hint, p)).collect();
        return Ok(lines.join("\n"));
    }
    let one: PalletStatus = Received::read(answer, "a pallet's count")?.value;
    Ok(line(robot, hint, &one))
}

/// `press-loader pallet out: slot 7 of 24 next, layer 2 of 4; 31 parts, 1 pallet done`, and
/// what the operator must do when the pallet waits for them.
fn line(robot: &str, hint: &str, p: &PalletStatus) -> String {
    let name = &p.name;
    let head = format!("{robot} pallet {name}");
    if !p.known {
        return format!(
            "{head}: count unknown (the pallets file was lost): set it, `linterpd pallet set \
             {name} INDEX{hint}`, before the cycle places on it"
        );
    }
    let counts = format!(
        "{} part{}, {} pallet{} done",
        p.parts,
        plural(p.parts),
        p.pallets,
        plural(p.pallets)
    );
    let place = if p.full {
        format!("full ({} of {} slots)", p.slots, p.slots)
    } else {
        format!(
            "slot {} of {} next, layer {} of {}",
            p.index,
            p.slots,
            p.layer + 1,
            p.layers
        )
    };
    format!("{head}: {place}; {counts}{}", to_do(hint, p))
}

/// What the operator must do (or what is under way), after a `; `; empty when nothing.
fn to_do(hint: &str, p: &PalletStatus) -> String {
    let name = &p.name;
    match p.in_progress {
        Some(s) if s.unsure => {
            let (slot, next) = (s.slot, (s.slot + 1).min(p.slots));
            format!(
                "; slot {slot} was interrupted with the part perhaps at the slot: choose \
                 `linterpd pallet redo {name}{hint}` (not placed: place at slot {slot} again) \
                 or `linterpd pallet go-on {name}{hint}` (placed: go on at slot {next})"
            )
        }
        Some(s) => {
            let phase = serde_json::to_value(s.phase).unwrap_or_default();
            let phase = phase.as_str().unwrap_or_default().to_owned();
            format!("; placing at slot {} ({phase})", s.slot)
        }
        None if p.full => format!("; when it is changed: `linterpd pallet reset {name}{hint}`"),
        None => String::new(),
    }
}

fn plural(n: u64) -> &'static str {
    if n == 1 { "" } else { "s" }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cli::pallet::PalletAction;
    use crate::cli::{Cli, Command};
    use clap::Parser;

    fn parse(args: &[&str]) -> PalletArgs {
        let cli = Cli::try_parse_from([&["linterpd", "pallet"], args].concat()).unwrap();
        let Command::Pallet(args) = cli.command else {
            panic!("not pallet")
        };
        args
    }

    #[test]
    fn actions_parse_into_their_requests() {
        let cases: [(&[&str], Method, &str, Option<Value>); 6] = [
            (&["status"], Method::GET, "pallets", None),
            (
                &["status", "out", "--json"],
                Method::GET,
                "pallets/out",
                None,
            ),
            (
                &["set", "out", "7"],
                Method::POST,
                "pallets/out/set",
                Some(json!({"index": 7})),
            ),
            (&["reset", "out"], Method::POST, "pallets/out/reset", None),
            (&["redo", "out"], Method::POST, "pallets/out/redo", None),
            (
                &["--robot", "r", "go-on", "out"],
                Method::POST,
                "pallets/out/go-on",
                None,
            ),
        ];
        for (args, method, path, body) in cases {
            let PalletAction::Counts(action) = parse(args).action else {
                panic!("{args:?} is not a count action");
            };
            assert_eq!(
                request(&action),
                (method, path.to_owned(), body),
                "{args:?}"
            );
        }
        assert!(parse(&["status", "--json"]).daemon.json);
        assert_eq!(
            parse(&["go-on", "out", "--robot", "r"]).robot.as_deref(),
            Some("r")
        );
        // An index is a number from 0.
        for bad in [
            &["set", "out", "-1"][..],
            &["set", "out", "x"],
            &["set", "out"],
        ] {
            let cli = Cli::try_parse_from([&["linterpd", "pallet"], bad].concat());
            assert!(cli.is_err(), "{bad:?}");
        }
    }

    fn status(json: Value) -> PalletStatus {
        serde_json::from_value(json).unwrap()
    }

    #[test]
    fn a_line_says_the_count_and_what_the_operator_must_do() {
        let base = json!({"name": "out", "slots": 24, "layers": 4, "index": 7, "layer": 1,
            "full": false, "parts": 31, "pallets": 1, "known": true});
        assert_eq!(
            line("r", "", &status(base.clone())),
            "r pallet out: slot 7 of 24 next, layer 2 of 4; 31 parts, 1 pallet done"
        );
        let mut unsure = base.clone();
        unsure["in_progress"] = json!({"slot": 7, "phase": "unsure", "unsure": true});
        assert_eq!(
            line("r", " --robot r", &status(unsure)),
            "r pallet out: slot 7 of 24 next, layer 2 of 4; 31 parts, 1 pallet done; slot 7 \
             was interrupted with the part perhaps at the slot: choose `linterpd pallet redo \
             out --robot r` (not placed: place at slot 7 again) or `linterpd pallet go-on out \
             --robot r` (placed: go on at slot 8)"
        );
        let mut moving = base.clone();
        moving["in_progress"] = json!({"slot": 7, "phase": "at-slot", "unsure": false});
        assert!(line("r", "", &status(moving)).ends_with("; placing at slot 7 (at-slot)"));
        let mut full = base.clone();
        full["full"] = json!(true);
        full["index"] = json!(24);
        assert_eq!(
            line("r", "", &status(full)),
            "r pallet out: full (24 of 24 slots); 31 parts, 1 pallet done; when it is changed: \
             `linterpd pallet reset out`"
        );
        let mut lost = base;
        lost["known"] = json!(false);
        assert!(line("r", "", &status(lost)).contains("count unknown"));
    }

    #[test]
    fn a_list_has_a_line_per_pallet_and_an_empty_one_says_so() {
        let one = json!({"name": "in", "slots": 6, "layers": 1, "index": 0, "layer": 0,
            "full": false, "parts": 1, "pallets": 0, "known": true});
        let mut two = one.clone();
        two["name"] = json!("out");
        let list = text("r", "", json!({"pallets": [one.clone(), two]})).unwrap();
        assert_eq!(list.lines().count(), 2, "{list}");
        assert!(
            list.starts_with("r pallet in: slot 0 of 6 next, layer 1 of 1; 1 part, 0 pallets done")
        );
        assert_eq!(
            text("r", "", json!({"pallets": []})).unwrap(),
            "r: no pallets ([robots.r.pallets.NAME])"
        );
        assert!(text("r", "", one).unwrap().starts_with("r pallet in:"));
        let e = format!("{:#}", text("r", "", json!({"x": 1})).unwrap_err());
        assert!(
            e.starts_with("the daemon's answer is not a pallet's count"),
            "{e}"
        );
    }
}
