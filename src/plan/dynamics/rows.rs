//! PURE. Whether a drive can follow a table row by row: F174 has no ramps, so every row boundary
//! is an instant step of the channel's frequency, the first row of a run from rest starts at
//! its frequency and the last row into rest stops from it.
//!
//! For a joint with `max_accel` (`a` pulses/s^2 here), two consecutive rows in one direction, of
//! real frequencies `f1`, `f2` and lengths `T1`, `T2` (the execution model's), may step by
//! `a (T1 + T2) / 2`: what a motion within `a` changes its average speed by between the two
//! rows. To that come a pulse of rounding per row (`1/T1 + 1/T2`: a row carries whole pulses,
//! its ends rounded from the planned motion) and the frequency model's step at each row's
//! value (the nearest frequency the channel can put out). A row from or into standstill (the
//! start, the end, either side of a reversal) steps from or to 0 over its half: within
//! `a T / 2` and its pulse of rounding, and within `start_hz` when the joint has one. A row of
//! one pulse is a single step (its frequency only times that step): the standstill checks
//! apply to rows of two pulses or more.
//!
//! A table that breaks any of these for a joint with the limit is never emitted; the figures
//! ([`DriveFigures`]) are reported for every joint.

use crate::kinematics::JOINTS;
use crate::robot::{Joint, Robot};
use crate::sim::{self, RowTiming, Settings};
use crate::table::{ChannelTable, Direction, FrequencyModel, FrequencyRange};

use crate::plan::error::PlanError;
use crate::plan::planned::{DriveFigures, Window};
use crate::plan::samples::Samples;

/// One row as the drive sees it.
#[derive(Debug, Clone, Copy)]
struct Played {
    hz: f64,
    len_s: f64,
    start_s: f64,
    way: Direction,
    /// The frequency model's step at its value, Hz.
    grain_hz: f64,
    /// Its pulses.
    pulses: u64,
}

/// The step from `hz` to the nearest other frequency the channel can put out in `range`: 1 Hz of
/// the written value under the ideal model; under the divider, `c/(d-1) - c/d` at the divisor
/// `d` that gives `hz` from the range's clock `c` (about `hz^2 / c`: 312 Hz at 31 kHz in range
/// 1).
fn grain_hz(model: FrequencyModel, range: FrequencyRange, hz: f64) -> f64 {
    match model {
        FrequencyModel::Ideal => 1.0,
        FrequencyModel::FpxDivider => {
            let clock = range.divider_clock_hz();
            let d = (clock / hz).round().max(2.0);
            clock / (d - 1.0) - clock / d
        }
    }
}

/// The rows of table `index` as played.
fn played(table: &ChannelTable, timings: &[RowTiming], model: FrequencyModel) -> Vec<Played> {
    timings
        .iter()
        .map(|r| {
            let seg = &table.segments[r.segment];
            Played {
                hz: r.actual_hz,
                len_s: (r.end_s - r.start_s).max(1e-9),
                start_s: r.start_s,
                way: seg.control.direction,
                grain_hz: grain_hz(model, seg.control.range, r.actual_hz),
                pulses: ((r.end_s - r.start_s) * r.actual_hz).round() as u64,
            }
        })
        .collect()
}

/// Checks every table of a start against its joint's drive limits and measures how hard each
/// drive is asked: the first row that breaks a limit of a joint that has it is the error.
pub(in crate::plan) fn judge(
    robot: &Robot,
    tables: &[ChannelTable],
    samples: &Samples,
    sample_s: f64,
    window: &Window,
    settings: Settings,
) -> Result<[DriveFigures; JOINTS], PlanError> {
    let max_hz: Vec<u32> = robot.joints.iter().map(|j| j.max_freq_hz).collect();
    let timings = sim::row_timings(tables, &max_hz, settings);
    let mut out = [DriveFigures::default(); JOINTS];
    let peaks = planned_peaks(robot, samples, sample_s, window.duration_s());
    for (j, joint) in robot.joints.iter().enumerate() {
        let mine: Vec<RowTiming> = timings.iter().filter(|r| r.table == j).copied().collect();
        let rows = played(&tables[j], &mine, settings.model);
        let (peak_speed, peak_accel) = peaks[j];
        let rests = Rests {
            begins: !window.begins_at_speed(),
            ends: !window.ends_at_speed,
        };
        out[j] = follow(joint, &rows, rests)?;
        out[j].peak_speed = peak_speed;
        out[j].peak_accel = peak_accel;
    }
    Ok(out)
}

/// Whether the start begins and ends at standstill.
#[derive(Debug, Clone, Copy)]
struct Rests {
    begins: bool,
    ends: bool,
}

/// Every joint's fastest acceleration over the samples, user units ([`planned_peaks`]).
pub(in crate::plan) fn planned_accels(
    robot: &Robot,
    samples: &Samples,
    sample_s: f64,
    end_s: f64,
) -> [f64; JOINTS] {
    planned_peaks(robot, samples, sample_s, end_s).map(|p| p.1)
}

/// Every joint's fastest speed and acceleration over the samples, user units: the points
/// `sample_s` apart but the last, at `end_s` (a time-optimal profile's last period has its
/// own length); each speed at the middle of its interval. The joints side by side, one pass.
fn planned_peaks(
    robot: &Robot,
    samples: &Samples,
    sample_s: f64,
    end_s: f64,
) -> [(f64, f64); JOINTS] {
    let last = samples.values.len().saturating_sub(1);
    let at = |k: usize| {
        if k == last {
            end_s
        } else {
            k as f64 * sample_s
        }
    };
    let (mut speed, mut accel) = ([0.0_f64; JOINTS], [0.0_f64; JOINTS]);
    // The interval before: its middle and every joint's speed over it.
    let mut before: Option<(f64, [f64; JOINTS])> = None;
    for (k, w) in samples.values.windows(2).enumerate() {
        let (t0, t1) = (at(k), at(k + 1));
        let (mid, dt) = (f64::midpoint(t0, t1), t1 - t0);
        let v: [f64; JOINTS] = std::array::from_fn(|j| (w[1][j] - w[0][j]) / dt);
        for j in 0..JOINTS {
            speed[j] = speed[j].max(v[j].abs());
        }
        if let Some((mid_before, v_before)) = before {
            let gap = mid - mid_before;
            for j in 0..JOINTS {
                accel[j] = accel[j].max(((v[j] - v_before[j]) / gap).abs());
            }
        }
        before = Some((mid, v));
    }
    std::array::from_fn(|j| {
        let joint = &robot.joints[j];
        (joint.user(speed[j]).abs(), joint.user(accel[j]).abs())
    })
}

/// One joint's rows against its limits.
fn follow(joint: &Joint, rows: &[Played], rests: Rests) -> Result<DriveFigures, PlanError> {
    let accel_pulses = joint.dynamics.max_accel.map(|a| a / joint.step.abs());
    let mut figures = DriveFigures {
        peak_hz: rows.iter().fold(0.0, |m, r| m.max(r.hz)),
        ..DriveFigures::default()
    };
    let n = rows.len();
    for (k, row) in rows.iter().enumerate() {
        let turns_before = k > 0 && rows[k - 1].way != row.way;
        let turns_after = k + 1 < n && rows[k + 1].way != row.way;
        // A row of one pulse is a single step, not a rate the drive is asked to run at.
        let steps = row.pulses >= 2;
        if steps && ((k == 0 && rests.begins) || turns_before) {
            rest_row(joint, row, true, accel_pulses, &mut figures)?;
        }
        if steps && ((k + 1 == n && rests.ends) || turns_after) {
            rest_row(joint, row, false, accel_pulses, &mut figures)?;
        }
        if k == 0 || turns_before {
            continue;
        }
        let Some(a) = accel_pulses else { continue };
        let before = rows[k - 1];
        let allowed_hz = a * (before.len_s + row.len_s) / 2.0
            + 1.0 / before.len_s
            + 1.0 / row.len_s
            + before.grain_hz
            + row.grain_hz;
        let step = (row.hz - before.hz).abs();
        let load = step / allowed_hz;
        figures.step_load = Some(figures.step_load.map_or(load, |m: f64| m.max(load)));
        if load > 1.0 {
            return Err(PlanError::RowStep {
                joint: joint.name.clone(),
                t_s: row.start_s,
                from_hz: before.hz,
                to_hz: row.hz,
                allowed_hz,
                max_accel: joint
                    .user(joint.dynamics.max_accel.unwrap_or_default())
                    .abs(),
                unit: joint.kind.user_unit(),
            });
        }
    }
    Ok(figures)
}

/// A row from (`from_rest`) or into standstill: within `start_hz`, and within `max_accel`
/// over its half.
fn rest_row(
    joint: &Joint,
    row: &Played,
    from_rest: bool,
    accel_pulses: Option<f64>,
    figures: &mut DriveFigures,
) -> Result<(), PlanError> {
    figures.rest_hz = figures.rest_hz.max(row.hz);
    let limits = [
        joint.dynamics.start_hz.map(|hz| (hz, "start_hz")),
        accel_pulses.map(|a| {
            (
                a * row.len_s / 2.0 + 1.0 / row.len_s + row.grain_hz,
                "max_accel over half the row",
            )
        }),
    ];
    for (limit_hz, limit) in limits.into_iter().flatten() {
        if row.hz > limit_hz {
            return Err(PlanError::RestRow {
                joint: joint.name.clone(),
                t_s: row.start_s,
                from_rest,
                freq_hz: row.hz,
                limit_hz,
                limit,
            });
        }
    }
    Ok(())
}
