//! The Delaunay triangulation of a group's distinct points, on spade's exact
//! predicates, as flat triangle and neighbour arrays.

use spade::{DelaunayTriangulation, HasPosition, Point2, Triangulation};

use crate::frame::{Frame, Xy};

/// "No neighbour": the edge is on the convex hull.
pub const NONE: u32 = u32::MAX;

/// The triangulation of one group.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    /// For every point of the group (by its index in the group), the point
    /// that represents it: itself, or the first point (in input order) of its
    /// set of exact or near-duplicates.
    pub rep: Vec<u32>,
    /// Number of distinct points (representatives).
    pub n_distinct: usize,
    /// Triangles as point indices, counter-clockwise.
    pub tri: Vec<[u32; 3]>,
    /// `nb[t][j]`: the triangle across the edge from `tri[t][j]` to
    /// `tri[t][(j + 1) % 3]`, or [`NONE`] on the convex hull.
    pub nb: Vec<[u32; 3]>,
}

#[derive(Clone, Copy)]
struct Vertex {
    pos: Point2<f64>,
    id: u32,
}

impl HasPosition for Vertex {
    type Scalar = f64;
    fn position(&self) -> Point2<f64> {
        self.pos
    }
}

/// Union-find over point indices whose root is the smallest index of its set.
pub struct MinUnion(Vec<u32>);

impl MinUnion {
    /// `n` singletons.
    pub fn new(n: usize) -> Self {
        MinUnion((0..n as u32).collect())
    }

    /// The root (smallest member) of `i`'s set.
    pub fn find(&mut self, mut i: u32) -> u32 {
        while self.0[i as usize] != i {
            let up = self.0[self.0[i as usize] as usize];
            self.0[i as usize] = up;
            i = up;
        }
        i
    }

    /// Merge the sets of `a` and `b`; true if they were apart.
    pub fn union(&mut self, a: u32, b: u32) -> bool {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra == rb {
            return false;
        }
        let (lo, hi) = if ra < rb { (ra, rb) } else { (rb, ra) };
        self.0[hi as usize] = lo;
        true
    }
}

/// Scaled position for spade: exact (a power of two), with coordinates below
/// spade's smallest allowed magnitude (2^-142 of an extent near 1, far below
/// the tolerance) set to zero.
fn scaled(p: Xy, s: f64) -> Point2<f64> {
    spade::mitigate_underflow(Point2::new(p[0] * s + 0.0, p[1] * s + 0.0))
}

fn delaunay(points: &[Xy], ids: &[u32], s: f64) -> Option<DelaunayTriangulation<Vertex>> {
    let vertices = ids
        .iter()
        .map(|&id| Vertex {
            pos: scaled(points[id as usize], s),
            id,
        })
        .collect();
    DelaunayTriangulation::<Vertex>::bulk_load(vertices).ok()
}

/// Exact duplicates (the same x and y, -0 equal to 0) into `union`.
fn exact_duplicates(points: &[Xy], union: &mut MinUnion) {
    let key = |i: u32| {
        let p = points[i as usize];
        (p[0] + 0.0, p[1] + 0.0)
    };
    let mut order: Vec<u32> = (0..points.len() as u32).collect();
    order.sort_unstable_by(|&a, &b| {
        let (ka, kb) = (key(a), key(b));
        ka.0.total_cmp(&kb.0).then(ka.1.total_cmp(&kb.1))
    });
    for w in order.windows(2) {
        if key(w[0]) == key(w[1]) {
            union.union(w[0], w[1]);
        }
    }
}

fn roots(union: &mut MinUnion, n: usize) -> Vec<u32> {
    (0..n as u32).filter(|&i| union.find(i) == i).collect()
}

/// Triangulate a group's points (`frame` is theirs).
///
/// Exact duplicates collapse; points closer than `frame.tol` are one point
/// (transitively: the Delaunay graph holds every nearest neighbour, so its
/// short edges find every close pair's set), the first in input order
/// representing them. The mesh has no triangle when the distinct points are
/// all exactly collinear or fewer than 3, or when `build` is false (then only
/// exact duplicates are merged: a group already known to be degenerate).
pub fn triangulate(points: &[Xy], frame: &Frame, build: bool) -> Mesh {
    let n = points.len();
    let s = frame.scale;
    let mut union = MinUnion::new(n);
    exact_duplicates(points, &mut union);
    let mut ids = roots(&mut union, n);
    let mut mesh = Mesh::default();
    let mut dt = None;
    if build && ids.len() >= 3 {
        dt = delaunay(points, &ids, s);
        if let Some(t) = &dt {
            let close = (frame.tol * s) * (frame.tol * s);
            let mut merged = false;
            for e in t.undirected_edges() {
                let [a, b] = e.vertices();
                let (pa, pb) = (points[a.data().id as usize], points[b.data().id as usize]);
                let (dx, dy) = ((pa[0] - pb[0]) * s, (pa[1] - pb[1]) * s);
                if dx * dx + dy * dy < close {
                    merged |= union.union(a.data().id, b.data().id);
                }
            }
            if merged {
                ids = roots(&mut union, n);
                dt = if ids.len() >= 3 {
                    delaunay(points, &ids, s)
                } else {
                    None
                };
            }
        }
    }
    mesh.rep = (0..n as u32).map(|i| union.find(i)).collect();
    mesh.n_distinct = ids.len();
    if let Some(t) = dt {
        fill_arrays(&t, &mut mesh);
    }
    mesh
}

fn fill_arrays(t: &DelaunayTriangulation<Vertex>, mesh: &mut Mesh) {
    let m = t.num_inner_faces();
    mesh.tri = vec![[0; 3]; m];
    mesh.nb = vec![[NONE; 3]; m];
    // Inner faces are numbered 1..=m (0 is the outer face).
    for f in t.inner_faces() {
        let i = f.fix().index() - 1;
        let v = f.vertices();
        mesh.tri[i] = [v[0].data().id, v[1].data().id, v[2].data().id];
        for (j, e) in f.adjacent_edges().iter().enumerate() {
            let across = e.rev().face();
            if !across.is_outer() {
                mesh.nb[i][j] = (across.fix().index() - 1) as u32;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_square_with_a_duplicate_has_two_triangles() {
        let pts = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0], [1.0, 1.0]];
        let mesh = triangulate(&pts, &Frame::of(&pts), true);
        assert_eq!(mesh.n_distinct, 4);
        assert_eq!(mesh.tri.len(), 2);
        assert_eq!(mesh.rep[4], 3);
    }

    #[test]
    fn near_duplicates_merge_into_the_first() {
        let pts = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0 + 1e-12, 0.0]];
        let mesh = triangulate(&pts, &Frame::of(&pts), true);
        assert_eq!(mesh.n_distinct, 3);
        assert_eq!(mesh.rep, vec![0, 1, 2, 1]);
        assert_eq!(mesh.tri.len(), 1);
    }

    #[test]
    fn collinear_points_have_no_triangle() {
        let pts = [[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]];
        assert!(triangulate(&pts, &Frame::of(&pts), true).tri.is_empty());
    }
}
