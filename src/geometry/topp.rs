//! PURE. The time-optimal speed along a path under linear limits on its speed and acceleration
//! (TOPP-RA, Pham & Pham 2018, "A new approach to time-optimal path parameterization based on
//! reachability analysis").
//!
//! The path is a grid of points `s_0 = 0 < s_1 < ... < s_N` (its length), and the motion along
//! it is `x = ṡ²` at every point with a constant `u = s̈` between two points, so
//! `x_{i+1} = x_i + 2 (s_{i+1} - s_i) u_i`: `x` is linear in `s` between grid points. At every
//! point the limits are linear in `(u, x)`:
//! - `x <= x_max_i` (every speed limit: a joint's speed `|q'(s)| ṡ`, the path's speed, an arc's
//!   centripetal speed);
//! - `lo <= a u + b x <= hi` (an acceleration: a joint's `q'(s) s̈ + q''(s) ṡ²`, the path's
//!   tangential `s̈`).
//!
//! The backward pass finds, from the end at rest, the highest `x` at every point from which the
//! end can still be reached within every limit (the controllable set's top: a two-variable
//! linear programme per point). The forward pass then takes, from rest at the start, the
//! highest acceleration that stays within every limit and keeps the next point controllable.
//! Every limit holds at every grid point; between them the joints' derivatives change by what
//! one grid step changes them, which the caller's grid and margins account for.

/// One acceleration limit at a grid point: `lo <= a u + b x <= hi`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AccelLimit {
    /// The coefficient of `u = s̈`.
    pub a: f64,
    /// The coefficient of `x = ṡ²`.
    pub b: f64,
    /// The lowest allowed value (at most 0).
    pub lo: f64,
    /// The highest allowed value (at least 0).
    pub hi: f64,
}

impl AccelLimit {
    /// `-limit <= a u + b x <= limit`.
    #[must_use]
    pub fn symmetric(a: f64, b: f64, limit: f64) -> Self {
        Self {
            a,
            b,
            lo: -limit,
            hi: limit,
        }
    }
}

/// The limits at one grid point.
#[derive(Debug, Clone, PartialEq)]
pub struct GridPoint {
    /// Distance along the path, in the path's own unit.
    pub s: f64,
    /// The highest `x = ṡ²` every speed limit allows here.
    pub x_max: f64,
    /// Every acceleration limit here.
    pub accels: Vec<AccelLimit>,
}

/// Why no motion along the grid keeps every limit.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum ToppError {
    /// Fewer than two points, a distance that does not rise, or a limit that is not a number.
    #[error("the path's grid is not usable at point {index}")]
    BadGrid {
        /// The point.
        index: usize,
    },
    /// From some point the end cannot be reached at rest (a limit with no room for a stop).
    #[error("no motion reaches the path's end at rest from point {index}")]
    Stuck {
        /// The point.
        index: usize,
    },
}

/// The highest `x` at every grid point of the time-optimal motion from rest to rest: `x_0` and
/// `x_N` are 0, `x` linear in `s` between points.
pub fn time_optimal(grid: &[GridPoint]) -> Result<Vec<f64>, ToppError> {
    check(grid)?;
    let n = grid.len() - 1;
    // The backward pass: `reach[i]`, the highest x at point i from which the end is reached.
    let mut reach = vec![0.0; grid.len()];
    for i in (0..n).rev() {
        let step = grid[i + 1].s - grid[i].s;
        reach[i] = highest_controllable(&grid[i], step, reach[i + 1]);
    }
    // The forward pass: the highest acceleration that keeps the next point controllable.
    let mut x = vec![0.0; grid.len()];
    for i in 0..n {
        let step = grid[i + 1].s - grid[i].s;
        let (lo, hi) = u_range(&grid[i], x[i], step, reach[i + 1]);
        if lo > hi + U_SLACK * (1.0 + hi.abs()) {
            return Err(ToppError::Stuck { index: i });
        }
        let next = (x[i] + 2.0 * step * hi).clamp(0.0, reach[i + 1]);
        x[i + 1] = next;
    }
    x[n] = 0.0;
    Ok(x)
}

/// The room a rounding leaves in a range of `u`, relative.
const U_SLACK: f64 = 1e-9;

fn check(grid: &[GridPoint]) -> Result<(), ToppError> {
    if grid.len() < 2 {
        return Err(ToppError::BadGrid { index: 0 });
    }
    for (i, p) in grid.iter().enumerate() {
        let rises = i == 0 || p.s > grid[i - 1].s;
        let numbers = p.s.is_finite()
            && !p.x_max.is_nan()
            && p.x_max >= 0.0
            && p.accels
                .iter()
                .all(|c| c.a.is_finite() && c.b.is_finite() && !c.lo.is_nan() && !c.hi.is_nan());
        if !rises || !numbers {
            return Err(ToppError::BadGrid { index: i });
        }
    }
    Ok(())
}

/// The range of `u` at `point` with `x`: every acceleration limit, and the next point (`step`
/// ahead) at an `x` between 0 and `next_max`.
fn u_range(point: &GridPoint, x: f64, step: f64, next_max: f64) -> (f64, f64) {
    let mut lo = -x / (2.0 * step);
    let mut hi = (next_max - x) / (2.0 * step);
    for c in &point.accels {
        if c.a == 0.0 {
            continue;
        }
        let (l, h) = ((c.lo - c.b * x) / c.a, (c.hi - c.b * x) / c.a);
        let (l, h) = if c.a > 0.0 { (l, h) } else { (h, l) };
        lo = lo.max(l);
        hi = hi.min(h);
    }
    (lo, hi)
}

/// One half-plane `p u + q x <= r`.
#[derive(Clone, Copy)]
struct Half {
    p: f64,
    q: f64,
    r: f64,
}

/// The highest `x` at `point` from which some `u` keeps every limit and lands the next point
/// (`step` ahead) at an `x` between 0 and `next_max`: a linear programme in `(u, x)`, solved
/// over the vertices of its feasible polygon (a dozen half-planes: every pair is cheap).
fn highest_controllable(point: &GridPoint, step: f64, next_max: f64) -> f64 {
    highest_vertex(&controllable_halves(point, step, next_max)).min(point.x_max)
}

/// The half-planes of [`highest_controllable`]'s programme at `point`.
fn controllable_halves(point: &GridPoint, step: f64, next_max: f64) -> Vec<Half> {
    let mut halves: Vec<Half> = Vec::with_capacity(2 * point.accels.len() + 4);
    // 0 <= x <= x_max.
    halves.push(Half {
        p: 0.0,
        q: 1.0,
        r: point.x_max,
    });
    halves.push(Half {
        p: 0.0,
        q: -1.0,
        r: 0.0,
    });
    // 0 <= x + 2 step u <= next_max.
    halves.push(Half {
        p: 2.0 * step,
        q: 1.0,
        r: next_max,
    });
    halves.push(Half {
        p: -2.0 * step,
        q: -1.0,
        r: 0.0,
    });
    for c in &point.accels {
        if c.hi.is_finite() {
            halves.push(Half {
                p: c.a,
                q: c.b,
                r: c.hi,
            });
        }
        if c.lo.is_finite() {
            halves.push(Half {
                p: -c.a,
                q: -c.b,
                r: -c.lo,
            });
        }
    }
    halves
}

/// The highest `x` (at least 0) of a vertex of the polygon `halves` bound: every pair's
/// crossing, kept when it is inside every half-plane.
fn highest_vertex(halves: &[Half]) -> f64 {
    let feasible = |u: f64, x: f64| {
        halves
            .iter()
            .all(|h| h.p * u + h.q * x <= h.r + 1e-9 * (1.0 + h.r.abs()))
    };
    let mut best = 0.0_f64;
    for (i, a) in halves.iter().enumerate() {
        for b in &halves[i + 1..] {
            let det = a.p * b.q - a.q * b.p;
            if det.abs() < 1e-300 {
                continue;
            }
            let u = (a.r * b.q - a.q * b.r) / det;
            let x = (a.p * b.r - a.r * b.p) / det;
            if x > best && u.is_finite() && x.is_finite() && feasible(u, x) {
                best = x;
            }
        }
    }
    best
}

/// The time the motion `x` over `grid` takes, in the unit of `s` over its speed: every step at
/// its constant acceleration, `2 Δs / (ṡ_i + ṡ_{i+1})`.
#[must_use]
pub fn duration(grid: &[GridPoint], x: &[f64]) -> f64 {
    grid.windows(2)
        .zip(x.windows(2))
        .map(|(g, x)| {
            let v = x[0].max(0.0).sqrt() + x[1].max(0.0).sqrt();
            if v > 0.0 {
                2.0 * (g[1].s - g[0].s) / v
            } else {
                f64::INFINITY
            }
        })
        .sum()
}

#[cfg(test)]
#[allow(clippy::float_cmp)] // the ends at rest are exactly 0
mod tests {
    use super::*;

    /// A path of `length` on `n` steps with a speed cap and one acceleration limit `|u| <= a`.
    fn straight(length: f64, n: usize, v_max: f64, a: f64) -> Vec<GridPoint> {
        (0..=n)
            .map(|i| GridPoint {
                s: length * i as f64 / n as f64,
                x_max: v_max * v_max,
                accels: vec![AccelLimit::symmetric(1.0, 0.0, a)],
            })
            .collect()
    }

    #[test]
    fn a_straight_path_runs_the_trapezoid_of_its_limits() {
        // 100 mm at 200 mm/s, 1000 mm/s^2: ramps of 0.2 s over 20 mm each, 60 mm of cruise.
        let grid = straight(100.0, 1_000, 200.0, 1_000.0);
        let x = time_optimal(&grid).unwrap();
        assert_eq!(x[0], 0.0);
        assert_eq!(x[1_000], 0.0);
        let t = duration(&grid, &x);
        assert!((t - 0.7).abs() < 1e-9, "{t}");
        // v² = 2 a s on the ramp, the cap on the cruise.
        assert!((x[100] - 2.0 * 1_000.0 * 10.0).abs() < 1e-6);
        assert!((x[500] - 200.0 * 200.0).abs() < 1e-6);
    }

    #[test]
    fn a_short_path_runs_a_triangle() {
        // 10 mm at 1000 mm/s^2 never reaches 200 mm/s: 2 sqrt(5 / 500) s.
        let grid = straight(10.0, 1_000, 200.0, 1_000.0);
        let x = time_optimal(&grid).unwrap();
        let t = duration(&grid, &x);
        assert!((t - 2.0 * (0.01f64).sqrt()).abs() < 1e-9, "{t}");
    }

    #[test]
    fn a_slow_stretch_is_left_and_reached_at_the_acceleration_limit_alone() {
        // A speed cap of 50 mm/s between 40 and 60 mm.
        let mut grid = straight(100.0, 1_000, 200.0, 1_000.0);
        for p in &mut grid[400..=600] {
            p.x_max = 50.0 * 50.0;
        }
        let x = time_optimal(&grid).unwrap();
        for (i, p) in grid.iter().enumerate() {
            assert!(x[i] <= p.x_max + 1e-9, "{i}");
        }
        for w in x.windows(2) {
            let u = (w[1] - w[0]) / (2.0 * 0.1);
            assert!(u.abs() <= 1_000.0 * (1.0 + 1e-9), "{u}");
        }
        // (200^2 - 50^2) / (2 * 1000) = 18.75 mm before 40 mm it starts braking.
        assert!((x[400 - 188] - 200.0 * 200.0).abs() < 1e-6);
        assert!(x[400 - 186] < 200.0 * 200.0);
    }

    #[test]
    fn a_joint_acceleration_through_a_curvature_term_is_kept_at_every_point() {
        // q(s) = s², so q' = 2 s, q'' = 2: |2 s u + 2 x| <= 50, and ṡ <= 30.
        let grid: Vec<GridPoint> = (0..=400)
            .map(|i| {
                let s = 2.0 * f64::from(i) / 400.0;
                GridPoint {
                    s,
                    x_max: 900.0,
                    accels: vec![AccelLimit::symmetric(2.0 * s, 2.0, 50.0)],
                }
            })
            .collect();
        let x = time_optimal(&grid).unwrap();
        for i in 0..400 {
            let u = (x[i + 1] - x[i]) / (2.0 * (grid[i + 1].s - grid[i].s));
            let qdd = 2.0 * grid[i].s * u + 2.0 * x[i];
            assert!(qdd.abs() <= 50.0 * (1.0 + 1e-6), "{i}: {qdd}");
        }
        assert!(x.iter().any(|&v| v > 1.0));
    }

    #[test]
    fn a_grid_that_does_not_rise_is_refused() {
        let mut grid = straight(10.0, 10, 1.0, 1.0);
        grid[5].s = grid[4].s;
        assert_eq!(time_optimal(&grid), Err(ToppError::BadGrid { index: 5 }));
    }
}
