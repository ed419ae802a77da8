//! One group, start to end: frame, triangulation, spectrum, optimum, rings.

use rayon::prelude::*;

use crate::frame::{circumradius, collinear, orient, Frame, Xy};
use crate::mesh::{placed, triangulate, Mesh, NONE};
use crate::rings::{take_in, trace, Polygons};
use crate::spectrum::{
    critical, fill_rank, lower_bound, lowest, merge_ties, pieces, sweep, Cover, Curve, Outliers,
    ALPHA_RTOL, PARALLEL_TRIANGLES,
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
    /// The kernel failed on this group (an error or a panic, caught: a bug);
    /// the other groups of the call are unaffected.
    Failed = 7,
}

/// Every [`Reason`] by name, as the kernel exports them (`REASON_NAMES`;
/// `geoalpha.kernel.Reason` is checked against it by a test).
pub const REASON_NAMES: [(&str, u8); 7] = [
    ("OK", Reason::Ok as u8),
    ("FEW", Reason::Few as u8),
    ("COLLINEAR", Reason::Collinear as u8),
    ("COLLINEAR_OUT", Reason::CollinearOut as u8),
    ("RINGS", Reason::Rings as u8),
    ("HEMISPHERE", Reason::Hemisphere as u8),
    ("FAILED", Reason::Failed as u8),
];

/// Why no smaller radius works (`DESIGN.md`, "Why a group got its radius").
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[repr(u8)]
pub enum LimitedBy {
    /// No search ran: the group has no shape.
    #[default]
    Degenerate = 0,
    /// At any smaller radius a point is outside the shape.
    Coverage = 1,
    /// At any smaller radius the shape has more than `components` pieces.
    Connection = 2,
    /// With `outliers=`, the budget is what is reached.
    Outliers = 3,
    /// The alpha was given.
    AlphaGiven = 4,
}

/// Every [`LimitedBy`] by name, as the kernel exports them (`LIMITED_BY`).
pub const LIMITED_BY_NAMES: [(&str, u8); 5] = [
    ("degenerate", LimitedBy::Degenerate as u8),
    ("coverage", LimitedBy::Coverage as u8),
    ("connection", LimitedBy::Connection as u8),
    ("outliers", LimitedBy::Outliers as u8),
    ("alpha given", LimitedBy::AlphaGiven as u8),
];

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
    /// `outliers=` counts locations (distinct points, 1 each), not rows.
    pub locations: bool,
    /// `outliers=` as a fraction of each group's rows (or locations), in
    /// `[0, 1)`; 0: the count of `batch::Input` (each group's `budget`) instead.
    pub fraction: f64,
    /// Say why: the critical triangle, what limits the radius, the points
    /// covered last.
    pub explain: bool,
    /// The alternatives: the outlier optimum for `k = 1..=max_left_out`.
    pub max_left_out: usize,
    /// The alternatives leave out locations (else rows).
    pub left_out_locations: bool,
    /// Flag a group whose radius one left-out location divides by at least
    /// this factor (0: no check; only at the exact optimum without outliers).
    pub suspicious: f64,
}

impl Options {
    /// Holes filled, one piece, nothing more than the optimum.
    pub const DEFAULT: Options = Options {
        holes: false,
        components: 1,
        curve: false,
        max_union_nodes: crate::spectrum::MAX_UNION_NODES,
        sphere: false,
        locations: false,
        fraction: 0.0,
        explain: false,
        max_left_out: 0,
        left_out_locations: true,
        suspicious: 0.0,
    };
}

/// The outlier optimum for one budget `k` (an alternative of [`Solved`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Alternative {
    /// Rows or locations left out at most.
    pub k: u32,
    /// The radius threshold.
    pub radius: f64,
    /// The area of the shape.
    pub area: f64,
    /// Its edge-connected pieces.
    pub n_parts: u32,
    /// The rows left out (indices into the group), ascending.
    pub left_out: Vec<u32>,
    /// The best-union search hit its node budget.
    pub capped: bool,
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
    /// A [`LimitedBy`] code (with `explain`).
    pub limited_by: u8,
    /// The critical triangle's three points (with `explain`; indices into
    /// the group, representatives of their duplicates).
    pub critical: Option<[u32; 3]>,
    /// With `limited_by` coverage: the points covered last.
    pub last: Vec<u32>,
    /// The outlier optima for `k = 1, 2, ...` (`max_left_out`; with the
    /// suspicious check, the one-location alternative of a flagged group).
    pub alternatives: Vec<Alternative>,
    /// One location divides the radius by at least `suspicious`.
    pub suspicious: bool,
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
    if crate::stop::requested() {
        return res; // (Ctrl-C: the call is dropped)
    }
    // Orientations in the scaled coordinates: exact, and never underflowing
    // for groups whose coordinates are tiny (1e-300 across).
    let area_of = |t: &[u32; 3]| {
        let [a, b, c] = t.map(|v| scaled[v as usize]);
        orient(a, b, c).abs() / 2.0 / s / s
    };
    // Merged points are taken in where they are, not where spade put them
    // (a coordinate below 2^-142 beside a 0 is placed at 0): scaled exactly.
    let exact: Vec<Xy> = points
        .iter()
        .map(|p| [p[0] * s + 0.0, p[1] * s + 0.0])
        .collect();
    finish(
        res,
        &mesh,
        &radius,
        (&scaled, &exact),
        &area_of,
        alpha,
        budget,
        options,
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
    // Where spade put them, so every triangle is counter-clockwise in them.
    let scaled: Vec<Xy> = plane.iter().map(|&p| placed(p, s).into()).collect();
    let radius = |t: &[u32; 3]| radius_of(t.map(|v| scaled[v as usize]));
    let radius = if mesh.tri.len() > PARALLEL_TRIANGLES {
        mesh.tri.par_iter().map(radius).collect()
    } else {
        mesh.tri.iter().map(radius).collect() // rayon would cost more here
    };
    Some((mesh, radius, scaled))
}

/// The optimum (or given alpha), shape, area and rings of a triangulated group
/// (`ring_points`: the points every triangle is counter-clockwise in, and
/// the same points as exactly as they are, in which merged points are taken in).
#[allow(clippy::too_many_arguments)]
pub fn finish(
    mut res: Solved,
    mesh: &Mesh,
    radius: &[f64],
    (ring_points, exact): (&[Xy], &[Xy]),
    area_of: &(dyn Fn(&[u32; 3]) -> f64 + Sync),
    alpha: Option<f64>,
    budget: u64,
    options: &Options,
) -> Solved {
    let n = mesh.rep.len();
    let (values, rank) = merge_ties(radius);
    let k = values.len();
    let filled;
    let w: &[u32] = if options.holes {
        &rank
    } else {
        filled = fill_rank(&rank, k, &mesh.nb);
        &filled
    };
    if crate::stop::requested() {
        return res; // (Ctrl-C: the call is dropped)
    }
    let value = |rank: u32| values[rank as usize];
    let sweep = |curve| sweep(w, k, mesh, options.components, curve);
    // Rows at each point, or 1 per location (0 at a merged near-duplicate).
    let mut rows = vec![0u64; n];
    for &r in &mesh.rep {
        rows[r as usize] += 1;
    }
    let places: Vec<u64> = rows.iter().map(|&x| u64::from(x > 0)).collect();
    let weight = if options.locations { &places } else { &rows };
    let budget = if options.fraction > 0.0 {
        let total = weight.iter().sum::<u64>() as f64;
        // numpy's floor(round(q * total, 9)), as geoalpha.arrays.budget
        ((options.fraction * total * 1e9).round_ties_even() / 1e9).floor() as u64
    } else {
        budget
    };
    let components = options.components;
    let nodes = options.max_union_nodes;
    let mut optimum = None;
    let (label, n_pieces) = if let Some(a) = alpha {
        res.radius = if a > 0.0 { 1.0 / a } else { f64::INFINITY };
        res.limited_by = LimitedBy::AlphaGiven as u8;
        let r = res.radius * (1.0 + ALPHA_RTOL);
        // Solid: a merged radius <= r, i.e. a rank below the first value > r.
        let solid = values.partition_point(|&v| v <= r) as u32;
        pieces(|t| w[t] < solid, &mesh.nb)
    } else if budget > 0 {
        let need = weight.iter().sum::<u64>().saturating_sub(budget);
        let search = Outliers::new(w, mesh, weight, components, nodes);
        let lo = lower_bound(&lowest(w, mesh), weight, budget);
        let (r, cover) = search.optimum(need, lo, search.top());
        res.capped = cover.capped;
        res.radius = value(r);
        res.limited_by = LimitedBy::Outliers as u8;
        optimum = Some(r);
        chosen(&cover)
    } else {
        let (first, curve) = sweep(options.curve);
        res.curve = curve;
        // The whole triangulation is always valid: a Delaunay triangulation
        // is edge-connected and has every distinct point as a vertex.
        let r = first.unwrap_or(k as u32 - 1);
        res.radius = value(r);
        optimum = Some(r);
        pieces(|t| w[t] <= r, &mesh.nb)
    };
    if let Some(r) =
        optimum.filter(|_| options.explain || options.suspicious > 0.0 || options.max_left_out > 0)
    {
        let low = lowest(w, mesh);
        if options.explain {
            res.critical = critical(r, &rank, w, radius).map(|t| mesh.tri[t]);
            if budget == 0 {
                let top = low.iter().filter(|&&l| l != NONE).max().copied();
                res.limited_by = if top == Some(r) {
                    res.last = (0..n as u32).filter(|&v| low[v as usize] == r).collect();
                    LimitedBy::Coverage
                } else {
                    LimitedBy::Connection
                } as u8;
            }
        }
        let unit = if options.left_out_locations {
            &places
        } else {
            &rows
        };
        let total: u64 = unit.iter().sum();
        let search = Outliers::new(w, mesh, unit, components, nodes);
        // Each budget's optimum is at most the previous one's.
        let mut hi = if budget == 0 { r } else { search.top() };
        let most = (options.max_left_out as u64).min(total.saturating_sub(3));
        for k in 1..=most {
            let lo = lower_bound(&low, unit, k).min(hi);
            let (rk, cover) = search.optimum(total - k, lo, hi);
            res.alternatives
                .push(alternative(k, value(rk), &cover, mesh, area_of));
            hi = rk;
        }
        if options.suspicious > 0.0 && budget == 0 {
            let limit = value(r) / options.suspicious;
            if options.left_out_locations && options.max_left_out > 0 {
                res.suspicious = res.alternatives.first().is_some_and(|a| a.radius <= limit);
            } else if places.iter().sum::<u64>() > 3 {
                // Cheap unless flagged: a bound, then one cover at the limit.
                let total = places.iter().sum::<u64>();
                let at = values.partition_point(|&v| v <= limit);
                let lo = lower_bound(&low, &places, 1);
                if at > 0 && lo < at as u32 {
                    let search = Outliers::new(w, mesh, &places, components, nodes);
                    let top = at as u32 - 1;
                    if search.cover(top).rows + 1 >= total {
                        res.suspicious = true;
                        let (rk, cover) = search.optimum(total - 1, lo, top);
                        if options.max_left_out == 0 {
                            res.alternatives
                                .push(alternative(1, value(rk), &cover, mesh, area_of));
                        }
                    }
                }
            }
        }
    }
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
        res.n_outliers = res.left_out.iter().filter(|&&x| x).count() as u64;
    }
    res.whole = label.iter().all(|&l| l != NONE);
    res.area = shape().fold(0.0, |area, (_, t)| area + area_of(t));
    if crate::stop::requested() {
        return res;
    }
    match trace(ring_points, mesh, &label, n_pieces) {
        Some(mut polygons) => {
            // Merged near-duplicates become vertices (coverage by construction).
            take_in(exact, &mesh.rep, &mut polygons);
            res.polygons = polygons
        }
        None => res.reason = Reason::Rings as u8,
    }
    res
}

/// The chosen pieces of `cover` only, numbered `0..`, and how many.
fn chosen(cover: &Cover) -> (Vec<u32>, usize) {
    let mut renumber = vec![NONE; cover.label.len()];
    for (k, &c) in cover.chosen.iter().enumerate() {
        renumber[c as usize] = k as u32;
    }
    let label = cover.label.iter();
    let label = label.map(|&l| renumber.get(l as usize).copied().unwrap_or(NONE));
    (label.collect(), cover.chosen.len())
}

/// The alternative of budget `k` at `radius` from its best pieces.
fn alternative(
    k: u64,
    radius: f64,
    cover: &Cover,
    mesh: &Mesh,
    area_of: &(dyn Fn(&[u32; 3]) -> f64 + Sync),
) -> Alternative {
    let (label, n_parts) = chosen(cover);
    let mut held = vec![false; mesh.rep.len()];
    let mut area = 0.0;
    for (_, t) in label.iter().zip(&mesh.tri).filter(|(&l, _)| l != NONE) {
        area += area_of(t);
        t.iter().for_each(|&v| held[v as usize] = true);
    }
    let rep = mesh.rep.iter().zip(0..);
    Alternative {
        k: k as u32,
        radius,
        area,
        n_parts: n_parts as u32,
        left_out: rep
            .filter(|&(&r, _)| !held[r as usize])
            .map(|(_, i)| i)
            .collect(),
        capped: cover.capped,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const OPTIONS: Options = Options::DEFAULT;

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
