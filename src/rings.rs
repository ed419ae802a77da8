//! Boundary rings of a set of triangles, one polygon per edge-connected piece.
//!
//! A ring follows the boundary with its piece on the left (shells turn
//! counter-clockwise, holes clockwise). Where a piece touches itself or
//! another piece at a vertex, the next edge is found by turning around the
//! vertex through what lies outside the piece: so a hole that touches the
//! shell at a vertex stays a ring of its own, and two pieces that touch are
//! two polygons. Every ring is then simple, and each piece has one shell,
//! which is the valid OGC form GEOS expects.

use crate::frame::{orient, Xy};
use crate::mesh::{Mesh, NONE};

/// One polygon per piece: its shell first, then its holes; each ring a list
/// of point indices, closed (the first index repeated at the end).
pub type Polygons = Vec<Vec<Vec<u32>>>;

fn corner(t: &[u32; 3], v: u32) -> usize {
    t.iter().position(|&x| x == v).unwrap_or(2)
}

/// The boundary edge that follows edge `j` of triangle `t` (which ends at
/// `v = tri[t][j + 1]`): turn counter-clockwise around `v` from the edge,
/// through triangles outside the piece and across the outside of the convex
/// hull, to the first triangle of the piece; its edge leaving `v` is next.
fn next_edge(mesh: &Mesh, label: &[u32], t: usize, j: usize) -> Option<(usize, usize)> {
    let (tri, nb) = (&mesh.tri, &mesh.nb);
    let piece = label[t];
    let v = tri[t][(j + 1) % 3];
    let inside = |s: usize| label[s] == piece;
    let mut cur = nb[t][j];
    // Each step passes one triangle around v; around v there are at most
    // all of them, and the hull is crossed at most once.
    for _ in 0..=tri.len() + 1 {
        if cur == NONE {
            // Across the outside of the hull: to the clockwise end of v's fan.
            let mut x = t;
            for steps in 0.. {
                let cw = nb[x][corner(&tri[x], v)];
                if cw == NONE {
                    break;
                }
                if steps == tri.len() {
                    return None;
                }
                x = cw as usize;
            }
            if inside(x) {
                return Some((x, corner(&tri[x], v)));
            }
            cur = x as u32;
            continue;
        }
        let c = cur as usize;
        if inside(c) {
            return Some((c, corner(&tri[c], v)));
        }
        let k = corner(&tri[c], v);
        cur = nb[c][(k + 2) % 3];
    }
    None
}

/// Trace the rings of the pieces (`label[t]` in `0..n_pieces`, or [`NONE`]
/// outside the shape), oriented exactly in `points`. `None` when a walk does
/// not end or a piece has not exactly one counter-clockwise ring (never
/// expected; reported rather than trusted).
pub fn trace(points: &[Xy], mesh: &Mesh, label: &[u32], n_pieces: usize) -> Option<Polygons> {
    let (tri, nb) = (&mesh.tri, &mesh.nb);
    let m = tri.len();
    let boundary = |t: usize, j: usize| {
        let s = nb[t][j];
        s == NONE || label[s as usize] != label[t]
    };
    let mut used = vec![false; 3 * m];
    let mut polygons: Polygons = vec![Vec::new(); n_pieces];
    let mut holes: Vec<Vec<Vec<u32>>> = vec![Vec::new(); n_pieces];
    for t0 in 0..m {
        if label[t0] == NONE {
            continue;
        }
        for j0 in 0..3 {
            if used[3 * t0 + j0] || !boundary(t0, j0) {
                continue;
            }
            let mut ring = Vec::new();
            let (mut t, mut j) = (t0, j0);
            loop {
                if ring.len() > 3 * m {
                    return None;
                }
                used[3 * t + j] = true;
                ring.push(tri[t][j]);
                (t, j) = next_edge(mesh, label, t, j)?;
                if (t, j) == (t0, j0) {
                    break;
                }
            }
            ring.push(ring[0]);
            let p = label[t0] as usize;
            if counter_clockwise(points, &ring) {
                if !polygons[p].is_empty() {
                    return None;
                }
                polygons[p].push(ring);
            } else {
                holes[p].push(ring);
            }
        }
    }
    for (poly, h) in polygons.iter_mut().zip(holes) {
        if poly.is_empty() {
            return None;
        }
        poly.extend(h);
    }
    Some(polygons)
}

/// Orientation of a simple closed ring, exactly: the turn at its
/// lexicographically smallest vertex.
fn counter_clockwise(points: &[Xy], ring: &[u32]) -> bool {
    let n = ring.len() - 1;
    let at = |i: usize| points[ring[i] as usize];
    let low = (0..n)
        .min_by(|&a, &b| {
            let (p, q) = (at(a), at(b));
            p[0].total_cmp(&q[0]).then(p[1].total_cmp(&q[1]))
        })
        .unwrap_or(0);
    orient(at((low + n - 1) % n), at(low), at((low + 1) % n)) > 0.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::Frame;
    use crate::mesh::triangulate;
    use crate::spectrum::pieces;

    fn rings_of(points: &[Xy], keep: impl Fn(&[Xy; 3]) -> bool) -> Polygons {
        let mesh = triangulate(points, &Frame::of(points), true);
        let inside = |t: usize| keep(&mesh.tri[t].map(|v| points[v as usize]));
        let (label, n) = pieces(inside, &mesh.nb);
        trace(points, &mesh, &label, n).unwrap()
    }

    #[test]
    fn a_square_is_one_ring_of_four_corners() {
        let pts = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        let polys = rings_of(&pts, |_| true);
        assert_eq!(polys.len(), 1);
        assert_eq!(polys[0].len(), 1);
        assert_eq!(polys[0][0].len(), 5);
    }

    #[test]
    fn an_annulus_has_a_shell_and_a_hole() {
        // An outer and an inner square; drop the triangles inside the inner.
        let pts = [
            [0.0, 0.0],
            [4.0, 0.0],
            [4.0, 4.0],
            [0.0, 4.0],
            [1.0, 1.2],
            [3.0, 1.0],
            [2.9, 3.0],
            [1.1, 2.9],
        ];
        let inner = |p: &Xy| p[0] > 0.5 && p[0] < 3.5 && p[1] > 0.5 && p[1] < 3.5;
        let polys = rings_of(&pts, |t| !t.iter().all(inner));
        assert_eq!(polys.len(), 1);
        assert_eq!(polys[0].len(), 2);
    }
}
