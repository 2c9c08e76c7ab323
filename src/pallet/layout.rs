//! A pallet table checked ([`Layout::check`]) and laid out in a frame ([`Layout::slots`]): the
//! grid of rows x columns of every layer, each layer's kind (turned, mirrored, shifted, brick
//! rows, or an explicit list), the fill order, and each slot's approach and retreat.
//!
//! How a slot's pose is worked, in the frame's coordinates (mm, degrees):
//! ```text
//! grid slot (row r, column c):   x = c * pitch_x (+ odd_rows_shift if r is odd),  y = r * pitch_y
//! centre of the grid:            C = ((columns - 1) * pitch_x / 2, (rows - 1) * pitch_y / 2)
//! kind:  d = (x, y) - C;  mirror x: d.x = -d.x, a = -a;  mirror y: d.y = -d.y, a = -a
//!        d turned by turn_deg, a + turn_deg;  (x, y) = C + d + shift
//! pose:  origin_mm + (x, y, layer * layer_height_mm), tool angle a_deg (or the listed slot's)
//! ```
//! A case is the same turned by half a turn, so a mirrored slot's tool angle is -a (its mirror
//! image modulo half a turn). The frame then places the pose in the world ([`Frame::pose`]).
//! The approach starts `height_mm` above the slot (moved by `side_mm` in the frame), runs to
//! `slow_mm` short of the slot, and the last line runs at `slow_speed_mm_s`; the retreat is the
//! same way out.

use nalgebra::{Vector2, Vector3};

use super::doc::{LayersDoc, MirrorDoc, OrderDoc, PalletDoc, PointDoc, ReachDoc};
use super::{Frame, PalletError, Pose, Slot, Waypoint, WhenFull};

/// The most rows, columns or layers a pallet may have.
pub const MAX_GRID: i64 = 100;
/// The most slots a pallet may have.
pub const MAX_SLOTS: usize = 10_000;
/// The largest pitch, layer height, shift or approach height, mm.
pub const MAX_LENGTH_MM: f64 = 5_000.0;

/// Where the layer-0 grid lies.
#[derive(Debug, Clone, PartialEq)]
pub enum Placement {
    /// In a frame (world without one), slot (0, 0) of layer 0 at `origin_mm`, the pitches given.
    Frame {
        /// The frame's name.
        frame: Option<String>,
        /// Slot (0, 0) of layer 0 in it, mm.
        origin_mm: Vector3<f64>,
    },
    /// Three slots of layer 0: (0, 0), (0, last column), (last row, 0); the frame and the
    /// pitches follow from them.
    Corners([PointDoc; 3]),
}

/// A checked layer kind.
#[derive(Debug, Clone, PartialEq)]
struct Kind {
    turn_rad: f64,
    mirror: Option<MirrorDoc>,
    shift_mm: Vector2<f64>,
    odd_rows_shift_mm: f64,
    /// An explicit list: x, y (mm), a (rad).
    listed: Option<Vec<[f64; 3]>>,
    order: OrderDoc,
}

/// A checked approach or retreat.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Reach {
    height_mm: f64,
    side_mm: Vector2<f64>,
    /// The slow stretch: its length and speed.
    slow: Option<(f64, f64)>,
    /// The approach's first point as a blended corner, mm.
    blend_mm: Option<f64>,
}

/// A checked pallet table.
#[derive(Debug, Clone, PartialEq)]
pub struct Layout {
    name: String,
    /// Where its grid lies.
    pub placement: Placement,
    rows: usize,
    columns: usize,
    pitch_mm: Vector2<f64>,
    layer_height_mm: f64,
    layers: Vec<Kind>,
    a_rad: f64,
    approach: Option<Reach>,
    retreat: Option<Reach>,
    /// The slow speeds of the approach and the retreat, mm/s, by key (for the robot's limit).
    pub slow_speeds_mm_s: Vec<(&'static str, f64)>,
    /// A cycle program run before every layer but the first.
    pub between_layers: Option<String>,
    /// What the cell does when the pallet is full.
    pub when_full: WhenFull,
}

/// Names values of one pallet's table in its errors.
struct Keys<'a> {
    owner: &'a str,
}

impl Keys<'_> {
    fn bad(
        &self,
        key: &str,
        value: impl std::fmt::Display,
        reason: impl Into<String>,
    ) -> PalletError {
        PalletError::Value {
            owner: self.owner.to_owned(),
            key: key.to_owned(),
            value: value.to_string(),
            reason: reason.into(),
        }
    }

    fn missing(&self, key: &str, reason: &str) -> PalletError {
        PalletError::Missing {
            owner: self.owner.to_owned(),
            key: key.to_owned(),
            reason: reason.to_owned(),
        }
    }

    /// A finite number within `min..=max`.
    fn within(&self, key: &str, v: f64, min: f64, max: f64) -> Result<f64, PalletError> {
        if v.is_finite() && (min..=max).contains(&v) {
            Ok(v)
        } else {
            Err(self.bad(key, v, format!("must be a number within {min}..={max}")))
        }
    }

    /// A finite number above 0 and at most `max`.
    fn positive(&self, key: &str, v: f64, max: f64) -> Result<f64, PalletError> {
        if v.is_finite() && v > 0.0 && v <= max {
            Ok(v)
        } else {
            Err(self.bad(key, v, format!("must be above 0 and at most {max}")))
        }
    }

    /// A count within `1..=MAX_GRID`.
    fn count(&self, key: &str, v: i64) -> Result<usize, PalletError> {
        if (1..=MAX_GRID).contains(&v) {
            Ok(v as usize)
        } else {
            Err(self.bad(key, v, format!("must be within 1..={MAX_GRID}")))
        }
    }

    fn pair(&self, key: &str, v: [f64; 2], max: f64) -> Result<Vector2<f64>, PalletError> {
        for (i, x) in v.into_iter().enumerate() {
            self.within(&format!("{key}[{i}]"), x, -max, max)?;
        }
        Ok(Vector2::new(v[0], v[1]))
    }

    fn name(&self, key: &str, v: Option<&String>) -> Result<Option<String>, PalletError> {
        match v {
            Some(s) if s.trim().is_empty() => {
                Err(self.bad(key, format!("{s:?}"), "must not be blank"))
            }
            other => Ok(other.cloned()),
        }
    }
}

impl Layout {
    /// Checks a pallet table: every key's value against its limit, every layer's kind known.
    ///
    /// # Errors
    /// The first value refused, naming the pallet, the key and the limit.
    pub fn check(name: &str, doc: &PalletDoc) -> Result<Self, PalletError> {
        let owner = format!("pallet {name:?}");
        let k = Keys { owner: &owner };
        let layers = layers(&k, doc)?;
        let placement = placement(&k, doc)?;
        let needs_grid =
            matches!(placement, Placement::Corners(_)) || layers.iter().any(|l| l.listed.is_none());
        let (rows, columns, pitch_mm) = grid(&k, doc, &placement, needs_grid)?;
        let per_layer: usize = layers
            .iter()
            .map(|l| l.listed.as_ref().map_or(rows * columns, Vec::len))
            .sum();
        if per_layer > MAX_SLOTS {
            return Err(k.bad(
                "layers",
                format!("{} layers", layers.len()),
                format!("make {per_layer} slots; a pallet has at most {MAX_SLOTS}"),
            ));
        }
        let (approach, retreat, slow_speeds_mm_s) = ways(&k, doc)?;
        let w = &doc.when_full;
        Ok(Self {
            name: name.to_owned(),
            placement,
            rows,
            columns,
            pitch_mm,
            layer_height_mm: k.positive("layer_height_mm", doc.layer_height_mm, MAX_LENGTH_MM)?,
            layers,
            a_rad: k
                .within("a_deg", doc.a_deg.unwrap_or(0.0), -360.0, 360.0)?
                .to_radians(),
            approach,
            retreat,
            slow_speeds_mm_s,
            between_layers: k.name("between_layers", doc.between_layers.as_ref())?,
            when_full: WhenFull {
                signal: k.name("when_full.signal", w.signal.as_ref())?,
                wait_for: k.name("when_full.wait_for", w.wait_for.as_ref())?,
                call: k.name("when_full.call", w.call.as_ref())?,
            },
        })
    }

    /// Its name.
    #[must_use]
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Each slot's layer, in fill order (its length is the pallet's slots): what a counter
    /// needs of a pallet, known without its frame or the taught positions.
    #[must_use]
    pub fn slot_layers(&self) -> Vec<usize> {
        let grid = self.rows * self.columns;
        self.layers
            .iter()
            .enumerate()
            .flat_map(|(layer, kind)| {
                std::iter::repeat_n(layer, kind.listed.as_ref().map_or(grid, Vec::len))
            })
            .collect()
    }

    /// Rows and columns of its grid (1 x 1 when every layer is a list).
    #[must_use]
    pub fn grid(&self) -> (usize, usize) {
        (self.rows, self.columns)
    }

    /// Every slot, in fill order, with its approach and retreat, in world coordinates: the grid
    /// at `origin_mm` in `frame`, `pitch_mm` apart (for corners: as the corners' frame gives).
    #[must_use]
    pub fn slots(
        &self,
        frame: &Frame,
        origin_mm: Vector3<f64>,
        pitch_mm: Vector2<f64>,
    ) -> Vec<Slot> {
        let centre = Vector2::new(
            (self.columns - 1) as f64 * pitch_mm.x / 2.0,
            (self.rows - 1) as f64 * pitch_mm.y / 2.0,
        );
        let mut slots = Vec::new();
        for (layer, kind) in self.layers.iter().enumerate() {
            for (row, column, [x, y, a]) in self.layer(kind, pitch_mm) {
                let (xy, a) = kind.place(Vector2::new(x, y), a, centre);
                let local =
                    origin_mm + Vector3::new(xy.x, xy.y, layer as f64 * self.layer_height_mm);
                let pose = frame.pose(&Pose {
                    position_mm: local,
                    a_rad: a,
                });
                let pose = Pose {
                    a_rad: wrap(pose.a_rad),
                    ..pose
                };
                let (approach, slot_speed_mm_s) = self
                    .approach
                    .map_or((vec![], None), |r| r.way_in(frame, &pose));
                let retreat = self.retreat.map_or(vec![], |r| r.way_out(frame, &pose));
                slots.push(Slot {
                    index: slots.len(),
                    layer,
                    row,
                    column,
                    pose,
                    approach,
                    slot_speed_mm_s,
                    retreat,
                });
            }
        }
        slots
    }

    /// The pitches given (`None` for corners).
    #[must_use]
    pub fn pitch_mm(&self) -> Vector2<f64> {
        self.pitch_mm
    }

    /// A layer's slots in fill order before its kind's turn: row, column, and x, y, a.
    fn layer(&self, kind: &Kind, pitch: Vector2<f64>) -> Vec<(usize, usize, [f64; 3])> {
        if let Some(listed) = &kind.listed {
            return listed.iter().enumerate().map(|(i, s)| (i, 0, *s)).collect();
        }
        fill_order(kind.order, self.rows, self.columns)
            .into_iter()
            .map(|(r, c)| {
                let brick = if r % 2 == 1 {
                    kind.odd_rows_shift_mm
                } else {
                    0.0
                };
                (
                    r,
                    c,
                    [c as f64 * pitch.x + brick, r as f64 * pitch.y, self.a_rad],
                )
            })
            .collect()
    }
}

/// An angle in (-pi, pi].
fn wrap(a: f64) -> f64 {
    let turn = std::f64::consts::TAU;
    let w = a - turn * (a / turn).round();
    if w <= -std::f64::consts::PI {
        w + turn
    } else {
        w
    }
}

/// Rows and columns of a layer, in the order `order` fills them.
fn fill_order(order: OrderDoc, rows: usize, columns: usize) -> Vec<(usize, usize)> {
    let mut out = Vec::with_capacity(rows * columns);
    let snake = matches!(order, OrderDoc::SnakeRows | OrderDoc::SnakeColumns);
    let (outer, inner) = match order {
        OrderDoc::Rows | OrderDoc::SnakeRows => (rows, columns),
        OrderDoc::Columns | OrderDoc::SnakeColumns => (columns, rows),
    };
    for o in 0..outer {
        for i in 0..inner {
            let i = if snake && o % 2 == 1 {
                inner - 1 - i
            } else {
                i
            };
            out.push(match order {
                OrderDoc::Rows | OrderDoc::SnakeRows => (o, i),
                OrderDoc::Columns | OrderDoc::SnakeColumns => (i, o),
            });
        }
    }
    out
}

impl Kind {
    /// A grid point and its tool angle as this kind places them about the grid's centre.
    fn place(&self, xy: Vector2<f64>, a: f64, centre: Vector2<f64>) -> (Vector2<f64>, f64) {
        let mut d = xy - centre;
        let mut a = a;
        match self.mirror {
            Some(MirrorDoc::X) => (d.x, a) = (-d.x, -a),
            Some(MirrorDoc::Y) => (d.y, a) = (-d.y, -a),
            None => {}
        }
        let (s, c) = self.turn_rad.sin_cos();
        // Quarter turns exactly: sin and cos of them rounded to the nearest of -1, 0, 1.
        let (s, c) = (s.round(), c.round());
        d = Vector2::new(c * d.x - s * d.y, s * d.x + c * d.y);
        (centre + d + self.shift_mm, a + self.turn_rad)
    }
}

impl Reach {
    /// The point `height_mm` above the slot (moved sideways) and the slow stretch's start.
    fn points(&self, frame: &Frame, slot: &Pose) -> (Pose, Option<(Pose, f64)>) {
        let offset = frame.direction(&Vector3::new(
            self.side_mm.x,
            self.side_mm.y,
            self.height_mm,
        ));
        let at = |v: Vector3<f64>| Pose {
            position_mm: slot.position_mm + v,
            a_rad: slot.a_rad,
        };
        let slow = self
            .slow
            .map(|(mm, speed)| (at(offset.normalize() * mm), speed));
        (at(offset), slow)
    }

    /// Approach waypoints and the speed of the line into the slot.
    fn way_in(&self, frame: &Frame, slot: &Pose) -> (Vec<Waypoint>, Option<f64>) {
        let (above, slow) = self.points(frame, slot);
        let mut way = vec![Waypoint {
            pose: above,
            speed_mm_s: None,
            blend_mm: self.blend_mm,
        }];
        if let Some((near, _)) = &slow {
            way.push(Waypoint {
                pose: *near,
                speed_mm_s: None,
                blend_mm: None,
            });
        }
        (way, slow.map(|s| s.1))
    }

    /// Retreat waypoints.
    fn way_out(&self, frame: &Frame, slot: &Pose) -> Vec<Waypoint> {
        let (above, slow) = self.points(frame, slot);
        let mut way: Vec<Waypoint> = slow
            .into_iter()
            .map(|(near, speed)| Waypoint {
                pose: near,
                speed_mm_s: Some(speed),
                blend_mm: None,
            })
            .collect();
        // Its last point ends the way: the cycle's next step begins there, from rest.
        way.push(Waypoint {
            pose: above,
            speed_mm_s: None,
            blend_mm: None,
        });
        way
    }
}

fn reach(k: &Keys<'_>, key: &str, r: &ReachDoc) -> Result<Reach, PalletError> {
    let height_mm = k.positive(&format!("{key}.height_mm"), r.height_mm, MAX_LENGTH_MM)?;
    let side_mm = k.pair(
        &format!("{key}.side_mm"),
        r.side_mm.unwrap_or([0.0; 2]),
        MAX_LENGTH_MM,
    )?;
    let length = side_mm.norm().hypot(height_mm);
    let slow = match (r.slow_mm, r.slow_speed_mm_s) {
        (None, None) => None,
        (Some(mm), Some(speed)) => Some((
            k.positive(&format!("{key}.slow_mm"), mm, length)?,
            k.positive(&format!("{key}.slow_speed_mm_s"), speed, f64::MAX)?,
        )),
        (Some(_), None) => {
            return Err(k.missing(
                &format!("{key}.slow_speed_mm_s"),
                "slow_mm runs at a slow speed",
            ));
        }
        (None, Some(_)) => {
            return Err(k.missing(
                &format!("{key}.slow_mm"),
                "slow_speed_mm_s is the speed of the last slow_mm",
            ));
        }
    };
    // The line from the first point on toward the slot, before its slow stretch.
    let line = length - slow.map_or(0.0, |(mm, _)| mm);
    let blend_mm = r
        .blend_mm
        .map(|mm| blend(k, &format!("{key}.blend_mm"), mm, line))
        .transpose()?;
    Ok(Reach {
        height_mm,
        side_mm,
        slow,
        blend_mm,
    })
}

/// `key` (`approach.blend_mm` or `retreat.blend_mm`) = `mm`, checked: the approach's alone,
/// within `line`, the line from its first point to its slow stretch.
fn blend(k: &Keys<'_>, key: &str, mm: f64, line: f64) -> Result<f64, PalletError> {
    if key == "retreat.blend_mm" {
        return Err(k.bad(
            key,
            mm,
            "the way out ends at its point above the slot, where the cycle's next step \
             begins from rest: only the approach's first point is blended",
        ));
    }
    if line <= 0.0 {
        return Err(k.bad(
            key,
            mm,
            "the approach is all slow stretch (slow_mm is all of it): its first point \
             begins a stretch at another speed, where the robot comes to rest",
        ));
    }
    k.positive(key, mm, line)
}

fn layers(k: &Keys<'_>, doc: &PalletDoc) -> Result<Vec<Kind>, PalletError> {
    let names: Vec<Option<&str>> = match &doc.layers {
        LayersDoc::Count(n) => vec![None; k.count("layers", *n)?],
        LayersDoc::Kinds(names) => {
            k.count("layers", names.len() as i64).map_err(|_| {
                k.bad(
                    "layers",
                    format!("{} kinds", names.len()),
                    format!("a pallet has 1..={MAX_GRID} layers"),
                )
            })?;
            names.iter().map(|n| Some(n.as_str())).collect()
        }
    };
    let order = doc.order.unwrap_or_default();
    let mut checked = std::collections::BTreeMap::new();
    for (name, kind) in &doc.kinds {
        checked.insert(
            name.as_str(),
            self::kind(k, &format!("kinds.{name}"), kind, order)?,
        );
    }
    let known: Vec<&str> = checked.keys().copied().collect();
    names
        .iter()
        .enumerate()
        .map(|(i, name)| match name {
            None => Ok(Kind::plain(order)),
            Some(n) => checked.get(n).cloned().ok_or_else(|| {
                let reason = if known.is_empty() {
                    "no kind is defined: add kinds.NAME = { ... }".to_owned()
                } else {
                    format!("the kinds defined are {}", known.join(", "))
                };
                k.bad(&format!("layers[{i}]"), format!("{n:?}"), reason)
            }),
        })
        .collect()
}

impl Kind {
    fn plain(order: OrderDoc) -> Self {
        Self {
            turn_rad: 0.0,
            mirror: None,
            shift_mm: Vector2::zeros(),
            odd_rows_shift_mm: 0.0,
            listed: None,
            order,
        }
    }
}

/// The way into a slot and out of it (out: as in, when not given), and the slow speeds they
/// ask, each with the key that gives it.
#[allow(clippy::type_complexity)]
fn ways(
    k: &Keys<'_>,
    doc: &PalletDoc,
) -> Result<(Option<Reach>, Option<Reach>, Vec<(&'static str, f64)>), PalletError> {
    let approach = doc
        .approach
        .as_ref()
        .map(|r| reach(k, "approach", r))
        .transpose()?;
    let (retreat, retreat_key) = match &doc.retreat {
        Some(r) => (Some(reach(k, "retreat", r)?), "retreat.slow_speed_mm_s"),
        None => (approach, "approach.slow_speed_mm_s"),
    };
    let slow_speeds_mm_s = [
        ("approach.slow_speed_mm_s", approach),
        (retreat_key, retreat),
    ]
    .into_iter()
    .filter_map(|(key, r)| r.and_then(|r| r.slow).map(|s| (key, s.1)))
    .collect();
    Ok((approach, retreat, slow_speeds_mm_s))
}

/// A listed layer's slots (`key.slots`), each within the limits: `[x, y, a]` in mm, mm, rad.
fn listed(
    k: &Keys<'_>,
    key: &str,
    slots: Option<&Vec<[f64; 3]>>,
) -> Result<Option<Vec<[f64; 3]>>, PalletError> {
    let Some(list) = slots else {
        return Ok(None);
    };
    if list.is_empty() || list.len() > MAX_SLOTS {
        return Err(k.bad(
            &format!("{key}.slots"),
            format!("{} slots", list.len()),
            format!("a listed layer has 1..={MAX_SLOTS} slots"),
        ));
    }
    list.iter()
        .enumerate()
        .map(|(i, [x, y, a])| {
            let at = format!("{key}.slots[{i}]");
            k.within(&at, *x, -MAX_LENGTH_MM, MAX_LENGTH_MM)?;
            k.within(&at, *y, -MAX_LENGTH_MM, MAX_LENGTH_MM)?;
            Ok([*x, *y, k.within(&at, *a, -360.0, 360.0)?.to_radians()])
        })
        .collect::<Result<Vec<_>, PalletError>>()
        .map(Some)
}

fn kind(
    k: &Keys<'_>,
    key: &str,
    doc: &super::doc::KindDoc,
    order: OrderDoc,
) -> Result<Kind, PalletError> {
    let turn = doc.turn_deg.unwrap_or(0.0);
    if !(turn.is_finite() && turn % 90.0 == 0.0 && (-270.0..=270.0).contains(&turn)) {
        return Err(k.bad(
            &format!("{key}.turn_deg"),
            turn,
            "must be a quarter turn: 0, 90, 180 or 270 (or their negatives)",
        ));
    }
    let listed = listed(k, key, doc.slots.as_ref())?;
    if let (Some(_), Some(shift)) = (&listed, doc.odd_rows_shift_mm) {
        return Err(k.bad(
            &format!("{key}.odd_rows_shift_mm"),
            shift,
            "a listed layer has no rows: place its slots where they go",
        ));
    }
    Ok(Kind {
        turn_rad: turn.to_radians(),
        mirror: doc.mirror,
        shift_mm: k.pair(
            &format!("{key}.shift_mm"),
            doc.shift_mm.unwrap_or([0.0; 2]),
            MAX_LENGTH_MM,
        )?,
        odd_rows_shift_mm: k.within(
            &format!("{key}.odd_rows_shift_mm"),
            doc.odd_rows_shift_mm.unwrap_or(0.0),
            -MAX_LENGTH_MM,
            MAX_LENGTH_MM,
        )?,
        listed,
        order: doc.order.unwrap_or(order),
    })
}

fn placement(k: &Keys<'_>, doc: &PalletDoc) -> Result<Placement, PalletError> {
    let Some(corners) = &doc.corners else {
        let o = doc.origin_mm.unwrap_or([0.0; 3]);
        for (i, v) in o.iter().enumerate() {
            k.within(&format!("origin_mm[{i}]"), *v, -1e5, 1e5)?;
        }
        return Ok(Placement::Frame {
            frame: k.name("frame", doc.frame.as_ref())?,
            origin_mm: Vector3::from(o),
        });
    };
    let clash = [
        ("frame", doc.frame.is_some()),
        ("origin_mm", doc.origin_mm.is_some()),
        ("pitch_mm", doc.pitch_mm.is_some()),
    ];
    if let Some((key, _)) = clash.iter().find(|(_, given)| *given) {
        return Err(k.bad(
            key,
            "(given)",
            "corners place the grid: give corners or frame, origin_mm and pitch_mm, not both",
        ));
    }
    Ok(Placement::Corners(corners.clone()))
}

fn grid(
    k: &Keys<'_>,
    doc: &PalletDoc,
    placement: &Placement,
    needed: bool,
) -> Result<(usize, usize, Vector2<f64>), PalletError> {
    let why = "a grid layer needs rows, columns and pitch_mm";
    let rows = match doc.rows {
        Some(r) => k.count("rows", r)?,
        None if needed => return Err(k.missing("rows", why)),
        None => 1,
    };
    let columns = match doc.columns {
        Some(c) => k.count("columns", c)?,
        None if needed => return Err(k.missing("columns", why)),
        None => 1,
    };
    if matches!(placement, Placement::Corners(_)) {
        for (key, n) in [("rows", rows), ("columns", columns)] {
            if n < 2 {
                return Err(k.bad(
                    key,
                    n,
                    "corners span the grid: at least 2 rows and 2 columns",
                ));
            }
        }
        return Ok((rows, columns, Vector2::zeros()));
    }
    let pitch = match doc.pitch_mm {
        Some([x, y]) => Vector2::new(
            k.positive("pitch_mm[0]", x, MAX_LENGTH_MM)?,
            k.positive("pitch_mm[1]", y, MAX_LENGTH_MM)?,
        ),
        None if needed => return Err(k.missing("pitch_mm", why)),
        None => Vector2::zeros(),
    };
    Ok((rows, columns, pitch))
}
