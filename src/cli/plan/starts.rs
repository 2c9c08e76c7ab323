//! A planned path's PLC starts placed along the path and in time: what the path command's
//! table, its CSV and its JSON all read the plans through.

use crate::geometry::Path;
use crate::plan::{PathPlan, Plan};

/// One PLC start of a planned path, placed along the path and in time.
#[derive(Debug, Clone, Copy)]
pub(super) struct Start<'a> {
    /// Its number, from 1.
    pub(super) number: usize,
    /// The section (between two stops) it runs, from 1.
    pub(super) section: usize,
    /// Its plan.
    pub(super) plan: &'a Plan,
    /// Where along the whole path its section begins, mm (its plan's path and profile are
    /// measured from there).
    pub(super) section_mm: f64,
    /// Where along the whole path it begins, mm.
    pub(super) begins_mm: f64,
    /// When it begins, s from the path's start (the starts back to back, without the PLC's
    /// scan between them).
    pub(super) begins_s: f64,
}

impl Start<'_> {
    /// Where along the whole path it ends, mm.
    pub(super) fn ends_mm(&self) -> f64 {
        self.section_mm + self.plan.course_mm(self.plan.window.to_s)
    }

    /// When the planned motion reaches `s_mm` along the whole path, s from the path's start.
    fn time_at_mm(&self, s_mm: f64) -> f64 {
        self.begins_s + self.plan.time_at_course_mm(s_mm - self.section_mm)
            - self.plan.window.from_s
    }

    /// The slowest planned speed between `from_mm` and `to_mm` along the whole path while its
    /// profile cruises, mm/s.
    pub(super) fn cruise_mm_s(&self, from_mm: f64, to_mm: f64) -> f64 {
        self.plan
            .cruise_mm_s(from_mm - self.section_mm, to_mm - self.section_mm)
    }

    /// The path it was planned on, measured from its own start.
    pub(super) fn own_path(&self) -> Path {
        self.plan
            .path
            .clone()
            .unwrap_or_else(|| Path::from(self.plan.line))
    }
}

/// Every start of `planned`, in order: the one place this command reads the plans out of a
/// [`PathPlan`] (one start per section, or several parts of a section cut into starts).
pub(super) fn starts(planned: &PathPlan) -> Vec<Start<'_>> {
    let (mut section_mm, mut s) = (0.0, 0.0);
    let mut out = Vec::with_capacity(planned.sections.len());
    for (i, section) in planned.sections.iter().enumerate() {
        for plan in &section.starts {
            out.push(Start {
                number: out.len() + 1,
                section: i + 1,
                plan,
                section_mm,
                begins_mm: section_mm + plan.course_mm(plan.window.from_s),
                begins_s: s,
            });
            s += plan.duration_s();
        }
        section_mm += section.path.length_mm();
    }
    out
}

/// The start that runs distance `s_mm` along the path (the later one at a boundary).
pub(super) fn holding<'a>(starts: &'a [Start<'a>], s_mm: f64) -> &'a Start<'a> {
    let i = starts
        .partition_point(|s| s.begins_mm <= s_mm)
        .saturating_sub(1);
    &starts[i]
}

/// When the planned motion reaches `s_mm` along the path, s from the path's start.
pub(super) fn time_at_mm(starts: &[Start<'_>], s_mm: f64) -> f64 {
    holding(starts, s_mm).time_at_mm(s_mm)
}

/// The elements the pieces of `path` between `from_mm` and `to_mm` come from, as "3" or
/// "2-4" (blends between them included): those whose middle lies between. With none, the
/// piece holding the stretch's own middle: its element, or "(a blend)".
pub(super) fn elements_between(path: &Path, from_mm: f64, to_mm: f64) -> String {
    let mut numbers = path.pieces().iter().filter_map(|p| {
        let mid = p.start_mm + p.primitive.length_mm() / 2.0;
        (from_mm..to_mm)
            .contains(&mid)
            .then_some(p.element)
            .flatten()
    });
    let first = numbers.next();
    match (first, numbers.next_back().or(first)) {
        (Some(a), Some(b)) if a == b => a.to_string(),
        (Some(a), Some(b)) => format!("{a}-{b}"),
        _ => {
            let mid = f64::midpoint(from_mm, to_mm);
            path.pieces()
                .iter()
                .find(|p| (p.start_mm..=p.start_mm + p.primitive.length_mm()).contains(&mid))
                .and_then(|p| p.element)
                .map_or_else(|| "(a blend)".to_owned(), |e| e.to_string())
        }
    }
}
