"""Degenerate groups and bad input (issue #2).

Groups with no triangle (0-2 distinct points, all collinear) get alpha nan,
an empty Polygon and a DegenerateGroupWarning from the one-group functions;
``alpha_shapes`` flags them without disturbing the other groups. Unusable
input raises InvalidInputError with a message that says what was wrong.
"""

from __future__ import annotations

import math
import re
import warnings

import numpy as np
import pytest
import shapely

import geoalpha
from geoalpha import (
    DegenerateGroupWarning,
    InvalidInputError,
    alpha_shape,
    alpha_shapes,
    optimal_alpha,
)

#: name -> (points, distinct points)
DEGENERATE = {
    "no points": (np.empty((0, 2)), 0),
    "one point": ([[3.5, -2.0]], 1),
    "two points": ([[0.0, 0.0], [10.0, 5.0]], 2),
    "all equal": ([[7.0, 7.0]] * 6, 1),
    "duplicates only": ([[0, 0], [1, 0], [0, 0], [1, 0], [1, 0]], 2),
    "collinear": ([[0, 0], [1, 1], [2, 2], [5, 5], [-3, -3]], 5),
    "collinear, unsorted": ([[2, 4], [0, 0], [3, 6], [1, 2]], 4),
    "collinear, vertical": ([[4, 0], [4, 1], [4, 7], [4, 3]], 4),
    "collinear, large offset": (
        [[500_000 + 3 * t, 6_000_000 + 4 * t] for t in (0, 5, 1, 9, 2, 7)],
        6,
    ),
    "collinear with duplicates": ([[0, 0], [2, 1], [0, 0], [4, 2], [2, 1]], 3),
}
TRIANGLE = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]  # circumradius sqrt(2) / 2


def message(distinct: int) -> str:
    return re.escape(
        f"the {distinct} distinct point(s) are fewer than 3 or all collinear"
    )


@pytest.mark.parametrize("name", list(DEGENERATE))
@pytest.mark.parametrize("search", ["exact", "ladder", "bisect"])
def test_optimal_alpha_is_nan_with_warning(name, search):
    points, distinct = DEGENERATE[name]
    with pytest.warns(DegenerateGroupWarning, match=message(distinct)) as record:
        alpha = optimal_alpha(points, search=search)
    assert math.isnan(alpha)
    assert len(record) == 1
    assert record[0].filename == __file__  # points at the caller's line


@pytest.mark.parametrize("name", list(DEGENERATE))
@pytest.mark.parametrize("alpha", [None, 0.0, 2.5])
@pytest.mark.parametrize("holes", [False, True])
def test_alpha_shape_is_empty_polygon(name, alpha, holes):
    points, distinct = DEGENERATE[name]
    with pytest.warns(DegenerateGroupWarning, match=message(distinct)):
        shape = alpha_shape(points, alpha, holes=holes)
    assert shape.geom_type == "Polygon"
    assert shape.is_empty


def test_degenerate_groups_beside_good_ones():
    names = list(DEGENERATE)
    groups = [np.asarray(DEGENERATE[n][0], dtype=float).reshape(-1, 2) for n in names]
    # Interleave the good group between the degenerate ones.
    groups.insert(3, np.array(TRIANGLE))
    good = 3
    points = np.concatenate(groups)
    codes = np.repeat(np.arange(len(groups)), [len(g) for g in groups])
    order = np.random.default_rng(1).permutation(len(points))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # alpha_shapes reports, never warns
        res = alpha_shapes(points[order], codes[order])

    expected_degenerate = np.ones(len(groups), dtype=bool)
    expected_degenerate[good] = False
    np.testing.assert_array_equal(res.degenerate, expected_degenerate)
    assert np.isnan(res.alpha[expected_degenerate]).all()
    assert res.alpha[good] == pytest.approx(math.sqrt(2), rel=1e-12)
    assert res.geometry[good].equals(shapely.Polygon(TRIANGLE))
    assert res.area[good] == pytest.approx(0.5)
    for g in np.flatnonzero(expected_degenerate):
        assert res.geometry[g].geom_type == "Polygon" and res.geometry[g].is_empty
        assert res.n_parts[g] == 0 and res.area[g] == 0
    np.testing.assert_array_equal(res.n_points, [len(g) for g in groups])
    distinct = [DEGENERATE[n][1] for n in names]
    distinct.insert(good, 3)
    np.testing.assert_array_equal(res.n_distinct, distinct)


def test_empty_codes_make_degenerate_groups():
    res = alpha_shapes(TRIANGLE, [2, 2, 2], n_groups=4)
    np.testing.assert_array_equal(res.degenerate, [True, True, False, True])
    np.testing.assert_array_equal(res.n_points, [0, 0, 3, 0])
    assert [g.is_empty for g in res.geometry] == [True, True, False, True]


@pytest.mark.parametrize("search", ["ladder", "bisect"])
def test_searches_skip_degenerate_groups(search):
    points = np.array([*TRIANGLE, [5, 5], [6, 6], [7, 7]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # in particular no SearchWarning
        res = alpha_shapes(points, [0, 0, 0, 1, 1, 1], search=search)
    assert math.isnan(res.alpha[1]) and res.degenerate[1]
    assert res.alpha[0] > 0


# --------------------------------------------------------------------------
# Bad input
# --------------------------------------------------------------------------


def test_input_errors_are_value_errors():
    assert issubclass(InvalidInputError, geoalpha.GeoAlphaError)
    assert issubclass(InvalidInputError, ValueError)


@pytest.mark.parametrize(
    ("bad_rows", "shown"),
    [
        ({0: (np.nan, 1.0)}, "in 1 row(s) (positions 0)"),
        ({3: (1.0, np.inf), 7: (-np.inf, np.nan)}, "in 2 row(s) (positions 3, 7)"),
        ({i: (np.nan, 0.0) for i in range(12)}, "in 12 row(s) (positions 0, 1, 2"),
    ],
)
@pytest.mark.parametrize("api", ["optimal_alpha", "alpha_shape", "alpha_shapes"])
def test_non_finite_coordinates_name_the_rows(bad_rows, shown, api):
    points = np.random.default_rng(0).uniform(0, 100, (20, 2))
    for row, value in bad_rows.items():
        points[row] = value
    call = {
        "optimal_alpha": lambda: optimal_alpha(points),
        "alpha_shape": lambda: alpha_shape(points),
        "alpha_shapes": lambda: alpha_shapes(points, np.arange(20) % 3),
    }[api]
    with pytest.raises(InvalidInputError, match="NaN or inf") as err:
        call()
    assert shown in str(err.value)
    if len(bad_rows) > 10:
        assert "9, ..." in str(err.value)  # first ten, then an ellipsis


def test_non_finite_rows_are_input_positions_not_sorted_positions():
    # Rows of several groups, not sorted by group: positions are input rows.
    points = np.array([[0, 0], [5, 5], [1, 0], [6, 5], [0, 1], [np.nan, 5], [5, 6]])
    with pytest.raises(InvalidInputError, match=r"\(positions 5\)"):
        alpha_shapes(points, [0, 1, 0, 1, 0, 1, 1])


@pytest.mark.parametrize(
    "points",
    [[[0, 0], [1]], [[0, 0], [1, "a"], [2, 2]]],
    ids=["ragged", "not numbers"],
)
def test_unreadable_points(points):
    with pytest.raises(InvalidInputError):
        optimal_alpha(points)


@pytest.mark.parametrize(
    "shape", [(4, 3), (4,), (2, 3, 2)], ids=["3 columns", "flat", "3-d"]
)
def test_wrong_point_shapes_are_named(shape):
    with pytest.raises(InvalidInputError, match=re.escape(f"got shape {shape}")):
        alpha_shapes(np.zeros(shape))


@pytest.mark.parametrize(
    ("groups", "expected"),
    [
        ([0, 0], "3 integer group codes"),
        ([0.0, 0.0, 0.0], "float64"),
        ([-1, 0, 0], "codes >= 0"),
    ],
)
def test_bad_group_codes(groups, expected):
    with pytest.raises(InvalidInputError, match=re.escape(expected)):
        alpha_shapes(TRIANGLE, groups)


def test_n_groups_smaller_than_codes():
    with pytest.raises(InvalidInputError, match="n_groups=1"):
        alpha_shapes(TRIANGLE, [0, 1, 1], n_groups=1)


def test_coords_of_wrong_shape():
    with pytest.raises(InvalidInputError, match=r"coords must have the shape"):
        alpha_shapes(TRIANGLE, coords=[[0.0, 0.0]])


@pytest.mark.parametrize(
    ("option", "expected"),
    [
        ({"holes": "yes"}, "holes must be True or False; got 'yes'"),
        ({"holes": 1}, "holes must be True or False; got 1"),
        ({"components": 0}, "components must be an integer >= 1; got 0"),
        ({"components": -2}, "components must be an integer >= 1; got -2"),
        ({"components": 1.5}, "components must be an integer >= 1; got 1.5"),
        ({"components": True}, "components must be an integer >= 1; got True"),
        (
            {"search": "foo"},
            "search must be one of 'exact', 'ladder', 'bisect'; got 'foo'",
        ),
    ],
)
@pytest.mark.parametrize("api", [optimal_alpha, alpha_shape, alpha_shapes])
def test_bad_options(option, expected, api):
    with pytest.raises(InvalidInputError, match=re.escape(expected)):
        api(TRIANGLE, **option)


@pytest.mark.parametrize("alpha", [-1, -1e-300, np.nan, np.inf, [1.0, -1.0]])
def test_bad_alpha(alpha):
    with pytest.raises(InvalidInputError, match="alpha must be finite and >= 0"):
        if isinstance(alpha, list):
            alpha_shapes([*TRIANGLE, *TRIANGLE], [0, 0, 0, 1, 1, 1], alpha=alpha)
        else:
            alpha_shape(TRIANGLE, alpha)


def test_bad_options_are_checked_before_degenerate_groups():
    # A bad option must not hide behind "no alpha shape".
    with pytest.raises(InvalidInputError, match="components"):
        optimal_alpha([[0, 0]], components=0)


def test_empty_list_is_no_points():
    with pytest.warns(geoalpha.DegenerateGroupWarning, match="0 distinct point"):
        assert math.isnan(geoalpha.optimal_alpha([]))


@pytest.mark.parametrize("alpha", ["x", [1.0, 2.0, 3.0]])
def test_alpha_that_is_not_a_number_per_group(alpha):
    with pytest.raises(geoalpha.InvalidInputError, match="alpha must be a number"):
        geoalpha.alpha_shape([[0, 0], [1, 0], [0, 1]], alpha=alpha)
