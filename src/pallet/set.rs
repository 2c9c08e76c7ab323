//! A robot's frames and pallets as the config gives them ([`RobotPallets`]), checked, and turned
//! into [`Pattern`]s once the taught positions their `"@name"` points name are known: every slot
//! and waypoint checked against the robot's reach and joint limits, the refusal naming the slot.

use std::collections::BTreeMap;

use nalgebra::{Vector2, Vector3};

use super::doc::{FrameDoc, PalletDoc, PointDoc};
use super::error::SlotAt;
use super::layout::{Layout, Placement};
use super::{Frame, PalletError, Pattern, Pose, Slot};
use crate::kinematics::Kinematics;
use crate::robot::{Position, Robot, is_position_name};

/// The largest coordinate of a point given as numbers, mm.
pub const MAX_COORDINATE_MM: f64 = 100_000.0;

/// A checked frame table: taught from three points, or level at an origin.
#[derive(Debug, Clone, PartialEq)]
pub enum FrameSpec {
    /// Origin, a point along +x, a point on the +y side of the plane.
    Taught([PointDoc; 3]),
    /// An origin and a turn about world z, degrees.
    Level {
        /// The origin.
        origin: PointDoc,
        /// The turn, degrees.
        rotation_deg: f64,
    },
}

const POINT_KEYS: [&str; 3] = ["origin", "x_point", "xy_point"];

impl FrameSpec {
    /// Checks a frame table.
    ///
    /// # Errors
    /// A key refused or missing, naming the frame.
    pub fn check(name: &str, doc: &FrameDoc) -> Result<Self, PalletError> {
        let owner = format!("frame {name:?}");
        let points = [
            Some(&doc.origin),
            doc.x_point.as_ref(),
            doc.xy_point.as_ref(),
        ];
        for (key, point) in POINT_KEYS.iter().zip(points) {
            if let Some(p) = point {
                check_point(&owner, key, p)?;
            }
        }
        match (&doc.x_point, &doc.xy_point, doc.rotation_deg) {
            (Some(x), Some(xy), None) => {
                Ok(Self::Taught([doc.origin.clone(), x.clone(), xy.clone()]))
            }
            (None, None, rotation) => {
                let rotation_deg = rotation.unwrap_or(0.0);
                if !(rotation_deg.is_finite() && (-360.0..=360.0).contains(&rotation_deg)) {
                    return Err(PalletError::Value {
                        owner,
                        key: "rotation_deg".into(),
                        value: rotation_deg.to_string(),
                        reason: "must be a number within -360..=360".into(),
                    });
                }
                Ok(Self::Level {
                    origin: doc.origin.clone(),
                    rotation_deg,
                })
            }
            (Some(_), Some(_), Some(r)) => Err(PalletError::Value {
                owner,
                key: "rotation_deg".into(),
                value: r.to_string(),
                reason: "a frame taught from x_point and xy_point takes its turn from them".into(),
            }),
            (x, _, _) => Err(PalletError::Missing {
                owner,
                key: if x.is_some() { "xy_point" } else { "x_point" }.into(),
                reason: "a frame is taught from three points: origin, x_point and xy_point".into(),
            }),
        }
    }

    fn points(&self) -> Vec<&PointDoc> {
        match self {
            Self::Taught(p) => p.iter().collect(),
            Self::Level { origin, .. } => vec![origin],
        }
    }

    /// The taught positions its `"@name"` points name.
    #[must_use]
    pub fn taught_points(&self) -> Vec<&str> {
        let points: Vec<&PointDoc> = match self {
            Self::Taught(p) => p.iter().collect(),
            Self::Level { origin, .. } => vec![origin],
        };
        points
            .into_iter()
            .filter_map(|p| match p {
                PointDoc::Taught(s) => Some(s.trim_start_matches('@')),
                PointDoc::Given(_) => None,
            })
            .collect()
    }

    /// The frame, its `"@name"` points looked up in `taught`.
    ///
    /// # Errors
    /// A position not taught, or points that make no frame.
    pub fn resolve(&self, name: &str, taught: Taught<'_>) -> Result<Frame, PalletError> {
        let owner = format!("frame {name:?}");
        let frame = match self {
            Self::Taught(p) => {
                let [o, x, xy] = resolve3(&owner, p, taught)?;
                Frame::from_points(o, x, xy)
            }
            Self::Level {
                origin,
                rotation_deg,
            } => Frame::level(taught.point(&owner, "origin", origin)?, *rotation_deg),
        };
        frame.map_err(|source| PalletError::Frame { owner, source })
    }
}

fn resolve3(
    owner: &str,
    p: &[PointDoc; 3],
    taught: Taught<'_>,
) -> Result<[Vector3<f64>; 3], PalletError> {
    Ok([
        taught.point(owner, POINT_KEYS[0], &p[0])?,
        taught.point(owner, POINT_KEYS[1], &p[1])?,
        taught.point(owner, POINT_KEYS[2], &p[2])?,
    ])
}

fn check_point(owner: &str, key: &str, p: &PointDoc) -> Result<(), PalletError> {
    let bad = |value: String, reason: String| PalletError::Value {
        owner: owner.to_owned(),
        key: key.to_owned(),
        value,
        reason,
    };
    match p {
        PointDoc::Given(v) => match v
            .iter()
            .find(|x| !(x.is_finite() && x.abs() <= MAX_COORDINATE_MM))
        {
            Some(x) => Err(bad(
                format!("{v:?}"),
                format!(
                    "{x} is not a coordinate within -{MAX_COORDINATE_MM}..={MAX_COORDINATE_MM} mm"
                ),
            )),
            None => Ok(()),
        },
        PointDoc::Taught(s) => match s.strip_prefix('@') {
            Some(n) if is_position_name(n) => Ok(()),
            _ => Err(bad(
                format!("{s:?}"),
                format!(
                    "a point is [x, y, z] in mm or \"@name\" of a taught position ({})",
                    crate::robot::POSITION_NAME_RULE
                ),
            )),
        },
    }
}

/// The taught positions `"@name"` points are looked up in.
#[derive(Debug, Clone, Copy)]
pub struct Taught<'a>(pub &'a BTreeMap<String, Position>);

impl Taught<'_> {
    fn point(self, owner: &str, key: &str, p: &PointDoc) -> Result<Vector3<f64>, PalletError> {
        match p {
            PointDoc::Given(v) => Ok(Vector3::from(*v)),
            PointDoc::Taught(s) => {
                let name = s.trim_start_matches('@');
                let pos = self.0.get(name).ok_or_else(|| PalletError::NotTaught {
                    owner: owner.to_owned(),
                    key: key.to_owned(),
                    position: name.to_owned(),
                })?;
                Ok(Vector3::new(pos.pose[0], pos.pose[1], pos.pose[2]))
            }
        }
    }
}

/// A robot's frames and pallets, checked as far as they can be without the taught positions.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RobotPallets {
    /// Frames by name.
    pub frames: BTreeMap<String, FrameSpec>,
    /// Pallets by name.
    pub layouts: BTreeMap<String, Layout>,
}

impl RobotPallets {
    /// Checks a robot's frame and pallet tables: every value, and every pallet's frame known.
    ///
    /// # Errors
    /// The first value refused: the frame or pallet, the key and the limit.
    pub fn check(
        frames: &BTreeMap<String, FrameDoc>,
        pallets: &BTreeMap<String, PalletDoc>,
    ) -> Result<Self, PalletError> {
        let mut out = Self::default();
        for (name, doc) in frames {
            out.add_frame(name, doc)?;
        }
        for (name, doc) in pallets {
            out.add_pallet(name, doc)?;
        }
        Ok(out)
    }

    /// Checks and adds a frame table.
    ///
    /// # Errors
    /// A value refused, naming the frame, the key and the limit.
    pub fn add_frame(&mut self, name: &str, doc: &FrameDoc) -> Result<(), PalletError> {
        self.frames
            .insert(name.to_owned(), FrameSpec::check(name, doc)?);
        Ok(())
    }

    /// Checks and adds a pallet table (after the frames it may sit in).
    ///
    /// # Errors
    /// A value refused, naming the pallet, the key and the limit; a frame not defined.
    pub fn add_pallet(&mut self, name: &str, doc: &PalletDoc) -> Result<(), PalletError> {
        let layout = Layout::check(name, doc)?;
        match &layout.placement {
            Placement::Frame { frame: Some(f), .. } if !self.frames.contains_key(f) => {
                let known: Vec<&str> = self.frames.keys().map(String::as_str).collect();
                return Err(PalletError::Value {
                    owner: format!("pallet {name:?}"),
                    key: "frame".into(),
                    value: format!("{f:?}"),
                    reason: if known.is_empty() {
                        "no frame is defined: add [robots.NAME.frames.NAME]".into()
                    } else {
                        format!("the frames defined are {}", known.join(", "))
                    },
                });
            }
            Placement::Corners(c) => {
                for (i, p) in c.iter().enumerate() {
                    check_point(&format!("pallet {name:?}"), &format!("corners[{i}]"), p)?;
                }
            }
            Placement::Frame { .. } => {}
        }
        self.layouts.insert(name.to_owned(), layout);
        Ok(())
    }

    /// Whether pallet `name` needs taught positions to be laid out (its frame's points or its
    /// corners name some).
    #[must_use]
    pub fn needs_taught(&self, name: &str) -> bool {
        let taught = |p: &&PointDoc| matches!(p, PointDoc::Taught(_));
        match self.layouts.get(name).map(|l| &l.placement) {
            Some(Placement::Corners(c)) => c.iter().any(|p| taught(&p)),
            Some(Placement::Frame { frame: Some(f), .. }) => self
                .frames
                .get(f)
                .is_some_and(|s| s.points().iter().any(taught)),
            _ => false,
        }
    }

    /// Every pallet's pattern, laid out with `taught` and checked against `robot`'s reach and
    /// joint limits.
    ///
    /// # Errors
    /// The first pallet that cannot be laid out or reached, naming the slot.
    pub fn patterns(
        &self,
        robot: &Robot,
        taught: &BTreeMap<String, Position>,
    ) -> Result<BTreeMap<String, Pattern>, PalletError> {
        self.layouts
            .keys()
            .map(|name| Ok((name.clone(), self.pattern(name, robot, taught)?)))
            .collect()
    }

    /// Pallet `name`'s pattern ([`Self::patterns`]); `None` if there is none of that name.
    ///
    /// # Errors
    /// As [`Self::patterns`].
    pub fn pattern(
        &self,
        name: &str,
        robot: &Robot,
        taught: &BTreeMap<String, Position>,
    ) -> Result<Pattern, PalletError> {
        let layout = self.layouts.get(name).ok_or_else(|| PalletError::Value {
            owner: format!("robot {:?}", robot.name),
            key: "pallets".into(),
            value: format!("{name:?}"),
            reason: format!(
                "the pallets defined are {}",
                self.layouts.keys().cloned().collect::<Vec<_>>().join(", ")
            ),
        })?;
        let slots = self.lay_out(layout, Taught(taught))?;
        for &(key, speed) in &layout.slow_speeds_mm_s {
            if speed > robot.max_speed_mm_s {
                return Err(PalletError::Value {
                    owner: format!("pallet {name:?}"),
                    key: key.into(),
                    value: speed.to_string(),
                    reason: format!(
                        "robot {:?} allows at most {} mm/s (motion.max_speed_mm_s)",
                        robot.name, robot.max_speed_mm_s
                    ),
                });
            }
        }
        for slot in &slots {
            check_slot(name, robot, slot)?;
        }
        let mut pattern = Pattern::from_slots(name, slots)?;
        pattern.between_layers.clone_from(&layout.between_layers);
        pattern.when_full = layout.when_full.clone();
        Ok(pattern)
    }

    fn lay_out(&self, layout: &Layout, taught: Taught<'_>) -> Result<Vec<Slot>, PalletError> {
        let owner = format!("pallet {:?}", layout.name());
        match &layout.placement {
            Placement::Frame { frame, origin_mm } => {
                let frame = match frame {
                    Some(f) => self.frames[f].resolve(f, taught)?,
                    None => Frame::world(),
                };
                Ok(layout.slots(&frame, *origin_mm, layout.pitch_mm()))
            }
            Placement::Corners(c) => {
                let p = resolve3(&owner, c, taught)?;
                let frame = Frame::from_points(p[0], p[1], p[2])
                    .map_err(|source| PalletError::Frame { owner, source })?;
                let (rows, columns) = layout.grid();
                let far = frame
                    .local(&Pose {
                        position_mm: p[2],
                        a_rad: 0.0,
                    })
                    .position_mm;
                let pitch = Vector2::new(
                    (p[1] - p[0]).norm() / (columns - 1) as f64,
                    far.y / (rows - 1) as f64,
                );
                Ok(layout.slots(&frame, Vector3::zeros(), pitch))
            }
        }
    }
}

/// Checks a slot's pose and waypoints against the robot's reach and joint limits, and the lines
/// between them against its reach.
fn check_slot(pallet: &str, robot: &Robot, slot: &Slot) -> Result<(), PalletError> {
    let poses = slot
        .approach
        .iter()
        .enumerate()
        .map(|(i, w)| (format!("approach waypoint {}", i + 1), w.pose))
        .chain(std::iter::once(("the slot".to_owned(), slot.pose)))
        .chain(
            slot.retreat
                .iter()
                .enumerate()
                .map(|(i, w)| (format!("retreat waypoint {}", i + 1), w.pose)),
        );
    let mut last: Option<Pose> = None;
    for (what, pose) in poses {
        let fail = |reason: String| PalletError::Unreachable {
            pallet: pallet.to_owned(),
            at: SlotAt {
                index: slot.index,
                layer: slot.layer,
                row: slot.row,
                column: slot.column,
                what: what.clone(),
            },
            reason,
        };
        crate::plan::check_pose(robot, &pose).map_err(|e| fail(e.to_string()))?;
        if let Some(from) = last {
            let line = crate::geometry::Line { from, to: pose };
            robot
                .kinematics
                .check_line(&line)
                .map_err(|e| fail(format!("the line to it from the pose before: {e}")))?;
        }
        last = Some(pose);
    }
    Ok(())
}
