//! How the tolerance becomes every joint's window, so that the windows alone keep the tool
//! within it.
//!
//! A joint whose pulses all land inside windows `delta` pulses wide is never more than
//! `1/2 + delta` pulses from its planned fractional count (see [`super::pulses`]); the rows hold
//! every pulse inside its window at the frequencies the channel really plays (see
//! [`super::rows`]). One pulse of joint `j` moves the tool by a vector `v_j` (the Jacobian's
//! column times the step), so the tool is off its planned pose by about `sum_j e_j v_j` with
//! `|e_j| <= 1/2 + delta_j`: the worst of that over the box of errors is at one of its corners,
//! and it is the joints' errors combined as vectors (a joint that moves the tool sideways and one
//! that moves it up add in quadrature, not in sum). Its part across the path bounds the path
//! deviation, its whole the tracking error.
//!
//! Windows sized so that this worst case stays within the tolerance hold whatever the rows make
//! of them: one pass, no retry, as long as the linearisation holds (the pulses are small against
//! the robot) and the samples of the vectors catch their largest.

use std::cell::Cell;

use nalgebra::Vector3;

use crate::kinematics::{JOINTS, Joints, Kinematics};
use crate::robot::Robot;

/// Points along the path at which the pulse vectors are taken (and both ends).
const POINTS: usize = 128;
/// The share of the tolerance the worst case may take: the rest covers the vectors between the
/// points they were taken at and the second-order terms of the kinematics.
const MARGIN: f64 = 0.95;
/// Halvings in the search for the windows' scale.
const HALVINGS: usize = 20;

/// One pulse of every joint at one point of the path: how it moves the tool, as the products
/// of the joints' vectors (`gram[j][k] = v_j . v_k`, mm^2), which is all the worst case needs.
#[derive(Debug, Clone, Copy)]
struct Point {
    /// Of the moves across the path.
    across: [[f64; JOINTS]; JOINTS],
    /// Of the whole moves.
    whole: [[f64; JOINTS]; JOINTS],
}

fn gram(v: &[Vector3<f64>; JOINTS]) -> [[f64; JOINTS]; JOINTS] {
    std::array::from_fn(|j| std::array::from_fn(|k| v[j].dot(&v[k])))
}

/// `|sum_j e_j v_j|^2` from the vectors' products.
/// The corners of the box of joint errors `1/2 + delta_j` pulses each side; the norm is even,
/// so those with the first joint's error positive suffice.
fn corners(deltas: &[f64; JOINTS]) -> [[f64; JOINTS]; 1 << (JOINTS - 1)] {
    let half = deltas.map(|d| 0.5 + d);
    std::array::from_fn(|corner| {
        std::array::from_fn(|j| {
            if j > 0 && corner & (1 << (j - 1)) != 0 {
                -half[j]
            } else {
                half[j]
            }
        })
    })
}

fn norm2(gram: &[[f64; JOINTS]; JOINTS], e: &[f64; JOINTS]) -> f64 {
    let mut sum = 0.0;
    for j in 0..JOINTS {
        for k in 0..JOINTS {
            sum += gram[j][k] * e[j] * e[k];
        }
    }
    sum
}

/// At least [`norm2`] of every corner of the box `|e_j| <= half[j]`: each product taken at
/// its largest (`|g_jk| half_j half_k`), exact when the vectors are square to each other.
fn above_every_corner(gram: &[[f64; JOINTS]; JOINTS], half: &[f64; JOINTS]) -> f64 {
    let mut sum = 0.0;
    for j in 0..JOINTS {
        for k in 0..JOINTS {
            sum += gram[j][k].abs() * half[j] * half[k];
        }
    }
    sum
}

/// Every joint's pulse vectors along the path.
#[derive(Debug, Clone)]
pub(super) struct Budget {
    points: Vec<Point>,
    /// Every joint's largest `max(|across|, |whole| / 2)` along the path, mm: what one pulse of
    /// error costs against the path limit (the tolerance) or the tracking limit (twice it).
    reach_mm: [f64; JOINTS],
    /// Every joint's largest whole move, mm.
    whole_mm: [f64; JOINTS],
    /// How many pulses every joint makes along the path.
    pulses: [f64; JOINTS],
    /// The point that last put windows past a limit: the next probe looks at it first.
    binding: Cell<usize>,
}

impl Budget {
    /// The pulse vectors at [`POINTS`] of `values` (the joints along the path, sampled in time).
    pub(super) fn new(robot: &Robot, values: &[Joints]) -> Self {
        let n = values.len();
        let fk = |q: &Joints| robot.kinematics.fk(q).position_mm;
        let steps: Joints = std::array::from_fn(|j| robot.joints[j].step);
        let mut points = Vec::with_capacity(POINTS + 2);
        let (mut reach_mm, mut whole_mm) = ([0.0f64; JOINTS], [0.0f64; JOINTS]);
        for i in (0..n).step_by((n / POINTS).max(1)).chain([n - 1]) {
            let (p, moved) = robot.kinematics.fk_moved(&values[i], &steps);
            let (before, after) = (i.saturating_sub(1), (i + 1).min(n - 1));
            let tangent = (fk(&values[after]) - fk(&values[before])).try_normalize(1e-12);
            let (mut across, mut whole) = ([Vector3::zeros(); JOINTS], [Vector3::zeros(); JOINTS]);
            for j in 0..JOINTS {
                let d = moved[j] - p;
                across[j] = tangent.map_or(d, |t| d - t * d.dot(&t));
                whole[j] = d;
                reach_mm[j] = reach_mm[j].max(across[j].norm().max(d.norm() / 2.0));
                whole_mm[j] = whole_mm[j].max(d.norm());
            }
            points.push(Point {
                across: gram(&across),
                whole: gram(&whole),
            });
        }
        // Every joint's pulses over the whole path.
        let pulses: [f64; JOINTS] = std::array::from_fn(|j| {
            let step = robot.joints[j].step;
            values
                .windows(2)
                .map(|w| (w[1][j] - w[0][j]).abs())
                .sum::<f64>()
                / step
        });
        Self {
            points,
            reach_mm,
            whole_mm,
            pulses,
            binding: Cell::new(0),
        }
    }

    /// Every joint's largest `max(|across|, |whole| / 2)` per pulse along the path, mm.
    pub(super) fn reach_mm(&self) -> [f64; JOINTS] {
        self.reach_mm
    }

    /// The worst path deviation, mm, of windows `deltas` counting only the joints that make
    /// more than `busy` pulses along the path (linearised, every product at its largest: see
    /// [`above_every_corner`]). A joint that makes only a few pulses in the whole move (the
    /// seed's base: 18) counts in the worst case with its whole window, which its rows, a
    /// pulse or two each, seldom take up.
    pub(super) fn busy_worst_mm(&self, deltas: &[f64; JOINTS], busy: f64) -> f64 {
        let half: [f64; JOINTS] = std::array::from_fn(|j| {
            if self.pulses[j] > busy {
                0.5 + deltas[j]
            } else {
                0.0
            }
        });
        self.points
            .iter()
            .map(|p| above_every_corner(&p.across, &half))
            .fold(0.0, f64::max)
            .sqrt()
    }

    /// Every joint's largest whole move per pulse, mm.
    pub(super) fn whole_mm(&self) -> [f64; JOINTS] {
        self.whole_mm
    }

    /// The worst path deviation and tracking error, mm, of joints each at most `1/2 + delta_j`
    /// pulses off (linearised): the largest over the points and the corners of the box.
    pub(super) fn worst_mm(&self, deltas: &[f64; JOINTS]) -> (f64, f64) {
        let corners = corners(deltas);
        let (mut across2, mut whole2) = (0.0f64, 0.0f64);
        for point in &self.points {
            for e in &corners {
                across2 = across2.max(norm2(&point.across, e));
                whole2 = whole2.max(norm2(&point.whole, e));
            }
        }
        (across2.sqrt(), whole2.sqrt())
    }

    /// Windows of `scale * pulses_j^(1/5) / reach_j^(4/5)` pulses, at most `max_delta`
    /// (`max_delta` for a joint that does not move the tool). A joint's rows go about as
    /// `sqrt(pulses / delta)` (a row of one frequency strays from a bending track as the square
    /// of its length), and its share of the worst case as `delta * reach`: spreading the
    /// tolerance in this proportion gives about the fewest rows in all.
    fn shaped(&self, scale: f64, max_delta: f64) -> [f64; JOINTS] {
        std::array::from_fn(|j| {
            let r = self.reach_mm[j];
            if r > 0.0 {
                (scale * self.pulses[j].powf(0.2) / r.powf(0.8)).min(max_delta)
            } else {
                max_delta
            }
        })
    }

    /// Whether windows `deltas` keep the worst path deviation within [`MARGIN`] of
    /// `tolerance_mm` and the worst tracking error within it of twice that.
    /// The same decision as comparing the worst case (`worst_mm`, in the tests) with both
    /// limits, made at the first point past either, the point that was past one last time
    /// looked at first (a bisection's refused probes are refused at once).
    fn fits(&self, deltas: &[f64; JOINTS], tolerance_mm: f64) -> bool {
        let (path_limit, tracking_limit) = (MARGIN * tolerance_mm, 2.0 * MARGIN * tolerance_mm);
        let corners = corners(deltas);
        let half = corners[0];
        // Below these (with room for the roundings) a point's every corner is within both
        // limits: it cannot decide.
        let (path_clear, tracking_clear) = (
            path_limit * path_limit * (1.0 - 1e-9),
            tracking_limit * tracking_limit * (1.0 - 1e-9),
        );
        let (mut across2, mut whole2) = (0.0f64, 0.0f64);
        let first = self.binding.get().min(self.points.len().saturating_sub(1));
        let order = std::iter::once(first).chain((0..self.points.len()).filter(|&i| i != first));
        for i in order {
            let point = &self.points[i];
            if above_every_corner(&point.across, &half) * (1.0 + 1e-9) <= path_clear
                && above_every_corner(&point.whole, &half) * (1.0 + 1e-9) <= tracking_clear
            {
                continue;
            }
            for e in &corners {
                let a = norm2(&point.across, e);
                if a > across2 {
                    across2 = a;
                    if across2.sqrt() > path_limit {
                        self.binding.set(i);
                        return false;
                    }
                }
                let w = norm2(&point.whole, e);
                if w > whole2 {
                    whole2 = w;
                    if whole2.sqrt() > tracking_limit {
                        self.binding.set(i);
                        return false;
                    }
                }
            }
        }
        true
    }

    /// The widest windows that fit ([`Self::fits`]): shaped ([`Self::shaped`]) as wide as they
    /// fit, then every joint, most pulses first, widened alone into what the others leave (a
    /// joint that moves the tool along the path is held by the tracking limit, not the path
    /// limit). `None` when not even windows of width 0 fit (the pulse grid's worst case is
    /// already too much).
    pub(super) fn widest(&self, tolerance_mm: f64, max_delta: f64) -> Option<[f64; JOINTS]> {
        if !self.fits(&[0.0; JOINTS], tolerance_mm) {
            return None;
        }
        let scale = largest(|scale| self.fits(&self.shaped(scale, max_delta), tolerance_mm));
        let mut deltas = self.shaped(scale, max_delta);
        let mut order: Vec<usize> = (0..JOINTS).filter(|&j| self.pulses[j] > 0.0).collect();
        order.sort_by(|&a, &b| self.pulses[b].total_cmp(&self.pulses[a]));
        for j in order {
            let from = deltas[j];
            let wider = |extra: f64| {
                let mut d = deltas;
                d[j] = (from + extra).min(max_delta);
                self.fits(&d, tolerance_mm)
            };
            deltas[j] = (from + largest(wider)).min(max_delta);
        }
        Some(deltas)
    }
}

/// The largest `x >= 0` for which `fits(x)` holds, to within a millionth of the first bound that
/// does not (`fits` monotonic, `fits(0)` true; at most 2^20 if every value fits).
fn largest(fits: impl Fn(f64) -> bool) -> f64 {
    // Where the doubling below ends when every probe fits (a window capped at its widest fits
    // at any scale): asked first, it spares the twenty probes on the way.
    const LAST_DOUBLING: f64 = 524_288.0;
    if fits(LAST_DOUBLING) {
        return LAST_DOUBLING;
    }
    let (mut good, mut bad) = (0.0, 1.0);
    while fits(bad) {
        good = bad;
        bad *= 2.0;
        if bad > 1e6 {
            return good;
        }
    }
    for _ in 0..HALVINGS {
        let mid = f64::midpoint(good, bad);
        if fits(mid) {
            good = mid;
        } else {
            bad = mid;
        }
    }
    good
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robot::seed_robot;

    /// The seed robot moving out from radius `r_mm` in `n` steps of 0.5 mm, rising `rise` mm
    /// per mm, its joints as the kinematics give them.
    fn moving_out(r_mm: f64, rise: f64, n: usize) -> (Robot, Vec<Joints>) {
        let robot = seed_robot();
        let values = (0..n)
            .map(|i| {
                let pose = robot
                    .pose_with_wrist_at_zero(
                        -r_mm - i as f64 * 0.5,
                        0.0,
                        100.0 + rise * i as f64 * 0.5,
                    )
                    .unwrap();
                robot.kinematics.ik(&pose, None).unwrap()
            })
            .collect();
        (robot, values)
    }

    #[test]
    fn joints_moving_the_tool_in_different_directions_add_in_quadrature() {
        // Moving out along x: theta1 moves the tool along y (across), d2 (height) along z
        // (across), d3 (reach) along x (along the path).
        let (robot, values) = moving_out(1_000.0, 0.0, 8);
        let budget = Budget::new(&robot, &values);
        let (path, _) = budget.worst_mm(&[0.0; JOINTS]);
        let side = 1_000.0 * robot.joints[0].step;
        let up = robot.joints[1].step;
        let quadrature = ((side / 2.0).powi(2) + (up / 2.0).powi(2)).sqrt();
        assert!(
            (path - quadrature).abs() < 0.01 * quadrature,
            "{path} {quadrature}"
        );
    }

    #[test]
    fn fits_decides_as_the_worst_case_compared_with_both_limits() {
        let (robot, values) = moving_out(1_000.0, 0.5, 8);
        let budget = Budget::new(&robot, &values);
        let (mut fitting, mut not) = (0, 0);
        for k in 0..200 {
            let d = f64::from(k) * 0.05;
            let deltas = [d, d * 0.5, d * 1.5, d];
            for tolerance_mm in [0.02, 0.05, 0.1] {
                let (path, tracking) = budget.worst_mm(&deltas);
                let expected =
                    path <= MARGIN * tolerance_mm && tracking <= 2.0 * MARGIN * tolerance_mm;
                assert_eq!(budget.fits(&deltas, tolerance_mm), expected, "{deltas:?}");
                if expected { fitting += 1 } else { not += 1 }
            }
        }
        assert!(fitting > 0 && not > 0, "{fitting} fit, {not} do not");
    }

    #[test]
    fn the_widest_windows_keep_the_worst_case_within_the_tolerance() {
        let (robot, values) = moving_out(1_000.0, 0.5, 8);
        let budget = Budget::new(&robot, &values);
        let deltas = budget.widest(0.05, 8.0).expect("the grid fits in 0.05 mm");
        let (path, tracking) = budget.worst_mm(&deltas);
        assert!(path <= 0.05 * MARGIN + 1e-12 && tracking <= 0.1 * MARGIN + 1e-12);
        // No wider: one of the limits is reached (d2 and d3 both move the tool across a
        // rising line).
        assert!(
            path > 0.05 * MARGIN * 0.99 || tracking > 0.1 * MARGIN * 0.99,
            "{path} {tracking}: the search stops short"
        );
        // The joints that move get windows; theta1 stands still here.
        assert!(deltas[1] > 0.0 && deltas[2] > 0.0, "{deltas:?}");
    }

    #[test]
    fn a_tolerance_below_the_grids_worst_case_gets_no_windows() {
        let (robot, values) = moving_out(1_000.0, 0.0, 8);
        assert!(Budget::new(&robot, &values).widest(0.01, 8.0).is_none());
    }
}
