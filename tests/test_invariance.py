"""Invariance of the optimum under moves that do not change the geometry.

Issue #2: translating by 1e7 m, scaling, reordering and duplicating rows do
not change the answer (up to the 1/scale of alpha). Coordinates are on a
1/1024 m grid (millimetre data), so that translations by whole metres are
exact in float64 and any difference comes from geoalpha, not from rounding
of the input.
"""

from __future__ import annotations

import numpy as np
import pytest
import reference
import shapely
from hypothesis import assume, given, note
from hypothesis import strategies as st
from scipy.spatial import Delaunay, QhullError

from geoalpha import alpha_shape, alpha_shapes, optimal_alpha

HOLES_COMPONENTS = pytest.mark.parametrize(
    ("holes", "components"), [(False, 1), (True, 1), (False, 2), (True, 2)]
)


def non_degenerate(p) -> bool:
    """At least 3 distinct points, not all collinear (scipy's Delaunay)."""
    try:
        Delaunay(np.unique(p, axis=0))
    except (QhullError, ValueError):
        return False
    return True


@st.composite
def millimetre_sets(draw, min_size=3, max_size=40):
    """Points spread over 10..5000 m on a 1/1024 m grid, uniform or clustered."""
    extent = draw(st.sampled_from([10, 100, 1000, 5000]))
    n = draw(st.integers(min_size, max_size))
    ticks = st.integers(0, extent * 1024)
    rows = draw(st.lists(st.tuples(ticks, ticks), min_size=n, max_size=n))
    p = np.array(rows, dtype=float) / 1024
    if draw(st.booleans()):  # pull the points towards a few centres
        k = draw(st.integers(1, 3))
        centre = p[draw(st.lists(st.integers(0, k - 1), min_size=n, max_size=n))]
        p = np.round((centre + p / 8) * 1024) / 1024
    assume(non_degenerate(p))
    note(f"points = np.array({p.tolist()!r})")
    return p


def assert_same_region(got, expected, rel=1e-9):
    assert got.geom_type == expected.geom_type
    diff = shapely.symmetric_difference(got, expected).area
    assert diff <= rel * expected.area, (diff, expected.area)


def assert_same_result(p, q, holes, components):
    """q is p reordered and/or with repeated rows: the same answer.

    The same up to the order of floating-point operations: geoalpha works
    relative to the group's first point, so alpha may move by an ulp.
    """
    a = optimal_alpha(p, holes=holes, components=components)
    b = optimal_alpha(q, holes=holes, components=components)
    assert b == pytest.approx(a, rel=1e-12, abs=0)
    shape_p = alpha_shape(p, holes=holes, components=components)
    shape_q = alpha_shape(q, holes=holes, components=components)
    assert shape_q.geom_type == shape_p.geom_type
    assert shape_q.equals(shape_p)


@HOLES_COMPONENTS
@given(
    p=millimetre_sets(),
    shift=st.tuples(
        st.integers(-(10**7), 10**7), st.sampled_from([-(10**7), 10**7])
    ).flatmap(st.permutations),
)
def test_translation_by_1e7_metres(p, shift, holes, components):
    t = np.array(shift, dtype=float)
    far = p + t
    assert np.array_equal(far - t, p)  # exact, by construction
    a = optimal_alpha(p, holes=holes, components=components)
    b = optimal_alpha(far, holes=holes, components=components)
    assert b == pytest.approx(a, rel=1e-9, abs=0)
    near = alpha_shape(p, holes=holes, components=components)
    back = shapely.transform(
        alpha_shape(far, holes=holes, components=components), lambda c: c - t
    )
    assert_same_region(back, near)


@given(p=millimetre_sets(), holes=st.booleans())
def test_translated_copies_in_one_batch(p, holes):
    # One call, the same group at the origin, at UTM-like and at 1e7 m offsets.
    offsets = np.array([[0, 0], [500_000, 6_000_000], [10**7, -(10**7)]], dtype=float)
    points = np.concatenate([p + o for o in offsets])
    codes = np.repeat(np.arange(len(offsets)), len(p))
    res = alpha_shapes(points, codes, holes=holes)
    assert res.alpha[1:] == pytest.approx([res.alpha[0]] * 2, rel=1e-9, abs=0)
    assert res.alpha[0] == pytest.approx(optimal_alpha(p, holes=holes), rel=1e-9)
    for geom, o in zip(res.geometry[1:], offsets[1:], strict=True):
        assert_same_region(
            shapely.transform(geom, lambda c, o=o: c - o), res.geometry[0]
        )


@HOLES_COMPONENTS
@given(
    p=millimetre_sets(),
    s=st.sampled_from([2.0**-7, 2.0**5, 0.3048, 1 / 111_320, 1e3, 1e-3, 3.7]),
)
def test_scaling_divides_alpha(p, s, holes, components):
    a = optimal_alpha(p, holes=holes, components=components)
    b = optimal_alpha(p * s, holes=holes, components=components)
    assert b == pytest.approx(a / s, rel=1e-9, abs=0)
    scaled = shapely.transform(
        alpha_shape(p, holes=holes, components=components), lambda c: c * s
    )
    assert_same_region(alpha_shape(p * s, holes=holes, components=components), scaled)


#: Exact maps of the plane onto itself (no rounding on a 1/1024 m grid).
MOVES = {
    "quarter turn": lambda c: np.c_[-c[:, 1], c[:, 0]],
    "half turn": lambda c: -c,
    "mirror": lambda c: np.c_[-c[:, 0], c[:, 1]],
    "swap axes": lambda c: c[:, ::-1],
}


@HOLES_COMPONENTS
@given(p=millimetre_sets(), move=st.sampled_from(sorted(MOVES)))
def test_exact_rotations_and_mirrors(p, move, holes, components):
    f = MOVES[move]
    a = optimal_alpha(p, holes=holes, components=components)
    b = optimal_alpha(f(p), holes=holes, components=components)
    assert b == pytest.approx(a, rel=1e-9, abs=0)
    moved = shapely.transform(alpha_shape(p, holes=holes, components=components), f)
    assert_same_region(alpha_shape(f(p), holes=holes, components=components), moved)


@HOLES_COMPONENTS
@given(data=st.data())
def test_row_order_does_not_matter(data, holes, components):
    p = data.draw(millimetre_sets(), label="points")
    order = data.draw(st.permutations(range(len(p))), label="order")
    assert_same_result(p, p[list(order)], holes, components)


@HOLES_COMPONENTS
@given(data=st.data())
def test_duplicated_rows_do_not_matter(data, holes, components):
    p = data.draw(millimetre_sets(), label="points")
    repeat = data.draw(
        st.lists(st.integers(0, len(p) - 1), min_size=1, max_size=2 * len(p)),
        label="repeated rows",
    )
    q = np.concatenate([p, p[repeat]])
    order = data.draw(st.permutations(range(len(q))), label="order")
    q = q[list(order)]
    assert_same_result(p, q, holes, components)
    res = alpha_shapes(q, holes=holes, components=components)
    assert res.n_points[0] == len(q)
    assert res.n_distinct[0] == len(np.unique(p, axis=0))


@st.composite
def utm_like_sets(draw):
    """Decimal coordinates (1 mm) spread over 10..5000 m, far from the origin."""
    extent = draw(st.sampled_from([10, 100, 1000, 5000]))
    n = draw(st.integers(3, 30))
    ticks = st.integers(0, extent * 1000)
    rows = draw(st.lists(st.tuples(ticks, ticks), min_size=n, max_size=n))
    offset = draw(
        st.sampled_from([(500_000, 6_000_000), (10**7, 10**7), (-(10**7), 3e6)])
    )
    p = np.array(rows, dtype=float) / 1000 + np.array(offset, dtype=float)
    assume(non_degenerate(p))
    note(f"points = np.array({p.tolist()!r})")
    return p


@HOLES_COMPONENTS
@given(p=utm_like_sets())
def test_large_offsets_against_reference(p, holes, components):
    # Not exact translations of a grid: the reference's exact circumradii of
    # these very floats decide.
    expected = reference.graph_optimum(p, holes=holes, components=components)
    got = optimal_alpha(p, holes=holes, components=components)
    assert got == pytest.approx(expected, rel=1e-9, abs=0)
