//! The kernel against a brute force written from DESIGN.md alone.
//!
//! The brute force shares nothing with the kernel but the float points: its
//! Delaunay triangles are the triples whose circumcircle holds no other point
//! (tested in exact rational-free form with the `robust` crate's incircle,
//! which is an exact sign), its radii come from the circumcentre, and every
//! spectrum value is tried in increasing order with the shape checked by its
//! definition (coverage, edge-connected pieces by pairwise edge sharing).

use _kernel::group::{solve, Options};
use _kernel::spectrum::MAX_UNION_NODES;
use proptest::prelude::*;
use robust::{incircle, orient2d, orient3d, Coord, Coord3D};

type Xy = [f64; 2];

fn coord(p: Xy) -> Coord<f64> {
    Coord { x: p[0], y: p[1] }
}

/// Delaunay triangles by definition: counter-clockwise triples with no point
/// strictly inside their circumcircle (points in general position).
fn brute_delaunay(p: &[Xy]) -> Vec<[usize; 3]> {
    let n = p.len();
    let mut out = Vec::new();
    for a in 0..n {
        for b in 0..n {
            for c in 0..n {
                if a >= b || a >= c || b == c {
                    continue;
                }
                if orient2d(coord(p[a]), coord(p[b]), coord(p[c])) <= 0.0 {
                    continue;
                }
                let empty = (0..n).all(|d| {
                    d == a
                        || d == b
                        || d == c
                        || incircle(coord(p[a]), coord(p[b]), coord(p[c]), coord(p[d])) <= 0.0
                });
                if empty {
                    out.push([a, b, c]);
                }
            }
        }
    }
    out
}

fn circumcentre_radius(a: Xy, b: Xy, c: Xy) -> f64 {
    let (bx, by) = (b[0] - a[0], b[1] - a[1]);
    let (cx, cy) = (c[0] - a[0], c[1] - a[1]);
    let d = 2.0 * (bx * cy - by * cx);
    let ux = (cy * (bx * bx + by * by) - by * (cx * cx + cy * cy)) / d;
    let uy = (bx * (cx * cx + cy * cy) - cx * (bx * bx + by * by)) / d;
    ux.hypot(uy)
}

fn shares_edge(s: &[usize; 3], t: &[usize; 3]) -> bool {
    s.iter().filter(|v| t.contains(v)).count() == 2
}

fn on_hull(tris: &[[usize; 3]], t: usize) -> bool {
    // A triangle is on the hull when one of its edges is in no other triangle.
    let e = tris[t];
    (0..3).any(|k| {
        let (u, v) = (e[k], e[(k + 1) % 3]);
        !tris
            .iter()
            .enumerate()
            .any(|(s, o)| s != t && o.contains(&u) && o.contains(&v))
    })
}

/// The shape at threshold `r`: solid triangles, plus (holes filled) every
/// non-solid triangle not reachable from the outside through non-solid ones.
fn shape(tris: &[[usize; 3]], radius: &[f64], r: f64, holes: bool) -> Vec<bool> {
    let solid: Vec<bool> = radius.iter().map(|&x| x <= r).collect();
    if holes {
        return solid;
    }
    let m = tris.len();
    let mut reach = vec![false; m];
    let mut stack: Vec<usize> = (0..m).filter(|&t| !solid[t] && on_hull(tris, t)).collect();
    for &t in &stack {
        reach[t] = true;
    }
    while let Some(t) = stack.pop() {
        for s in 0..m {
            if !solid[s] && !reach[s] && shares_edge(&tris[t], &tris[s]) {
                reach[s] = true;
                stack.push(s);
            }
        }
    }
    reach.iter().map(|&x| !x).collect()
}

/// Vertex sets of the edge-connected pieces of the triangles in `inside`.
fn piece_sets(tris: &[[usize; 3]], inside: &[bool]) -> Vec<Vec<usize>> {
    let m = tris.len();
    let mut label = vec![usize::MAX; m];
    let mut sets = Vec::new();
    for t0 in 0..m {
        if !inside[t0] || label[t0] != usize::MAX {
            continue;
        }
        let k = sets.len();
        let mut verts = Vec::new();
        let mut stack = vec![t0];
        label[t0] = k;
        while let Some(t) = stack.pop() {
            verts.extend_from_slice(&tris[t]);
            for s in 0..m {
                if inside[s] && label[s] == usize::MAX && shares_edge(&tris[t], &tris[s]) {
                    label[s] = k;
                    stack.push(s);
                }
            }
        }
        verts.sort_unstable();
        verts.dedup();
        sets.push(verts);
    }
    sets
}

/// Most rows a union of at most `c` of the sets holds (every choice tried).
fn best_union(sets: &[Vec<usize>], c: usize, rows: &[u64]) -> u64 {
    let k = sets.len();
    let mut best = 0;
    for mask in 0u32..(1 << k) {
        if mask.count_ones() as usize > c {
            continue;
        }
        let mut held = vec![false; rows.len()];
        for (i, s) in sets.iter().enumerate() {
            if mask >> i & 1 == 1 {
                for &v in s {
                    held[v] = true;
                }
            }
        }
        let total = held
            .iter()
            .zip(rows)
            .filter(|(h, _)| **h)
            .map(|(_, r)| r)
            .sum();
        best = best.max(total);
    }
    best
}

/// The distinct spectrum values, ascending (the kernel merges values within
/// 1e-10; the generated points keep them far apart, see `spread`).
fn spectrum(radius: &[f64]) -> Vec<f64> {
    let mut v = radius.to_vec();
    v.sort_by(f64::total_cmp);
    v.dedup();
    v
}

/// The brute-force optimum: the first spectrum value at which `c` pieces
/// hold at least `rows - k` rows (k = 0: every point, at most `c` pieces).
fn brute_optimum(p: &[Xy], rows: &[u64], holes: bool, c: usize, k: u64) -> (f64, u64) {
    let tris = brute_delaunay(p);
    let radius: Vec<f64> = tris
        .iter()
        .map(|t| circumcentre_radius(p[t[0]], p[t[1]], p[t[2]]))
        .collect();
    optimum_of(p.len(), &tris, &radius, rows, holes, c, k)
}

/// The brute-force optimum over a given triangulation of `n` points.
fn optimum_of(
    n: usize,
    tris: &[[usize; 3]],
    radius: &[f64],
    rows: &[u64],
    holes: bool,
    c: usize,
    k: u64,
) -> (f64, u64) {
    let total: u64 = rows.iter().sum();
    for r in spectrum(radius) {
        let inside = shape(tris, radius, r, holes);
        let sets = piece_sets(tris, &inside);
        let held = if k == 0 {
            let all: usize = {
                let mut v: Vec<usize> = sets.iter().flatten().copied().collect();
                v.sort_unstable();
                v.dedup();
                v.len()
            };
            if all == n && sets.len() <= c {
                total
            } else {
                0
            }
        } else {
            best_union(&sets, c, rows)
        };
        if held + k >= total {
            return (1.0 / r, total - held);
        }
    }
    unreachable!("the convex hull is always valid")
}

/// Points whose pairwise distances and radii are well separated: random
/// floats, rejected when two points are closer than 1e-3 of the extent or
/// three nearly collinear (the kernel's tolerances then decide, not the
/// definition this brute force implements).
fn spread(p: &[Xy]) -> bool {
    let n = p.len();
    for a in 0..n {
        for b in a + 1..n {
            if (p[a][0] - p[b][0]).hypot(p[a][1] - p[b][1]) < 0.1 {
                return false;
            }
            for c in b + 1..n {
                if orient2d(coord(p[a]), coord(p[b]), coord(p[c])).abs() < 0.5 {
                    return false;
                }
            }
        }
    }
    true
}

type V3 = [f64; 3];

fn unit(p: Xy) -> V3 {
    let (lon, lat) = (p[0].to_radians(), p[1].to_radians());
    [lat.cos() * lon.cos(), lat.cos() * lon.sin(), lat.sin()]
}

fn c3(p: V3) -> Coord3D<f64> {
    Coord3D {
        x: p[0],
        y: p[1],
        z: p[2],
    }
}

/// Spherical Delaunay triangles by definition: triples counter-clockwise seen
/// from outside (origin below their plane) with no point beyond their plane.
fn brute_sphere_delaunay(u: &[V3]) -> Vec<[usize; 3]> {
    let n = u.len();
    let o = c3([0.0; 3]);
    let mut out = Vec::new();
    for a in 0..n {
        for b in 0..n {
            for c in 0..n {
                if a >= b || a >= c || b == c {
                    continue;
                }
                if orient3d(c3(u[a]), c3(u[b]), c3(u[c]), o) <= 0.0 {
                    continue;
                }
                let empty = (0..n).all(|d| {
                    d == a
                        || d == b
                        || d == c
                        || orient3d(c3(u[a]), c3(u[b]), c3(u[c]), c3(u[d])) >= 0.0
                });
                if empty {
                    out.push([a, b, c]);
                }
            }
        }
    }
    out
}

/// Geodesic radius (metres) of the small circle through three unit vectors:
/// the angle between their plane's normal and a vertex, on the authalic sphere.
fn cap_radius(a: V3, b: V3, c: V3) -> f64 {
    let sub = |p: V3, q: V3| [p[0] - q[0], p[1] - q[1], p[2] - q[2]];
    let cross = |p: V3, q: V3| {
        [
            p[1] * q[2] - p[2] * q[1],
            p[2] * q[0] - p[0] * q[2],
            p[0] * q[1] - p[1] * q[0],
        ]
    };
    let n = cross(sub(b, a), sub(c, a));
    let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    let n = [n[0] / len, n[1] / len, n[2] / len];
    let m = cross(n, a);
    let sin = (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
    let cos = (n[0] * a[0] + n[1] * a[1] + n[2] * a[2]).abs();
    6_371_007.2 * sin.atan2(cos)
}

/// Lon/lat points within `d` degrees of a centre, well separated on the
/// sphere (no two within 1e-3 of the spread, no three near one great circle).
fn sphere_points() -> impl Strategy<Value = Vec<Xy>> {
    (-180.0f64..180.0, -60.0f64..60.0, 0.01f64..30.0)
        .prop_flat_map(|(lon0, lat0, d)| {
            prop::collection::vec(
                (-1.0f64..1.0, -1.0f64..1.0).prop_map(move |(x, y)| [lon0 + d * x, lat0 + d * y]),
                3..9,
            )
            .prop_map(move |p| (p, d))
        })
        .prop_filter("well separated", |(p, d)| {
            let u: Vec<V3> = p.iter().map(|&q| unit(q)).collect();
            let scale = d.to_radians();
            let n = u.len();
            (0..n).all(|a| {
                (a + 1..n).all(|b| {
                    let dist = ((u[a][0] - u[b][0]).powi(2)
                        + (u[a][1] - u[b][1]).powi(2)
                        + (u[a][2] - u[b][2]).powi(2))
                    .sqrt();
                    dist > 0.05 * scale
                        && (b + 1..n).all(|c| {
                            orient3d(c3(u[a]), c3(u[b]), c3(u[c]), c3([0.0; 3])).abs()
                                > 0.005 * scale * scale
                        })
                })
            })
        })
        .prop_map(|(p, _)| p)
}

fn points() -> impl Strategy<Value = Vec<Xy>> {
    prop::collection::vec(
        (0.0f64..100.0, 0.0f64..100.0).prop_map(|(x, y)| [x, y]),
        3..9,
    )
    .prop_filter("well separated", |p| spread(p))
}

/// Whether `q` is in the closed region of a ring (exact: on an edge, or a
/// nonzero winding number, both by `orient2d`).
fn in_ring(points: &[Xy], ring: &[u32], q: Xy) -> bool {
    let mut winding = 0i32;
    for w in ring.windows(2) {
        let (a, b) = (points[w[0] as usize], points[w[1] as usize]);
        let o = orient2d(coord(a), coord(b), coord(q));
        let within = |k: usize| a[k].min(b[k]) <= q[k] && q[k] <= a[k].max(b[k]);
        if o == 0.0 && within(0) && within(1) {
            return true;
        }
        if a[1] <= q[1] && b[1] > q[1] && o > 0.0 {
            winding += 1;
        } else if a[1] > q[1] && b[1] <= q[1] && o < 0.0 {
            winding -= 1;
        }
    }
    winding != 0
}

/// Whether `q` is covered by one of the polygons (shell, then holes).
fn covered(points: &[Xy], polygons: &[Vec<Vec<u32>>], q: Xy) -> bool {
    polygons.iter().any(|poly| {
        let on_hole_edge = poly[1..].iter().any(|h| {
            h.windows(2).any(|w| {
                let (a, b) = (points[w[0] as usize], points[w[1] as usize]);
                let within = |k: usize| a[k].min(b[k]) <= q[k] && q[k] <= a[k].max(b[k]);
                orient2d(coord(a), coord(b), coord(q)) == 0.0 && within(0) && within(1)
            })
        });
        in_ring(points, &poly[0], q)
            && (on_hole_edge || !poly[1..].iter().any(|h| in_ring(points, h, q)))
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn the_optimum_is_the_brute_force_one(p in points(), holes in any::<bool>(), c in 1usize..4) {
        let options = Options { holes, components: c, curve: false, max_union_nodes: MAX_UNION_NODES, sphere: false, ..Options::DEFAULT };
        let res = solve(&p, None, None, 0, &options);
        prop_assert_eq!(res.reason, 0);
        let rows = vec![1u64; p.len()];
        let (alpha, _) = brute_optimum(&p, &rows, holes, c, 0);
        prop_assert!((res.alpha - alpha).abs() <= 1e-9 * alpha, "{} vs {}", res.alpha, alpha);
        prop_assert!(res.polygons.len() <= c && !res.polygons.is_empty());
        // Every ring is closed and made of input points.
        for ring in res.polygons.iter().flatten() {
            prop_assert_eq!(ring.first(), ring.last());
            prop_assert!(ring.len() >= 4);
        }
    }

    #[test]
    fn the_outlier_optimum_is_the_brute_force_one(
        p in points(),
        holes in any::<bool>(),
        c in 1usize..3,
        dup in prop::collection::vec(0usize..8, 0..4),
        k in 1u64..4,
    ) {
        // Repeat some points (rows at one location) and leave out up to k rows.
        let mut all = p.clone();
        for &i in &dup {
            all.push(p[i % p.len()]);
        }
        let mut rows = vec![1u64; p.len()];
        for &i in &dup {
            rows[i % p.len()] += 1;
        }
        let options = Options { holes, components: c, curve: false, max_union_nodes: MAX_UNION_NODES, sphere: false, ..Options::DEFAULT };
        let res = solve(&all, None, None, k, &options);
        let (alpha, left) = brute_optimum(&p, &rows, holes, c, k);
        prop_assert!((res.alpha - alpha).abs() <= 1e-9 * alpha, "{} vs {}", res.alpha, alpha);
        prop_assert_eq!(res.n_outliers, left);
        prop_assert!(res.n_outliers <= k);
        prop_assert_eq!(res.left_out.iter().filter(|&&x| x).count() as u64, left);
    }

    #[test]
    fn the_alternatives_and_location_budgets_are_the_brute_force_optima(
        p in points(),
        holes in any::<bool>(),
        c in 1usize..3,
        dup in prop::collection::vec(0usize..8, 0..5),
        locations in any::<bool>(),
        k in 1u64..4,
    ) {
        // Some points hold several rows: the two units differ.
        let mut all = p.clone();
        let mut rows = vec![1u64; p.len()];
        for &i in &dup {
            all.push(p[i % p.len()]);
            rows[i % p.len()] += 1;
        }
        let ones = vec![1u64; p.len()];
        let unit = if locations { &ones } else { &rows };
        let options = Options {
            holes,
            components: c,
            explain: true,
            max_left_out: 3,
            left_out_locations: locations,
            ..Options::DEFAULT
        };
        let res = solve(&all, None, None, 0, &options);
        let total: u64 = unit.iter().sum();
        prop_assert_eq!(res.alternatives.len() as u64, 3.min(total - 3));
        for a in &res.alternatives {
            let (alpha, _) = brute_optimum(&p, unit, holes, c, u64::from(a.k));
            prop_assert!((1.0 / a.radius - alpha).abs() <= 1e-9 * alpha, "k {}: {} vs {}", a.k, 1.0 / a.radius, alpha);
            // What it leaves out weighs at most k in the unit.
            let mut gone: Vec<usize> = a.left_out.iter().map(|&i| res.rep[i as usize] as usize).collect();
            gone.sort_unstable();
            if locations { gone.dedup(); }
            prop_assert!(gone.len() as u64 <= u64::from(a.k));
        }
        // The critical triangle's circumradius is the radius.
        let t = res.critical.expect("a critical triangle");
        let r = circumcentre_radius(all[t[0] as usize], all[t[1] as usize], all[t[2] as usize]);
        prop_assert!((r / res.radius - 1.0).abs() <= 1e-12, "{} vs {}", r, res.radius);
        // outliers= counted in locations.
        let by_place = Options { holes, components: c, locations: true, ..Options::DEFAULT };
        let res = solve(&all, None, None, k, &by_place);
        let (alpha, _) = brute_optimum(&p, &ones, holes, c, k);
        prop_assert!((res.alpha - alpha).abs() <= 1e-9 * alpha, "{} vs {}", res.alpha, alpha);
        let left = res.left_out.iter().zip(&res.rep).filter(|(&x, _)| x).map(|(_, &r)| r);
        let mut places: Vec<u32> = left.collect();
        places.sort_unstable();
        places.dedup();
        prop_assert!(places.len() as u64 <= k);
    }

    #[test]
    fn the_shape_at_the_optimal_alpha_is_the_optimal_shape(p in points(), holes in any::<bool>()) {
        let options = Options { holes, components: 1, curve: false, max_union_nodes: MAX_UNION_NODES, sphere: false, ..Options::DEFAULT };
        let best = solve(&p, None, None, 0, &options);
        let again = solve(&p, None, Some(best.alpha), 0, &options);
        prop_assert_eq!(best.area, again.area);
        prop_assert_eq!(best.polygons, again.polygons);
    }

    #[test]
    fn the_sphere_optimum_is_the_brute_force_one(p in sphere_points(), holes in any::<bool>(), c in 1usize..4) {
        let options = Options { holes, components: c, curve: false, max_union_nodes: MAX_UNION_NODES, sphere: true, ..Options::DEFAULT };
        let res = solve(&p, None, None, 0, &options);
        prop_assert_eq!(res.reason, 0);
        let u: Vec<V3> = p.iter().map(|&q| unit(q)).collect();
        let tris = brute_sphere_delaunay(&u);
        let radius: Vec<f64> = tris.iter().map(|t| cap_radius(u[t[0]], u[t[1]], u[t[2]])).collect();
        let rows = vec![1u64; p.len()];
        let (alpha, _) = optimum_of(p.len(), &tris, &radius, &rows, holes, c, 0);
        prop_assert!((res.alpha - alpha).abs() <= 1e-7 * alpha, "{} vs {}", res.alpha, alpha);
        // alpha = 0: every spherical Delaunay triangle, the spherical hull.
        let hull = solve(&p, None, Some(0.0), 0, &options);
        prop_assert_eq!(hull.polygons.len(), 1);
    }

    #[test]
    fn merged_near_duplicates_are_covered_by_the_kernel_polygon(
        p in points(),
        holes in any::<bool>(),
        copies in prop::collection::vec((0usize..8, -4i32..5, -4i32..5), 1..12),
    ) {
        // Copies of some points moved by up to 5.7e-8 (merged when the
        // extent is above 57, the tolerance being 1e-9 of it): the kernel's
        // polygon covers every one of them exactly, in the input coordinates
        // (issue #37), and the optimal alpha fed back gives the same polygons.
        // (the comment's premise: an extent of at least 60, so that every copy
        // is merged; a copy just beyond the tolerance is a point of its own,
        // which the Python guarantee covers, `docs/user_guide/guarantee.md`)
        let span = |k: usize| {
            let (lo, hi) = p.iter().fold((f64::MAX, f64::MIN), |(l, h), q| (l.min(q[k]), h.max(q[k])));
            hi - lo
        };
        prop_assume!(span(0).max(span(1)) >= 60.0);
        let mut all = p.clone();
        for &(i, dx, dy) in &copies {
            let q = p[i % p.len()];
            all.push([q[0] + f64::from(dx) * 1e-8, q[1] + f64::from(dy) * 1e-8]);
        }
        let options = Options { holes, components: 1, curve: false, max_union_nodes: MAX_UNION_NODES, sphere: false, ..Options::DEFAULT };
        let best = solve(&all, None, None, 0, &options);
        prop_assert_eq!(best.reason, 0);
        for (i, &q) in all.iter().enumerate() {
            prop_assert!(covered(&all, &best.polygons, q), "point {} {:?} outside {:?}", i, q, best.polygons);
        }
        let again = solve(&all, None, Some(best.alpha), 0, &options);
        prop_assert_eq!(best.polygons, again.polygons);
    }
}

/// A tiny magnitude: 0, or `m * 2^-e` with `e` from spade's smallest
/// (2^-142) down into the subnormals (2^-1074), either sign.
fn tiny() -> impl Strategy<Value = f64> {
    prop_oneof![
        Just(0.0),
        Just(5e-324),
        Just(-5e-324),
        Just(1e-60),
        (1.0f64..2.0, 142i32..1075, any::<bool>())
            .prop_map(|(m, e, neg)| if neg { -m } else { m } * 2f64.powi(-e)),
    ]
}

/// Well-separated points with one at exactly (0, 0), all times `2^k` (mixed
/// scales, exactly), and tiny points beside the one at (0, 0) (`extras`).
fn tiny_beside_zero() -> impl Strategy<Value = (Vec<Xy>, Vec<Xy>, i32)> {
    let moved = points()
        .prop_map(|p| {
            p.iter()
                .map(|q| [q[0] - p[0][0], q[1] - p[0][1]])
                .collect::<Vec<Xy>>()
        })
        .prop_filter("well separated", |p| spread(p));
    let extras = prop::collection::vec((tiny(), tiny()).prop_map(|(x, y)| [x, y]), 1..4);
    (moved, extras, -900i32..900)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    /// Issue #37: a coordinate below 2^-142 of the extent beside a 0 made
    /// spade merge two points and the kernel panic. The tiny points are one
    /// point with (0, 0) (far below the tolerance), the optimum is that of the
    /// other points, at every scale.
    #[test]
    fn tiny_and_subnormal_coordinates_beside_zero_are_near_duplicates(
        (p, extras, k) in tiny_beside_zero(),
        holes in any::<bool>(),
    ) {
        let scale = 2f64.powi(k);
        let mut all: Vec<Xy> = p.iter().map(|q| [q[0] * scale, q[1] * scale]).collect();
        all.extend(extras.iter().map(|q| [q[0] * scale, q[1] * scale]));
        let options = Options { holes, components: 1, curve: false, max_union_nodes: MAX_UNION_NODES, sphere: false, ..Options::DEFAULT };
        let res = solve(&all, None, None, 0, &options);
        prop_assert_eq!(res.reason, 0);
        prop_assert_eq!(res.n_distinct as usize, p.len());
        for (i, q) in all.iter().enumerate().skip(p.len()) {
            prop_assert_eq!(res.rep[i], 0, "extra {:?} is not one with (0, 0)", q);
        }
        let rows = vec![1u64; p.len()];
        let (alpha, _) = brute_optimum(&p, &rows, holes, 1, 0);
        let got = res.alpha * scale;
        prop_assert!((got - alpha).abs() <= 1e-9 * alpha, "{} vs {}", got, alpha);
        prop_assert_eq!(res.polygons.len(), 1);
    }

    /// Any mix of zeros, subnormals, tiny and large coordinates: no panic, a
    /// reason code of the plane, and a shape when the reason is 0.
    #[test]
    fn mixed_scale_hostile_groups_never_panic(
        p in prop::collection::vec(
            (prop_oneof![tiny(), -1e100f64..1e100, -1.0f64..1.0], prop_oneof![tiny(), -1e100f64..1e100, -1.0f64..1.0])
                .prop_map(|(x, y)| [x, y]),
            1..12,
        ),
        holes in any::<bool>(),
    ) {
        let options = Options { holes, components: 1, curve: false, max_union_nodes: MAX_UNION_NODES, sphere: false, ..Options::DEFAULT };
        let res = solve(&p, None, None, 0, &options);
        prop_assert!(res.reason <= 3, "reason {}", res.reason);
        prop_assert_eq!(res.reason == 0, !res.polygons.is_empty());
        prop_assert_eq!(res.rep.len(), p.len());
    }
}
