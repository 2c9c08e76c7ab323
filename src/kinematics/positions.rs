//! Tool positions of many joint vectors that differ a joint at a time, as the accuracy figures
//! need one at every pulse: bit for bit what [`Kinematics::fk`] gives, with each sine and cosine
//! computed only when its angle has changed since the last position.

use nalgebra::Vector3;

use super::{Arm, Joints, Kinematics, Model};

/// An angle with its sine and cosine.
#[derive(Debug, Clone, Copy)]
struct Trig {
    angle: f64,
    sin: f64,
    cos: f64,
}

impl Trig {
    const UNSET: Self = Self {
        angle: f64::NAN,
        sin: f64::NAN,
        cos: f64::NAN,
    };

    /// The sine and cosine of `angle`, computed again only when it differs from the last.
    fn of(&mut self, angle: f64) -> (f64, f64) {
        if angle.to_bits() != self.angle.to_bits() {
            *self = Self {
                angle,
                sin: angle.sin(),
                cos: angle.cos(),
            };
        }
        (self.sin, self.cos)
    }
}

/// Forward kinematics' position for a run of joint vectors (see the module docs). `TOOL` is
/// whether the arm has a tool offset: a constant, so that a loop over pulses is made once for
/// each and the common one (no offset) tests nothing per pulse.
#[derive(Debug, Clone)]
pub struct Positions<'a, const TOOL: bool> {
    arm: &'a Arm,
    trig: [Trig; 2],
}

impl<'a, const TOOL: bool> Positions<'a, TOOL> {
    /// Positions of `arm`'s tool, `None` unless `TOOL` is whether `arm` has a tool offset.
    #[must_use]
    pub fn new(arm: &'a Arm) -> Option<Self> {
        (arm.has_tool() == TOOL).then_some(Self {
            arm,
            trig: [Trig::UNSET; 2],
        })
    }

    /// The tool position at joints `q`, exactly `arm.fk(q).position_mm`.
    #[allow(clippy::inline_always)]
    #[inline(always)]
    pub fn at(&mut self, q: &Joints) -> Vector3<f64> {
        let flange = match &self.arm.model {
            Model::Cylindrical(k) => {
                let [theta1, d2, d3, _] = *q;
                let r = d3 + k.l0_mm;
                let (sin, cos) = self.trig[0].of(theta1);
                Vector3::new(-r * sin, r * cos, d2)
            }
            Model::Cartesian(_) => Vector3::new(q[0], q[1], q[2]),
            Model::Scara(k) => {
                let [t1, t2, d3, _] = *q;
                let (s1, c1) = self.trig[0].of(t1);
                let (s12, c12) = self.trig[1].of(t1 + t2);
                Vector3::new(
                    k.l1_mm * c1 + k.l2_mm * c12,
                    k.l1_mm * s1 + k.l2_mm * s12,
                    d3,
                )
            }
        };
        // The tool's offset is added to the flange (as `Arm::fk` adds it), never returned in
        // place of it: a position made out of line comes back through memory, and merged
        // with the flange's it stalled every pulse on the store.
        if TOOL {
            flange + self.offset(q)
        } else {
            flange
        }
    }

    /// The tool's offset from the flange at joints `q`, world mm.
    #[cold]
    #[inline(never)]
    fn offset(&self, q: &Joints) -> Vector3<f64> {
        self.arm.offset_at(self.arm.model.fk(q).a_rad)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::{Cartesian, Cylindrical, Elbow, Scara};

    #[test]
    fn positions_are_fk_bit_for_bit_as_one_joint_moves_at_a_time() {
        let models = [
            Model::Cylindrical(Cylindrical {
                l0_mm: 500.0,
                min_axis_distance_mm: 50.0,
            }),
            Model::Cartesian(Cartesian),
            Model::Scara(Scara {
                l1_mm: 400.0,
                l2_mm: 300.0,
                elbow: Elbow::Left,
                reach_margin_mm: 1.0,
            }),
        ];
        for model in models {
            let tools = [Vector3::zeros(), Vector3::new(80.0, -20.0, -50.0)];
            for arm in tools.map(|tool_mm| Arm {
                model: model.clone(),
                tool_mm,
            }) {
                assert!(Positions::<true>::new(&arm).is_some() == arm.has_tool());
                assert!(Positions::<false>::new(&arm).is_some() != arm.has_tool());
                match Positions::<true>::new(&arm) {
                    Some(positions) => walk(&arm, positions, Positions::at),
                    None => walk(&arm, Positions::<false>::new(&arm).unwrap(), Positions::at),
                }
            }
        }
    }

    /// Moves a pseudo-random joint a step at a time (now and then none) and checks each
    /// position `at` gives against the arm's forward kinematics.
    fn walk<P>(arm: &Arm, mut positions: P, at: impl Fn(&mut P, &Joints) -> Vector3<f64>) {
        let mut q = [1.047, 50.0, 570.0, 0.0];
        for i in 0..400u32 {
            let j = (i * 7 + i / 3) as usize % 4;
            q[j] += f64::from(i % 5) * 4.363e-5;
            assert_eq!(
                at(&mut positions, &q),
                arm.fk(&q).position_mm,
                "{arm:?} {q:?}"
            );
        }
    }
}
