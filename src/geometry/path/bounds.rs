//! The distance from a point to a path of many pieces without measuring every piece: a binary
//! tree of bounding spheres over runs of consecutive pieces, searched nearest first. A run whose
//! sphere is farther than the nearest piece found so far cannot hold a nearer one and is
//! skipped, so a point near the path measures a few pieces however long the path is, and the
//! answer is exactly the smallest distance over every piece.

use nalgebra::Vector3;

use super::{Piece, Primitive};

/// How much nearer than its sphere allows a piece is still looked at, mm: the sphere's bound
/// holds exactly, a piece's measured distance only to rounding.
const SLACK_MM: f64 = 1e-6;

/// A sphere holding every point of a run of pieces.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Sphere {
    centre: Vector3<f64>,
    radius: f64,
}

impl Sphere {
    /// One holding the whole primitive: a line's from its middle; an arc's about its circle's
    /// centre (every point of it lies on the circle).
    fn of(primitive: &Primitive) -> Self {
        match primitive {
            Primitive::Line(l) => Self {
                centre: (l.from.position_mm + l.to.position_mm) / 2.0,
                radius: l.length_mm() / 2.0,
            },
            Primitive::Arc(a) => Self {
                centre: a.centre_mm,
                radius: a.radius_mm,
            },
        }
    }

    /// The smallest sphere holding both.
    fn around(a: Self, b: Self) -> Self {
        let d = (b.centre - a.centre).norm();
        if d + b.radius <= a.radius {
            return a;
        }
        if d + a.radius <= b.radius {
            return b;
        }
        let radius = (d + a.radius + b.radius) / 2.0;
        // On the line through both centres, `radius` beyond a's far side.
        let centre = a.centre + (b.centre - a.centre) * ((radius - a.radius) / d);
        Self {
            centre,
            radius: radius + SLACK_MM,
        }
    }

    /// No point inside it is nearer to `p` than this, mm.
    fn below_mm(&self, p: &Vector3<f64>) -> f64 {
        (p - self.centre).norm() - self.radius
    }
}

/// A node of the tree: its sphere, and either one piece or two child nodes.
#[derive(Debug, Clone, PartialEq)]
struct Node {
    sphere: Sphere,
    holds: Holds,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Holds {
    Piece(usize),
    Nodes(usize, usize),
}

/// The tree over a path's pieces (the root last).
#[derive(Debug, Clone, PartialEq, Default)]
pub(super) struct Bounds {
    nodes: Vec<Node>,
}

impl Bounds {
    /// The tree over `pieces`.
    pub(super) fn new(pieces: &[Piece]) -> Self {
        let mut bounds = Self { nodes: Vec::new() };
        if !pieces.is_empty() {
            bounds.build(pieces, 0, pieces.len());
        }
        bounds
    }

    /// Builds the node over pieces `lo..hi` (at least one), returning its index.
    fn build(&mut self, pieces: &[Piece], lo: usize, hi: usize) -> usize {
        let node = if hi - lo == 1 {
            Node {
                sphere: Sphere::of(&pieces[lo].primitive),
                holds: Holds::Piece(lo),
            }
        } else {
            let mid = lo + (hi - lo) / 2;
            let a = self.build(pieces, lo, mid);
            let b = self.build(pieces, mid, hi);
            Node {
                sphere: Sphere::around(self.nodes[a].sphere, self.nodes[b].sphere),
                holds: Holds::Nodes(a, b),
            }
        };
        self.nodes.push(node);
        self.nodes.len() - 1
    }

    /// The smallest distance from `p` to any of `pieces` (those the tree was built over), mm:
    /// exactly the smallest of every piece's `distance_mm`; and a piece that is that near.
    pub(super) fn nearest(&self, pieces: &[Piece], p: &Vector3<f64>) -> (f64, usize) {
        let mut best = (f64::INFINITY, 0);
        if let Some(root) = self.nodes.len().checked_sub(1) {
            let below = self.nodes[root].sphere.below_mm(p);
            self.search(pieces, p, root, below, &mut best);
        }
        best
    }

    fn search(
        &self,
        pieces: &[Piece],
        p: &Vector3<f64>,
        node: usize,
        below: f64,
        best: &mut (f64, usize),
    ) {
        if below - SLACK_MM > best.0 {
            return;
        }
        match self.nodes[node].holds {
            Holds::Piece(i) => {
                let d = pieces[i].primitive.distance_mm(p);
                if d < best.0 {
                    *best = (d, i);
                }
            }
            Holds::Nodes(a, b) => {
                let (below_a, below_b) = (
                    self.nodes[a].sphere.below_mm(p),
                    self.nodes[b].sphere.below_mm(p),
                );
                if below_a <= below_b {
                    self.search(pieces, p, a, below_a, best);
                    self.search(pieces, p, b, below_b, best);
                } else {
                    self.search(pieces, p, b, below_b, best);
                    self.search(pieces, p, a, below_a, best);
                }
            }
        }
    }
}
