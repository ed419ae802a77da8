"""Outlier-tolerant optimum (issue #14) against the brute-force reference.

``alpha_shapes(..., outliers=q)`` must give, for every group, the largest
alpha at which at most ``components`` pieces cover at least ``rows - k`` rows
(issue #24: a location weighs as many rows as it holds), as
``reference.coverage_curve`` finds by trying every spectrum value and counting
pieces and covered rows directly; the rows it reports as left out must be
exactly those the kept pieces miss.
"""

from __future__ import annotations

import math
import re
import warnings

import geopandas as gpd
import numpy as np
import pandas as pd
import pytest
import reference
import shapely
from hypothesis import event, given, note
from hypothesis import strategies as st
from test_cli import run as run_cli
from test_exact import (
    COORD,
    STRATEGIES,
    UNIT,
    as_points,
    examples,
    reference_triangulation,
    same_triangulation,
    well_conditioned,
)
from test_real_groups import EXPECTED_GROUPS, real_dataset

import geoalpha
from geoalpha import (
    InvalidInputError,
    OutlierWarning,
    alpha_shape,
    alpha_shapes,
    datasets,
    optimal_alpha,
)
from geoalpha._arrays.budget import outlier_budget

# --------------------------------------------------------------------------
# Point sets with stray points
# --------------------------------------------------------------------------


@st.composite
def with_strays(draw):
    """A clustered set plus 1-4 stray points far from it (mis-geocoded)."""
    spread = draw(st.sampled_from([0.5, 1.0, 5.0]))
    n = draw(st.integers(4, 20))
    centre = np.array([draw(COORD), draw(COORD)])
    body = centre + spread * as_points(
        draw(st.lists(st.tuples(UNIT, UNIT), min_size=n, max_size=n))
    )
    k = draw(st.integers(1, 4))
    far = st.integers(3, 40).map(float) | st.integers(-40, -3).map(float)
    strays = centre + spread * as_points(
        draw(st.lists(st.tuples(far, far), min_size=k, max_size=k))
    )
    return np.r_[body, strays]


@st.composite
def two_clusters(draw):
    """Two or three clusters of different sizes, so pieces compete."""
    sizes = draw(st.lists(st.integers(3, 12), min_size=2, max_size=3))
    centres = as_points(
        draw(
            st.lists(
                st.tuples(st.integers(-50, 50), st.integers(-50, 50)),
                min_size=len(sizes),
                max_size=len(sizes),
            )
        )
    )
    parts = [
        c
        + as_points(draw(st.lists(st.tuples(UNIT, UNIT), min_size=s, max_size=s)))
        * draw(st.sampled_from([1.0, 3.0]))
        for c, s in zip(centres, sizes, strict=True)
    ]
    return np.concatenate(parts)


@st.composite
def with_near_duplicates(draw):
    """Strays or clusters with some points repeated 1e-14..1e-10 of the extent away.

    Such copies are one point (below ``kernel.NEAR_RTOL``): they are left
    out together, and each counts as a row.
    """
    p = draw(with_strays() | two_clusters())
    extent = float(np.ptp(p, axis=0).max())
    which = draw(st.lists(st.integers(0, len(p) - 1), min_size=1, max_size=4))
    copies = []
    for i in which:
        n = draw(st.integers(1, 8))
        exponent = draw(st.integers(-14, -10))
        angle = draw(st.floats(0, 2 * math.pi))
        step = extent * 10.0**exponent * np.array([math.cos(angle), math.sin(angle)])
        copies.append(p[i] + np.arange(1, n + 1)[:, None] * step / n)
    return np.concatenate([p, *copies])


KINDS = {
    **STRATEGIES,
    "strays": with_strays(),
    "clusters": two_clusters(),
    "near duplicates": with_near_duplicates(),
}
BUDGETS = [0.05, 0.1, 0.25, 0.5, 1, 2, 3]


def parts(geom) -> int:
    if geom.is_empty:
        return 0
    return len(geom.geoms) if geom.geom_type == "MultiPolygon" else 1


def check_result(res, p, g, components, rows=None):
    """What ``alpha_shapes`` promises of one group's outlier result."""
    rows = np.arange(len(p)) if rows is None else rows
    shape = res.geometry[g]
    assert shapely.is_valid(shape), shapely.is_valid_reason(shape)
    assert 1 <= parts(shape) <= components
    left_out = res.outlier[rows]
    inside = shapely.covers(shape, shapely.points(p))
    assert inside[~left_out].all(), "a kept point is outside the shape"
    assert not inside[left_out].any(), "a left-out point is inside the shape"
    # Points closer than the tolerance are one point: left out together; the
    # count is in rows.
    label = reference.near_labels(p)
    for one in np.unique(label):
        assert len(set(left_out[label == one].tolist())) == 1, "a set split"
    assert left_out.sum() == res.n_outliers[g]
    inputs = set(map(tuple, p.tolist()))
    coords = map(tuple, shapely.get_coordinates(shape).tolist())
    assert all(c in inputs for c in coords), "a vertex that is not an input point"


# --------------------------------------------------------------------------
# Generated sets
# --------------------------------------------------------------------------


@pytest.mark.parametrize("holes", [False, True], ids=["filled", "holes"])
@pytest.mark.parametrize("kind", list(KINDS))
@examples(60)
@given(data=st.data())
def test_matches_reference(kind, holes, data):
    p = data.draw(KINDS[kind], label="points")
    components = data.draw(st.integers(1, 3), label="components")
    outliers = data.draw(st.sampled_from(BUDGETS), label="outliers")
    note(f"points = np.array({p.tolist()!r})")
    tri = reference_triangulation(p)
    if tri is None or not (same_triangulation(p, tri) and well_conditioned(tri)):
        event("not compared (degenerate or ill-conditioned)")
        return
    curve = reference.coverage_curve(p, holes=holes, components=(components,))
    n, _, cover = curve
    # The best coverage never decreases as the radius grows (checked, not assumed).
    assert (np.diff(cover[components]) >= 0).all(), cover[components]
    res = alpha_shapes(p, holes=holes, components=components, outliers=outliers)
    k = reference.budget(outliers, n)
    assert outlier_budget(outliers, [n])[0] == k
    if k == 0:
        event("k = 0")
        plain = alpha_shapes(p, holes=holes, components=components)
        assert res.alpha[0] == plain.alpha[0] and res.n_outliers[0] == 0
        assert shapely.equals_exact(res.geometry[0], plain.geometry[0], 0)
        return
    alpha, left_out = reference.outlier_optimum_from_curve(curve, components, k)
    event(f"{left_out} left out" if left_out < 3 else "3+ left out")
    assert res.alpha[0] == pytest.approx(alpha, rel=1e-9, abs=0)
    assert res.n_outliers[0] == left_out
    check_result(res, p, 0, components)


@pytest.mark.parametrize("holes", [False, True], ids=["filled", "holes"])
def test_pieces_that_share_a_point(holes):
    # Two fans touching at the origin (a bow-tie) and a far triangle. With
    # two pieces allowed, the two fans (4 points each) cover 7 distinct
    # points (rows) together, not 8: the best union is found by the exact search
    # (here a tie with one fan and the far triangle, 4 + 3).
    fan = np.array([[0, 0], [-2, 1], [-2, -1], [-3, 0], [2, 1], [2, -1], [3, 0]])
    far = np.array([[40, 0], [41, 0], [40.5, 1]])
    p = np.r_[fan, far]
    res = alpha_shapes(p, holes=holes, components=2, outliers=3)
    alpha, left_out = reference.outlier_optimum(
        p, holes=holes, components=2, outliers=3
    )
    assert res.alpha[0] == pytest.approx(alpha, rel=1e-12)
    assert res.n_outliers[0] == left_out == 3
    check_result(res, p, 0, 2)


@examples(30)
@given(data=st.data())
def test_batched_equals_per_group(data):
    # Not with near-duplicates: the first of them in input order represents
    # them, so shuffling the rows may move the shape by up to the tolerance.
    kinds = [v for k, v in KINDS.items() if k != "near duplicates"]
    sets = data.draw(st.lists(st.one_of(*kinds), min_size=2, max_size=4))
    outliers = data.draw(st.sampled_from(BUDGETS), label="outliers")
    points = np.concatenate(sets)
    codes = np.repeat(np.arange(len(sets)), [len(s) for s in sets])
    order = np.array(data.draw(st.permutations(range(len(points))), label="order"))
    res = alpha_shapes(points[order], codes[order], outliers=outliers)
    outlier = np.empty(len(points), dtype=bool)
    outlier[order] = res.outlier
    start = 0
    for g, p in enumerate(sets):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            alone = alpha_shapes(p, outliers=outliers)
        rows = slice(start, start + len(p))
        start += len(p)
        if alone.degenerate[0]:
            assert res.degenerate[g] and math.isnan(res.alpha[g])
            assert not outlier[rows].any()
            continue
        assert res.alpha[g] == alone.alpha[0]
        assert res.n_outliers[g] == alone.n_outliers[0]
        assert (outlier[rows] == alone.outlier).all()
        assert shapely.equals_exact(
            shapely.normalize(res.geometry[g]), shapely.normalize(alone.geometry[0]), 0
        )


# --------------------------------------------------------------------------
# Real groups: every group of the bundled datasets
# --------------------------------------------------------------------------

REAL_BUDGETS = [0.02, 0.05, 0.1, 1, 3]


def reference_curves(name, holes):
    xy, codes, names = real_dataset(name)
    curves = {}
    for g in range(len(names)):
        if reference_triangulation(xy[codes == g]) is not None:
            curves[g] = reference.coverage_curve(xy[codes == g], holes=holes)
    return curves


@pytest.mark.exhaustive  # every spectrum value of every real group: minutes
@pytest.mark.parametrize("holes", [False, True], ids=["filled", "holes"])
@pytest.mark.parametrize("name", list(EXPECTED_GROUPS))
def test_every_real_group_matches_reference(name, holes):
    xy, codes, names = real_dataset(name)
    curves = reference_curves(name, holes)
    assert len(curves) == EXPECTED_GROUPS[name][1]
    for curve in curves.values():  # monotone, checked rather than assumed
        for c in (1, 2, 3):
            assert (np.diff(curve[2][c]) >= 0).all()
    mismatches, compared = [], 0
    for components in (1, 2, 3):
        plain = alpha_shapes(xy, codes, holes=holes, components=components)
        for outliers in REAL_BUDGETS:
            res = alpha_shapes(
                xy, codes, holes=holes, components=components, outliers=outliers
            )
            for g, curve in curves.items():
                k = reference.budget(outliers, curve[0])
                if k == 0:  # today's result, bit for bit
                    assert res.alpha[g] == plain.alpha[g]
                    assert res.n_outliers[g] == 0
                    assert shapely.equals_exact(res.geometry[g], plain.geometry[g], 0)
                    continue
                compared += 1
                alpha, left_out = reference.outlier_optimum_from_curve(
                    curve, components, k
                )
                if not (
                    res.alpha[g] == pytest.approx(alpha, rel=1e-9, abs=0)
                    and res.n_outliers[g] == left_out
                ):
                    mismatches.append((names[g], components, outliers))
            rows = np.flatnonzero(~res.degenerate[codes])
            covered = shapely.covers(
                res.geometry[codes[rows]], shapely.points(xy[rows])
            )
            assert (covered == ~res.outlier[rows]).all()
            assert not res.outlier[res.degenerate[codes]].any()
            assert shapely.is_valid(res.geometry).all()
            assert (res.n_parts <= components).all()
    assert not mismatches, f"{len(mismatches)} of {compared}: {mismatches[:5]}"
    assert compared > 0


# --------------------------------------------------------------------------
# The API
# --------------------------------------------------------------------------

SQUARE_AND_STRAY = np.array([[0, 0], [4, 0], [4, 4], [0, 4], [2, 3.5], [30, 30]])


def test_stray_point_is_left_out():
    res = alpha_shapes(SQUARE_AND_STRAY, outliers=1)
    assert res.outlier.tolist() == [False] * 5 + [True]
    assert res.n_outliers.tolist() == [1]
    assert res.alpha[0] == pytest.approx(optimal_alpha(SQUARE_AND_STRAY[:5]))
    assert res.geometry[0].equals(alpha_shape(SQUARE_AND_STRAY[:5]))
    assert alpha_shapes(SQUARE_AND_STRAY, outliers=0.2).n_outliers.tolist() == [1]
    # 0.1 * 6 points: k = 0, no point may stay out
    assert alpha_shapes(SQUARE_AND_STRAY, outliers=0.1).n_outliers.tolist() == [0]


def test_one_group_functions_take_outliers():
    alpha = optimal_alpha(SQUARE_AND_STRAY, outliers=1)
    assert alpha == pytest.approx(optimal_alpha(SQUARE_AND_STRAY[:5]), rel=1e-12)
    assert alpha > optimal_alpha(SQUARE_AND_STRAY)
    shape = alpha_shape(SQUARE_AND_STRAY, outliers=1)
    assert shape.area == pytest.approx(15.0)
    assert not shape.covers(shapely.Point(30, 30))


def test_duplicates_of_a_left_out_point_are_marked():
    p = np.r_[SQUARE_AND_STRAY, [[30, 30], [30, 30]]]
    res = alpha_shapes(p, outliers=3)
    assert res.n_outliers.tolist() == [3]  # rows, not locations
    assert res.outlier.tolist() == [False] * 5 + [True] * 3


def test_the_budget_counts_rows():
    # The stray location holds 3 rows: a budget of 1 or 2 rows cannot leave
    # it out (issue #24: outliers=0.02 left out 6.3% of a state's rows).
    p = np.r_[SQUARE_AND_STRAY, [[30, 30], [30, 30]]]
    for outliers in (1, 2, 0.25):  # 0.25 * 8 rows = 2
        res = alpha_shapes(p, outliers=outliers)
        assert res.n_outliers.tolist() == [0]
        assert not res.outlier.any()
    assert alpha_shapes(p, outliers=0.375).n_outliers.tolist() == [3]


def test_zero_is_todays_result():
    for outliers in (0, 0.0):
        res = alpha_shapes(SQUARE_AND_STRAY, outliers=outliers)
        plain = alpha_shapes(SQUARE_AND_STRAY)
        for field in ("alpha", "n_parts", "area"):
            assert (getattr(res, field) == getattr(plain, field)).all()
        assert shapely.equals_exact(res.geometry[0], plain.geometry[0], 0)
        assert res.n_outliers.tolist() == [0] and not res.outlier.any()


def test_a_capped_union_search_is_warned(monkeypatch):
    # Two pieces allowed and a node budget of 1: the exact union search stops
    # at once and the group is named, never silently approximate.
    from geoalpha import _core as kernel

    monkeypatch.setattr(kernel, "MAX_UNION_NODES", 1)
    fan = np.array([[0, 0], [-2, 1], [-2, -1], [-3, 0], [2, 1], [2, -1], [3, 0]])
    p = np.r_[fan, [[40, 0], [41, 0], [40.5, 1]]]
    with pytest.warns(OutlierWarning, match=r"stopped after 1 steps for 1 group"):
        res = alpha_shapes(p, components=2, outliers=3)
    assert res.capped.tolist() == [True]
    assert not alpha_shapes(p, components=1, outliers=3).capped.any()


def test_threads_give_the_same_rows():
    rng = np.random.default_rng(7)
    codes = rng.integers(0, 40, 3000)  # shuffled rows, runs of a few groups
    pts = rng.normal(size=(3000, 2)) * 100 + codes[:, None] * 1000.0
    one = alpha_shapes(pts, codes, outliers=2)
    two = alpha_shapes(pts, codes, outliers=2, n_jobs=2)
    assert (one.outlier == two.outlier).all() and one.outlier.sum() > 0
    assert (one.n_outliers == two.n_outliers).all()
    assert (one.alpha == two.alpha).all()


@pytest.mark.parametrize(
    ("value", "message"),
    [
        (1.0, "outliers must be a fraction in [0, 1) or a count >= 0"),
        (-1, "outliers must be a fraction"),
        (True, "outliers must be a fraction"),
        ("2%", "outliers must be a fraction"),
    ],
)
def test_bad_outliers(value, message):
    with pytest.raises(InvalidInputError, match=re.escape(message)):
        alpha_shapes(SQUARE_AND_STRAY, outliers=value)


def test_outliers_need_the_exact_optimum():
    with pytest.raises(InvalidInputError, match="outliers applies to the exact"):
        alpha_shapes(SQUARE_AND_STRAY, outliers=1, alpha=0.5)
    with pytest.raises(InvalidInputError, match="search='exact'"):
        alpha_shapes(SQUARE_AND_STRAY, outliers=1, search="ladder")


# --------------------------------------------------------------------------
# hull(), outlier_rows() and the command line
# --------------------------------------------------------------------------


@pytest.fixture(scope="module")
def airports():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return datasets.load("us_airports")


def quiet_hull(points, **kwargs):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        hulls = geoalpha.hull(points, **kwargs)
    return hulls, [w for w in caught if w.category is OutlierWarning]


@pytest.mark.parametrize("outliers", [0.02, 3])
def test_hull_leaves_out_the_rows_it_reports(airports, outliers):
    hulls, told = quiet_hull(airports, by="state", outliers=outliers)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # dropped rows, degenerate groups
        rows = geoalpha.outlier_rows(airports, by="state", outliers=outliers)
    assert rows.index.equals(airports.index) and rows.dtype == bool
    per_state = rows.groupby(airports["state"]).sum()
    table = hulls.set_index("state")["n_outliers"]
    assert table.to_dict() == per_state.reindex(table.index).to_dict()
    assert table.sum() > 0
    # The warning counts them per group, e.g. "'CA' (4 rows)".
    (warning,) = told
    message = str(warning.message)
    assert (
        f"hull() left {table.sum()} row(s) of {(table > 0).sum()} group(s)" in message
    )
    first = table[table > 0].index[0]
    assert f"'{first}' ({table[first]} row" in message
    # Every kept row is inside its hull, every left-out row outside (lon/lat).
    shapes = hulls.set_index("state").geometry
    kept = airports[airports["state"].notna()]
    inside = shapely.covers(
        shapes.loc[kept["state"]].to_numpy(), kept.geometry.to_numpy()
    )
    assert (inside == ~rows[kept.index].to_numpy()).all()
    # Tighter than without outliers: a larger alpha wherever a row is left
    # out (a smaller shape of the same triangulation), never a larger area.
    plain = quiet_hull(airports, by="state")[0].set_index("state")
    some = table > 0
    assert (hulls.set_index("state")["alpha"][some] > plain["alpha"][some]).all()
    assert (hulls.set_index("state")["area_m2"] <= plain["area_m2"]).all()


def test_hull_without_outliers_is_unchanged(airports):
    plain, told = quiet_hull(airports, by="state")
    zero, _ = quiet_hull(airports, by="state", outliers=0.0)
    assert not told and (plain["n_outliers"] == 0).all()
    assert plain.drop(columns="geometry").equals(zero.drop(columns="geometry"))
    assert plain.geom_equals_exact(zero, 0).all()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # dropped rows, degenerate groups
        assert not geoalpha.outlier_rows(airports, by="state").any()


def test_hull_n_jobs_and_dask_agree(airports):
    eager, _ = quiet_hull(airports, by="state", outliers=0.02)
    jobs, _ = quiet_hull(airports, by="state", outliers=0.02, n_jobs=2)
    pd.testing.assert_frame_equal(
        eager.drop(columns="geometry"), jobs.drop(columns="geometry")
    )
    dask_geopandas = pytest.importorskip("dask_geopandas")
    lazy = geoalpha.hull(
        dask_geopandas.from_geopandas(airports, npartitions=3),
        by="state",
        outliers=0.02,
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        computed = lazy.compute()
    assert computed["n_outliers"].tolist() == eager["n_outliers"].tolist()
    assert computed.geom_equals_exact(eager, 0).all()


def test_hull_outliers_need_method_alpha(airports):
    with pytest.raises(InvalidInputError, match="method='alpha'; got method='convex'"):
        geoalpha.hull(airports, by="state", method="convex", outliers=1)
    with pytest.raises(InvalidInputError, match="outliers must be a fraction"):
        geoalpha.hull(airports, by="state", outliers=2.0)


def test_cli_outliers(tmp_path):
    out = tmp_path / "h.gpkg"
    result = run_cli("demo", out, "--dataset", "us_airports")
    assert result.exit_code == 0
    plain = gpd.read_file(out)
    csv = tmp_path / "airports.csv"
    frame = datasets.load("us_airports")
    pd.DataFrame(frame.drop(columns="geometry")).to_csv(csv, index=False)
    for value, expected in (("0.02", 0.02), ("3", 3)):
        out = tmp_path / f"h{value}.gpkg"
        result = run_cli("hull", csv, out, "--by", "state", "--outliers", value)
        assert result.exit_code == 0, result.stderr
        assert "left" in result.stderr and "outside their hulls" in result.stderr
        back = gpd.read_file(out)
        hulls, _ = quiet_hull(frame, by="state", outliers=expected)
        assert back["n_outliers"].tolist() == hulls["n_outliers"].tolist()
        assert (back["alpha"] >= plain["alpha"].fillna(0) - 1e-12).sum() > 40
    result = run_cli("hull", csv, tmp_path / "x.gpkg", "--outliers", "1.5")
    assert result.exit_code == 2
    assert "'--outliers': --outliers must be a fraction in [0, 1)" in result.stderr


def test_outlier_rows_needs_an_eager_frame(airports):
    dask_geopandas = pytest.importorskip("dask_geopandas")
    lazy = dask_geopandas.from_geopandas(airports, npartitions=2)
    with pytest.raises(InvalidInputError, match=r"call \.compute\(\) first"):
        geoalpha.outlier_rows(lazy, by="state", outliers=1)


def test_outlier_rows_of_a_geoseries_without_groups():
    pts = gpd.GeoSeries(shapely.points(SQUARE_AND_STRAY), crs="EPSG:32631")
    rows = geoalpha.outlier_rows(pts, outliers=1)
    assert rows.tolist() == [False] * 5 + [True]
    hulls, told = quiet_hull(pts, outliers=1)
    assert hulls["n_outliers"].tolist() == [1]
    assert "'all points' (1 row)" not in str(told[0].message)  # no key: plain text
    assert "all points (1 row)" in str(told[0].message)
