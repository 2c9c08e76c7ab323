//! The pallet and frame tables exactly as written (`[robots.NAME.pallets.NAME]`,
//! `[robots.NAME.frames.NAME]`): serde structs that refuse unknown keys and wrong types; every
//! value is checked by `layout` and `set`, which name the key and the limit.
//!
//! ```toml
//! [robots.r.frames.station]        # taught: three points, numbers or "@position"
//! origin = "@station-0"             # or given: origin = [800, -300, 0]
//! x_point = "@station-x"            #           rotation_deg = 90
//! xy_point = "@station-y"
//!
//! [robots.r.pallets.out]
//! frame = "station"                 # optional: world coordinates without one
//! origin_mm = [0, 0, 150]           # slot (row 0, column 0) of layer 0 in the frame; default 0
//! rows = 6                          # along the frame's y, `pitch_mm[1]` apart
//! columns = 4                       # along the frame's x, `pitch_mm[0]` apart
//! pitch_mm = [300, 200]
//! # or: corners = [first, last of row 0, first of the last row], points or "@position"
//! layer_height_mm = 250
//! layers = ["A", "B", "A", "B"]     # kinds bottom up, or a count of plain layers
//! a_deg = 0                         # the tool angle of grid slots in the frame
//! order = "rows"                    # rows, columns, snake-rows, snake-columns
//! approach = { height_mm = 150, side_mm = [0, -50], slow_mm = 30, slow_speed_mm_s = 40,
//!              blend_mm = 40 }      # its first point passed without a stop, the corner rounded
//! retreat = { height_mm = 150 }     # default: the approach's (its blend_mm does not apply)
//! between_layers = "slip-sheet"     # a cycle program, before every layer but the first
//! when_full = { signal = "pallet-full", wait_for = "pallet-empty", call = "change" }
//! [robots.r.pallets.out.kinds.B]    # a layer kind; one not listed is the plain grid
//! turn_deg = 180                    # 0, 90, 180 or 270, about the grid's centre
//! mirror = "x"                      # x or y: mirrored across the centre line square to it
//! shift_mm = [150, 0]               # the whole layer moved (half a pitch: interlocked)
//! odd_rows_shift_mm = 150           # rows 1, 3, ... moved along x (brick rows)
//! slots = [[0, 0, 90], [300, 0, 0]] # or an explicit layer: x, y mm and the tool angle
//! order = "columns"                 # this kind's own fill order
//! ```

use std::collections::BTreeMap;

use serde::Deserialize;

/// A point: numbers (x, y, z mm, world) or `"@name"`, a taught position.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(untagged)]
pub enum PointDoc {
    /// x, y, z in mm.
    Given([f64; 3]),
    /// `"@name"`: the taught position `name`, resolved when the positions are known.
    Taught(String),
}

/// `[robots.NAME.frames.NAME]`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FrameDoc {
    /// The frame's origin.
    pub origin: PointDoc,
    /// A point along its +x axis (taught frames).
    pub x_point: Option<PointDoc>,
    /// A point on the +y side of its xy plane (taught frames).
    pub xy_point: Option<PointDoc>,
    /// Its turn about world z, degrees (given frames; default 0).
    pub rotation_deg: Option<f64>,
}

/// `layers`: a count of plain layers or the kinds bottom up.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(untagged)]
pub enum LayersDoc {
    /// This many plain grid layers.
    Count(i64),
    /// A kind per layer, bottom up.
    Kinds(Vec<String>),
}

/// The order slots of a layer are filled in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum OrderDoc {
    /// Row 0 column by column, then row 1, ...
    #[default]
    Rows,
    /// Column 0 row by row, then column 1, ...
    Columns,
    /// As `rows`, every other row run backwards.
    SnakeRows,
    /// As `columns`, every other column run backwards.
    SnakeColumns,
}

/// `mirror`: the axis the mirror runs along.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum MirrorDoc {
    /// x becomes -x about the grid's centre.
    X,
    /// y becomes -y about the grid's centre.
    Y,
}

/// `[robots.NAME.pallets.NAME.kinds.KIND]`.
#[derive(Debug, Clone, PartialEq, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KindDoc {
    /// A turn of the whole layer about the grid's centre, degrees: 0, 90, 180 or 270.
    pub turn_deg: Option<f64>,
    /// A mirror of the layer across the grid's centre.
    pub mirror: Option<MirrorDoc>,
    /// The whole layer moved, mm in the frame (after the turn).
    pub shift_mm: Option<[f64; 2]>,
    /// Rows 1, 3, 5, ... moved along x, mm (brick rows).
    pub odd_rows_shift_mm: Option<f64>,
    /// An explicit layer: x, y (mm, as grid slots are placed) and the tool angle (degrees).
    pub slots: Option<Vec<[f64; 3]>>,
    /// This kind's fill order (default: the pallet's).
    pub order: Option<OrderDoc>,
}

/// `approach` and `retreat`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReachDoc {
    /// How far above the slot the way in starts (the way out ends), mm.
    pub height_mm: f64,
    /// That point moved sideways, mm in the frame's x and y.
    pub side_mm: Option<[f64; 2]>,
    /// The last (first) millimetres at `slow_speed_mm_s`.
    pub slow_mm: Option<f64>,
    /// The speed of those millimetres, mm/s.
    pub slow_speed_mm_s: Option<f64>,
    /// The approach only: its first point (`height_mm` above the slot) is a blended corner of
    /// this size, mm, passed without a stop from wherever the robot comes (as a path's `blend`).
    pub blend_mm: Option<f64>,
}

/// `when_full`.
#[derive(Debug, Clone, PartialEq, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WhenFullDoc {
    /// An output set while the pallet is full.
    pub signal: Option<String>,
    /// A condition that says an empty pallet is in place.
    pub wait_for: Option<String>,
    /// A cycle program to call.
    pub call: Option<String>,
}

/// `[robots.NAME.pallets.NAME]`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PalletDoc {
    /// The frame it sits in (world coordinates without one).
    pub frame: Option<String>,
    /// Slot (row 0, column 0) of layer 0 in the frame, mm.
    pub origin_mm: Option<[f64; 3]>,
    /// Three slots of layer 0 instead of a frame, an origin and pitches.
    pub corners: Option<[PointDoc; 3]>,
    /// Rows of the grid, along the frame's y.
    pub rows: Option<i64>,
    /// Columns of the grid, along the frame's x.
    pub columns: Option<i64>,
    /// The distance between columns (x) and rows (y), mm.
    pub pitch_mm: Option<[f64; 2]>,
    /// The rise from one layer to the next, mm.
    pub layer_height_mm: f64,
    /// The layers.
    pub layers: LayersDoc,
    /// The tool angle of grid slots in the frame, degrees (default 0).
    pub a_deg: Option<f64>,
    /// The fill order of a layer.
    pub order: Option<OrderDoc>,
    /// Layer kinds by name.
    #[serde(default)]
    pub kinds: BTreeMap<String, KindDoc>,
    /// The way into every slot.
    pub approach: Option<ReachDoc>,
    /// The way out of every slot (default: the approach's).
    pub retreat: Option<ReachDoc>,
    /// A cycle program run before every layer but the first.
    pub between_layers: Option<String>,
    /// What the cell does when the pallet is full.
    #[serde(default)]
    pub when_full: WhenFullDoc,
}
