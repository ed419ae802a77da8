//! One group, start to end: frame, triangulation, spectrum, optimum, rings.

use rayon::prelude::*;

use crate::frame::{circumradius, collinear, orient, Frame, Xy};
use crate::mesh::{triangulate, Mesh, NONE};
use crate::rings::{take_in, trace, Polygons};
use crate::spectrum::{
    fill_rank, merge_ties, outlier_optimum, pieces, sweep, Curve, ALPHA_RTOL, PARALLEL_TRIANGLES,
};

/// Why a group has no alpha shape (0: it has one); worded in
/// `geoalpha.kernel.REASONS`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Reason {
    /// A shape was computed.
    Ok = 0,
    /// Fewer than 3 distinct points (after near-duplicates merged).
    Few = 1,
    /// All points within the tolerance of a line.
    Collinear = 2,
    /// All points within the tolerance of a line in the output coordinates.
    CollinearOut = 3,
    /// The rings of the shape could not be traced (never expected).
    Rings = 4,
    /// On the sphere: a point beyond `crate::sphere::MAX_ANGLE_DEGREES` of
    /// the group's centre.
    Hemisphere = 6,
}

/// What to compute, the same for every group.
#[derive(Clone, Copy, Debug)]
pub struct Options {
    /// Keep holes (the shape is the solid triangles) or fill them.
    pub holes: bool,
    /// Largest number of edge-connected pieces of a valid shape.
    pub components: usize,
    /// Return the validity curve (for the comparison searches).
    pub curve: bool,
    /// Node budget of the best union of several pieces (`outliers=`).
    pub max_union_nodes: usize,
    /// The points are longitudes and latitudes in degrees, computed on the
    /// sphere ([`crate::sphere`]); radii and areas in metres.
    pub sphere: bool,
}

/// The result of one group.
#[derive(Clone, Debug, Default)]
pub struct Solved {
    /// A [`Reason`] code.
    pub reason: u8,
    /// The alpha used (1 / radius; 0 for the convex hull); NaN if degenerate.
    pub alpha: f64,
    /// The radius threshold (the optimal spectrum value, or 1 / given alpha).
    pub radius: f64,
    /// Distinct points.
    pub n_distinct: u32,
    /// Area of the shape, in the squared units of the points.
    pub area: f64,
    /// Rows left out (`outliers=`).
    pub n_outliers: u64,
    /// Every triangle of the triangulation is in the shape.
    pub whole: bool,
    /// The best-union search of `outliers=` hit its node budget.
    pub capped: bool,
    /// Representative of each point (an index into the group).
    pub rep: Vec<u32>,
    /// Rows left out, per point (empty when none are).
    pub left_out: Vec<bool>,
    /// The polygons, one per piece.
    pub polygons: Polygons,
    /// The validity curve, when asked (thresholds as ranks).
    pub curve: Curve,
    /// The curve's thresholds as radii.
    pub curve_values: Vec<f64>,
}

/// Solve one group. `out`: the same points in the output coordinates (where
/// collinearity is decided too); `alpha`: a given alpha instead of the
/// optimum; `budget`: rows that may be left out.
pub fn solve(
    points: &[Xy],
    out: Option<&[Xy]>,
    alpha: Option<f64>,
    budget: u64,
    options: &Options,
) -> Solved {
    let mut res = Solved {
        alpha: f64::NAN,
        radius: f64::NAN,
        ..Solved::default()
    };
    if points.is_empty() {
        res.reason = Reason::Few as u8;
        return res;
    }
    if options.sphere {
        return crate::sphere::solve(points, out, alpha, budget, options, res);
    }
    let frame = Frame::of(points);
    let s = frame.scale;
    let line = collinear(points, &frame);
    let radius_of = |[a, b, c]: [Xy; 3]| circumradius(a, b, c) / s;
    let Some((mesh, radius, scaled)) = triangulated(points, &frame, line, out, &mut res, radius_of)
    else {
        return res;
    };
    // Orientations in the scaled coordinates: exact, and never underflowing
    // for groups whose coordinates are tiny (1e-300 across).
    let area_of = |t: &[u32; 3]| {
        let [a, b, c] = t.map(|v| scaled[v as usize]);
        orient(a, b, c).abs() / 2.0 / s / s
    };
    finish(
        res, &mesh, &radius, &scaled, &area_of, alpha, budget, options,
    )
}

/// Triangulate a group in `plane` (`frame` is theirs, `line` whether they lie
/// on one line there, or in `out`) and set its reason code. With a shape: the
/// mesh, each triangle's radius (`radius_of` its corners scaled by
/// `frame.scale`) and the scaled points, every triangle counter-clockwise in
/// them; `None` when the group is degenerate.
pub fn triangulated(
    plane: &[Xy],
    frame: &Frame,
    line: bool,
    out: Option<&[Xy]>,
    res: &mut Solved,
    radius_of: impl Fn([Xy; 3]) -> f64 + Sync + Send,
) -> Option<(Mesh, Vec<f64>, Vec<Xy>)> {
    let line_out = out.is_some_and(|o| collinear(o, &Frame::of(o)));
    let mesh = triangulate(plane, frame, !(line || line_out));
    res.rep = mesh.rep.clone();
    res.n_distinct = mesh.n_distinct as u32;
    res.reason = if mesh.n_distinct < 3 {
        Reason::Few
    } else if line || mesh.tri.is_empty() {
        Reason::Collinear
    } else if line_out {
        Reason::CollinearOut
    } else {
        Reason::Ok
    } as u8;
    if res.reason != Reason::Ok as u8 {
        return None;
    }
    let s = frame.scale;
    let scaled: Vec<Xy> = plane.iter().map(|p| [p[0] * s, p[1] * s]).collect();
    let radius = |t: &[u32; 3]| radius_of(t.map(|v| scaled[v as usize]));
    let radius = if mesh.tri.len() > PARALLEL_TRIANGLES {
        mesh.tri.par_iter().map(radius).collect()
    } else {
        mesh.tri.iter().map(radius).collect() // rayon would cost more here
    };
    Some((mesh, radius, scaled))
}

/// The optimum (or given alpha), shape, area and rings of a triangulated group
/// (`ring_points`: the points every triangle is counter-clockwise in).
#[allow(clippy::too_many_arguments)]
pub fn finish(
    mut res: Solved,
    mesh: &Mesh,
    radius: &[f64],
    ring_points: &[Xy],
    area_of: &(dyn Fn(&[u32; 3]) -> f64 + Sync),
    alpha: Option<f64>,
    budget: u64,
    options: &Options,
) -> Solved {
    let n = mesh.rep.len();
    let (values, rank) = merge_ties(radius);
    let k = values.len();
    let w = if options.holes {
        rank
    } else {
        fill_rank(&rank, k, &mesh.nb)
    };
    let value = |rank: u32| values[rank as usize];
    let sweep = |curve| sweep(&w, k, mesh, options.components, curve);
    let (label, n_pieces) = if let Some(a) = alpha {
        res.radius = if a > 0.0 { 1.0 / a } else { f64::INFINITY };
        let r = res.radius * (1.0 + ALPHA_RTOL);
        // Solid: a merged radius <= r, i.e. a rank below the first value > r.
        let solid = values.partition_point(|&v| v <= r) as u32;
        pieces(|t| w[t] < solid, &mesh.nb)
    } else if budget > 0 {
        let mut weight = vec![0u64; n];
        for &r in &mesh.rep {
            weight[r as usize] += 1;
        }
        let need = (n as u64).saturating_sub(budget);
        let components = options.components;
        let (r, cover) =
            outlier_optimum(&w, mesh, &weight, components, need, options.max_union_nodes);
        res.capped = cover.capped;
        res.radius = value(r);
        res.n_outliers = n as u64 - cover.rows;
        // Keep the chosen pieces only, numbered 0..
        let mut renumber = vec![NONE; cover.label.len()];
        for (k, &c) in cover.chosen.iter().enumerate() {
            renumber[c as usize] = k as u32;
        }
        let label = cover.label.iter();
        let label = label.map(|&l| renumber.get(l as usize).copied().unwrap_or(NONE));
        (label.collect(), cover.chosen.len())
    } else {
        let (first, curve) = sweep(options.curve);
        res.curve = curve;
        // The whole triangulation is always valid: a Delaunay triangulation
        // is edge-connected and has every distinct point as a vertex.
        let r = first.unwrap_or(k as u32 - 1);
        res.radius = value(r);
        pieces(|t| w[t] <= r, &mesh.nb)
    };
    // 1 / inf is 0: the convex hull.
    res.alpha = alpha.unwrap_or(1.0 / res.radius);
    if options.curve && (alpha.is_some() || budget > 0) {
        res.curve = sweep(true).1;
    }
    res.curve_values = res.curve.ranks.iter().map(|&r| value(r)).collect();
    let shape = || label.iter().zip(&mesh.tri).filter(|(&l, _)| l != NONE);
    // Rows left out: points whose representative no chosen piece holds.
    if budget > 0 && alpha.is_none() {
        let mut held = vec![false; n];
        for &v in shape().flat_map(|(_, t)| t) {
            held[v as usize] = true;
        }
        res.left_out = mesh.rep.iter().map(|&r| !held[r as usize]).collect();
    }
    res.whole = label.iter().all(|&l| l != NONE);
    res.area = shape().fold(0.0, |area, (_, t)| area + area_of(t));
    match trace(ring_points, mesh, &label, n_pieces) {
        Some(mut polygons) => {
            // Merged near-duplicates become vertices (coverage by construction).
            take_in(ring_points, &mesh.rep, &mut polygons);
            res.polygons = polygons
        }
        None => res.reason = Reason::Rings as u8,
    }
    res
}

#[cfg(test)]
mod tests {
    use super::*;

    const OPTIONS: Options = Options {
        holes: false,
        components: 1,
        curve: false,
        max_union_nodes: crate::spectrum::MAX_UNION_NODES,
        sphere: false,
    };

    #[test]
    fn the_docstring_square_with_a_notch() {
        let pts = [[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0], [2.0, 3.5]];
        let res = solve(&pts, None, None, 0, &OPTIONS);
        assert_eq!(res.reason, 0);
        assert!((res.alpha - 0.430769).abs() < 1e-6, "{}", res.alpha);
        assert!((res.area - 15.0).abs() < 1e-12);
        assert_eq!(res.polygons.len(), 1);
    }

    #[test]
    fn a_stray_point_may_stay_out() {
        let pts = [
            [0.0, 0.0],
            [4.0, 0.0],
            [4.0, 4.0],
            [0.0, 4.0],
            [2.0, 3.5],
            [30.0, 30.0],
        ];
        let res = solve(&pts, None, None, 1, &OPTIONS);
        assert!((res.alpha - 0.430769).abs() < 1e-6, "{}", res.alpha);
        assert_eq!(res.n_outliers, 1);
        assert_eq!(res.left_out, vec![false, false, false, false, false, true]);
    }

    #[test]
    fn a_line_is_degenerate() {
        let pts = [[0.0, 0.0], [1.0, 1.0], [2.0, 2.0], [3.0, 3.0]];
        let res = solve(&pts, None, None, 0, &OPTIONS);
        assert_eq!(res.reason, Reason::Collinear as u8);
        assert!(res.alpha.is_nan());
    }
}
