"""Tests of geoalpha._arrays.knn: the KNN concave hull (Moreira & Santos)."""

from __future__ import annotations

import numpy as np
import pyproj
import pytest
import shapely
from example_counts import examples
from hypothesis import given
from hypothesis import strategies as st
from shapely.geometry import box

from geoalpha import datasets
from geoalpha._arrays.knn import knn_hull
from geoalpha.errors import InvalidInputError


def check_hull(points, polygon):
    """The promises of knn_hull: valid, covers all, vertices are input points."""
    points = np.asarray(points, dtype=float)
    assert isinstance(polygon, shapely.Polygon)
    assert shapely.is_valid(polygon), shapely.is_valid_reason(polygon)
    assert len(polygon.interiors) == 0
    assert polygon.exterior.is_ccw
    assert shapely.covers(polygon, shapely.points(points)).all()
    vertices = np.asarray(polygon.exterior.coords)
    assert (vertices[:, None, :] == points[None, :, :]).all(axis=2).any(axis=1).all()
    assert polygon.area <= shapely.multipoints(points).convex_hull.area * (1 + 1e-12)


def grid(shape):
    """Integer grid points (x, y) with shape(x, y) true, x, y in 0..20."""
    return np.array(
        [(x, y) for x in range(21) for y in range(21) if shape(x, y)], dtype=float
    )


# --- shapes a user can check by eye -------------------------------------------


@pytest.mark.parametrize("k", [3, 5, 10])
def test_square_with_points_inside_gives_the_square(k):
    rng = np.random.default_rng(0)
    side = np.arange(0.0, 10.0, 0.5)
    boundary = np.concatenate(
        [
            np.c_[side, np.zeros_like(side)],
            np.c_[np.full_like(side, 10.0), side],
            np.c_[10.0 - side, np.full_like(side, 10.0)],
            np.c_[np.zeros_like(side), 10.0 - side],
        ]
    )
    inside = rng.uniform(1.0, 9.0, size=(200, 2))
    points = np.concatenate([inside, boundary])
    polygon, used_k = knn_hull(points, k=k)
    check_hull(points, polygon)
    assert polygon.equals(box(0, 0, 10, 10))
    assert used_k == k


def test_l_shape_follows_the_corner():
    points = grid(lambda x, y: x <= 4 or y <= 4)
    polygon, k = knn_hull(points)
    check_hull(points, polygon)
    assert k == 3
    assert polygon.area < 0.6 * polygon.convex_hull.area
    assert not polygon.intersects(box(6, 6, 20, 20))


def test_c_shape_leaves_the_bay_open():
    points = grid(lambda x, y: not (5 < x and 5 < y < 15))
    polygon, k = knn_hull(points)
    check_hull(points, polygon)
    assert k == 3
    assert polygon.area == pytest.approx(250.0)  # 20 x 20 minus the 15 x 10 bay
    assert polygon.convex_hull.area == pytest.approx(400.0)
    assert not polygon.contains(shapely.Point(12, 10))


def test_triangle_is_returned_with_k_two():
    polygon, k = knn_hull([(0, 0), (4, 0), (0, 3)])
    assert polygon.area == 6.0
    assert k == 2
    assert polygon.exterior.is_ccw


def test_duplicates_and_signed_zeros_are_ignored():
    points = np.array([(0.0, 0.0), (-0.0, 0.0), (0.0, -0.0), (1, 0), (0, 1), (1, 0)])
    polygon, k = knn_hull(points)
    check_hull(points, polygon)
    assert len(polygon.exterior.coords) == 4  # a triangle, closed
    assert k == 2


# --- k grows when it has to ---------------------------------------------------


def two_clusters():
    block = np.array([(x, y) for x in range(3) for y in range(3)], dtype=float)
    return np.concatenate([block, block + np.array([100.0, 0.0])])


def test_k_grows_until_every_point_is_covered():
    points = two_clusters()
    polygon, k = knn_hull(points)
    check_hull(points, polygon)
    assert k > 3  # k = 3 never reaches the far cluster
    # every smaller k fails, so with max_k = k - 1 the convex hull comes back
    fallback, k_fallback = knn_hull(points, k=3, max_k=k - 1)
    check_hull(points, fallback)
    assert fallback.equals(shapely.multipoints(points).convex_hull)
    assert k_fallback == len(points)


def test_k_starts_at_three_and_stops_at_n_minus_one():
    points = grid(lambda x, y: x <= 4 or y <= 4)
    assert knn_hull(points, k=1)[1] == 3
    square = [(0, 0), (1, 0), (1, 1), (0, 1)]
    polygon, k = knn_hull(square, k=50)
    assert k == 3
    assert polygon.equals(box(0, 0, 1, 1))


# --- random point sets --------------------------------------------------------


def random_points(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(3, 120))
    kind = seed % 4
    if kind == 0:
        return rng.uniform(0, 1000, size=(n, 2))
    if kind == 1:  # small integer grid: duplicates and many collinear points
        return rng.integers(0, 7, size=(n, 2)).astype(float)
    if kind == 2:  # thin and far from the origin, as in projected metres
        return rng.normal(size=(n, 2)) * (300.0, 15.0) + (530_000.0, 180_000.0)
    centres = np.array([(0.0, 0.0), (300.0, 0.0), (0.0, 300.0)])
    return rng.normal(size=(n, 2)) * 10 + centres[rng.integers(0, 3, n)]


def is_degenerate(points):
    distinct = np.unique(points, axis=0)
    if len(distinct) < 3:
        return True
    rel = distinct - distinct[0]
    return bool(
        (rel[:, 0] * rel[1:, 1, None] - rel[:, 1] * rel[1:, 0, None] == 0).all()
    )


@pytest.mark.parametrize("seed", range(300))
def test_random_sets_give_valid_covering_polygons(seed):
    points = random_points(seed)
    if is_degenerate(points):
        with pytest.raises(InvalidInputError):
            knn_hull(points)
        return
    polygon, k = knn_hull(points)
    check_hull(points, polygon)
    assert 2 <= k <= len(np.unique(points, axis=0))


@examples(200, deadline=None)
@given(
    st.lists(
        st.tuples(st.integers(-4, 4), st.integers(-4, 4)), min_size=1, max_size=40
    ),
    st.integers(1, 8),
)
def test_small_integer_sets_match_the_degeneracy_rule(coords, k):
    points = np.array(coords, dtype=float)
    if is_degenerate(points):
        with pytest.raises(InvalidInputError):
            knn_hull(points, k=k)
    else:
        polygon, _ = knn_hull(points, k=k)
        check_hull(points, polygon)


# --- bad input ----------------------------------------------------------------


@pytest.mark.parametrize(
    ("points", "kwargs", "message"),
    [
        ([(0, 0), (1, 1)], {}, "at least 3 distinct points; got 2"),
        ([(0, 0), (1, 1), (1, 1), (0, 0)], {}, "at least 3 distinct points; got 2"),
        ([(0, 0), (1, 1), (2, 2), (5, 5)], {}, "not all collinear; got 4"),
        (np.zeros((0, 2)), {}, "at least 3 distinct points; got 0"),
        (np.zeros((5, 3)), {}, r"\(n, 2\) array .* shape \(5, 3\)"),
        ([1.0, 2.0, 3.0], {}, r"\(n, 2\) array .* shape \(3,\)"),
        ([(0, 0), (1, np.nan), (0, 1), (np.inf, 2)], {}, r"2 rows .*\(index 1, 3\)"),
        ([(0, 0), (1, 0), (0, 1)], {"k": 0}, "k to be a positive integer; got 0"),
        ([(0, 0), (1, 0), (0, 1)], {"k": 2.5}, "k to be a positive integer"),
        ([(0, 0), (1, 0), (0, 1)], {"max_k": 2}, r"max_k >= max\(k, 3\) = 3"),
        ([(0, 0), (1, 0), (0, 1)], {"k": 6, "max_k": 5}, "= 6; got max_k=5"),
    ],
)
def test_bad_input_raises_with_a_clear_message(points, kwargs, message):
    with pytest.raises(InvalidInputError, match=message):
        knn_hull(points, **kwargs)


def test_invalid_input_error_is_a_value_error():
    with pytest.raises(ValueError, match="collinear"):
        knn_hull([(0, 0), (1, 0), (2, 0)])


# --- real data: the UK accident clusters ----------------------------------------


@pytest.fixture(scope="module")
def uk_groups():
    gdf = datasets.load("uk_clusters")
    to_bng = pyproj.Transformer.from_crs(4326, 27700, always_xy=True)
    x, y = to_bng.transform(gdf.geometry.x.to_numpy(), gdf.geometry.y.to_numpy())
    xy = np.column_stack([x, y])
    labels = gdf["Cluster"].to_numpy()
    return {c: np.unique(xy[labels == c], axis=0) for c in np.unique(labels)}


def test_uk_clusters_all_get_valid_covering_hulls(uk_groups):
    assert len(uk_groups) == 691
    ks = []
    for points in uk_groups.values():
        if is_degenerate(points):
            with pytest.raises(InvalidInputError):
                knn_hull(points)
            continue
        polygon, k = knn_hull(points)
        check_hull(points, polygon)
        ks.append(k)
    assert len(ks) >= 680
    assert np.median(ks) == 3
    assert max(ks) > 3
