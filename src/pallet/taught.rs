//! Taught positions kept in a frame: a position saved with a frame holds its pose in the
//! frame's coordinates, so re-teaching the frame's three points moves it with everything else
//! on the frame. [`RobotPallets::world_positions`] gives every position as the robot reaches
//! it now: a frame's own points are world positions (a frame taught on a point of a frame
//! could move itself), and a position in a frame is carried by the frame as its points are
//! taught now, its counts those of its world pose.

use std::collections::BTreeMap;

use super::set::Taught;
use super::{Frame, PalletError, Pose, RobotPallets};
use crate::plan::check_pose;
use crate::robot::{Position, Robot};

impl RobotPallets {
    /// Frame `frame` as its points are taught now, for position `position` (the owner named
    /// by a refusal); its points must be world positions.
    ///
    /// # Errors
    /// No such frame, a point taught in a frame, or points that make no frame.
    pub fn frame_for(
        &self,
        position: &str,
        frame: &str,
        taught: &BTreeMap<String, Position>,
    ) -> Result<Frame, PalletError> {
        let Some(spec) = self.frames.get(frame) else {
            let known: Vec<&str> = self.frames.keys().map(String::as_str).collect();
            return Err(PalletError::Value {
                owner: format!("position {position:?}"),
                key: "frame".into(),
                value: format!("{frame:?}"),
                reason: if known.is_empty() {
                    "no frame is defined: add [robots.NAME.frames.NAME]".into()
                } else {
                    format!("the frames defined are {}", known.join(", "))
                },
            });
        };
        for point in spec.taught_points() {
            if let Some(inner) = taught.get(point).and_then(|p| p.frame.as_deref()) {
                return Err(PalletError::Value {
                    owner: format!("frame {frame:?}"),
                    key: "points".into(),
                    value: format!("\"@{point}\""),
                    reason: format!(
                        "position {point:?} is kept in frame {inner:?}; a frame's points are \
                         taught in world coordinates"
                    ),
                });
            }
        }
        spec.resolve(frame, Taught(taught))
    }

    /// Every taught position as the robot reaches it now: those kept in a frame carried by it.
    ///
    /// # Errors
    /// The first position kept in a frame that cannot be resolved (no such frame, its points
    /// not taught) or whose world pose the robot cannot reach, naming the position.
    pub fn world_positions(
        &self,
        robot: &Robot,
        taught: &BTreeMap<String, Position>,
    ) -> Result<BTreeMap<String, Position>, PalletError> {
        taught
            .iter()
            .map(|(name, p)| Ok((name.clone(), self.world_position(robot, name, p, taught)?)))
            .collect()
    }

    fn world_position(
        &self,
        robot: &Robot,
        name: &str,
        p: &Position,
        taught: &BTreeMap<String, Position>,
    ) -> Result<Position, PalletError> {
        let Some(frame_name) = &p.frame else {
            return Ok(p.clone());
        };
        let frame = self.frame_for(name, frame_name, taught)?;
        let [x, y, z, a] = p.pose;
        let world = frame.pose(&Pose::from_mm_deg(x, y, z, a));
        let joint_counts = check_pose(robot, &world).map_err(|e| PalletError::Value {
            owner: format!("position {name:?}"),
            key: "pose".into(),
            value: format!("{:?} in frame {frame_name:?}", p.pose),
            reason: format!(
                "in world coordinates {:?} the robot cannot reach it: {e}",
                world.to_mm_deg()
            ),
        })?;
        Ok(Position {
            pose: world.to_mm_deg(),
            joint_counts,
            saved_unix_s: p.saved_unix_s,
            frame: None,
        })
    }

    /// The world pose `world` in frame `frame`'s coordinates as its points are taught now:
    /// what a position saved in the frame keeps.
    ///
    /// # Errors
    /// As [`Self::frame_for`].
    pub fn in_frame(
        &self,
        position: &str,
        frame: &str,
        world: &Pose,
        taught: &BTreeMap<String, Position>,
    ) -> Result<[f64; 4], PalletError> {
        Ok(self
            .frame_for(position, frame, taught)?
            .local(world)
            .to_mm_deg())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pallet::doc::FrameDoc;
    use crate::robot::seed_robot;

    fn world(pose: [f64; 4], robot: &Robot) -> Position {
        let [x, y, z, a] = pose;
        Position {
            pose,
            joint_counts: check_pose(robot, &Pose::from_mm_deg(x, y, z, a)).unwrap(),
            saved_unix_s: 1,
            frame: None,
        }
    }

    fn station() -> RobotPallets {
        let doc: FrameDoc = toml::from_str(
            r#"origin = "@o"
x_point = "@x"
xy_point = "@xy""#,
        )
        .expect("a frame table");
        let mut set = RobotPallets::default();
        set.add_frame("station", &doc).unwrap();
        set
    }

    fn taught(robot: &Robot, shift: f64) -> BTreeMap<String, Position> {
        [
            ("o", [shift, 500.0, 100.0, 0.0]),
            ("x", [shift + 100.0, 500.0, 100.0, 0.0]),
            ("xy", [shift, 600.0, 100.0, 0.0]),
        ]
        .into_iter()
        .map(|(n, p)| (n.to_owned(), world(p, robot)))
        .collect()
    }

    #[test]
    fn a_position_kept_in_a_frame_moves_with_the_frames_points() {
        let robot = seed_robot();
        let set = station();
        let mut positions = taught(&robot, 0.0);
        let grip = Pose::from_mm_deg(30.0, 540.0, 120.0, 10.0);
        let local = set.in_frame("grip", "station", &grip, &positions).unwrap();
        for (got, want) in local.iter().zip([30.0, 40.0, 20.0, 10.0]) {
            assert!((got - want).abs() < 1e-9, "{local:?}");
        }
        let kept = Position {
            pose: local,
            joint_counts: [0; 4],
            saved_unix_s: 2,
            frame: Some("station".into()),
        };
        positions.insert("grip".into(), kept.clone());
        let now = set.world_positions(&robot, &positions).unwrap();
        let expected = world(grip.to_mm_deg(), &robot);
        assert_eq!(now["grip"].joint_counts, expected.joint_counts);
        // The frame's points re-taught 50 mm along x: the position moves with them.
        let mut moved = taught(&robot, 50.0);
        moved.insert("grip".into(), kept);
        let now = set.world_positions(&robot, &moved).unwrap();
        let expected = world([80.0, 540.0, 120.0, 10.0], &robot);
        assert_eq!(now["grip"].joint_counts, expected.joint_counts);
        assert!((now["grip"].pose[0] - 80.0).abs() < 1e-9);
        assert_eq!(now["o"], moved["o"]);
    }

    #[test]
    fn a_frame_on_a_point_kept_in_a_frame_or_an_unknown_frame_is_refused_by_name() {
        let robot = seed_robot();
        let set = station();
        let mut positions = taught(&robot, 0.0);
        positions.get_mut("x").unwrap().frame = Some("station".into());
        let e = set.world_positions(&robot, &positions).unwrap_err();
        assert!(
            e.to_string()
                .contains("position \"x\" is kept in frame \"station\""),
            "{e}"
        );
        let mut positions = taught(&robot, 0.0);
        positions.get_mut("o").unwrap().frame = Some("die".into());
        let e = set.world_positions(&robot, &positions).unwrap_err();
        assert!(
            e.to_string().contains("the frames defined are station"),
            "{e}"
        );
    }
}
