//! Alpha shapes on the sphere (`crs="sphere"`): a group's longitudes and
//! latitudes as unit vectors, triangulated by empty circumscribed caps; a
//! triangle's radius is the geodesic radius of its circumscribed small
//! circle, in metres on a sphere of radius [`EARTH_RADIUS`].
//!
//! The group's centre `c` is the normalised mean of its unit vectors. The
//! points are projected stereographically from `-c` onto the plane tangent at
//! `c` (`X = 2x / (1 + z)`, `Y = 2y / (1 + z)` in a basis `e1, e2, c`), which
//! maps circles to circles, and triangulated exactly in the plane
//! ([`crate::mesh::triangulate`]): an empty circumcircle there is an empty
//! cap (the one that does not hold `-c`).
//!
//! # What the plane misses, and why it is exact
//!
//! With every point within [`MAX_ANGLE_DEGREES`] (< 90) of `c`:
//!
//! 1. Every planar Delaunay triangle is a spherical Delaunay triangle: its
//!    empty cap is smaller than a hemisphere (a cap larger than a hemisphere
//!    that holds no point leaves every point in the opposite cap, smaller
//!    than a hemisphere and holding `-c`; that cap is convex and holds the
//!    points' mean direction `c` too, so it would hold two antipodes).
//! 2. The spherical Delaunay triangles the plane misses are those whose empty
//!    cap holds `-c`: they lie along the boundary (their vertices are planar
//!    convex hull vertices: the link of `-c` once `-c` is deleted from the
//!    spherical Delaunay triangulation of the points and `-c`). Such a cap,
//!    of angular radius `rho` and centre `m`, holds `-c`, so the angle from
//!    `m` to `c` is more than `pi - rho`; it is at most `rho + theta_max`
//!    (a vertex is at `rho` from `m` and within `theta_max` of `c`). So
//!    `rho > (pi - theta_max) / 2` (50 degrees, 5,560 km, at most).
//! 3. Below that radius the two triangulations give the same shape at every
//!    alpha: the missing triangles are not solid, they are outside the convex
//!    hull of the planar mesh, where they only lengthen, with large radii,
//!    the paths to the outside that decide which holes are filled. So the
//!    optimum on the planar mesh, when it is below the bound, is the spherical
//!    optimum, with the same shape. Otherwise (and for the validity curve)
//!    the mesh is completed by gift-wrapping across its boundary edges
//!    ([`complete`]) and the group is solved again.

use robust::{incircle, orient3d, Coord3D};
use std::collections::HashMap;

use crate::frame::{collinear, coord, orient, Frame, Xy};
use crate::group::{finish, triangulated, Options, Reason, Solved};
use crate::mesh::{triangulate, Mesh, NONE};

/// The sphere's radius in metres: the authalic radius of WGS84 (the sphere
/// with the ellipsoid's area).
pub const EARTH_RADIUS: f64 = 6_371_007.2;

/// The largest angle (degrees) from a group's centre to one of its points;
/// groups beyond are refused ([`Reason::Hemisphere`]).
pub const MAX_ANGLE_DEGREES: f64 = 80.0;

type V3 = [f64; 3];

fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn norm(a: V3) -> f64 {
    dot(a, a).sqrt()
}

fn scale(a: V3, k: f64) -> V3 {
    [a[0] * k, a[1] * k, a[2] * k]
}

/// The orientation of `a, b, c, d`, exact sign; with `d` = [`O`], `det[a, b,
/// c]` (positive: counter-clockwise seen from outside the sphere).
pub fn orient3(a: V3, b: V3, c: V3, d: V3) -> f64 {
    let k = |p: V3| Coord3D {
        x: p[0],
        y: p[1],
        z: p[2],
    };
    orient3d(k(a), k(b), k(c), k(d))
}

/// The centre of the sphere.
pub const O: V3 = [0.0; 3];

/// One group in the frame of its centre.
pub struct Local {
    /// Unit vectors in the basis `e1, e2, c`.
    pub unit: Vec<V3>,
    /// Stereographic projection from `-c` (the triangulation's plane).
    pub stereo: Vec<Xy>,
    /// Gnomonic projection from the centre (great circles are lines).
    pub gnomonic: Vec<Xy>,
    /// The largest angle from the centre to a point, in radians.
    pub theta_max: f64,
}

/// The group in the frame of its centre; `None` beyond [`MAX_ANGLE_DEGREES`].
///
/// The centre `c` (longitude `l0`, latitude `p0`) is the normalised mean of
/// the unit vectors; each point's coordinates in the frame east, north, `c`
/// are computed from its longitude and latitude differences to the centre,
/// in degrees (exact for nearby points), by formulas without cancellation:
/// `x = cos p sin dl`, `y = sin(p - p0) + 2 sin p0 cos p sin^2(dl / 2)`,
/// `z = cos(p - p0) - 2 cos p0 cos p sin^2(dl / 2)`. So a small cap (metres
/// across) keeps the relative accuracy of its coordinates, about an ulp of
/// its own size, not an ulp of the sphere's radius, and points 1e-12 degrees
/// apart keep their offsets (issue #37: differences of unit vectors lost
/// them).
pub fn local(points: &[Xy]) -> Option<Local> {
    let unit_vector = |p: &Xy| {
        let (sl, cl) = p[0].to_radians().sin_cos();
        let (sp, cp) = p[1].to_radians().sin_cos();
        [cp * cl, cp * sl, sp]
    };
    let add = |m: V3, p: &Xy| {
        let u = unit_vector(p);
        [m[0] + u[0], m[1] + u[1], m[2] + u[2]]
    };
    let mean = points.iter().fold([0.0; 3], add);
    let m = norm(mean);
    if !(m > 0.0 && m.is_finite()) {
        return None;
    }
    let c = scale(mean, 1.0 / m);
    // The centre's longitude and latitude, in degrees (any longitude at a pole).
    let l0 = c[1].atan2(c[0]).to_degrees();
    let p0 = c[2].atan2(c[0].hypot(c[1])).to_degrees();
    let (sp0, cp0) = p0.to_radians().sin_cos();
    let mut out = Local {
        unit: Vec::with_capacity(points.len()),
        stereo: Vec::with_capacity(points.len()),
        gnomonic: Vec::with_capacity(points.len()),
        theta_max: 0.0,
    };
    let limit = MAX_ANGLE_DEGREES.to_radians();
    for p in points {
        // The longitude difference in (-180, 180].
        let mut dl = p[0] - l0;
        if dl > 180.0 {
            dl -= 360.0;
        } else if dl <= -180.0 {
            dl += 360.0;
        }
        let dl = dl.to_radians();
        let dp = (p[1] - p0).to_radians();
        let cp = p[1].to_radians().cos();
        let (sdp, cdp) = dp.sin_cos();
        let h = (0.5 * dl).sin();
        let h2 = 2.0 * h * h;
        let (x, y, z) = (cp * dl.sin(), sdp + sp0 * cp * h2, cdp - cp0 * cp * h2);
        let theta = x.hypot(y).atan2(z);
        if theta.is_nan() || theta > limit {
            return None;
        }
        out.theta_max = out.theta_max.max(theta);
        out.unit.push([x, y, z]);
        out.stereo.push([2.0 * x / (1.0 + z), 2.0 * y / (1.0 + z)]);
        out.gnomonic.push([x / z, y / z]);
    }
    Some(out)
}

/// Angular radius (radians) of the circle on the sphere whose stereographic
/// image passes through `a, b, c` (coordinates scaled by `s`), the radius of
/// the cap smaller than a hemisphere: with `rho` the planar circumradius and
/// `pow` the power of the centre of projection to the planar circle,
/// `theta = atan2(rho, 1 + pow / 4)` (the difference of the arctangents of
/// its nearest and farthest points' half distances), then `min(theta, pi -
/// theta)`.
pub fn cap_radius(a: Xy, b: Xy, c: Xy, s: f64) -> f64 {
    let o = orient(a, b, c);
    let rho = crate::frame::circumradius(a, b, c) / s;
    // incircle(a, b, c, d) = orient(a, b, c) * (rho^2 - |d - q|^2)
    let pow = -incircle(coord(a), coord(b), coord(c), coord([0.0, 0.0])) / o / (s * s);
    let theta = rho.atan2(1.0 + pow / 4.0);
    if theta.is_finite() {
        theta.min(std::f64::consts::PI - theta)
    } else {
        std::f64::consts::FRAC_PI_2
    }
}

/// Area (steradians) of the spherical triangle `a, b, c` (unit vectors):
/// `2 atan2(|det|, 1 + a.b + b.c + c.a)` (Van Oosterom and Strackee).
pub fn triangle_area(a: V3, b: V3, c: V3) -> f64 {
    let d = orient3(a, b, c, O).abs();
    2.0 * d.atan2(1.0 + dot(a, b) + dot(b, c) + dot(c, a))
}

/// Add to `mesh` the spherical Delaunay triangles of `unit` it misses, across
/// its boundary edges (gift-wrapping over the boundary's vertices, exact
/// orientations): how many, or `None` if the wrapping did not close.
pub fn complete(mesh: &mut Mesh, unit: &[V3]) -> Option<usize> {
    let mut open: HashMap<(u32, u32), (u32, usize)> = HashMap::new();
    let mut stack = Vec::new();
    for (t, tri) in mesh.tri.iter().enumerate() {
        for j in 0..3 {
            if mesh.nb[t][j] == NONE {
                open.insert((tri[j], tri[(j + 1) % 3]), (t as u32, j));
                stack.push((t as u32, j));
            }
        }
    }
    let mut link: Vec<u32> = open.keys().map(|e| e.0).collect();
    link.sort_unstable();
    let start = mesh.tri.len();
    let bound = 2 * link.len() + 4;
    while let Some((t, j)) = stack.pop() {
        if mesh.nb[t as usize][j] != NONE {
            continue;
        }
        let tri = mesh.tri[t as usize];
        let (u, v) = (tri[j], tri[(j + 1) % 3]);
        let (pu, pv) = (unit[u as usize], unit[v as usize]);
        let beyond = |&w: &u32| w != u && w != v && orient3(pu, pv, unit[w as usize], O) < 0.0;
        // w strictly inside the cap of (v, u, b), beyond its plane
        let inside = |b: u32, w: u32| orient3(pv, pu, unit[b as usize], unit[w as usize]) < 0.0;
        let best = link.iter().copied().filter(beyond);
        let Some(w) = best.reduce(|b, w| if inside(b, w) { w } else { b }) else {
            continue;
        };
        if mesh.tri.len() - start >= bound {
            return None;
        }
        let new = mesh.tri.len() as u32;
        mesh.tri.push([v, u, w]);
        mesh.nb.push([t, NONE, NONE]);
        mesh.nb[t as usize][j] = new;
        open.remove(&(u, v));
        for (k, (a, b)) in [(1, (u, w)), (2, (w, v))] {
            if let Some((s, i)) = open.remove(&(b, a)) {
                mesh.nb[new as usize][k] = s;
                mesh.nb[s as usize][i] = new;
            } else {
                open.insert((a, b), (new, k));
                stack.push((new, k));
            }
        }
    }
    Some(mesh.tri.len() - start)
}

/// [`crate::group::solve`] on the sphere (longitudes and latitudes in
/// degrees), filling its `res`.
pub fn solve(
    points: &[Xy],
    out: Option<&[Xy]>,
    alpha: Option<f64>,
    budget: u64,
    options: &Options,
    mut res: Solved,
) -> Solved {
    let Some(local) = local(points) else {
        // Fewer than 3 distinct points have no shape wherever they are.
        let mesh = triangulate(points, &Frame::of(points), false);
        res.reason = if mesh.n_distinct < 3 {
            res.rep = mesh.rep;
            res.n_distinct = mesh.n_distinct as u32;
            Reason::Few
        } else {
            Reason::Hemisphere
        } as u8;
        return res;
    };
    let frame = Frame::of(&local.stereo);
    // Great circles are the gnomonic projection's lines.
    let line = collinear(&local.gnomonic, &Frame::of(&local.gnomonic));
    let radius_of = |[a, b, c]: [Xy; 3]| EARTH_RADIUS * cap_radius(a, b, c, frame.scale);
    let Some((mut mesh, mut radius, scaled)) =
        triangulated(&local.stereo, &frame, line, out, &mut res, radius_of)
    else {
        return res;
    };
    let unit = &local.unit;
    let area_of = |t: &[u32; 3]| {
        let [a, b, c] = t.map(|v| unit[v as usize]);
        EARTH_RADIUS * EARTH_RADIUS * triangle_area(a, b, c)
    };
    let copy = res.clone();
    let planar = finish(
        copy,
        &mesh,
        &radius,
        (&scaled, &scaled),
        &area_of,
        alpha,
        budget,
        options,
    );
    // Below the bound the planar mesh gives the spherical answer (module doc).
    let bound = EARTH_RADIUS * (std::f64::consts::PI - local.theta_max) / 2.0 * (1.0 - 1e-9);
    if !options.curve && planar.radius < bound {
        return planar;
    }
    let before = mesh.tri.len();
    let Some(added) = complete(&mut mesh, unit) else {
        res.reason = Reason::Rings as u8;
        return res;
    };
    if added == 0 {
        return planar;
    }
    // The added triangles' caps hold -c: the cap on the far side of their plane.
    for t in &mesh.tri[before..] {
        let [a, b, c] = t.map(|v| unit[v as usize]);
        radius.push(EARTH_RADIUS * cap_of_units(a, b, c));
    }
    // Every triangle is counter-clockwise in the gnomonic projection.
    let g = Frame::of(&local.gnomonic).scale;
    let gnomonic: Vec<Xy> = local.gnomonic.iter().map(|p| p.map(|x| x * g)).collect();
    finish(
        res,
        &mesh,
        &radius,
        (&gnomonic, &gnomonic),
        &area_of,
        alpha,
        budget,
        options,
    )
}

/// Angular radius of the small circle through three unit vectors (the cap
/// smaller than a hemisphere): the angle from their plane's normal to one.
pub fn cap_of_units(a: V3, b: V3, c: V3) -> f64 {
    let sub = |p: V3, q: V3| [p[0] - q[0], p[1] - q[1], p[2] - q[2]];
    let nrm = cross(sub(b, a), sub(c, a));
    let k = norm(nrm);
    if k.is_nan() || k <= 0.0 {
        return std::f64::consts::FRAC_PI_2;
    }
    let nrm = scale(nrm, 1.0 / k);
    let theta = norm(cross(nrm, a)).atan2(dot(nrm, a).abs());
    theta.min(std::f64::consts::FRAC_PI_2)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_determinant_is_positive_counter_clockwise_from_outside() {
        assert!(orient3([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], O) > 0.0);
    }

    #[test]
    fn the_incircle_identity_gives_the_power_of_the_origin() {
        // circle centre (3, 0), radius 1: the origin's power is 9 - 1 = 8
        let (a, b, c) = ([4.0, 0.0], [3.0, 1.0], [2.0, 0.0]);
        let o = orient(a, b, c);
        let pow = -incircle(coord(a), coord(b), coord(c), coord([0.0, 0.0])) / o;
        assert!((pow - 8.0).abs() < 1e-12, "{pow}");
    }

    #[test]
    fn an_octant_has_a_circle_of_its_three_corners() {
        // The corners of an octant: the small circle around (1,1,1)/sqrt 3.
        let want = (1.0f64 / 3.0f64.sqrt()).acos();
        let (a, b, c) = ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]);
        assert!((cap_of_units(a, b, c) - want).abs() < 1e-15);
        let pts = [[0.0, 0.0], [90.0, 0.0], [0.0, 90.0]];
        let l = local(&pts).unwrap();
        let [p, q, r] = [0, 1, 2].map(|i| l.stereo[i]);
        assert!((cap_radius(p, q, r, 1.0) - want).abs() < 1e-14);
        let area = triangle_area(l.unit[0], l.unit[1], l.unit[2]);
        assert!((area - std::f64::consts::FRAC_PI_2).abs() < 1e-14);
    }

    #[test]
    fn two_points_far_apart_are_too_few_not_refused() {
        let options = Options {
            sphere: true,
            ..Options::DEFAULT
        };
        let pts = [[0.0, 51.5], [151.2, -33.9], [151.2, -33.9]];
        let res = crate::group::solve(&pts, None, None, 0, &options);
        assert_eq!(res.reason, Reason::Few as u8);
        assert_eq!(res.rep, vec![0, 1, 1]);
    }

    #[test]
    fn a_point_beyond_the_limit_is_refused() {
        assert!(local(&[[0.0, 0.0], [179.0, 0.0], [0.0, 1.0]]).is_none());
        assert!(local(&[[0.0, 0.0], [100.0, 0.0], [50.0, 1.0]]).is_some());
    }
}
