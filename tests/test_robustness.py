"""The guarantee on near-degenerate input (issue #10).

For every group: a valid Polygon/MultiPolygon that covers every input point
(``shapely.covers``, distance 0, in the coordinates it is returned in), or
a group declared degenerate with a ``DegenerateGroupWarning``. Nothing but
``InvalidInputError`` is raised, and nothing takes more than 10 s.

Families (hypothesis): nearly collinear points at any rotation and offset
with noise 1e-15 .. 1e-6 of the length, near-duplicate pairs 1e-15 .. 1e-6
apart, last-bit duplicates, rounded GPS grids, extreme scales 1e-9 .. 1e9
with offsets up to 1e7, and lon/lat groups on one meridian or one parallel
through ``hull()``. Then the issue's reproducers, one test each.
"""

from __future__ import annotations

import datetime
import warnings

import geopandas as gpd
import numpy as np
import pandas as pd
import pytest
import shapely
import shapely.affinity
from example_counts import examples as scaled_examples
from hypothesis import given, settings
from hypothesis import strategies as st

import geoalpha
from geoalpha import (
    DegenerateGroupWarning,
    InvalidInputError,
    alpha_shape,
    alpha_shapes,
    optimal_alpha,
)
from geoalpha._core import REPAIR_RTOL
from geoalpha._options import Request

TEN_SECONDS = datetime.timedelta(seconds=10)


def examples(n: int) -> settings:
    """n examples per family in the "ci" profile (tests/example_counts.py)."""
    return scaled_examples(n, deadline=TEN_SECONDS)


def check_guarantee(p, repaired=False, **options):
    """Run alpha_shape and assert the guarantee; return the shape or None.

    ``repaired``: the family may need the documented repair of the check where
    polygons are returned (a point GEOS cannot take in as a vertex: its ear,
    widened by ``REPAIR_RTOL`` times the extent, at least 1); then the polygon
    must stay within that width of the points instead of having only input
    points as vertices.
    """
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            shape = alpha_shape(p, **options)
        except InvalidInputError:
            return None
    declared = any(issubclass(w.category, DegenerateGroupWarning) for w in caught)
    if declared:
        assert shape.is_empty
        return None
    assert shape.geom_type in ("Polygon", "MultiPolygon"), shape.geom_type
    assert shapely.is_valid(shape), shapely.is_valid_reason(shape)
    assert not shape.is_empty
    outside = ~shapely.covers(shape, shapely.points(p))
    assert not outside.any(), f"points outside: {p[outside][:5].tolist()}"
    # Every polygon vertex is an input point (or, repaired, near them).
    inputs = set(map(tuple, np.asarray(p, dtype=float).tolist()))
    corners = set(map(tuple, shapely.get_coordinates(shape).tolist()))
    if repaired and not corners <= inputs:
        extent = max(np.ptp(p, axis=0).max(), np.abs(p).max(), 1.0)
        width = 2 * REPAIR_RTOL * extent
        near = shapely.buffer(shapely.multipoints(p).convex_hull, width)
        assert near.covers(shape)  # no more than the repair's width added
        return shape
    assert corners <= inputs, sorted(corners - inputs)[:5]
    return shape


def rotate(p, theta, offset):
    c, s = np.cos(theta), np.sin(theta)
    return p @ np.array([[c, s], [-s, c]]) + offset


ANGLE = st.floats(0, 2 * np.pi)
OFFSET = st.tuples(st.floats(-1e7, 1e7), st.floats(-1e7, 1e7))
HOLES = st.booleans()


@examples(150)
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(3, 40),
    noise=st.floats(-15, -6),
    length=st.floats(-3, 5),
    theta=ANGLE,
    offset=OFFSET,
    holes=HOLES,
)
def test_nearly_collinear(seed, n, noise, length, theta, offset, holes):
    rng = np.random.default_rng(seed)
    size = 10.0**length
    t = rng.random(n) * size
    p = np.c_[t, rng.normal(size=n) * size * 10.0**noise]
    check_guarantee(rotate(p, theta, offset), holes=holes)


@examples(150)
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(3, 20),
    gap=st.floats(-15, -6),
    theta=ANGLE,
    offset=OFFSET,
    holes=HOLES,
    components=st.integers(1, 2),
)
def test_near_duplicate_pairs(seed, n, gap, theta, offset, holes, components):
    rng = np.random.default_rng(seed)
    base = rng.random((n, 2)) * 100
    moved = base + rng.normal(size=base.shape) * 100 * 10.0**gap
    p = rotate(np.r_[base, moved], theta, offset)
    check_guarantee(p, holes=holes, components=components)


@examples(100)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(3, 30), holes=HOLES)
def test_last_bit_duplicates(seed, n, holes):
    rng = np.random.default_rng(seed)
    lon = -3 + rng.random(n) * 0.01
    lat = 51 + rng.random(n) * 0.01
    twin = np.c_[np.degrees(np.radians(lon)), np.nextafter(lat, 90)]
    check_guarantee(np.r_[np.c_[lon, lat], twin], holes=holes)


@examples(100)
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(3, 60),
    digits=st.integers(3, 6),
    holes=HOLES,
)
def test_rounded_gps_grid(seed, n, digits, holes):
    rng = np.random.default_rng(seed)
    p = np.round(np.c_[-2 + rng.random(n) * 0.01, 53 + rng.random(n) * 0.01], digits)
    check_guarantee(p, holes=holes)


@examples(100)
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(3, 30),
    scale=st.floats(-9, 9),
    offset=st.floats(-1e7, 1e7),
    holes=HOLES,
)
def test_extreme_scales(seed, n, scale, offset, holes):
    rng = np.random.default_rng(seed)
    p = rng.random((n, 2)) * 10.0**scale + offset
    check_guarantee(p, holes=holes)


TINY = st.one_of(
    st.sampled_from([0.0, 5e-324, -5e-324, 1e-60, -1e-300]),
    st.builds(lambda m, e: m * 2.0**-e, st.floats(-2, 2), st.integers(142, 1074)),
)


@examples(100)
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(3, 30),
    # (Groups below about 1e-100 across are left out: there the products of
    # the Python repair's near-duplicate take-in underflow, see issue #37.)
    scale=st.integers(-300, 900),
    tiny=st.lists(st.tuples(TINY, TINY), min_size=1, max_size=4),
    holes=HOLES,
)
def test_tiny_and_subnormal_coordinates_beside_zero(seed, n, scale, tiny, holes):
    # Issue #37: below 2^-142 of the extent beside a 0, spade merged two
    # points and the kernel panicked; now they are one point, at any scale.
    rng = np.random.default_rng(seed)
    p = np.r_[[[0.0, 0.0]], rng.random((n, 2)), np.array(tiny)] * 2.0**scale
    # A merged point 1e-300 of the extent off its representative is a ring
    # vertex of the kernel's polygon, but GEOS's products underflow there and
    # call that ring invalid: the repair takes it in (hypothesis, ci profile).
    check_guarantee(p, repaired=True, holes=holes)


def lonlat_frame(lon, lat, group=None):
    frame = gpd.GeoDataFrame(
        {"g": group if group is not None else np.zeros(len(lon), dtype=int)},
        geometry=gpd.points_from_xy(lon, lat),
        crs="EPSG:4326",
    )
    return frame


def check_hull(frame, crs="auto"):
    """hull() in lon/lat: every group covered, or declared degenerate."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        hulls = frame.alpha.hull(by="g", crs=crs)
    text = " ".join(
        str(w.message) for w in caught if issubclass(w.category, DegenerateGroupWarning)
    )
    assert hulls.crs == frame.crs
    for key, row in zip(hulls["g"], hulls.geometry, strict=True):
        mine = frame.geometry[frame["g"] == key].to_numpy()
        if np.isnan(hulls.loc[hulls["g"] == key, "alpha"].iloc[0]):
            assert repr(key) in text or str(key) in text
            continue
        assert shapely.is_valid(row) and not row.is_empty
        assert shapely.covers(row, mine).all()
    return hulls


@pytest.mark.parametrize("crs", ["auto", "sphere"])
@examples(50)
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(3, 30),
    meridian=st.booleans(),
    twins=st.booleans(),
)
def test_one_meridian_or_parallel(crs, seed, n, meridian, twins):
    # Collinear in lon/lat: degenerate there, whatever their UTM image. On the
    # sphere a meridian is a great circle (degenerate on the sphere) and a
    # parallel a line in the lon/lat the result is returned in.
    rng = np.random.default_rng(seed)
    along = 50 + np.round(rng.random(n) * 0.01, 7)
    lon, lat = (np.full(n, -2.9), along) if meridian else (along - 52, np.full(n, 51.5))
    if twins:
        lon = np.r_[lon, np.degrees(np.radians(lon))]
        lat = np.r_[lat, lat]
    hulls = check_hull(lonlat_frame(lon, lat), crs=crs)
    assert np.isnan(hulls["alpha"]).all()
    assert (hulls.geometry.area > 0).all()  # the default policy: a buffer


@examples(40)
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(3, 40),
    noise=st.floats(-15, -6),
    digits=st.integers(3, 7),
)
def test_near_degenerate_lonlat_on_the_sphere(seed, n, noise, digits):
    # Nearly on the equator (a great circle), rounded like GPS, with last-bit
    # twins: covered on the sphere, or declared degenerate.
    rng = np.random.default_rng(seed)
    lon = np.round(rng.random(n) * 5, digits)
    lat = rng.normal(size=n) * 10.0**noise
    lon, lat = np.r_[lon, np.degrees(np.radians(lon))], np.r_[lat, lat]
    check_hull(lonlat_frame(lon, lat), crs="sphere")


# --------------------------------------------------------------------------
# The reproducers
# --------------------------------------------------------------------------


def recipe(seed):
    rng = np.random.default_rng(seed)
    n = rng.integers(4, 40)
    t = rng.random(n) * 100
    eps = 10 ** rng.uniform(-14, -10)
    return np.column_stack([t, rng.normal(size=n) * eps])


@pytest.mark.parametrize("seed", [334, 0, 2, 118])
@pytest.mark.parametrize("holes", [False, True])
def test_nearly_collinear_recipes_are_degenerate(seed, holes):
    # 334 never returned, 0 raised IndexError, 2 GEOSException, 118 invalid:
    # all within 1e-9 of the extent of a line, so degenerate, with a warning.
    p = recipe(seed)
    with pytest.warns(DegenerateGroupWarning, match="collinear"):
        shape = alpha_shape(p, holes=holes)
    assert shape.is_empty
    with pytest.warns(DegenerateGroupWarning):
        assert np.isnan(optimal_alpha(p, holes=holes))


def test_meridian_group_is_degenerate_not_empty():
    # 30 points on lon -2.9: hull() returned a finite alpha and an EMPTY
    # geometry. Now: degenerate (named), the default buffer holds them all.
    rng = np.random.default_rng(7)
    lat = 50 + np.round(rng.random(30) * 0.01, 7)
    frame = lonlat_frame(np.full(30, -2.9), lat, np.full(30, 5))
    with pytest.warns(DegenerateGroupWarning, match="'5'|5 "):
        hulls = frame.alpha.hull(by="g")
    assert np.isnan(hulls["alpha"][0])
    assert shapely.covers(hulls.geometry[0], frame.geometry.to_numpy()).all()


def test_near_duplicate_pairs_are_covered():
    # Each point copied and moved by 1e-14 .. 1e-11 of the extent: shapes
    # missed 17 points up to 21 % of the extent away, with no warning.
    rng = np.random.default_rng(3)
    base = rng.random((40, 2)) * 100
    for gap in (1e-14, 1e-13, 1e-12, 1e-11):
        p = np.r_[base, base + rng.normal(size=base.shape) * 100 * gap]
        for holes in (False, True):
            shape = check_guarantee(p, holes=holes)
            assert shape is not None  # 40 distinct points: a real shape
            # Merged (closer than 1e-9 of the extent), so the optimum is the
            # base points' optimum.
            assert optimal_alpha(p, holes=holes) == optimal_alpha(base, holes=holes)


def test_last_bit_duplicates_in_lonlat_are_covered():
    # np.degrees(np.radians(lon)) next to lon: 35 of 40 groups left points
    # outside by ~3e-17 degrees, with no warning.
    rng = np.random.default_rng(11)
    n = 40 * 12
    lon = -3 + rng.random(n) * 0.05
    lat = 51 + rng.random(n) * 0.05
    group = np.repeat(np.arange(40), 12)
    frame = lonlat_frame(
        np.r_[lon, np.degrees(np.radians(lon))], np.r_[lat, lat], np.r_[group, group]
    )
    hulls = frame.alpha.hull(by="g")
    for key, geom in zip(hulls["g"], hulls.geometry, strict=True):
        mine = frame.geometry[frame["g"] == key].to_numpy()
        assert shapely.covers(geom, mine).all()


@pytest.mark.parametrize("magnitude", [1e-60, 1e-9, 1e9, 1e52, 1e80])
def test_scale_extremes_give_right_answers(magnitude):
    # 1e-60 gave alpha inf, 1e52 gave 0, >= 1e80 NaN: alpha scales as 1/size.
    p = np.array([[0, 0], [4, 0], [4, 4], [0, 4], [2, 3.5]])
    expected = optimal_alpha(p)
    got = optimal_alpha(p * magnitude)
    assert got == pytest.approx(expected / magnitude, rel=1e-12)
    assert alpha_shape(p * magnitude).area == pytest.approx(15 * magnitude**2)


@pytest.mark.parametrize("magnitude", [1e-200, 1e-300])
def test_tiny_groups_give_right_answers_without_numpy_warnings(magnitude):
    # Down to ~1e-300 across (the audit: an overflow warning leaked from the
    # triangle areas below 1e-154, and the docs promised every scale).
    p = np.array([[0, 0], [4, 0], [4, 4], [0, 4], [2, 3.5]])
    expected = optimal_alpha(p)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        got = alpha_shapes(p * magnitude)
    assert got.alpha[0] == pytest.approx(expected / magnitude, rel=1e-12)
    assert shapely.covers(got.geometry[0], shapely.points(p * magnitude)).all()


def test_a_near_duplicate_qhull_drops_without_listing_it_is_merged():
    # The thorough profile: GEOS fails the group (a needle), Qhull then drops
    # the near-duplicate of (0, -1.000088) without listing it as coplanar,
    # and the group was declared collinear ("fewer than 3 or collinear").
    import reference

    p = np.array(
        [[0, 0], [0, 0], [0, 1e-6], [1e-6, 0], [0, -1.000088], [0, -1.0000880000010002]]
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        res = alpha_shapes(p)
    assert res.alpha[0] == pytest.approx(reference.graph_optimum(p), rel=1e-9)
    assert res.n_distinct[0] == 4
    assert shapely.covers(res.geometry[0], shapely.points(p)).all()


def test_alpha_zero_is_the_convex_hull_of_a_grid_with_flat_slivers():
    # A 3x3 grid straight to a few ulps: GEOS gives flat slivers along the
    # hull (radii ~1e16) that kept the rings from closing, and alpha 0 (and
    # method="convex") came back empty / degenerate.
    p = np.array(
        [
            [11.677334885683626, -4.516224862846358],
            [20.426289270916033, -4.516224862846356],
            [29.175243656148453, -4.516224862846357],
            [11.677334885683623, 4.232729522386055],
            [20.426289270916033, 4.232729522386054],
            [29.175243656148453, 4.232729522386053],
            [11.67733488568363, 12.98168390761846],
            [20.42628927091604, 12.981683907618464],
            [29.17524365614844, 12.981683907618466],
        ]
    )
    hull = shapely.convex_hull(shapely.multipoints(p))
    for alpha in [0.0, 2e-17]:
        res = alpha_shapes(p, alpha=alpha)
        assert not res.degenerate[0]
        assert res.geometry[0].is_valid
        assert res.geometry[0].area == pytest.approx(hull.area, rel=1e-12)
        assert shapely.covers(res.geometry[0], shapely.points(p)).all()
    frame = gpd.GeoDataFrame(geometry=gpd.points_from_xy(*p.T), crs="EPSG:27700")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        convex = frame.alpha.hull(method="convex")
    assert convex["alpha"].item() == 0.0
    assert convex.geometry.item().area == pytest.approx(hull.area, rel=1e-12)


def test_alpha_zero_covers_every_point_in_lon_lat():
    # Five nearly collinear lon/lat points along 7.5 km: the convex hull built
    # in metres folds in lon/lat; at alpha=0 the repaired polygon missed a
    # point, with no warning (a given alpha > 0 need not cover; alpha 0 must).
    xy = np.array(
        [
            [-11.850472428544453, -53.26773614925367],
            [-11.872486110821281, -53.290251182372295],
            [-11.837574507975809, -53.25455993753908],
            [-11.874526810620932, -53.29230953914366],
            [-11.903717277704017, -53.32212983244502],
        ]
    )
    frame = gpd.GeoDataFrame(geometry=gpd.points_from_xy(*xy.T), crs="EPSG:4326")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        hulls = frame.alpha.hull(alpha=0.0)
    geom = hulls.geometry.item()
    assert geom.is_valid
    assert shapely.covers(geom, frame.geometry.to_numpy()).all()


def test_a_chain_of_near_duplicates_where_pieces_touch_is_named_for_what_failed():
    # Six points plus a chain of 24 near-duplicates of one of them (merged
    # transitively), holes=True, components=3: taking the chain in where two
    # pieces touch gives no valid polygon of <= 3 parts in float64. The group
    # may be degenerate (the guarantee), but not "collinear" (it is not).
    p = np.array(
        [
            [72.48701777415407, 88.67564185836281],
            [72.48701723749176, 88.67564136273235],
            [92.86431642229985, 36.801844443163766],
            [72.48701759526664, 88.67564169315266],
            [47.295334859590334, 14.729254263427727],
            [72.48701848970381, 88.67564251920342],
            [72.48701735675004, 88.67564147287246],
            [72.4870172971209, 88.67564141780241],
            [72.48701807229979, 88.67564213371307],
            [72.48701854933296, 88.67564257427348],
            [72.48701717786261, 88.6756413076623],
            [72.48701771452492, 88.67564180329276],
            [72.48701825118724, 88.67564229892322],
            [72.48701789341236, 88.67564196850292],
            [72.4870186089621, 88.67564262934353],
            [23.64943113045235, 18.21179677929804],
            [72.48701831081638, 88.67564235399327],
            [72.48701837044553, 88.67564240906333],
            [72.48701747600833, 88.67564158301256],
            [15.979425518097411, 42.94267179161431],
            [72.48701741637919, 88.6756415279425],
            [2.6769563972987687, 57.39778360170935],
            [72.48701753563749, 88.67564163808261],
            [72.48701783378321, 88.67564191343287],
            [72.48701819155808, 88.67564224385318],
            [72.48701813192893, 88.67564218878312],
            [72.48701801267065, 88.67564207864302],
            [72.48701843007467, 88.67564246413338],
            [72.48701765489578, 88.67564174822272],
            [72.4870179530415, 88.67564202357296],
        ]
    )
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        shape = alpha_shape(p, holes=True, components=3)
    messages = [str(w.message) for w in caught]
    if shape.is_empty:
        assert any("got no valid polygon holding all of them" in m for m in messages)
    else:
        assert shape.is_valid and shapely.covers(shape, shapely.points(p)).all()
    assert not any("collinear" in m for m in messages), messages


def test_huge_coordinates_are_a_clear_error():
    p = np.array([[0, 0], [4, 0], [4, 4], [0, 4]]) * 1e120
    with pytest.raises(InvalidInputError, match=r"within \+-1e\+100"):
        optimal_alpha(p)


def test_alpha_is_exact_on_a_thin_strip():
    # Nearly collinear but above the tolerance (1e-7 of the length): alpha
    # was off by up to 8e-4 (relative); now within 1e-12 of the reciprocal
    # of the exact circumradius of the triangle it comes from.
    import reference

    rng = np.random.default_rng(5)
    t = np.sort(rng.random(25)) * 100
    p = np.c_[t, rng.normal(size=25) * 1e-5]
    _, _, _, exact = reference.triangulation(p)
    a = optimal_alpha(p)
    assert min(abs(a * exact - 1)) < 1e-12


@pytest.mark.parametrize(
    "geoms",
    [
        lambda p: shapely.multipoints(p),
        lambda p: list(shapely.points(p)),
        lambda p: gpd.GeoSeries(shapely.points(p)),
    ],
    ids=["MultiPoint", "list of Points", "GeoSeries"],
)
def test_shapely_points_are_accepted(geoms):
    p = np.array([[0, 0], [4, 0], [4, 4], [0, 4], [2, 3.5]])
    assert optimal_alpha(geoms(p)) == optimal_alpha(p)
    assert alpha_shape(geoms(p)).equals(alpha_shape(p))


def test_string_coordinates_are_an_error():
    with pytest.raises(InvalidInputError, match="numbers"):
        optimal_alpha([["0", "0"], ["1", "0"], ["0", "1"]])


def test_many_groups_one_bad_group_keeps_the_batch():
    rng = np.random.default_rng(2)
    good = rng.random((30, 2)) * 100
    bad = recipe(334)
    res = alpha_shapes(
        np.r_[good, bad], np.r_[np.zeros(30, int), np.ones(len(bad), int)]
    )
    assert res.degenerate.tolist() == [False, True]
    assert shapely.covers(res.geometry[0], shapely.points(good)).all()
    assert res.geometry[1].is_empty and np.isnan(res.alpha[1])


def test_geoalpha_exports_the_tolerance():
    assert geoalpha._core.NEAR_RTOL == 1e-9
    assert geoalpha._core.TIE_RTOL == 1e-10


# --------------------------------------------------------------------------
# Every path of hull(): methods, n_jobs, dask
# --------------------------------------------------------------------------


def hostile_frame(crs="EPSG:27700"):
    """Groups of every family at once, around a British National Grid point."""
    rng = np.random.default_rng(42)
    parts, keys = [], []
    for i, seed in enumerate([334, 0, 2, 118]):  # nearly collinear, degenerate
        parts.append(recipe(seed) * 10)
        keys += [f"line{i}"] * len(parts[-1])
    for i, gap in enumerate([1e-13, 1e-10, 1e-7]):  # near-duplicate pairs
        base = rng.random((25, 2)) * 500
        parts.append(np.r_[base, base + rng.normal(size=base.shape) * 500 * gap])
        keys += [f"dup{i}"] * len(parts[-1])
    for i in range(3):  # thin but above the tolerance
        t = rng.random(30) * 800
        parts.append(np.c_[t, rng.normal(size=30) * 800 * 10.0 ** (-7 + i)])
        keys += [f"strip{i}"] * len(parts[-1])
    parts.append(rng.random((60, 2)) * 300)  # plain
    keys += ["plain"] * 60
    xy = np.concatenate(parts) + np.array([400_000.0, 300_000.0])
    return gpd.GeoDataFrame(
        {"g": keys}, geometry=gpd.points_from_xy(xy[:, 0], xy[:, 1]), crs=crs
    )


@pytest.mark.parametrize("method", ["alpha", "convex", "concave", "knn"])
@pytest.mark.parametrize("holes", [False, True])
def test_every_method_keeps_the_guarantee(method, holes):
    frame = hostile_frame()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        hulls = frame.alpha.hull(by="g", method=method, holes=holes)
    assert len(hulls) == frame["g"].nunique()
    for key, geom in zip(hulls["g"], hulls.geometry, strict=True):
        mine = frame.geometry[frame["g"] == key].to_numpy()
        assert shapely.is_valid(geom), (key, shapely.is_valid_reason(geom))
        assert shapely.covers(geom, mine).all(), key  # buffers cover too


@pytest.mark.parametrize("method", ["alpha", "convex", "concave", "knn"])
def test_overlap_split_keeps_the_guarantee_on_hostile_groups(method):
    """overlap="split" (#38) on groups of every family, all overlapping each other.

    A group whose split cannot hold the guarantee keeps its hull and is named
    in a warning (with "concave" and "knn", GEOS gives a line of points a
    polygon 1e-10 m wide, below the float resolution of these coordinates).
    """
    frame = hostile_frame()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        hulls = frame.alpha.hull(by="g", method=method, overlap="split")
    kept = " ".join(
        str(w.message) for w in caught if "kept their hull" in str(w.message)
    )
    assert (hulls["area_ceded_m2"] > 0).sum() >= 2  # they did overlap
    geoms = list(hulls.geometry)
    total = sum(g.area for g in geoms)
    for i, (key, geom) in enumerate(zip(hulls["g"], geoms, strict=True)):
        mine = frame["g"] == key
        assert shapely.is_valid(geom), (key, shapely.is_valid_reason(geom))
        assert shapely.covers(geom, frame.geometry[mine].to_numpy()).all(), key
        if key in kept:  # its hull, unsplit, as the warning says
            continue
        inside = shapely.contains_properly(geom, frame.geometry[~mine].to_numpy())
        held = frame["g"][~mine][inside]
        assert held.isin(kept.split()).all(), (key, held.tolist())
        for other, name in zip(geoms[i + 1 :], hulls["g"][i + 1 :], strict=True):
            if name not in kept:
                assert geom.intersection(other).area <= 1e-9 * total, (key, name)
    assert method in ("concave", "knn") or not kept


def test_n_jobs_and_dask_keep_the_guarantee():
    frame = hostile_frame()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        eager = frame.alpha.hull(by="g")
        jobs = frame.alpha.hull(by="g", n_jobs=2)
    assert eager.drop(columns="geometry").equals(jobs.drop(columns="geometry"))
    assert eager.geometry.geom_equals_exact(jobs.geometry, 0).all()
    degenerate = eager.loc[eager["alpha"].isna(), "g"].tolist()
    assert degenerate == ["line0", "line1", "line2", "line3"]
    dask_geopandas = pytest.importorskip("dask_geopandas")
    import geoalpha.dask  # noqa: F401

    lazy = dask_geopandas.from_geopandas(frame.sample(frac=1, random_state=1), 3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        computed = lazy.alpha.hull(by="g").compute()
    computed = computed.sort_values("g").reset_index(drop=True)
    assert computed["g"].tolist() == eager["g"].tolist()
    for key, geom in zip(computed["g"], computed.geometry, strict=True):
        mine = frame.geometry[frame["g"] == key].to_numpy()
        assert shapely.is_valid(geom) and shapely.covers(geom, mine).all(), key
    assert computed["alpha"].isna().tolist() == eager["alpha"].isna().tolist()


def test_repairs_work_with_shapely_2_0(monkeypatch):
    """Shapely 2.0's make_valid has no method= (QGIS's env pins 2.0.x): no TypeError.

    A group spanning more than 180 degrees of longitude gets an invalid
    (self-crossing) hull on the way, which is repaired; the result is the one
    shapely 2.1+ gives.
    """
    lonlat = [(-109.48, 37.58), (-64.8, 17.7), (-64.7, 17.75), (101.38, 14.08)]
    lonlat += [(134.54, 7.37), (138.1, 9.52), (145.62, 15.0), (-80, 30), (-90, 35)]
    xy = np.array(lonlat)
    frame = gpd.GeoDataFrame(geometry=gpd.points_from_xy(xy[:, 0], xy[:, 1]), crs=4326)

    def run():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", geoalpha.GeoAlphaWarning)
            return [geoalpha.hull(frame, method=m) for m in ("convex", "alpha")]

    wanted = run()
    make_valid = shapely.make_valid

    def make_valid_2_0(geometry, **kwargs):  # shapely 2.0's signature
        if kwargs:
            raise TypeError(f"make_valid() got an unexpected keyword {list(kwargs)}")
        return make_valid(geometry)

    monkeypatch.setattr(shapely, "make_valid", make_valid_2_0)
    monkeypatch.setattr(geoalpha._arrays.guarantee, "_MAKE_VALID_METHOD", False)
    for got, want in zip(run(), wanted, strict=True):
        assert got.geometry.is_valid.all()
        assert got["n_parts"].tolist() == want["n_parts"].tolist()
        np.testing.assert_allclose(got["area_m2"], want["area_m2"], rtol=1e-9)
    # A ring that overlaps itself: valid, and every point still covered.
    ring = [(0, 0), (4, 0), (4, 4), (1, 4), (1, 1), (3, 1), (3, 3), (0, 3)]
    pts = np.array(ring, dtype=float)
    codes, check = np.zeros(len(pts), dtype=int), np.ones(1, dtype=bool)
    fixed, failed = geoalpha._arrays.guarantee.enforce(
        np.array([shapely.Polygon(ring)]), pts, codes, check
    )
    assert not failed[0] and fixed[0].is_valid
    assert shapely.covers(fixed[0], shapely.points(pts)).all()


def spoil_first_group(monkeypatch, make):
    """Make compute() hand a chosen geometry to the next stages for group 0.

    The one guarantee stage, in the output CRS, must find what is wrong with
    it (a polygon other than the kernel's is tested point by point) and
    repair it or declare the group degenerate.
    """
    from geoalpha._frame import pipeline

    real = pipeline.compute

    def spoiled(points, proj, n_groups, options, **kwargs):
        shapes = real(points, proj, n_groups, options, **kwargs)
        geometry = shapes.geometry.copy()
        geometry[0] = make(geometry[0])
        return shapes._replace(geometry=geometry)

    monkeypatch.setattr(pipeline, "compute", spoiled)


def test_hull_takes_in_a_point_its_polygon_missed(monkeypatch):
    # A polygon that misses points (here: the group's hull shrunk) is repaired
    # in the output CRS: the points become vertices, and all are covered.
    spoil_first_group(monkeypatch, lambda g: shapely.affinity.scale(g, 0.9, 0.9))
    frame = hostile_frame()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        hulls = frame.alpha.hull(by="g")
    key = hulls["g"][0]
    mine = frame.geometry[frame["g"] == key].to_numpy()
    assert not np.isnan(hulls["alpha"][0])
    assert shapely.is_valid(hulls.geometry[0])
    assert shapely.covers(hulls.geometry[0], mine).all()


def test_hull_declares_degenerate_what_it_cannot_repair(monkeypatch):
    # An empty "optimum" covers nothing and cannot be repaired: the group is
    # declared degenerate with a warning, and the default policy buffers it.
    spoil_first_group(monkeypatch, lambda g: shapely.Polygon())
    frame = hostile_frame()
    with pytest.warns(DegenerateGroupWarning, match="no valid polygon covering"):
        hulls = frame.alpha.hull(by="g")
    key = hulls["g"][0]
    mine = frame.geometry[frame["g"] == key].to_numpy()
    assert np.isnan(hulls["alpha"][0])
    assert shapely.covers(hulls.geometry[0], mine).all()


def test_enforce_takes_in_points_a_repair_left_out_even_when_not_asked_to_test():
    # A caller may skip points whose coverage is certain for the polygon it
    # built (test=False); once the polygon is invalid and repaired, that
    # certainty is gone: every point of the group is tested again, and a
    # point the repair left outside is taken in (not just reported).
    bow = shapely.Polygon([(0, 0), (2, 2), (2, 0), (0, 2)])  # self-crossing
    pts = np.array([[0, 0], [2, 2], [2, 0], [0, 2], [1, 0.2]])
    repaired = geoalpha._arrays.guarantee.repair_invalid(np.array([bow]))[0]
    assert not repaired.covers(shapely.Point(1, 0.2))
    fixed, failed = geoalpha._arrays.guarantee.enforce(
        np.array([bow]),
        pts,
        np.zeros(len(pts), dtype=int),
        np.ones(1, bool),
        test=np.zeros(len(pts), bool),
    )
    assert not failed[0]
    assert fixed[0].is_valid
    assert shapely.covers(fixed[0], shapely.points(pts)).all()


def test_the_kernel_sorts_groups_as_a_stable_argsort():
    # kernel.solve hands unsorted groups to _kernel.sort_groups: the same rows,
    # in numpy's stable order, whatever the threads; bad codes are refused.
    rng = np.random.default_rng(3)
    codes = rng.integers(0, 70_000, 20_000)
    xy, out = rng.random((20_000, 2)), rng.random((20_000, 2))
    order = np.argsort(codes, kind="stable")
    for threads in (1, 2):
        sxy, sout, got = geoalpha._kernel.sort_groups(
            xy, codes, 70_000, out_xy=out, threads=threads
        )
        assert np.array_equal(got, order)
        assert np.array_equal(sxy, xy[order]) and np.array_equal(sout, out[order])
    assert geoalpha._kernel.sort_groups(xy, codes, 70_000)[1] is None
    with pytest.raises(ValueError, match=r"^codes must be in 0\.\.5$"):
        geoalpha._kernel.sort_groups(xy, codes, 5)
    with pytest.raises(ValueError, match="one row per point"):
        geoalpha._kernel.sort_groups(xy, codes[1:], 70_000)


def test_the_kernel_refuses_coordinates_not_in_row_order():
    # A Fortran-ordered (n, 2) array is contiguous too, but its flat order is
    # x0 x1 ... y0 y1 ...: read as pairs it would be other points.
    xy = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 3.0], [0.0, 3.0]])
    offsets = np.array([0, 4], dtype=np.int64)
    request = geoalpha._core.Compiled(Request(n_jobs=1), 1)
    done = geoalpha._kernel.alpha_shapes(xy, offsets, request)
    assert done["area"].tolist() == [12.0]
    with pytest.raises(ValueError, match=r"^xy must be C-contiguous$"):
        geoalpha._kernel.alpha_shapes(np.asfortranarray(xy), offsets, request)
    with pytest.raises(ValueError, match=r"^out_xy must be C-contiguous$"):
        geoalpha._kernel.alpha_shapes(
            xy, offsets, request, out_xy=np.asfortranarray(xy)
        )


def test_explain_and_curve_take_every_family_of_group():
    # Nearly collinear, near-duplicate, thin and plain groups in one call: each
    # group gets its own row; one without a shape takes no other down (#35).
    frame = hostile_frame()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        hulls = frame.alpha.hull(by="g")
        why = frame.alpha.explain(by="g")
        curve = frame.alpha.curve(by="g", max_left_out=2, outlier_unit="locations")
    assert why["g"].tolist() == hulls["g"].tolist()
    np.testing.assert_array_equal(why["radius"], hulls["radius"])
    shaped = why["limited_by"] != "degenerate"
    assert set(why.loc[~shaped, "g"]) == set(hulls.loc[hulls["alpha"].isna(), "g"])
    assert why.loc[shaped, "geometry"].notna().all()
    assert why.loc[~shaped, "geometry"].isna().all()
    assert set(curve["g"]) == set(why.loc[shaped, "g"])
    for _, one in curve.groupby("g"):  # never wider with more left out
        radius = one["radius"].to_numpy()  # (k = 0 is hull()'s 1 / alpha)
        assert (np.diff(radius) <= 1e-12 * radius[0]).all()


def test_points_outside_are_taken_in_in_linear_time(monkeypatch):
    # Issue #37 (item 2): at most TAKE_IN_POINTS points of a group are taken in
    # one at a time (each rebuilding the rings); the rest at once. 3,000 points
    # just outside one edge of a square were 3,000 rebuilds before.
    from geoalpha._arrays import guarantee

    calls = []
    real = guarantee._take_in
    monkeypatch.setattr(
        guarantee, "_take_in", lambda poly, p: calls.append(p) or real(poly, p)
    )
    x = np.linspace(0.001, 0.999, 3000)
    pts = np.r_[[[0, 0], [1, 0], [1, 1], [0, 1]], np.c_[x, -1e-7 * (1 + x)]]
    square = np.array([shapely.box(0, 0, 1, 1)])
    fixed, failed = guarantee.enforce(
        square, pts, np.zeros(len(pts), dtype=int), np.ones(1, bool)
    )
    assert not failed[0]
    assert fixed[0].is_valid
    assert shapely.covers(fixed[0], shapely.points(pts)).all()
    assert len(calls) <= guarantee.TAKE_IN_POINTS


@pytest.mark.parametrize("npartitions", [1, 3, 11])
def test_dask_explain_and_curve_take_every_family_of_group(npartitions):
    # The same hostile groups per dask partition (some partitions hold only
    # groups without a shape, or none): the eager tables, row for row (#35).
    dask_geopandas = pytest.importorskip("dask_geopandas")
    import geoalpha.dask  # noqa: F401

    frame = hostile_frame().sample(frac=1, random_state=3)
    lazy = dask_geopandas.from_geopandas(frame, npartitions=3, sort=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        why = frame.alpha.explain(by="g")
        curve = frame.alpha.curve(by="g", max_left_out=2, outlier_unit="locations")
        got = lazy.alpha.explain(by="g", npartitions=npartitions).compute()
        table = lazy.alpha.curve(
            by="g", max_left_out=2, outlier_unit="locations", npartitions=npartitions
        ).compute()
    assert got["g"].tolist() == why["g"].tolist()
    assert got["limited_by"].tolist() == why["limited_by"].tolist()
    assert got["critical_rows"].tolist() == why["critical_rows"].tolist()
    assert got["rows_without_1"].tolist() == why["rows_without_1"].tolist()
    np.testing.assert_array_equal(got["radius"], why["radius"])
    np.testing.assert_array_equal(got["radius_without_1"], why["radius_without_1"])
    assert got.geometry.to_wkb().tolist() == why.geometry.to_wkb().tolist()
    assert table[["g", "k"]].values.tolist() == curve[["g", "k"]].values.tolist()
    assert table["left_out"].tolist() == curve["left_out"].tolist()
    np.testing.assert_array_equal(table["radius"], curve["radius"])
    np.testing.assert_array_equal(table["area_m2"], curve["area_m2"])


# The coordinates read already (dask's partitions take the shuffled x/y):
# the same rows kept, dropped and refused, the same hulls, bit for bit.

#: A coordinate of every kind: NaN, infinities, subnormals, -0.0, huge, plain.
ANY_FLOAT = st.floats(allow_nan=True, allow_infinity=True, allow_subnormal=True)


@scaled_examples(200)
@given(
    rows=st.lists(st.tuples(ANY_FLOAT, ANY_FLOAT, st.booleans()), max_size=25),
    seed=st.integers(0, 2**16),
)
def test_scan_xy_reads_the_rows_as_scan_rows(rows, seed):
    from geoalpha._frame.pipeline import scan_rows, scan_xy

    xy = np.array([r[:2] for r in rows], dtype=np.float64).reshape(-1, 2)
    codes = np.where([r[2] for r in rows], -1, 0).astype(np.int64)
    index = pd.Index(np.random.default_rng(seed).permutation(len(rows)) * 3 + 7)
    frame = gpd.GeoDataFrame(
        {"k": codes}, geometry=shapely.points(xy), index=index, crs=None
    )
    report, coords, which = scan_rows(frame, codes, vertices=False)
    got_report, got_coords, got_which = scan_xy(frame.index, xy, codes)
    assert got_report == report
    np.testing.assert_array_equal(got_which, which)
    np.testing.assert_array_equal(got_coords, coords)  # (NaN equals NaN here)


@pytest.mark.parametrize("method", ["alpha", "convex", "concave", "knn"])
@pytest.mark.parametrize("crs", ["EPSG:27700", "EPSG:4326", None])
def test_hull_from_coordinates_read_already_is_the_hull_from_geometries(method, crs):
    from geopandas.testing import assert_geodataframe_equal

    from geoalpha._frame.pipeline import run
    from geoalpha._options import Options

    frame = hostile_frame()
    if crs == "EPSG:4326":
        frame = frame.to_crs(crs)
    elif crs is None:
        frame = frame.set_crs(None, allow_override=True)
    nan = [shapely.Point(np.nan, 1.0), shapely.Point(2.0, np.nan)]  # (not empty)
    frame.loc[[3, 70], "geometry"] = nan
    frame.loc[[0, 8], "g"] = None  # dropped: a warning names them
    frame.index = frame.index * 10 + 5  # labels that are not positions
    xy = np.column_stack([shapely.get_x(frame.geometry), shapely.get_y(frame.geometry)])
    bare = frame.set_geometry(gpd.GeoSeries([None] * len(frame), index=frame.index))
    bare = bare.set_crs(frame.crs, allow_override=True)
    options = Options.from_kwargs({"method": method, "crs": "auto" if crs else None})

    def outcome(*args, **kwargs):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            table, left_out = run(*args, **kwargs)
        shown = [(w.category, str(w.message)) for w in caught]
        return table, left_out, shown

    table, left_out, shown = outcome(frame, "g", options)
    got, got_left_out, got_shown = outcome(bare, "g", options, xy=xy)
    assert got_shown == shown
    assert any("dropped 4 of" in message for _, message in shown)
    assert_geodataframe_equal(got, table)
    assert got.geom_equals_exact(table, tolerance=0).all()
    np.testing.assert_array_equal(got_left_out, left_out)
    for key, geom in zip(got["g"], got.geometry, strict=True):
        mine = frame.geometry[frame["g"] == key].to_numpy()
        mine = mine[np.isfinite(shapely.get_coordinates(mine)).all(axis=1)]
        assert shapely.is_valid(geom) and shapely.covers(geom, mine).all(), key
