//! A group's working frame: its extent, the exact power-of-two scale the
//! kernel computes in, and the one near-degeneracy tolerance.

/// Points closer than this times the group's extent are one point; a group
/// within it of a line is degenerate.
pub const NEAR_RTOL: f64 = 1e-9;

/// Floor of the tolerance, in units in the last place of the group's largest
/// coordinate: the resolution of its float64 coordinates.
pub const PRECISION_ULPS: f64 = 64.0;

/// A point as the kernel reads it: `(x, y)` in the computation CRS.
pub type Xy = [f64; 2];

/// Scale, tolerance and bounding box of one group.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    /// A power of two that brings the extent into `[0.5, 1)` (1 for a zero
    /// extent): multiplying by it is exact.
    pub scale: f64,
    /// The near-degeneracy tolerance, in the input units.
    pub tol: f64,
    /// The bounding box: its smallest and its largest coordinates.
    pub bounds: [Xy; 2],
}

/// The distance from `x` to the next float of larger magnitude (numpy's
/// `spacing` for `x >= 0`; NaN for a NaN or an infinity, whose next bit
/// pattern is a NaN).
pub fn ulp(x: f64) -> f64 {
    let x = x.abs();
    f64::from_bits(x.to_bits() + 1) - x
}

/// `2^-e` where `extent = m * 2^e`, `m` in `[0.5, 1)`.
fn power_of_two_scale(extent: f64) -> f64 {
    if extent <= 0.0 || !extent.is_finite() {
        return 1.0;
    }
    // frexp: the exponent of the leading bit, plus one (in a subnormal, whose
    // exponent field is 0, that bit is at 63 - leading zeros, times 2^-1074).
    let bits = extent.to_bits();
    let e = match bits >> 52 {
        0 => -1010 - bits.leading_zeros() as i32,
        biased => biased as i32 - 1022,
    };
    // Checked coordinates keep the extent below 2^1022, so 2^-e is a normal
    // float, or beyond the largest for an extent below 2^-1023.
    if e < -1023 {
        return f64::INFINITY;
    }
    f64::from_bits(((1023 - e) as u64) << 52)
}

impl Frame {
    /// The frame of a set of points (not empty).
    pub fn of<'a>(points: impl IntoIterator<Item = &'a Xy>) -> Frame {
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for p in points {
            for k in 0..2 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let extent = (hi[0] - lo[0]).max(hi[1] - lo[1]);
        let big = lo.iter().chain(&hi).fold(0.0f64, |m, v| m.max(v.abs()));
        Frame {
            scale: power_of_two_scale(extent),
            tol: (NEAR_RTOL * extent).max(PRECISION_ULPS * ulp(big)),
            bounds: [lo, hi],
        }
    }
}

/// Whether the points all lie within `tol` of their principal axis (the
/// least-squares line through their centroid); fewer than 3 points do.
/// Relative to the first point and scaled: offsets and scales lose nothing.
pub fn collinear(points: &[Xy], frame: &Frame) -> bool {
    if points.len() < 3 {
        return true;
    }
    let s = frame.scale;
    let o = points[0];
    let n = points.len() as f64;
    let local = |p: &Xy| [(p[0] - o[0]) * s, (p[1] - o[1]) * s];
    let add = |s: Xy, [x, y]: Xy| [s[0] + x, s[1] + y];
    let sum = points.iter().map(local).fold([0.0; 2], add);
    let (cx, cy) = (sum[0] / n, sum[1] / n);
    let (mut sxx, mut syy, mut sxy) = (0.0, 0.0, 0.0);
    for p in points {
        let [x, y] = local(p);
        let (dx, dy) = (x - cx, y - cy);
        sxx += dx * dx;
        syy += dy * dy;
        sxy += dx * dy;
    }
    let (uy, ux) = (0.5 * (2.0 * sxy).atan2(sxx - syy)).sin_cos();
    let width = |[x, y]: Xy| ((x - cx) * uy - (y - cy) * ux).abs();
    let widest = points.iter().map(local).map(width).fold(0.0, f64::max);
    widest <= frame.tol * s
}

/// `p` as a point of the exact predicates (crate `robust`).
pub fn coord(p: Xy) -> robust::Coord<f64> {
    robust::Coord { x: p[0], y: p[1] }
}

/// Twice the signed area of the triangle `a, b, c`, with the exact sign
/// (positive counter-clockwise); its magnitude is the float determinant's
/// whenever that has the right sign (see [`cross_accurate`] for one accurate
/// to a few ulps).
pub fn orient(a: Xy, b: Xy, c: Xy) -> f64 {
    robust::orient2d(coord(a), coord(b), coord(c))
}

/// Circumradius of the triangle `a, b, c` (scaled coordinates), in scaled
/// units: `|ab| |bc| |ca| / (2 |cross|)`, `inf` for a flat triangle.
///
/// The cross product is taken at the vertex of the largest angle, where the
/// edge vectors are furthest from parallel, and in the accurate form of
/// [`cross_accurate`] where it cancels (a nearly flat triangle): the radius
/// is accurate to a few ulps for needles and slivers alike. Plain square
/// roots, not `hypot`: scaled edges are between the tolerance and 2 long.
pub fn circumradius(a: Xy, b: Xy, c: Xy) -> f64 {
    let sq = |p: Xy, q: Xy| {
        let (dx, dy) = (q[0] - p[0], q[1] - p[1]);
        dx * dx + dy * dy
    };
    let (ab, bc, ca) = (sq(a, b), sq(b, c), sq(c, a));
    // Rotations keep the orientation; the last vertex is the pivot.
    let (a, b, c) = if ab >= bc && ab >= ca {
        (a, b, c)
    } else if bc >= ca {
        (b, c, a)
    } else {
        (c, a, b)
    };
    // Flat exactly when the exact predicate says so.
    if orient(a, b, c) == 0.0 {
        return f64::INFINITY;
    }
    let cross = cross_accurate(a, b, c).abs();
    ab.sqrt() * bc.sqrt() / (2.0 * cross) * ca.sqrt()
}

/// `(s, e)` with `s = a + b` rounded and `s + e = a + b` exactly (Knuth's
/// two-sum).
fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bb = s - a;
    (s, (a - (s - bb)) + (b - bb))
}

/// `(p, e)` with `p = a * b` rounded and `p + e = a * b` exactly (one fused
/// multiply-add; exact unless the product underflows).
fn two_product(a: f64, b: f64) -> (f64, f64) {
    let p = a * b;
    (p, a.mul_add(b, -p))
}

/// The cross product `(a - c) x (b - c)` accurate to about one ulp of its
/// value however much it cancels: the exact adaptive `orient2d` returns the
/// plain float determinant whenever its sign is certain, which can be wrong
/// in all but the first digits of a nearly flat triangle. Here each
/// coordinate difference is split exactly into two floats (two-sum), the
/// sixteen partial products are each split exactly (two-product) and the
/// thirty-two terms are summed in twice the working precision (Ogita, Rump
/// and Oishi's `Sum2`): the error is at most `eps |det| + 32^2 eps^2
/// sum|terms|`, so a few ulps for a cancellation down to `1e-15` of the
/// terms. Used where the float determinant's error bound (Shewchuk's
/// `ccwerrboundA`) is above `2^-50` of its value; exact for an exactly flat
/// triangle (0).
pub fn cross_accurate(a: Xy, b: Xy, c: Xy) -> f64 {
    let (acx, acy) = (a[0] - c[0], a[1] - c[1]);
    let (bcx, bcy) = (b[0] - c[0], b[1] - c[1]);
    let det = acx * bcy - acy * bcx;
    let detsum = (acx * bcy).abs() + (acy * bcx).abs();
    // Shewchuk's bound on the float determinant's error: (3 + 16 eps) eps.
    const ERR: f64 = 3.330_669_073_875_471_6e-16;
    if ERR * detsum <= 2.0 * f64::EPSILON * det.abs() {
        return det;
    }
    let ax = two_sum(a[0], -c[0]);
    let ay = two_sum(a[1], -c[1]);
    let bx = two_sum(b[0], -c[0]);
    let by = two_sum(b[1], -c[1]);
    let mut terms = [0.0f64; 32];
    let mut k = 0;
    for (u, v, sign) in [(ax, by, 1.0), (ay, bx, -1.0)] {
        for x in [u.0, u.1] {
            for y in [v.0, v.1] {
                let (p, e) = two_product(x, sign * y);
                terms[k] = p;
                terms[k + 1] = e;
                k += 2;
            }
        }
    }
    // Sum2: a cascade of two-sums, the rounding errors added up apart.
    let (mut s, mut err) = (0.0f64, 0.0f64);
    for t in terms {
        let (sum, e) = two_sum(s, t);
        s = sum;
        err += e;
    }
    s + err
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scale_brings_the_extent_into_half_one() {
        for extent in [1e-300, 3.0e-7, 0.5, 1.0, 7.5, 1e9, 1e300] {
            let s = power_of_two_scale(extent);
            let scaled = extent * s;
            assert!((0.5..1.0).contains(&scaled), "{extent}: {scaled}");
        }
    }

    #[test]
    fn ulp_matches_numpy_spacing() {
        assert_eq!(ulp(1.0), f64::EPSILON);
        assert_eq!(ulp(0.0), f64::from_bits(1));
        assert!(ulp(f64::INFINITY).is_nan() && ulp(f64::NAN).is_nan());
    }

    #[test]
    fn a_needle_has_one_radius_in_every_vertex_order() {
        // (100, 0) and (100 + 1e-6, 3e-7) are 1e-8 of the extent apart; the
        // cross product at (30, 90) cancels to 1e-8 of its terms. The
        // radius 61.137... is 1 / 0.016356725744076647 (exact rationals, in
        // tests/test_exact.py::test_needle_triangle_radius).
        let (a, b, c) = ([100.0, 0.0], [30.0, 90.0], [100.000001, 3e-7]);
        let s = 1.0 / 128.0;
        let q = |p: Xy| [p[0] * s, p[1] * s];
        let exact = 1.0 / 0.016356725744076647;
        for (x, y, z) in [
            (a, b, c),
            (b, c, a),
            (c, a, b),
            (b, a, c),
            (a, c, b),
            (c, b, a),
        ] {
            let r = circumradius(q(x), q(y), q(z)) / s;
            assert!((r / exact - 1.0).abs() < 1e-14, "{r} vs {exact}");
        }
    }

    #[test]
    fn a_sliver_cross_product_is_accurate_where_the_float_one_is_not() {
        // (a - c) x (b - c) = cy - cx / 2 for a = (0, 0), b = (1, 0.5): exact
        // in floats (Sterbenz), while the float determinant of the rounded
        // differences keeps only its first digits at these flatnesses.
        for d in [1e-6, 3.5e-9, 1e-10, 1e-12, 1e-14] {
            let (a, b) = ([0.0, 0.0], [1.0, 0.5]);
            let c = [0.3, 0.15 + d];
            let exact = c[1] - 0.5 * c[0];
            let got = cross_accurate(a, b, c);
            assert!(
                (got / exact - 1.0).abs() <= 4.0 * f64::EPSILON,
                "{d}: {got} {exact}"
            );
            // In every vertex order (a rotation keeps the sign).
            assert_eq!(cross_accurate(b, c, a), got);
            assert_eq!(cross_accurate(c, a, b), got);
        }
        assert_eq!(cross_accurate([0.0, 0.0], [1.0, 0.5], [0.3, 0.15]), 0.0);
    }

    #[test]
    fn a_right_triangle_has_half_its_hypotenuse_as_radius() {
        let r = circumradius([0.0, 0.0], [4.0, 0.0], [0.0, 3.0]);
        assert!((r - 2.5).abs() < 1e-15);
        assert_eq!(
            circumradius([0.0, 0.0], [1.0, 1.0], [2.0, 2.0]),
            f64::INFINITY
        );
    }

    #[test]
    fn a_nearly_straight_set_is_collinear_within_the_tolerance() {
        let pts = [[0.0, 0.0], [1.0, 1.0], [2.0, 2.0 + 1e-12]];
        assert!(collinear(&pts, &Frame::of(&pts)));
        let tri = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]];
        assert!(!collinear(&tri, &Frame::of(&tri)));
    }
}
