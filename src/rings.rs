//! Boundary rings of a set of triangles, one polygon per edge-connected piece.
//!
//! A ring follows the boundary with its piece on the left (shells turn
//! counter-clockwise, holes clockwise). Where a piece touches itself or
//! another piece at a vertex, the next edge is found by turning around the
//! vertex through what lies outside the piece: so a hole that touches the
//! shell at a vertex stays a ring of its own, and two pieces that touch are
//! two polygons. Every ring is then simple, and each piece has one shell,
//! which is the valid OGC form GEOS expects.

use std::cmp::Ordering;

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

/// Take merged near-duplicates into the rings as vertices: each point `m`
/// whose representative `r = rep[m]` is a ring vertex, and that lies outside
/// the shape around `r` (decided exactly: the ring edges at `r` cut the turn
/// around it into sectors, inside and outside in turn, where rings touch at
/// `r` too), is inserted into the edge at `r` that bounds its sector, when
/// it is to the right of that edge's line, the points of one edge in
/// counter-clockwise order around their representative (each edge gains
/// simple fans from its ends, outside the shape near them). So a merged
/// point is a vertex of the polygon, in the output coordinates too (the
/// rings are indices of input points).
/// The others (inside the turn, or not on a ring) are left to the check
/// where the polygons are returned. Time: linear in the points and ring
/// vertices, plus sorting the inserted points; exact duplicates of their
/// representative (the same coordinates) are never inserted. Returns how
/// many points were inserted.
pub fn take_in(points: &[Xy], rep: &[u32], polygons: &mut Polygons) -> usize {
    let moved = |m: usize| rep[m] as usize != m && points[m] != points[rep[m] as usize];
    let mut wanted = vec![false; rep.len()];
    for m in (0..rep.len()).filter(|&m| moved(m)) {
        wanted[rep[m] as usize] = true;
    }
    if !wanted.iter().any(|&w| w) {
        return 0;
    }
    // Every place of a wanted vertex: (vertex, polygon, ring, position).
    let mut places: Vec<[u32; 4]> = Vec::new();
    for (pi, poly) in polygons.iter().enumerate() {
        for (ri, ring) in poly.iter().enumerate() {
            for (k, &v) in ring[..ring.len() - 1].iter().enumerate() {
                if wanted[v as usize] {
                    places.push([v, pi as u32, ri as u32, k as u32]);
                }
            }
        }
    }
    places.sort_unstable();
    // The corners of a place: the vertex before, the vertex, the one after.
    let corners = |&[_, pi, ri, k]: &[u32; 4]| {
        let ring = &polygons[pi as usize][ri as usize];
        let len = ring.len() - 1;
        let k = k as usize;
        let before = (k + len - 1) % len;
        let at = |i: usize| points[ring[i] as usize];
        (at(before), at(k), at((k + 1) % len), before, k)
    };
    // Insertions: (polygon, ring, edge, side, point, representative); side 0:
    // after the edge's first vertex (its representative), 1: before its last.
    let mut inserts: Vec<(u32, u32, u32, u8, u32, u32)> = Vec::new();
    let mut rays: Vec<(Xy, usize, bool)> = Vec::new();
    for m in (0..rep.len()).filter(|&m| moved(m)) {
        let v = rep[m];
        let lo = places.partition_point(|p| p[0] < v);
        let hi = places.partition_point(|p| p[0] <= v);
        if lo == hi {
            continue; // not a ring vertex
        }
        let (x, r) = (points[m], points[v as usize]);
        // The rays from r along its ring edges, in clockwise order from x:
        // the sectors between them alternate inside and outside the shape
        // (a ring's piece is on its left: inside from the ray out of r
        // counter-clockwise to the ray into r).
        rays.clear();
        for (i, place) in places[lo..hi].iter().enumerate() {
            let (p, _, q, _, _) = corners(place);
            rays.extend([(p, i, true), (q, i, false)]);
        }
        rays.sort_by(|a, b| clockwise_from(r, x, a.0, b.0));
        let (first, last) = (rays[0], rays[rays.len() - 1]);
        // Outside: the ray just clockwise of x leads into r.
        if !first.2 {
            continue;
        }
        let (p, q) = (first.0, last.0);
        let (place, edge, side) = if orient(p, r, x) < 0.0 {
            let place = &places[lo + first.1];
            (place, corners(place).3, 1) // into r, from the ray's end
        } else if !last.2 && orient(r, q, x) < 0.0 {
            let place = &places[lo + last.1];
            (place, corners(place).4, 0) // out of r
        } else {
            continue;
        };
        inserts.push((place[1], place[2], edge as u32, side, m as u32, v));
    }
    // Along an edge: the points after its first vertex, then those before its
    // last, each in counter-clockwise order around their representative (all
    // are within half a turn of it, to the right of the edge's line), so the
    // ring gains fans from the representative: p, m1 .. mk, r with the mi
    // turning counter-clockwise around r is a simple, counter-clockwise fan,
    // outside the shape near r. On one ray: towards the representative last
    // (before it) or first (after it).
    let dist = |m: u32, v: u32| {
        let (a, b) = (points[m as usize], points[v as usize]);
        (a[0] - b[0]).hypot(a[1] - b[1])
    };
    inserts.sort_unstable_by(|u, w| {
        (u.0, u.1, u.2, u.3)
            .cmp(&(w.0, w.1, w.2, w.3))
            .then_with(|| {
                let (r, a, b) = (
                    points[u.5 as usize],
                    points[u.4 as usize],
                    points[w.4 as usize],
                );
                let turn = 0.0.partial_cmp(&orient(r, a, b)).unwrap_or(Ordering::Equal);
                let along = dist(u.4, u.5).total_cmp(&dist(w.4, w.5));
                let along = if u.3 == 1 { along.reverse() } else { along };
                turn.then(along).then(u.4.cmp(&w.4))
            })
    });
    let mut i = 0;
    while i < inserts.len() {
        let (pi, ri) = (inserts[i].0, inserts[i].1);
        let old = std::mem::take(&mut polygons[pi as usize][ri as usize]);
        let mut ring = Vec::with_capacity(old.len() + inserts.len() - i);
        for (edge, &v) in old[..old.len() - 1].iter().enumerate() {
            ring.push(v);
            while let Some(&(_, _, _, _, m, _)) = inserts
                .get(i)
                .filter(|s| (s.0, s.1, s.2 as usize) == (pi, ri, edge))
            {
                ring.push(m);
                i += 1;
            }
        }
        ring.push(ring[0]);
        polygons[pi as usize][ri as usize] = ring;
    }
    inserts.len()
}

/// The order of the directions from `r` to `a` and to `b` by their
/// clockwise angle from the direction to `x` (exactly; the direction of `x`
/// itself first, the opposite one at half a turn).
fn clockwise_from(r: Xy, x: Xy, a: Xy, b: Xy) -> std::cmp::Ordering {
    let half = |v: Xy| {
        let o = orient(r, x, v);
        let ahead = (v[0] - r[0]) * (x[0] - r[0]) + (v[1] - r[1]) * (x[1] - r[1]) > 0.0;
        u8::from(o > 0.0 || (o == 0.0 && !ahead))
    };
    half(a)
        .cmp(&half(b))
        .then_with(|| orient(r, a, b).partial_cmp(&0.0).unwrap_or(Ordering::Equal))
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
    fn merged_points_outside_are_taken_in_along_their_edges() {
        // The ring (0, 0), (4, 0), (2, 1), (0, 4): (2, 1) is a reflex vertex
        // with two merged points beyond it (right of both its edges), one
        // merged point inside the turn (left alone), one exact duplicate.
        let points = [
            [0.0, 0.0],
            [4.0, 0.0],
            [2.0, 1.0],
            [0.0, 4.0],
            [2.2, 1.0],
            [2.1, 1.0],
            [1.9, 0.9],
            [2.0, 1.0],
        ];
        let rep = [0, 1, 2, 3, 2, 2, 2, 2];
        let mut polys: Polygons = vec![vec![vec![0, 1, 2, 3, 0]]];
        assert_eq!(take_in(&points, &rep, &mut polys), 2);
        // Along the edge (4, 0) -> (2, 1): the farther from (4, 0) later.
        assert_eq!(polys, vec![vec![vec![0, 1, 4, 5, 2, 3, 0]]]);
        let mut none: Polygons = vec![vec![vec![0, 1, 2, 3, 0]]];
        assert_eq!(take_in(&points, &[0, 1, 2, 3, 4, 5, 6, 2], &mut none), 0);
    }

    #[test]
    fn a_merged_point_where_a_hole_touches_the_shell_is_taken_in() {
        // The shell (0, 0), (4, 0), (2, 2), (4, 4), (0, 4) and a hole that
        // touches it at (2, 2): (2.5, 2) is outside (in the notch: into the
        // shell's edge into (2, 2)), (1.5, 2) inside the piece (left alone),
        // (2, 1.7) in the hole (into the hole ring's edge into (2, 2)).
        let points = [
            [0.0, 0.0],
            [4.0, 0.0],
            [2.0, 2.0],
            [4.0, 4.0],
            [0.0, 4.0],
            [1.0, 1.0],
            [2.5, 1.0],
            [2.5, 2.0],
            [1.5, 2.0],
            [2.0, 1.7],
        ];
        let rep = [0, 1, 2, 3, 4, 5, 6, 2, 2, 2];
        // The hole (clockwise, the piece on its left): (2, 2), (2.5, 1), (1, 1).
        let mut polys: Polygons = vec![vec![vec![0, 1, 2, 3, 4, 0], vec![2, 6, 5, 2]]];
        assert_eq!(take_in(&points, &rep, &mut polys), 2);
        assert_eq!(polys[0][0], vec![0, 1, 7, 2, 3, 4, 0]);
        assert_eq!(polys[0][1], vec![2, 6, 5, 9, 2]);
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
