//! What a followed move shows on a terminal (stderr): one bar for the move, its stage and the
//! share of its planned time gone; and for a path section's move, one bar per piece of the
//! section under it (`element 2`, `blend 2`, ...), each filled as the robot runs through it, the
//! piece it is on marked. A piece's share is of the time the plan gives it, from the report's
//! `section.pieces[].begins` and `ends` (shares of the move's planned time, as its `progress`).
//!
//! ```text
//!    running [=================>                      ]  45%
//!  element 1 [========================================] 100%
//! > blend 1  [=============>                          ]  35%
//!  element 2 [                                        ]   0%
//! ```

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};

use crate::daemon::{MoveReport, PieceReport, Stage};

/// Positions a bar has.
const STEPS: u64 = 1_000;

/// The bars of one followed move.
pub(super) struct Bars {
    multi: MultiProgress,
    /// The move's bar.
    main: ProgressBar,
    /// One per piece of a path section (made from the first report that lists them).
    pieces: Vec<ProgressBar>,
}

impl Bars {
    /// Bars on stderr, or hidden (`--json`).
    pub(super) fn new(quiet: bool) -> Self {
        let target = if quiet {
            ProgressDrawTarget::hidden()
        } else {
            ProgressDrawTarget::stderr()
        };
        let multi = MultiProgress::with_draw_target(target);
        let main = multi.add(ProgressBar::new(STEPS));
        main.set_style(style());
        Self {
            multi,
            main,
            pieces: Vec::new(),
        }
    }

    /// Shows `report`, the move's latest.
    pub(super) fn show(&mut self, report: &MoveReport) {
        let progress = match report.stage {
            Stage::Uploading | Stage::Prepared | Stage::Queued => 0.0,
            _ => report.progress,
        };
        self.main.set_message(report.stage.name());
        self.main.set_position(position(progress));
        let Some(section) = &report.section else {
            return;
        };
        let pieces = section.pieces.as_slice();
        if self.pieces.is_empty() {
            for _ in pieces {
                let bar = self.multi.add(ProgressBar::new(STEPS));
                bar.set_style(style());
                self.pieces.push(bar);
            }
        }
        let on = current(pieces, progress);
        for (i, (bar, piece)) in self.pieces.iter().zip(pieces).enumerate() {
            let mark = if Some(i) == on { "> " } else { "" };
            bar.set_message(format!("{mark}{}", piece_name(piece)));
            bar.set_position(position(piece_share(piece, progress)));
        }
    }

    /// Prints a line above the bars.
    pub(super) fn say(&self, line: &str) {
        self.multi.suspend(|| eprintln!("{line}"));
    }

    /// Takes the bars off the terminal.
    pub(super) fn clear(&self) {
        for bar in self.pieces.iter().chain([&self.main]) {
            bar.finish_and_clear();
        }
    }

    /// The move's bar and its pieces' bars: (message, position of [`STEPS`]) each.
    #[cfg(test)]
    fn shown(&self) -> Vec<(String, u64)> {
        [&self.main]
            .into_iter()
            .chain(&self.pieces)
            .map(|b| (b.message(), b.position()))
            .collect()
    }
}

fn style() -> ProgressStyle {
    ProgressStyle::with_template("{msg:>12} [{bar:40}] {percent:>3}%")
        .expect("template")
        .progress_chars("=> ")
}

fn position(share: f64) -> u64 {
    (share.clamp(0.0, 1.0) * STEPS as f64).round() as u64
}

/// A piece as the operator knows it: `element 2`, or `blend 2` for the corner arc rounding
/// waypoint 2.
pub(super) fn piece_name(piece: &PieceReport) -> String {
    match (piece.element, piece.waypoint) {
        (Some(e), _) => format!("element {e}"),
        (None, Some(w)) => format!("blend {w}"),
        (None, None) => "blend".to_owned(),
    }
}

/// How much of its planned time a piece has run when the move has run `progress` of its own.
fn piece_share(piece: &PieceReport, progress: f64) -> f64 {
    let (begins, ends) = (piece.begins, piece.ends);
    if ends <= begins {
        return if progress >= ends { 1.0 } else { 0.0 };
    }
    ((progress - begins) / (ends - begins)).clamp(0.0, 1.0)
}

/// The piece the robot is on at `progress` (the last once the move is over).
fn current(pieces: &[PieceReport], progress: f64) -> Option<usize> {
    let running = pieces.iter().position(|p| progress < p.ends);
    running.or_else(|| pieces.len().checked_sub(1))
}

/// The elements a section's report covers, as "3" or "2-4" (`None` for a move that is no path
/// section).
pub(super) fn elements(report: &MoveReport) -> Option<String> {
    let pieces = &report.section.as_ref()?.pieces;
    let mut numbers = pieces.iter().filter_map(|p| p.element);
    let first = numbers.next()?;
    let last = numbers.next_back().unwrap_or(first);
    Some(if first == last {
        first.to_string()
    } else {
        format!("{first}-{last}")
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cli::client::Received;
    use serde_json::{Value, json};

    /// A report of move 1 at `stage` and `progress`, of `section` if given.
    fn report(stage: &str, progress: f64, section: Option<Value>) -> MoveReport {
        let mut json = json!({"id": 1, "robot": "r", "stage": stage, "progress": progress});
        if let Some(section) = section {
            json["section"] = section;
        }
        Received::read(json, "a report").unwrap().value
    }

    fn section() -> Value {
        json!({"number": 1, "of": 2, "pieces": [
            {"kind": "line", "element": 1, "waypoint": null, "begins": 0.0, "ends": 0.5},
            {"kind": "arc", "element": null, "waypoint": 1, "begins": 0.5, "ends": 0.6},
            {"kind": "line", "element": 2, "waypoint": null, "begins": 0.6, "ends": 1.0},
        ]})
    }

    #[test]
    fn a_section_shows_a_bar_per_element_and_blend_marking_the_one_the_robot_is_on() {
        let mut bars = Bars::new(true);
        bars.show(&report("uploading", 0.0, Some(section())));
        let shown = bars.shown();
        assert_eq!(shown.len(), 4);
        assert_eq!(shown[1], ("> element 1".to_owned(), 0));
        bars.show(&report("running", 0.55, Some(section())));
        assert_eq!(
            bars.shown(),
            [
                ("running".to_owned(), 550),
                ("element 1".to_owned(), 1000),
                ("> blend 1".to_owned(), 500),
                ("element 2".to_owned(), 0),
            ]
        );
        bars.show(&report("done", 1.0, Some(section())));
        let shown = bars.shown();
        assert!(shown[1..].iter().all(|(_, p)| *p == 1000), "{shown:?}");
        assert_eq!(shown[3].0, "> element 2");
    }

    #[test]
    fn a_plain_move_has_one_bar_and_waits_at_zero_until_it_runs() {
        let mut bars = Bars::new(true);
        bars.show(&report("queued", 0.3, None));
        assert_eq!(bars.shown(), [("queued".to_owned(), 0)]);
        bars.show(&report("running", 0.3, None));
        assert_eq!(bars.shown(), [("running".to_owned(), 300)]);
    }

    #[test]
    fn a_sections_elements_are_named_first_to_last() {
        assert_eq!(
            elements(&report("done", 1.0, Some(section()))).as_deref(),
            Some("1-2")
        );
        let one = json!({"number": 1, "of": 1, "pieces": [{"kind": "line", "element": 3,
            "begins": 0.0, "ends": 1.0}]});
        assert_eq!(
            elements(&report("done", 1.0, Some(one))).as_deref(),
            Some("3")
        );
        assert_eq!(elements(&report("done", 1.0, None)), None);
    }
}
