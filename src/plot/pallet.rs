//! An SVG picture of a pallet's layers ([`layers_svg`]), as a string (no IO): one panel per
//! layer seen from above, every slot a square at its place (x right, y up, all panels on one
//! scale), filled when placed, outlined when not, numbered in fill order, with a tick showing
//! the tool angle.
//!
//! ```text
//! +--------------- pallet "out": 30 of 96 placed ----------------+
//! | layer 1 (24 placed) | layer 2 (6 placed) | layer 3 | layer 4 |
//! |  [1][2][3][4]       |  [25][26] ...      |         |         |
//! +---------------------------------------------------------------+
//! ```

use std::fmt::Write as _;

use crate::pallet::{Pattern, Slot};

/// A panel's side, px.
const PANEL_PX: f64 = 260.0;
/// The margin around a panel's slots and above it for its title, px.
const MARGIN_PX: f64 = 24.0;
/// Panels per row of the picture.
const PER_ROW: usize = 4;

/// The picture of `pattern`'s layers with its first `placed` slots (in fill order) placed.
#[must_use]
pub fn layers_svg(pattern: &Pattern, placed: usize) -> String {
    let layers = pattern.layers().max(1);
    let columns = layers.min(PER_ROW);
    let rows = layers.div_ceil(PER_ROW);
    let (w, h) = (
        columns as f64 * PANEL_PX,
        rows as f64 * PANEL_PX + MARGIN_PX,
    );
    let placed = placed.min(pattern.len());
    let mut svg = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" viewBox=\"0 0 {w} {h}\" \
         font-family=\"sans-serif\" font-size=\"10\">\n<rect width=\"{w}\" height=\"{h}\" fill=\"white\"/>\n\
         <text x=\"{}\" y=\"16\" text-anchor=\"middle\" font-size=\"14\">pallet {}: {placed} of {} placed</text>\n",
        w / 2.0,
        escape(&format!("{:?}", pattern.name())),
        pattern.len(),
    );
    let scale = Scale::of(pattern);
    for layer in 0..layers {
        layer_panel(&mut svg, pattern, &scale, layer, placed);
    }
    svg.push_str("</svg>\n");
    svg
}

/// Writes the panel of `layer` (its place in the picture, its title, its slots) to `svg`.
fn layer_panel(svg: &mut String, pattern: &Pattern, scale: &Scale, layer: usize, placed: usize) {
    let (ox, oy) = (
        (layer % PER_ROW) as f64 * PANEL_PX,
        (layer / PER_ROW) as f64 * PANEL_PX + MARGIN_PX,
    );
    let in_layer = pattern.slots().iter().filter(|s| s.layer == layer);
    let done = in_layer.clone().filter(|s| s.index < placed).count();
    let _ = writeln!(
        svg,
        "<g transform=\"translate({ox},{oy})\"><rect x=\"2\" y=\"2\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"#999\"/>\
         <text x=\"{}\" y=\"16\" text-anchor=\"middle\">layer {} ({done} of {} placed)</text>",
        PANEL_PX - 4.0,
        PANEL_PX - 4.0,
        PANEL_PX / 2.0,
        layer + 1,
        in_layer.clone().count(),
    );
    for slot in in_layer {
        slot_mark(svg, scale, slot, slot.index < placed);
    }
    svg.push_str("</g>\n");
}

/// Writes `slot` to `svg`: a square at its place (filled when `placed`), a tick showing the tool
/// angle and its number in fill order.
fn slot_mark(svg: &mut String, scale: &Scale, slot: &Slot, placed: bool) {
    let (x, y) = scale.at(slot.pose.position_mm.x, slot.pose.position_mm.y);
    let half = scale.slot_px / 2.0;
    let fill = if placed { "#4a7fb5" } else { "none" };
    let (s, c) = slot.pose.a_rad.sin_cos();
    let _ = writeln!(
        svg,
        "<rect x=\"{:.1}\" y=\"{:.1}\" width=\"{:.1}\" height=\"{:.1}\" fill=\"{fill}\" stroke=\"#1d3d5e\"/>\
         <line x1=\"{x:.1}\" y1=\"{y:.1}\" x2=\"{:.1}\" y2=\"{:.1}\" stroke=\"#c33\"/>\
         <text x=\"{x:.1}\" y=\"{:.1}\" text-anchor=\"middle\" font-size=\"8\">{}</text>",
        x - half,
        y - half,
        scale.slot_px,
        scale.slot_px,
        x + c * half,
        y - s * half,
        y + half + 9.0,
        slot.index + 1,
    );
}

/// World x, y -> a panel's px, the same for every layer.
struct Scale {
    min: (f64, f64),
    px_per_mm: f64,
    offset: (f64, f64),
    slot_px: f64,
}

impl Scale {
    fn of(pattern: &Pattern) -> Self {
        let xs = pattern.slots().iter().map(|s| s.pose.position_mm.x);
        let ys = pattern.slots().iter().map(|s| s.pose.position_mm.y);
        let (x0, x1) = xs.fold((f64::MAX, f64::MIN), |(a, b), x| (a.min(x), b.max(x)));
        let (y0, y1) = ys.fold((f64::MAX, f64::MIN), |(a, b), y| (a.min(y), b.max(y)));
        let inner = PANEL_PX - 2.0 * MARGIN_PX - 12.0;
        let span = (x1 - x0).max(y1 - y0).max(1.0);
        let px_per_mm = inner / span;
        let nearest = nearest_gap(pattern).map_or(inner / 4.0, |g| g * px_per_mm);
        Self {
            min: (x0, y0),
            px_per_mm,
            offset: (
                MARGIN_PX + 6.0 + (inner - (x1 - x0) * px_per_mm) / 2.0,
                MARGIN_PX + 6.0 + (inner - (y1 - y0) * px_per_mm) / 2.0,
            ),
            slot_px: (nearest * 0.8).clamp(4.0, inner / 2.0),
        }
    }

    fn at(&self, x: f64, y: f64) -> (f64, f64) {
        let px = self.offset.0 + (x - self.min.0) * self.px_per_mm;
        // y up: the panel's bottom is the pallet's lowest y.
        let py = PANEL_PX - (self.offset.1 + (y - self.min.1) * self.px_per_mm);
        (px, py)
    }
}

/// The smallest distance in x, y between two slots of one layer, mm.
fn nearest_gap(pattern: &Pattern) -> Option<f64> {
    let slots = pattern.slots();
    let mut best: Option<f64> = None;
    for (i, a) in slots.iter().enumerate() {
        for b in slots[i + 1..].iter().filter(|b| b.layer == a.layer) {
            let d = (a.pose.position_mm.xy() - b.pose.position_mm.xy()).norm();
            if d > 1e-6 {
                best = Some(best.map_or(d, |m| m.min(d)));
            }
        }
    }
    best
}

fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Pose;
    use crate::pallet::Slot;

    fn pattern() -> Pattern {
        let slots = (0..12)
            .map(|i| Slot {
                index: i,
                layer: i / 6,
                row: (i % 6) / 3,
                column: i % 3,
                pose: Pose::from_mm_deg(
                    300.0 * (i % 3) as f64,
                    200.0 * ((i % 6) / 3) as f64,
                    100.0 * (i / 6) as f64,
                    0.0,
                ),
                approach: vec![],
                slot_speed_mm_s: None,
                retreat: vec![],
            })
            .collect();
        Pattern::from_slots("out", slots).unwrap()
    }

    #[test]
    fn one_panel_per_layer_and_the_placed_slots_filled() {
        let svg = layers_svg(&pattern(), 8);
        assert_eq!(svg.matches("<g transform").count(), 2);
        assert_eq!(svg.matches("fill=\"#4a7fb5\"").count(), 8);
        assert_eq!(svg.matches("fill=\"none\" stroke=\"#1d3d5e\"").count(), 4);
        assert!(
            svg.contains("pallet &quot;out&quot;: 8 of 12 placed"),
            "{svg}"
        );
        assert!(svg.contains("layer 2 (2 of 6 placed)"), "{svg}");
        // Slot 1 (index 0) sits left of slot 2 and below slot 4 (row 1).
        let x_of = |n: usize| -> f64 {
            let at = svg.find(&format!(">{n}</text>")).unwrap();
            let tag = &svg[svg[..at].rfind("<text x=\"").unwrap() + 9..];
            tag[..tag.find('"').unwrap()].parse().unwrap()
        };
        assert!(x_of(1) < x_of(2) && x_of(2) < x_of(3));
    }

    #[test]
    fn more_placed_than_slots_is_a_full_pallet() {
        assert!(layers_svg(&pattern(), 99).contains("12 of 12 placed"));
    }
}
