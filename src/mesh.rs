//! The Delaunay triangulation of a group's distinct points, on spade's exact
//! predicates, as flat triangle and neighbour arrays.

use rayon::prelude::*;
use spade::handles::{FaceHandle, FixedVertexHandle, PossiblyOuterTag};
use spade::{DelaunayTriangulation, HasPosition, Point2, Triangulation};

use crate::frame::{Frame, Xy};

/// "No neighbour": the edge is on the convex hull.
pub const NONE: u32 = u32::MAX;

/// The triangulation of one group.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    /// For every point of the group, the one that represents it: itself, or
    /// the first (in input order) of its exact or near-duplicates.
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
    /// Index of the point in the group.
    id: u32,
    /// Place along the Z-order curve through the group's distinct points.
    rank: u32,
}

impl HasPosition for Vertex {
    type Scalar = f64;
    fn position(&self) -> Point2<f64> {
        self.pos
    }
}

/// Union-find (path halving, union by size).
pub struct Union {
    parent: Vec<u32>,
    size: Vec<u32>,
}

impl Union {
    /// `n` singletons.
    pub fn new(n: usize) -> Self {
        Union {
            parent: (0..n as u32).collect(),
            size: vec![1; n],
        }
    }

    /// The root of `i`'s set.
    pub fn find(&mut self, mut i: u32) -> u32 {
        while self.parent[i as usize] != i {
            let up = self.parent[self.parent[i as usize] as usize];
            self.parent[i as usize] = up;
            i = up;
        }
        i
    }

    /// Merge the sets of `a` and `b`; true if they were apart.
    pub fn union(&mut self, a: u32, b: u32) -> bool {
        let (mut ra, mut rb) = (self.find(a), self.find(b));
        if ra == rb {
            return false;
        }
        if self.size[ra as usize] < self.size[rb as usize] {
            std::mem::swap(&mut ra, &mut rb);
        }
        self.parent[rb as usize] = ra;
        self.size[ra as usize] += self.size[rb as usize];
        true
    }
}

/// Position of `(x, y)` along the Z-order (Morton) curve over a 2^32 x 2^32
/// grid: the bits of `x` and `y` interleaved.
fn morton(x: u32, y: u32) -> u64 {
    fn spread(v: u32) -> u64 {
        let mut v = u64::from(v);
        v = (v | (v << 16)) & 0x0000_FFFF_0000_FFFF;
        v = (v | (v << 8)) & 0x00FF_00FF_00FF_00FF;
        v = (v | (v << 4)) & 0x0F0F_0F0F_0F0F_0F0F;
        v = (v | (v << 2)) & 0x3333_3333_3333_3333;
        (v | (v << 1)) & 0x5555_5555_5555_5555
    }
    spread(x) | (spread(y) << 1)
}

/// Where spade puts point `p` of a group scaled by `s`: scaled (exactly but
/// for subnormal results), coordinates below spade's smallest magnitude
/// (2^-142, far below the tolerance) set to zero, -0 as 0. Two points at the
/// same place are one vertex of spade's, so they are exact duplicates here.
pub fn placed(p: Xy, s: f64) -> Point2<f64> {
    let q = spade::mitigate_underflow(Point2::new(p[0] * s + 0.0, p[1] * s + 0.0));
    Point2::new(q.x + 0.0, q.y + 0.0)
}

/// The points along a Z-order curve through their bounding box, sorted
/// `(place on the curve, bits of the place spade gives it, index)`: exact
/// duplicates (at spade's places: [`placed`]) end up next to each other, and
/// the order (with it spade's triangulation) depends on the points alone, not
/// on the order of the rows.
fn along_curve(points: &[Xy], frame: &Frame) -> Vec<(u64, [u64; 2], u32)> {
    let [lo, hi] = frame.bounds;
    // Grid cells of the bounding box; the cast saturates, so rounding at the
    // top edge stays on the grid, and takes NaN (0 / 0: no extent) to 0.
    let cell = |a: usize, v: f64| ((v - lo[a]) / (hi[a] - lo[a]) * 4_294_967_295.0) as u32;
    let mut along: Vec<(u64, [u64; 2], u32)> = points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let at = placed(*p, frame.scale);
            let bits = [at.x.to_bits(), at.y.to_bits()];
            // The cell of the place too (unscaled exactly), so points at one
            // place are in one cell.
            let cell = morton(cell(0, at.x / frame.scale), cell(1, at.y / frame.scale));
            (cell, bits, i as u32)
        })
        .collect();
    if along.len() > PARALLEL_POINTS {
        along.par_sort_unstable();
    } else {
        along.sort_unstable();
    }
    along
}

/// The insertion order of the points with `rep[i] == i`, as `(index, rank)`
/// pairs (`rank`: the place among them along the curve): biased randomized
/// insertion order (BRIO), each round in the curve's order.
///
/// A point's round comes from a hash of its coordinates: half of the points
/// in the last round, a quarter in the one before, and so on. The random
/// rounds keep each insertion's expected work constant whatever the shape
/// (spade's `bulk_load` slows to quadratic time on nearly collinear chains);
/// the curve keeps each insertion next to the one before, where its walk
/// starts.
fn insertion_order(points: &[Xy], along: &[(u64, [u64; 2], u32)], rep: &[u32]) -> Vec<(u32, u32)> {
    // From the input coordinates (-0 and 0 are one).
    let round = |p: Xy| {
        let bits = [(p[0] + 0.0).to_bits(), (p[1] + 0.0).to_bits()];
        64 - mix(bits[0] ^ mix(bits[1])).trailing_zeros() as usize
    };
    let kept = along.iter().filter(|e| rep[e.2 as usize] == e.2);
    let rounds = kept
        .enumerate()
        .map(|(rank, &(_, _, id))| (round(points[id as usize]), (id, rank as u32)));
    counting_sort(rounds, 65)
}

/// The values of `items`, `(bucket < k, value)` pairs, by bucket, ties in
/// their order (a counting sort).
pub fn counting_sort<T: Copy + Default>(
    items: impl Iterator<Item = (usize, T)> + Clone,
    k: usize,
) -> Vec<T> {
    let mut start = vec![0usize; k + 1];
    for (b, _) in items.clone() {
        start[b + 1] += 1;
    }
    for b in 0..k {
        start[b + 1] += start[b];
    }
    let mut order = vec![T::default(); start[k]];
    for (b, value) in items {
        order[start[b]] = value;
        start[b] += 1;
    }
    order
}

/// splitmix64's finaliser: every output bit depends on every input bit, so
/// coordinates with many zero bits (integers, rounded values) still spread
/// evenly over the rounds.
fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Above this many points, the insertion order is sorted on every thread.
const PARALLEL_POINTS: usize = 1 << 16;

/// The Delaunay triangulation of the points with `rep[i] == i` (no `rep`).
fn delaunay(points: &[Xy], along: &[(u64, [u64; 2], u32)], rep: &[u32], s: f64) -> Mesh {
    let order = insertion_order(points, along, rep);
    let n = order.len();
    if n < 3 {
        return Mesh::default();
    }
    let mut dt = DelaunayTriangulation::<Vertex>::with_capacity(n, 3 * n, 2 * n);
    let mut hint = None;
    for (i, (id, rank)) in order.into_iter().enumerate() {
        if i % 4096 == 0 && crate::stop::requested() {
            return Mesh::default(); // (Ctrl-C: the call is dropped)
        }
        let vertex = Vertex {
            pos: placed(points[id as usize], s),
            id,
            rank,
        };
        let inserted = match hint {
            Some(h) => dt.insert_with_hint(vertex, h),
            None => dt.insert(vertex),
        };
        let Ok(inserted) = inserted else {
            return Mesh::default();
        };
        hint = Some(inserted);
    }
    // Distinct places are distinct vertices (spade merges only equal ones).
    assert_eq!(dt.num_vertices(), n, "spade merged two distinct places");
    fill_arrays(&dt)
}

/// Each point's representative: the smallest index of its set.
fn reps(union: &mut Union) -> Vec<u32> {
    let n = union.parent.len();
    let root: Vec<u32> = (0..n as u32).map(|i| union.find(i)).collect();
    let mut smallest = vec![NONE; n];
    for (i, &r) in root.iter().enumerate().rev() {
        smallest[r as usize] = i as u32;
    }
    root.iter().map(|&r| smallest[r as usize]).collect()
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
    let s = frame.scale;
    let mut union = Union::new(points.len());
    let along = along_curve(points, frame);
    if crate::stop::requested() {
        return Mesh::default(); // (Ctrl-C: the call is dropped)
    }
    for w in along.windows(2).filter(|w| w[0].1 == w[1].1) {
        union.union(w[0].2, w[1].2);
    }
    let mut rep = reps(&mut union);
    let mut mesh = Mesh::default();
    if build {
        mesh = delaunay(points, &along, &rep, s);
        let mut merged = false;
        for (a, b) in close_pairs(points, &mesh, s * frame.tol, s) {
            merged |= union.union(a, b);
        }
        if merged && !crate::stop::requested() {
            rep = reps(&mut union);
            mesh = delaunay(points, &along, &rep, s);
        }
    }
    let n_distinct = rep.iter().zip(0..).filter(|&(&r, i)| r == i).count();
    Mesh {
        rep,
        n_distinct,
        ..mesh
    }
}

/// The mesh's edges shorter than `close` (scaled by `s`), each once.
fn close_pairs(points: &[Xy], mesh: &Mesh, close: f64, s: f64) -> Vec<(u32, u32)> {
    let close = close * close;
    let edges = |t: usize| {
        (0..3).filter_map(move |j| {
            let across = mesh.nb[t][j];
            let (a, b) = (mesh.tri[t][j], mesh.tri[t][(j + 1) % 3]);
            let (pa, pb) = (points[a as usize], points[b as usize]);
            let (dx, dy) = ((pa[0] - pb[0]) * s, (pa[1] - pb[1]) * s);
            let once = across == NONE || across > t as u32;
            (once && dx * dx + dy * dy < close).then_some((a, b))
        })
    };
    // Here and below: rayon's machinery costs more than a small group's work.
    if mesh.tri.len() > PARALLEL_POINTS {
        (0..mesh.tri.len())
            .into_par_iter()
            .flat_map_iter(edges)
            .collect()
    } else {
        (0..mesh.tri.len()).flat_map(edges).collect()
    }
}

/// The triangle and neighbour arrays, the triangles numbered along the curve
/// (the sweeps find neighbours close in memory): each listed by its vertex of
/// smallest rank, one walk around each vertex in rank order, on every thread.
fn fill_arrays(t: &DelaunayTriangulation<Vertex>) -> Mesh {
    let mut by_rank = vec![0u32; t.num_vertices()];
    for v in t.vertices() {
        by_rank[v.data().rank as usize] = v.fix().index() as u32;
    }
    let face = |f: FaceHandle<PossiblyOuterTag, Vertex, (), (), ()>| {
        f.as_inner().map_or(NONE, |f| f.fix().index() as u32)
    };
    let around = |&v: &u32| {
        let v = t.vertex(FixedVertexHandle::from_index(v as usize));
        let rank = v.data().rank;
        // Ctrl-C: no more triangles (the call is dropped).
        let stopped = crate::stop::requested();
        v.out_edges()
            .take_while(move |_| !stopped)
            .filter_map(move |e| {
                let f = face(e.face());
                let (next, prev) = (e.next(), e.prev());
                let lowest = next.from().data().rank > rank && prev.from().data().rank > rank;
                (f != NONE && lowest).then(|| {
                    let tri = [v.data().id, next.from().data().id, prev.from().data().id];
                    let nb = [e, next, prev].map(|d| face(d.rev().face()));
                    (f, (tri, nb))
                })
            })
    };
    let (faces, (tri, mut nb)): (Vec<u32>, (Vec<_>, Vec<_>)) =
        if by_rank.len() > PARALLEL_POINTS / 8 {
            by_rank.par_iter().flat_map_iter(around).unzip()
        } else {
            by_rank.iter().flat_map(around).unzip()
        };
    let mut place = vec![NONE; t.num_all_faces()];
    for (p, &f) in faces.iter().enumerate() {
        place[f as usize] = p as u32;
    }
    nb.par_iter_mut()
        .with_min_len(PARALLEL_POINTS)
        .for_each(|n| *n = n.map(|s| if s == NONE { NONE } else { place[s as usize] }));
    Mesh {
        tri,
        nb,
        ..Mesh::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The nearly collinear chain of issue #23: x every 1 cm, y = 0.3 x
    /// rounded to 3 decimals, and one point off the line.
    fn chain(n: usize) -> Vec<Xy> {
        let mut pts: Vec<Xy> = (0..n)
            .map(|i| {
                let x = i as f64 * 0.01;
                [x, (0.3 * x * 1000.0).round() / 1000.0]
            })
            .collect();
        let x = (n / 2) as f64 * 0.01;
        pts.push([x, 0.3 * x + 1.0]);
        pts
    }

    /// Checks a mesh against the definition, exactly: counter-clockwise
    /// triangles, neighbours that share the edge, every interior edge
    /// locally Delaunay (which makes the whole triangulation Delaunay), and
    /// `2n - h - 2` triangles for `n` points with `h` on the hull.
    fn assert_delaunay(pts: &[Xy], mesh: &Mesh) {
        use robust::{incircle, orient2d, Coord};
        let c = |v: u32| Coord {
            x: pts[v as usize][0],
            y: pts[v as usize][1],
        };
        let mut hull_edges = 0;
        for (t, tri) in mesh.tri.iter().enumerate() {
            assert!(orient2d(c(tri[0]), c(tri[1]), c(tri[2])) > 0.0);
            for j in 0..3 {
                let s = mesh.nb[t][j];
                if s == NONE {
                    hull_edges += 1;
                    continue;
                }
                let (a, b) = (tri[j], tri[(j + 1) % 3]);
                let other = mesh.tri[s as usize];
                assert!(other.contains(&a) && other.contains(&b));
                let d = *other.iter().find(|&&v| v != a && v != b).unwrap();
                assert!(incircle(c(tri[0]), c(tri[1]), c(tri[2]), c(d)) <= 0.0);
            }
        }
        assert_eq!(mesh.tri.len(), 2 * mesh.n_distinct - hull_edges - 2);
    }

    #[test]
    fn a_nearly_collinear_chain_is_triangulated_exactly() {
        let pts = chain(5_000);
        let mesh = triangulate(&pts, &Frame::of(&pts), true);
        assert_eq!(mesh.n_distinct, pts.len());
        assert_delaunay(&pts, &mesh);
    }

    #[test]
    fn the_order_of_the_rows_does_not_change_the_triangles() {
        let pts = chain(300);
        let mut reversed = pts.clone();
        reversed.reverse();
        let n = pts.len() as u32;
        let canonical = |mesh: &Mesh, flip: bool| {
            let mut tris: Vec<[u32; 3]> = mesh
                .tri
                .iter()
                .map(|t| {
                    let mut t = t.map(|v| if flip { n - 1 - v } else { v });
                    t.sort_unstable();
                    t
                })
                .collect();
            tris.sort_unstable();
            tris
        };
        let a = triangulate(&pts, &Frame::of(&pts), true);
        let b = triangulate(&reversed, &Frame::of(&reversed), true);
        assert_delaunay(&pts, &a);
        assert_eq!(canonical(&a, false), canonical(&b, true));
    }

    #[test]
    fn a_square_with_a_duplicate_has_two_triangles() {
        let pts = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0], [1.0, 1.0]];
        let mesh = triangulate(&pts, &Frame::of(&pts), true);
        assert_eq!(mesh.n_distinct, 4);
        assert_eq!(mesh.tri.len(), 2);
        assert_eq!(mesh.rep[4], 3);
    }

    #[test]
    fn a_group_above_the_parallel_size_is_triangulated_on_threads_exactly() {
        // More points than PARALLEL_POINTS: the curve sort, the close pairs
        // and the triangle arrays take their rayon branches.
        let mut state = 12345u64;
        let mut next = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut pts: Vec<Xy> = (0..PARALLEL_POINTS + 5_000)
            .map(|_| [next(), next()])
            .collect();
        let first = pts[0];
        pts.push([first[0] + 1e-13, first[1]]); // a near-duplicate of row 0
        let mesh = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap()
            .install(|| triangulate(&pts, &Frame::of(&pts), true));
        assert_eq!(mesh.n_distinct, pts.len() - 1);
        assert_eq!(mesh.rep[pts.len() - 1], 0);
        assert_delaunay(&pts, &mesh);
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
