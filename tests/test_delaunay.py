"""The GEOS triangulation backend (issue #12): index arrays, checks, fallback.

``geoalpha.delaunay.triangulate_groups`` triangulates all groups in one GEOS
call; ``core.triangulate`` sends the groups it rejects to Qhull. These tests
compare its output with scipy's Qhull triangulation and with brute-force
structure checks, and make it fail on purpose to see the fallback.
"""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from example_counts import examples
from hypothesis import given
from hypothesis import strategies as st
from scipy.spatial import Delaunay, QhullError
from test_real_groups import EXPECTED_GROUPS, real_dataset

from geoalpha import alpha_shapes, core, delaunay


def geos(local, point_ptr, groups, progress=None):
    """The backend the array API hands to core.triangulate (looked up at call time)."""
    return delaunay.triangulate_groups(local, point_ptr, groups, progress)


def qhull_only(monkeypatch):
    """Make every group fail in the backend, so that Qhull triangulates all."""
    real = delaunay.triangulate_groups

    def none_pass(local, point_ptr, groups, progress=None):
        out = real(local, point_ptr, groups[:0])
        k = len(groups)
        return out._replace(
            n_triangles=np.zeros(k, np.int64), failed=np.ones(k, dtype=bool)
        )

    monkeypatch.setattr(delaunay, "triangulate_groups", none_pass)


def sorted_radii(tri, g):
    return np.sort(tri.radius[tri.tri_ptr[g] : tri.tri_ptr[g + 1]])


def batch(sets):
    points = np.concatenate(sets)
    codes = np.repeat(np.arange(len(sets)), [len(p) for p in sets])
    return points, codes


def group_arrays(sets):
    """(local, point_ptr, groups) as core.triangulate hands them over."""
    points, codes = batch(sets)
    ptr = np.concatenate([[0], np.cumsum([len(p) for p in sets])])
    local = points - points[ptr[:-1]][codes]
    return local, ptr, np.arange(len(sets))


# --- real data ----------------------------------------------------------------------


@pytest.mark.parametrize("name", list(EXPECTED_GROUPS))
def test_geos_and_qhull_radius_spectra_agree_on_real_groups(name):
    # Every real group with a triangle: GEOS's triangles have the radii of
    # Qhull's (the triangle sets differ at most by cocircular diagonals,
    # which keep every radius), and no group needs the fallback.
    xy, codes, names = real_dataset(name)
    tri = core.triangulate(xy, codes, backend=geos)
    order = np.argsort(codes, kind="stable")
    local = tri.local
    todo = np.flatnonzero(np.diff(tri.point_ptr) >= 3)
    out = delaunay.triangulate_groups(local, tri.point_ptr, todo)
    compared = 0
    for g in range(len(names)):
        p = np.unique(xy[order][tri.point_ptr[g] : tri.point_ptr[g + 1]], axis=0)
        try:
            d = Delaunay(p - p[0])
        except (QhullError, ValueError):
            assert tri.degenerate[g]
            continue
        i = np.searchsorted(todo, g)
        assert not out.failed[i], names[g]
        assert (
            out.n_triangles[i]
            == len(d.simplices)
            == tri.tri_ptr[g + 1] - tri.tri_ptr[g]
        )
        a, b, c = (p[d.simplices[:, k]] for k in range(3))
        cross = np.abs((b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0])
        qhull_r = np.sort(
            np.sqrt(
                np.square(b - a).sum(1)
                * np.square(c - b).sum(1)
                * np.square(a - c).sum(1)
            )
            / (2 * cross)
        )
        np.testing.assert_allclose(sorted_radii(tri, g), qhull_r, rtol=1e-9)
        compared += 1
    assert compared == EXPECTED_GROUPS[name][1]


@pytest.mark.parametrize("name", ["uk_clusters", "stats19"])
def test_real_optima_equal_the_qhull_path(name, monkeypatch):
    xy, codes, _ = real_dataset(name)
    geos = alpha_shapes(xy, codes)
    qhull_only(monkeypatch)
    qhull = alpha_shapes(xy, codes)
    np.testing.assert_array_equal(geos.degenerate, qhull.degenerate)
    np.testing.assert_allclose(geos.alpha, qhull.alpha, rtol=1e-12)
    ok = ~geos.degenerate
    assert shapely.equals(geos.geometry[ok], qhull.geometry[ok]).all()


# --- structure, against brute force ---------------------------------------------------

COORD = st.integers(0, 2000).map(lambda i: i / 16)
GROUP = st.lists(st.tuples(COORD, COORD), min_size=3, max_size=30).map(
    lambda rows: np.array(rows, dtype=float)
)


@examples(60)
@given(sets=st.lists(GROUP, min_size=1, max_size=4))
def test_triangles_neighbours_and_duplicates(sets):
    local, ptr, groups = group_arrays(sets)
    out = delaunay.triangulate_groups(local, ptr, groups)
    tri, nb = out.triangles, out.neighbors
    first = np.concatenate([[0], np.cumsum(out.n_triangles)])
    for g, p in enumerate(sets):
        mine = tri[first[g] : first[g + 1]]
        distinct = np.unique(p, axis=0)
        # Duplicates are represented by a point at the same place.
        rows = np.arange(ptr[g], ptr[g + 1])
        assert (local[out.vertex[rows]] == local[rows]).all()
        assert (out.vertex[rows] >= ptr[g]).all() and (
            out.vertex[rows] < ptr[g + 1]
        ).all()
        if out.failed[g]:
            assert len(mine) == 0
            continue
        assert len(np.unique(mine)) == len(distinct)  # every distinct point
        assert ((mine >= ptr[g]) & (mine < ptr[g + 1])).all()
        a, b, c = (local[mine[:, k]] for k in range(3))
        area2 = (b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0]
        assert (area2 > 0).all()  # counter-clockwise, not flat
        hull = shapely.convex_hull(shapely.multipoints(distinct))
        assert area2.sum() / 2 == pytest.approx(hull.area, rel=1e-12)
    # Neighbours by brute force: the triangle holding the same two points.
    for t in range(len(tri)):
        for j in range(3):
            edge = {tri[t, (j + 1) % 3], tri[t, (j + 2) % 3]}
            others = [s for s in range(len(tri)) if s != t and edge <= set(tri[s])]
            assert len(others) <= 1
            assert nb[t, j] == (others[0] if others else -1)


# --- failures and the fallback --------------------------------------------------------

RNG = np.random.default_rng(12)
GOOD = RNG.random((40, 2)) * 100
COLLINEAR = np.column_stack([np.arange(6.0), 2 * np.arange(6.0)])
FLAT = np.column_stack([RNG.random(20) * 100, RNG.normal(size=20) * 1e-10])
NEEDLE = np.r_[GOOD[:10], GOOD[:3] + 1e-13]  # closer than 1e-12 of the extent


def test_groups_geos_cannot_do_fall_back_alone():
    sets = [GOOD, COLLINEAR, GOOD + 7, FLAT, NEEDLE, GOOD[:5]]
    out = delaunay.triangulate_groups(*group_arrays(sets))
    assert out.failed.tolist() == [False, True, False, True, True, False]
    assert (out.n_triangles[out.failed] == 0).all()


def test_fallback_gives_the_qhull_result(monkeypatch):
    sets = [GOOD, COLLINEAR, GOOD + 7, FLAT, NEEDLE, GOOD[:5]]
    points, codes = batch(sets)
    geos_tri = core.triangulate(points, codes, backend=geos)
    qhull_only(monkeypatch)
    qhull = core.triangulate(points, codes, backend=geos)
    assert geos_tri.degenerate.tolist() == qhull.degenerate.tolist()
    # FLAT is within core's collinearity tolerance: degenerate either way.
    assert geos_tri.degenerate.tolist() == [False, True, False, True, False, False]
    np.testing.assert_array_equal(geos_tri.tri_ptr, qhull.tri_ptr)
    np.testing.assert_array_equal(geos_tri.n_distinct, qhull.n_distinct)
    for g in np.flatnonzero(~geos_tri.degenerate):
        np.testing.assert_allclose(sorted_radii(geos_tri, g), sorted_radii(qhull, g))
    # The Qhull groups' triangles sit in their place, neighbours remapped.
    t = np.arange(len(geos_tri.triangles))
    for j in range(3):
        n = geos_tri.neighbors[:, j]
        has = n >= 0
        assert (geos_tri.tri_group[n[has]] == geos_tri.tri_group[t[has]]).all()
        assert (geos_tri.neighbors[n[has]] == t[has, None]).any(axis=1).all()


def test_geos_exception_fails_only_its_group(monkeypatch):
    # GEOS raises for a whole array when one geometry fails: the batch is
    # split until the failing group is alone, the others keep GEOS's output.
    real = shapely.delaunay_triangles
    sets = [GOOD * scale for scale in (1, 2, 3, 4, 5)]
    local, ptr, groups = group_arrays(sets)
    poison = local[ptr[2] + 7, 0]  # a coordinate of group 2 only

    def flaky(lines, *args, **kwargs):
        if (shapely.get_coordinates(lines)[:, 0] == poison).any():
            raise shapely.errors.GEOSException("TopologyException: test")
        return real(lines, *args, **kwargs)

    monkeypatch.setattr(shapely, "delaunay_triangles", flaky)
    out = delaunay.triangulate_groups(local, ptr, groups)
    assert out.failed.tolist() == [False, False, True, False, False]
    points, codes = batch(sets)
    res = alpha_shapes(points, codes)  # the failed group goes to Qhull
    assert not res.degenerate.any()
    assert res.alpha[2] == pytest.approx(res.alpha[0] / 3, rel=1e-9)


def test_progress_counts_every_group():
    class Bar:
        n = 0

        def update(self, k):
            self.n += k

    sets = [GOOD + i for i in range(600)] + [COLLINEAR]
    bar = Bar()
    core.triangulate(*batch(sets), progress=bar, backend=geos)
    assert bar.n == 600  # the collinear group is flagged before triangulating


def test_duplicates_found_whatever_the_hash_and_collisions_fall_back(monkeypatch):
    # Points GEOS leaves out (exact duplicates) are matched to their vertex by
    # a hash of (group, x, y). Every pair is compared exactly: a hash that
    # collides for every point leaves the groups with duplicates to Qhull,
    # with the same optimum; it never pairs different points.
    rng = np.random.default_rng(5)
    sets = [rng.integers(0, 6, (40, 2)).astype(float) * 7.5 for _ in range(6)]
    points, codes = batch(sets)
    expected = alpha_shapes(points, codes)
    local, ptr, groups = group_arrays(sets)
    found = delaunay.triangulate_groups(local, ptr, groups)
    assert not found.failed.any()
    # Every point is represented by an equal point that GEOS kept.
    np.testing.assert_array_equal(local[found.vertex], local)
    assert len(np.unique(found.vertex)) < len(local)  # duplicates were there

    zero = lambda *w: np.zeros(len(w[0]), np.uint64)  # noqa: E731
    monkeypatch.setattr(delaunay, "hash64", zero)
    # (and in alpha_shapes' removal of exact duplicates, which then finds only
    # those next to each other in the input and leaves the rest to GEOS)
    monkeypatch.setattr(core, "hash64", zero)
    collided = delaunay.triangulate_groups(local, ptr, groups)
    np.testing.assert_array_equal(local[collided.vertex], local)
    assert collided.failed.any()  # some group lost its pairing: Qhull's now
    got = alpha_shapes(points, codes)
    np.testing.assert_array_equal(got.alpha, expected.alpha)
    assert shapely.equals(got.geometry, expected.geometry).all()


# --------------------------------------------------------------------------
# Exact repeats set aside before the triangulation (core.exact_duplicates)
# --------------------------------------------------------------------------


def first_equal_rows(xy, codes, other=None):
    """Brute force: the first row with the same group and coordinates."""
    seen, rep = {}, []
    for i in range(len(xy)):
        key = (int(codes[i]), xy[i, 0] + 0.0, xy[i, 1] + 0.0)
        if other is not None:
            key += (other[i, 0] + 0.0, other[i, 1] + 0.0)
        rep.append(seen.setdefault(key, i))
    return np.array(rep)


@examples(150, deadline=None)
@given(
    n=st.integers(0, 60),
    values=st.integers(1, 6),
    groups=st.integers(1, 3),
    seed=st.integers(0, 2**32 - 1),
    with_other=st.booleans(),
)
def test_exact_duplicates_are_the_brute_force_ones(n, values, groups, seed, with_other):
    rng = np.random.default_rng(seed)
    # Few distinct values: many repeats, -0.0 next to 0.0.
    grid = np.array([-0.0, 0.0, 1.5, -2.25, 1e-300, 7.0])[:values]
    xy = rng.choice(grid, (n, 2))
    codes = rng.integers(0, groups, n)
    other = rng.choice(grid, (n, 2)) if with_other else None
    got = core.exact_duplicates(xy, codes, other)
    expected = first_equal_rows(xy, codes, other)
    if got is None:
        np.testing.assert_array_equal(expected, np.arange(n))
    else:
        np.testing.assert_array_equal(got, expected)


def test_exact_duplicates_never_join_different_points_on_collisions(monkeypatch):
    monkeypatch.setattr(core, "hash64", lambda *w: np.zeros(len(w[0]), np.uint64))
    xy = np.array([[0.0, 0], [1, 1], [0, 0], [0, 0], [1, 1], [2, 2]])
    codes = np.zeros(6, dtype=int)
    # Every hash equal: the stable order is the input order, so only repeats
    # next to each other are found (row 3); the others stay rows of their own.
    assert core.exact_duplicates(xy, codes).tolist() == [0, 1, 2, 2, 4, 5]


def test_repeated_rows_count_and_share_their_points_result():
    rng = np.random.default_rng(3)
    base = rng.uniform(0, 10, (30, 2))
    base[0] = [60.0, 60.0]  # an outlier
    codes = np.zeros(30, dtype=int)
    repeat = rng.integers(0, 30, 25)
    repeat[:3] = 0  # the outlier three more times
    xy = np.concatenate([base, base[repeat]])
    groups = np.concatenate([codes, codes[repeat]])
    plain = alpha_shapes(base, codes, outliers=1)
    got = alpha_shapes(xy, groups, outliers=1)
    assert got.n_points.tolist() == [55]  # every row counts
    assert got.n_distinct.tolist() == plain.n_distinct.tolist() == [30]
    assert got.alpha.tolist() == plain.alpha.tolist()
    assert shapely.equals_exact(got.geometry, plain.geometry, tolerance=0).all()
    # The outlier's four rows are all left out, and only they.
    assert np.flatnonzero(got.outlier).tolist() == [0, 30, 31, 32]
    assert got.n_outliers.tolist() == plain.n_outliers.tolist() == [1]
