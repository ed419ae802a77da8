"""Exactness of the optimum and of its shape against brute-force references.

Issue #2 ("Must show"): on thousands of small random point sets (clustered,
uniform, annuli with holes, near-duplicates, cocircular integer grids, thin
strips, pinches), ``optimal_alpha`` equals the alpha that
``reference.shapely_optimum`` finds by trying every spectrum value with
shapely, and the shapes equal the reference unions of triangles.
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest
import reference
import shapely
from example_counts import examples
from hypothesis import assume, event, given, note
from hypothesis import strategies as st
from scipy.spatial import QhullError

import geoalpha
from geoalpha import (
    DegenerateGroupWarning,
    alpha_shape,
    alpha_shapes,
    optimal_alpha,
)
from geoalpha import (
    _core as kernel,
)
from geoalpha._options import Request

# --------------------------------------------------------------------------
# Point-set strategies (coordinates in metres of some metric CRS)
# --------------------------------------------------------------------------

#: A coordinate in [-100, 100] on a 1e-6 grid: realistic, never subnormal.
COORD = st.integers(-(10**8), 10**8).map(lambda i: i / 10**6)
#: A number in [-1, 1] on a 1e-3 grid.
UNIT = st.integers(-1000, 1000).map(lambda i: i / 1000)


def as_points(rows) -> np.ndarray:
    return np.array(rows, dtype=float).reshape(-1, 2)


@st.composite
def uniform(draw):
    return as_points(draw(st.lists(st.tuples(COORD, COORD), min_size=3, max_size=25)))


@st.composite
def clustered(draw):
    centres = as_points(draw(st.lists(st.tuples(COORD, COORD), min_size=1, max_size=3)))
    spread = draw(st.sampled_from([0.01, 0.1, 1.0, 5.0, 10.0]))
    n = draw(st.integers(3, 25))
    which = draw(st.lists(st.integers(0, len(centres) - 1), min_size=n, max_size=n))
    offset = as_points(draw(st.lists(st.tuples(UNIT, UNIT), min_size=n, max_size=n)))
    return centres[which] + spread * offset


@st.composite
def annulus(draw):
    """Two jittered rings of k points each: shapes with a hole in the middle."""
    k = draw(st.integers(6, 12))
    width = draw(st.sampled_from([0.1, 0.2, 0.35, 0.6]))
    scale = draw(st.sampled_from([1.0, 7.5, 100.0, 1000.0]))
    centre = np.array([draw(COORD), draw(COORD)])
    wobble = st.integers(-100, 100).map(lambda i: i / 100)
    turn = np.array(draw(st.lists(wobble, min_size=2 * k, max_size=2 * k)))
    depth = np.array(draw(st.lists(wobble, min_size=2 * k, max_size=2 * k)))
    theta = 2 * np.pi * (np.r_[np.arange(k), np.arange(k) + 0.5] + 0.3 * turn) / k
    rho = scale * (np.repeat([1.0, 1.0 + width], k) + 0.3 * width * depth)
    return centre + np.c_[rho * np.cos(theta), rho * np.sin(theta)]


def near_duplicates(smallest=1e-8, largest=1e-6):
    """A few points plus copies of some of them moved by 0 or smallest..largest.

    At coordinates ~100 the default moves are 1e-10..1e-8 of the extent (GPS
    jitter at the km scale is ~1e-6). Much closer (~1e-12 of the extent) is
    Qhull's own precision: it merges points there, and float64 geometry around
    such needles is not reliable (see docs/user_guide/guarantee.md);
    test_merged_points_are_covered checks what geoalpha still promises there.
    """
    magnitude = st.integers(round(smallest * 1e12), round(largest * 1e12))
    shift = st.just(0.0) | st.builds(
        lambda m, s: s * m * 1e-12, magnitude, st.sampled_from([-1, 1])
    )

    @st.composite
    def build(draw):
        base = draw(uniform().filter(lambda p: len(p) <= 12))
        k = draw(st.integers(1, 13))
        copy_of = draw(st.lists(st.integers(0, len(base) - 1), min_size=k, max_size=k))
        moves = as_points(
            draw(st.lists(st.tuples(shift, shift), min_size=k, max_size=k))
        )
        return np.r_[base, base[copy_of] + moves]

    return build()


@st.composite
def cocircular(draw):
    """Subsets of integer grids and of lattice points on one circle."""
    if draw(st.booleans()):
        w, h = draw(st.integers(2, 6)), draw(st.integers(2, 6))
        ij = np.array([(i, j) for i in range(w) for j in range(h)], dtype=float)
    else:
        r2 = draw(st.sampled_from([25, 65, 325]))
        m = math.isqrt(r2)
        ij = np.array(
            [
                (i, j)
                for i in range(-m, m + 1)
                for j in range(-m, m + 1)
                if i * i + j * j == r2
            ]
            + [(0, 0)] * draw(st.booleans()),
            dtype=float,
        )
    keep = np.array(draw(st.lists(st.booleans(), min_size=len(ij), max_size=len(ij))))
    rows = ij[keep] if keep.sum() >= 3 else ij
    step = draw(st.sampled_from([1.0, 0.1, 0.5, 3.0, 1000.0]))
    offset = np.array(draw(st.tuples(*[st.integers(-(10**6), 10**6)] * 2)), float)
    return rows * step + offset


@st.composite
def thin_strip(draw):
    """Nearly collinear points: a strip 2**-3 .. 2**-16 as wide as it is long.

    Coordinates are dyadic (exact in binary) and the strip is turned by 0, 90
    or 45 degrees with exact maps, so near-collinearity is in the data, not
    an artefact of rounding: a rotation by an arbitrary angle would make
    collinear points merely nearly collinear, with circumradii that no
    float64 method gets to 1e-9 (relative error ~ eps / sin of the angle).
    """
    n = draw(st.integers(3, 25))
    length = 2.0 ** draw(st.integers(-4, 10))
    width = length * 2.0 ** -draw(st.sampled_from([3, 6, 10, 13, 16]))
    tick = st.integers(-1024, 1024).map(lambda i: i / 1024)
    x = np.array(draw(st.lists(tick, min_size=n, max_size=n))) * length
    y = np.array(draw(st.lists(tick, min_size=n, max_size=n))) * width
    turn = draw(st.sampled_from(["none", "quarter", "diagonal"]))
    if turn == "quarter":
        x, y = -y, x
    elif turn == "diagonal":
        x, y = x - y, x + y
    offset = draw(st.tuples(st.integers(-(10**4), 10**4), st.integers(-(10**4), 10**4)))
    return np.c_[x, y] + np.array(offset, dtype=float)


def bowtie_points(jitter=(), lobe=2):
    """Two fans of triangles touching at the origin only."""
    a = np.radians([-40.0, 40.0, -20.0, 20.0, 0.0][:lobe])
    left = -np.c_[2 * np.cos(a), np.sin(a) * 2]
    right = np.c_[2.5 * np.cos(a), np.sin(a) * 2.5]
    p = np.r_[[[0.0, 0.0]], left, right]
    moves = as_points(jitter)[: len(p) - 1]
    p[1 : 1 + len(moves)] += moves
    return p


def keyhole_points(k=12, jitter=()):
    """A ring of points around a hole that touches the convex hull at one point.

    With ``holes=True`` the optimal shape is a Polygon whose hole meets its
    shell at the vertex (1.35, 0).
    """
    t = 2 * np.pi * np.arange(k) / k
    inner = np.c_[np.cos(t), np.sin(t)]
    outer = 1.3 * np.c_[np.cos(t + np.pi / k), np.sin(t + np.pi / k)]
    inner[0] = [1.35, 0.0]
    p = np.r_[inner, outer]
    moves = as_points(jitter)[: len(p)]
    p[: len(moves)] += moves
    return p


@st.composite
def pinch(draw):
    """Bow-ties and keyholes, rotated, scaled and slightly jittered."""
    small = st.integers(-20, 20).map(lambda i: i * 1e-3)
    jitter = draw(st.lists(st.tuples(small, small), max_size=24))
    if draw(st.booleans()):
        p = bowtie_points(jitter, lobe=draw(st.integers(2, 5)))
    else:
        p = keyhole_points(draw(st.sampled_from([10, 12, 14])), jitter)
    theta = np.radians(draw(st.integers(0, 359)))
    c, s = np.cos(theta), np.sin(theta)
    scale = draw(st.sampled_from([1.0, 0.01, 37.0, 2000.0]))
    return scale * (p @ np.array([[c, s], [-s, c]])) + np.array(
        [draw(COORD), draw(COORD)]
    )


#: Strategies on which geoalpha is expected to match the reference to 1e-9.
STRATEGIES = {
    "uniform": uniform(),
    "clustered": clustered(),
    "annulus": annulus(),
    "cocircular": cocircular(),
    "thin_strip": thin_strip(),
    "pinch": pinch(),
}

# --------------------------------------------------------------------------
# Checks
# --------------------------------------------------------------------------


def reference_triangulation(p):
    """The reference triangulation, or None if the set is degenerate."""
    try:
        return reference.triangulation(p)
    except (QhullError, ValueError):
        return None


def parts(geom) -> int:
    if geom.is_empty:
        return 0
    return len(geom.geoms) if geom.geom_type == "MultiPolygon" else 1


def count_holes(geom) -> str:
    polygons = getattr(geom, "geoms", [geom])
    return "some" if any(len(g.interiors) for g in polygons) else "no"


def assert_same_region(got, expected, slack=0.0):
    """Symmetric difference area <= 1e-9 of the area (+ ``slack``, tiny floor)."""
    diff = shapely.symmetric_difference(got, expected).area
    assert diff <= 1e-9 * max(expected.area, got.area) + slack + 1e-300, (
        f"shapes differ by area {diff} (areas {got.area}, {expected.area})"
    )


def assert_vertices_are_inputs(geom, p):
    inputs = set(map(tuple, p.tolist()))
    stray = [
        c for c in map(tuple, shapely.get_coordinates(geom).tolist()) if c not in inputs
    ]
    assert not stray, f"polygon vertices that are not input points: {stray[:5]}"


def assert_optimal_shape(shape, p, components):
    """What issue #2 promises of the shape at the optimum."""
    assert shapely.is_valid(shape), shapely.is_valid_reason(shape)
    assert not shape.is_empty
    if components == 1:
        assert shape.geom_type == "Polygon"
    else:
        assert shape.geom_type in ("Polygon", "MultiPolygon")
        assert parts(shape) <= components
    outside = ~shapely.covers(shape, shapely.points(p))
    assert not outside.any(), f"input points outside the shape: {p[outside][:5]}"
    assert_vertices_are_inputs(shape, p)


def probe_alphas(r) -> list[float]:
    """Alphas strictly between spectrum values, above all, and 0 (hull).

    Between two radii that differ by more than 1e-6 (relative) the shape does
    not depend on how either radius is rounded.
    """
    finite = np.unique(r[np.isfinite(r)])
    gap = finite[1:] > finite[:-1] * (1 + 1e-6)
    between = 1.0 / np.sqrt(finite[1:] * finite[:-1])[gap]
    return [0.0, 2.0 / finite[0], *between.tolist()]


def same_triangulation(p, tri) -> bool:
    """Whether geoalpha's triangulation of ``p`` has the reference's spectrum.

    The reference triangulates with Qhull, in floating point: for nearly
    collinear or nearly coincident points its output depends on the order
    and origin of the coordinates and may not be the Delaunay triangulation
    that geoalpha's exact predicates find. The optimum is exact relative to
    a triangulation, so the comparison is made when both have the same
    circumradius spectrum (the kernel's validity curve with holes kept lists
    every distinct merged radius).
    """
    xy = np.asarray(p, dtype=float)
    codes = np.zeros(len(xy), dtype=np.int64)
    ours = kernel.solve(xy, codes, 1, Request(holes=True, curve=True))
    if ours.reason[0] != 0:
        return False
    values = ours.curve[0]
    theirs = reference.spectrum(tri[3])
    return len(values) == len(theirs) and bool(
        np.allclose(values, theirs, rtol=1e-9, atol=0)
    )


def well_conditioned(tri, limit: float = 1e6) -> bool:
    """Whether every circumradius is determined well beyond 1e-9 in float64.

    The relative error of a float circumradius grows like eps times
    (longest edge)^2 / (2 * area); past ``limit`` (relative error ~1e-10)
    rounding alone can swap two spectrum values that the exact reference
    orders, so only geoalpha's own promises are checked there.
    """
    pts, simplices = tri[0], tri[1]
    a, b, c = (pts[simplices[:, k]] for k in range(3))
    cross = np.abs((b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0])
    longest = np.max(
        [np.square(b - a).sum(1), np.square(c - b).sum(1), np.square(a - c).sum(1)],
        axis=0,
    )
    with np.errstate(divide="ignore"):
        return bool((longest / cross < limit).all())


def check_against_reference(p, holes, components, data):
    note(f"points = np.array({p.tolist()!r})")
    tri = reference_triangulation(p)
    if tri is None:  # fewer than 3 distinct points or collinear
        with warnings.catch_warnings(record=True):
            warnings.simplefilter("always")
            a = optimal_alpha(p, holes=holes, components=components)
        if not math.isnan(a):  # Qhull triangulated geoalpha's (sorted) input
            assert_optimal_shape(alpha_shape(p, holes=holes), p, components)
        return
    if not (same_triangulation(p, tri) and well_conditioned(tri)):
        # Different but equally legitimate float triangulations: geoalpha's
        # own promises must still hold (valid, covering, input vertices).
        event("triangulations differ (ill-conditioned input)")
        with warnings.catch_warnings(record=True):
            warnings.simplefilter("always")
            a = optimal_alpha(p, holes=holes, components=components)
            if not math.isnan(a):
                shape = alpha_shape(p, holes=holes, components=components)
                assert_optimal_shape(shape, p, components)
        return
    a_ref, shape_ref = reference.shapely_optimum(p, holes=holes, components=components)
    note(f"reference alpha {a_ref!r}")

    a = optimal_alpha(p, holes=holes, components=components)
    assert a == pytest.approx(a_ref, rel=1e-9, abs=0)

    shape = alpha_shape(p, holes=holes, components=components)
    assert_optimal_shape(shape, p, components)
    # Near-duplicates merged into one point (closer than the tolerance) are
    # taken in as vertices: each may add a sliver of width < tolerance.
    merged = len(np.unique(p, axis=0)) - len(tri[0])
    slack = merged * reference.tolerance(p) * 2 * float(np.ptp(p, axis=0).max())
    assert_same_region(shape, shape_ref, slack)
    event(f"optimum: {shape.geom_type}, {count_holes(shape)} hole(s)")
    # Feeding the optimum back gives the optimal shape (inclusive solid test).
    assert_same_region(alpha_shape(p, a, holes=holes), shape_ref, slack)

    pts, simplices, neighbors, r = tri
    alphas = data.draw(
        st.lists(st.sampled_from(probe_alphas(r)), min_size=1, max_size=3, unique=True),
        label="alphas",
    )
    for alpha in alphas:
        radius = 1.0 / alpha if alpha > 0 else math.inf
        mask = reference.shape_mask(neighbors, r, radius, holes)
        got = alpha_shape(p, alpha, holes=holes)
        if not mask.any():
            event("probe: nothing solid")
            assert got.geom_type == "Polygon" and got.is_empty, (alpha, got.wkt)
            continue
        expected = reference.shapely_shape(pts, simplices, mask)
        event(f"probe: {expected.geom_type}, {count_holes(expected)} hole(s)")
        assert shapely.is_valid(got), (alpha, shapely.is_valid_reason(got))
        assert (got.geom_type, parts(got)) == (expected.geom_type, parts(expected)), (
            alpha
        )
        # At every alpha, merged near-duplicates outside the shape beside a
        # ring vertex are taken in as vertices, as at the optimum (issue #37).
        assert_same_region(got, expected, slack)
        assert_vertices_are_inputs(got, p)


HOLES_COMPONENTS = pytest.mark.parametrize(
    ("holes", "components"), [(False, 1), (True, 1), (False, 2), (True, 2)]
)


# --------------------------------------------------------------------------
# Tests
# --------------------------------------------------------------------------


@HOLES_COMPONENTS
@pytest.mark.parametrize("kind", list(STRATEGIES))
@examples(200)
@given(data=st.data())
def test_optimum_matches_reference(kind, holes, components, data):
    p = data.draw(STRATEGIES[kind], label="points")
    check_against_reference(p, holes, components, data)


@HOLES_COMPONENTS
@given(data=st.data())
def test_near_duplicates_match_reference(holes, components, data):
    p = data.draw(near_duplicates(), label="points")
    check_against_reference(p, holes, components, data)


def test_needle_triangle_radius():
    # (100 + 1e-6, 3e-7) is a near-duplicate of (100, 0), 1e-8 of the extent
    # away: above the merge tolerance (1e-9), so it stays a vertex, and the
    # optimum is 1 / r of the needle triangle (100, 0), (30, 90), that point.
    # Its circumradius must be accurate to ~1e-15 (exact rational reference),
    # although its cross product cancels to 1e-8 of its terms.
    p = np.array([[0, 0], [100, 0], [30, 90], [100.000001, 3e-7]])
    needle = reference.exact_circumradius(p[1], p[2], p[3])
    assert optimal_alpha(p) == pytest.approx(1 / needle, rel=1e-14)
    assert reference.graph_optimum(p) == pytest.approx(1 / needle, rel=1e-14)


@st.composite
def slivers(draw):
    """Points exactly on y = x / 2, one a flatness of 1e-12..1e-6 off it, one far off.

    The off point's triangles with the line are nearly flat (issue #37, repro
    02): its smallest radius is the optimum, a needle's radius. The far point
    (below the line) keeps the group from being collinear.
    """
    xs = draw(st.lists(st.integers(0, 800), min_size=3, max_size=7, unique=True))
    line = [(x / 8, x / 16) for x in xs]  # exact: y is x / 2
    flat = 10.0 ** draw(st.floats(-12, -6))
    ax = draw(st.integers(0, 800).filter(lambda x: x not in xs)) / 8
    apex = (ax, ax / 2 + flat * 100)
    far = draw(st.integers(0, 800)) / 8
    return np.array([*line, apex, (far, far / 2 - draw(st.sampled_from([5, 20, 60])))])


@examples(200)
@given(p=slivers())
def test_sliver_radii_are_exact_to_a_few_ulps(p):
    # Issue #37 (item 4): the optimum against a rational Delaunay triangulation
    # and correctly rounded radii, on flatnesses 1e-12..1e-6 of the extent.
    assume(not reference.is_collinear(p))
    exact = reference.exact_delaunay(p)
    assume(exact is not None)
    simplices, neighbors = exact
    r = np.array([reference.exact_circumradius(*p[s]) for s in simplices])
    for holes in (False, True):
        want = reference.mesh_optimum(len(p), simplices, neighbors, r, holes)
        # A few ulps: the radius's and the division's roundings.
        assert optimal_alpha(p, holes=holes) == pytest.approx(want, rel=1e-15, abs=0)


def test_the_needle_fan_of_repro_02_is_exact():
    # 196 points on y = x / 2 and one 3.5e-9 of the extent off it: the fan's
    # largest radius was off by 2.4e-9 (the float determinant of orient2d).
    from fractions import Fraction as F

    xs = np.linspace(0, 100, 196)
    line = np.c_[xs, xs / 2]
    apex = np.array([50.0, 25 + 3.5e-7])
    p = np.r_[[apex], line]

    def r2(a, b, c):
        (ax, ay), (bx, by), (cx, cy) = ((F(u), F(v)) for u, v in (a, b, c))
        cr = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
        sq = [
            (u - v) ** 2 + (w - z) ** 2
            for u, w, v, z in ((ax, ay, bx, by), (bx, by, cx, cy), (cx, cy, ax, ay))
        ]
        return sq[0] * sq[1] * sq[2] / (4 * cr * cr)

    want = math.sqrt(float(max(r2(apex, line[i], line[i + 1]) for i in range(195))))
    assert 1 / optimal_alpha(p) == pytest.approx(want, rel=4e-16, abs=0)


def test_near_duplicate_below_tolerance_is_merged():
    # 1e-11 of the extent apart: one point (docs/user_guide/guarantee.md).
    # The optimum is that of the three other points, and the merged point is
    # still covered, as a vertex of the polygon.
    p = np.array([[0, 0], [100, 0], [30, 90], [100.000000001, 3e-10]])
    triangle = reference.exact_circumradius(p[0], p[1], p[2])
    assert optimal_alpha(p) == pytest.approx(1 / triangle, rel=1e-14)
    shape = alpha_shape(p)
    assert shapely.covers(shape, shapely.points(p)).all()
    assert_vertices_are_inputs(shape, p)


def test_merged_point_is_covered():
    # Minimal reproducer: Qhull merges (0, -1e-14) into the vertex (0, 0); the
    # triangle (0, 0), (10, 0), (0, 10) is returned and misses (0, -1e-14).
    p = np.array([[0, 0], [10, 0], [0, 10], [0, -1e-14]])
    shape = alpha_shape(p)
    assert shapely.covers(shape, shapely.points(p)).all(), shape.wkt


@given(p=near_duplicates(smallest=1e-13, largest=1e-11))
def test_merged_points_are_covered(p):
    # No reference needed: every input point must be in the optimal shape.
    assume(reference_triangulation(p) is not None)
    for holes in (False, True):
        shape = alpha_shape(p, holes=holes)
        outside = ~shapely.covers(shape, shapely.points(p))
        assert not outside.any(), f"{p[outside]} outside {shape.wkt}"


@st.composite
def tiny_at_an_offset(draw):
    """A group ~1e-9 across at an offset of up to 1e3 (issue #37, repro 07)."""
    n = draw(st.integers(4, 40))
    seed = draw(st.integers(0, 2**32 - 1))
    offset = draw(st.tuples(st.integers(-1000, 1000), st.integers(-1000, 1000)))
    rng = np.random.default_rng(seed)
    return rng.random((n, 2)) * 1e-9 + np.array(offset, dtype=float)


FED_BACK = {
    "near_duplicates": near_duplicates(smallest=1e-14, largest=1e-6),
    "tiny_at_an_offset": tiny_at_an_offset(),
    "uniform": uniform(),
}


def assert_the_optimum_feeds_back(p, holes):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DegenerateGroupWarning)
        alpha = optimal_alpha(p, holes=holes)
        assume(np.isfinite(alpha))
        best = alpha_shape(p, holes=holes)
        fed = alpha_shape(p, alpha=alpha, holes=holes)
    points = shapely.points(p)
    assert shapely.covers(best, points).all()
    assert shapely.covers(fed, points).all(), f"{p[~shapely.covers(fed, points)]}"
    assert fed.equals(best), f"{fed.wkt} != {best.wkt}"
    assert fed.area == pytest.approx(best.area, rel=1e-12, abs=0)


@pytest.mark.parametrize("holes", [False, True])
@pytest.mark.parametrize("kind", list(FED_BACK))
@examples(200)
@given(data=st.data())
def test_the_optimal_alpha_fed_back_gives_the_optimal_shape(kind, holes, data):
    # Issue #37 (item 3): alpha_shape(p, alpha=optimal_alpha(p)) is the optimal
    # shape, merged near-duplicates and holes included.
    assert_the_optimum_feeds_back(data.draw(FED_BACK[kind], label="points"), holes)


@pytest.mark.parametrize("holes", [False, True])
@pytest.mark.parametrize(
    "name", ["roundtrip_near_duplicates", "roundtrip_tiny_extent_holes"]
)
def test_the_campaign_round_trips_feed_back(name, holes):
    # Issue #37, repros 05 and 07 (tests/data/README.md): the fed-back shape left
    # 14 merged points outside, or had a triangle less.
    p = np.load(Path(__file__).parent / "data" / "issue37" / f"{name}.npy")
    assert_the_optimum_feeds_back(p, holes)


def test_merged_points_off_the_shape_are_vertices_of_the_kernel_polygon():
    # Issue #37 (item 2, repro 03): a chain of 4,000 points 0.5 x the tolerance
    # apart is one point; the 3,999 merged ones are outside the shape's turn
    # at their representative and come back from the kernel as ring vertices,
    # in order (no take-in one at a time, which was quadratic).
    n = 4000
    chain = np.c_[200 + np.arange(n) * 0.5e-6, np.full(n, 200.0)]
    p = np.r_[[[0, 0], [1000, 0], [0, 1000]], chain]
    res = kernel.solve(p, np.zeros(len(p), dtype=np.int64), 1, Request(n_jobs=1))
    assert res.n_distinct.tolist() == [4]
    assert res.certain.all()
    ring = shapely.get_coordinates(res.geometry[0])
    assert len(ring) == len(p) + 1
    assert res.geometry[0].is_valid
    assert shapely.covers(res.geometry[0], shapely.points(p)).all()


def test_bowtie_by_hand():
    # Triangles O-A-B and O-C-D (circumradius 1.25) touch at O only; the
    # top and bottom triangles O-A-C, O-B-D have circumradius 2.5.
    p = np.array([[0, 0], [-2, 1], [-2, -1], [2, 1], [2, -1]], dtype=float)
    assert optimal_alpha(p) == pytest.approx(1 / 2.5, rel=1e-12)
    assert optimal_alpha(p, components=2) == pytest.approx(1 / 1.25, rel=1e-12)
    two = alpha_shape(p, components=2)
    assert two.geom_type == "MultiPolygon" and len(two.geoms) == 2
    assert shapely.is_valid(two) and two.area == pytest.approx(4.0)
    assert alpha_shape(p).equals(shapely.convex_hull(shapely.multipoints(p)))


@pytest.mark.parametrize("k", [10, 12, 14])
def test_keyhole_by_hand(k):
    p = keyhole_points(k)
    pinch_vertex = (1.35, 0.0)
    kept = alpha_shape(p, holes=True)
    assert kept.geom_type == "Polygon" and shapely.is_valid(kept)
    assert len(kept.interiors) == 1
    assert pinch_vertex in kept.exterior.coords
    assert pinch_vertex in kept.interiors[0].coords
    filled = alpha_shape(p)
    assert filled.geom_type == "Polygon" and not filled.interiors
    # The hole is the inner polygon, whose triangles are not solid.
    assert filled.area - kept.area == pytest.approx(
        shapely.Polygon(kept.interiors[0]).area, rel=1e-12
    )
    assert optimal_alpha(p) == optimal_alpha(p, holes=True)


DEGENERATE_GROUPS = [
    np.array([[5.0, 5.0]]),
    np.array([[0.0, 0.0], [3.0, 4.0], [6.0, 8.0], [3.0, 4.0]]),
]


@HOLES_COMPONENTS
@examples(60)
@given(data=st.data())
def test_batched_equals_per_group(holes, components, data):
    sets = data.draw(
        st.lists(
            st.one_of(*STRATEGIES.values()) | st.sampled_from(DEGENERATE_GROUPS),
            min_size=2,
            max_size=5,
        ),
        label="groups",
    )
    points = np.concatenate(sets)
    codes = np.repeat(np.arange(len(sets)), [len(p) for p in sets])
    order = np.array(data.draw(st.permutations(range(len(points))), label="order"))
    res = alpha_shapes(points[order], codes[order], holes=holes, components=components)

    assert len(res.alpha) == len(res.geometry) == len(sets)
    for g, p in enumerate(sets):
        assert res.n_points[g] == len(p)
        assert res.n_distinct[g] == len(np.unique(p, axis=0))
        degenerate = reference_triangulation(p) is None
        assert res.degenerate[g] == degenerate
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DegenerateGroupWarning)
            alone_alpha = optimal_alpha(p, holes=holes, components=components)
            alone = alpha_shape(p, holes=holes, components=components)
        if degenerate:
            assert math.isnan(res.alpha[g]) and math.isnan(alone_alpha)
            assert res.geometry[g].geom_type == "Polygon" and res.geometry[g].is_empty
            assert res.n_parts[g] == 0
            continue
        assert res.alpha[g] == pytest.approx(alone_alpha, rel=1e-9, abs=0)
        assert res.geometry[g].geom_type == alone.geom_type
        assert res.n_parts[g] == parts(alone)
        assert_same_region(res.geometry[g], alone)


@pytest.mark.parametrize("holes", [False, True], ids=["filled", "holes"])
@pytest.mark.parametrize("kind", list(STRATEGIES))
@examples(25)
@given(data=st.data())
def test_the_critical_triangle_has_the_optimal_radius(kind, holes, data):
    """explain()'s critical triangle: its exact circumradius is the radius (#35).

    Cocircular sets and grids tie many triangles at the optimum: the rule
    (the largest circumradius of the tie run) names one whose radius is it.
    """
    import geopandas as gpd

    p = data.draw(STRATEGIES[kind], label="points")
    frame = gpd.GeoDataFrame(geometry=shapely.points(p))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        why = geoalpha.explain(frame, crs=None, holes=holes, suspicious=False)
    if why["limited_by"].item() == "degenerate":
        return
    rows = why["critical_rows"].item()
    corners = p[rows[:3]]
    radius = reference.exact_circumradius(*corners)
    assert radius == pytest.approx(why["radius"].item(), rel=1e-12, abs=0)
    assert why["limited_by"].item() in ("coverage", "connection")


@pytest.mark.parametrize("holes", [False, True], ids=["filled", "holes"])
@examples(40)
@given(data=st.data())
def test_the_hull_from_coordinates_read_already_is_the_reference_optimum(holes, data):
    # dask's partitions hand hull()'s pipeline the shuffled x/y instead of
    # geometries (pipeline.run(xy=...)): the reference optimum of every group,
    # and the table of the geometries' path, bit for bit.
    import geopandas as gpd
    from geopandas.testing import assert_geodataframe_equal

    from geoalpha._frame.pipeline import run
    from geoalpha._options import Options

    sets = data.draw(
        st.lists(st.one_of(*STRATEGIES.values()), min_size=1, max_size=3),
        label="groups",
    )
    points = np.concatenate(sets)
    codes = np.repeat(np.arange(len(sets)), [len(p) for p in sets])
    order = np.array(data.draw(st.permutations(range(len(points))), label="order"))
    xy, codes = np.ascontiguousarray(points[order]), codes[order]
    frame = gpd.GeoDataFrame({"g": codes}, geometry=shapely.points(xy), crs=None)
    bare = frame.set_geometry(gpd.GeoSeries([None] * len(frame), index=frame.index))
    options = Options.from_kwargs({"crs": None, "holes": holes, "suspicious": False})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DegenerateGroupWarning)
        table, _ = run(frame, "g", options)
        got, _ = run(bare, "g", options, xy=xy)
    assert_geodataframe_equal(got, table)
    assert got.geom_equals_exact(table, tolerance=0).all()
    for g, p in enumerate(sets):
        tri = reference_triangulation(p)
        if tri is None or not (same_triangulation(p, tri) and well_conditioned(tri)):
            continue  # (check_against_reference's other branches: no reference)
        a_ref, _ = reference.shapely_optimum(p, holes=holes)
        assert got["alpha"].iloc[g] == pytest.approx(a_ref, rel=1e-9, abs=0)
        event("a group compared with the reference")
