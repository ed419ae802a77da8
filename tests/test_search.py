"""The seed paper's integer ladder and alphashape's float bisection (issue #2).

``search="ladder"`` is checked against a brute-force ladder written here on
top of ``reference`` (no geoalpha code), on random sets in degree-like units
(optimal alphas 1..5000); ``search="bisect"`` against the exact optimum; and
``search.ladder_alpha`` / ``search.bisect_alpha`` with synthetic oracles.
"""

from __future__ import annotations

import math
import sys
import warnings

import numpy as np
import pytest
import reference
import shapely
from example_counts import examples
from hypothesis import assume, event, given, note
from hypothesis import strategies as st
from scipy.sparse import csr_array
from scipy.sparse.csgraph import connected_components
from scipy.spatial import QhullError

from geoalpha import SearchWarning, alpha_shape, alpha_shapes, optimal_alpha
from geoalpha._arrays.search import LADDER, bisect_alpha, ladder_alpha
from geoalpha.errors import InvalidInputError

#: The seed paper's rungs, copied from the paper, not from geoalpha.
RUNGS = (5000, 3000, 1000, 500, 300, 100, 50, 25, 18, 10, 5, 0)
EPS = np.finfo(float).eps

HOLES_COMPONENTS = pytest.mark.parametrize(
    ("holes", "components"), [(False, 1), (True, 1), (False, 2), (True, 2)]
)


# --------------------------------------------------------------------------
# A validity test and a ladder built on reference.py only
# --------------------------------------------------------------------------


class ReferenceShape:
    """S(alpha) of one point set by DESIGN.md, from reference.py primitives."""

    def __init__(self, points, holes, components):
        self.pts, self.simplices, self.neighbors, self.r = reference.triangulation(
            points
        )
        self.holes, self.components = holes, components
        m = len(self.r)
        a = np.repeat(np.arange(m), 3)
        b = self.neighbors.ravel()
        self.edge_a, self.edge_b = a[b >= 0], b[b >= 0]

    def valid_at_radius(self, radius) -> bool:
        mask = reference.shape_mask(self.neighbors, self.r, radius, self.holes)
        covered = np.zeros(len(self.pts), dtype=bool)
        covered[self.simplices[mask].ravel()] = True
        if not covered.all():
            return False
        e = mask[self.edge_a] & mask[self.edge_b]
        m = len(self.r)
        graph = csr_array(
            (np.ones(e.sum()), (self.edge_a[e], self.edge_b[e])), shape=(m, m)
        )
        _, label = connected_components(graph, directed=False)
        return 1 <= len(np.unique(label[mask])) <= self.components

    def valid(self, alpha) -> bool:
        return self.valid_at_radius(1.0 / alpha if alpha > 0 else math.inf)

    def monotone(self) -> bool:
        """Valid at every spectrum value above the smallest valid one?"""
        ok = [self.valid_at_radius(R) for R in reference.spectrum(self.r)]
        return all(ok[ok.index(True) :])


def brute_ladder(valid) -> tuple[int, int]:
    """The paper's ladder, one test at a time: (alpha, number of tests).

    Walk the rungs down to the first valid one (alpha = 0, the convex hull,
    always is), then bisect the integers between it and the rung above.
    """
    i = 0
    while RUNGS[i] != 0 and not valid(RUNGS[i]):
        i += 1
    tests = i + 1
    lo, hi = RUNGS[i], RUNGS[max(i - 1, 0)]
    while hi - lo > 1:
        mid = (lo + hi) // 2
        tests += 1
        if valid(mid):
            lo = mid
        else:
            hi = mid
    return lo, tests


# --------------------------------------------------------------------------
# Point sets with a chosen optimum
# --------------------------------------------------------------------------

UNIT = st.integers(0, 10**6).map(lambda i: i / 10**6)


@st.composite
def unit_sets(draw):
    """3..25 points in the unit square, uniform or in a few clusters."""
    n = draw(st.integers(3, 25))
    p = np.array(draw(st.lists(st.tuples(UNIT, UNIT), min_size=n, max_size=n)))
    if draw(st.booleans()):
        k = draw(st.integers(1, 3))
        p = p[draw(st.lists(st.integers(0, k - 1), min_size=n, max_size=n))] + p / 10
    return p


def scaled_to(p, target, holes, components):
    """p scaled so that its exact optimum (per reference) is about target."""
    try:
        a = reference.graph_optimum(p, holes=holes, components=components)
    except (QhullError, ValueError):  # degenerate: no triangle
        assume(False)
    assume(a > 0)
    q = p * (a / target)
    note(f"points = np.array({q.tolist()!r})")
    return q


# --------------------------------------------------------------------------
# search="ladder"
# --------------------------------------------------------------------------


def test_ladder_rungs_are_the_papers():
    assert LADDER == RUNGS


#: Optimal alphas like 1.05 .. 9999.95, at least 0.05 from an integer: at an
#: integer optimum the ladder's answer would hinge on rounding (geoalpha's
#: solid test has 8 eps of slack, the reference's 1e-10).
TARGETS = st.builds(
    lambda tenths_of_decade, twentieths: (
        int(10 ** (tenths_of_decade / 10)) + twentieths / 20
    ),
    st.integers(0, 39),  # integer part 1 .. 7943, log-uniform
    st.integers(1, 19),  # fraction .05 .. .95
)


@HOLES_COMPONENTS
@examples(60)
@given(p=unit_sets(), target=TARGETS)
def test_ladder_matches_brute_force(p, target, holes, components):
    q = scaled_to(p, target, holes, components)
    ref = ReferenceShape(q, holes, components)
    exact = reference.graph_optimum(q, holes=holes, components=components)

    got = optimal_alpha(q, holes=holes, components=components, search="ladder")
    assert float(got).is_integer()
    assert got == brute_ladder(ref.valid)[0]
    assert got <= exact  # the ladder only ever stands on valid alphas
    assert got == 0 or ref.valid(got)
    event("validity monotone" if ref.monotone() else "validity NOT monotone")
    event(f"ladder result {'0' if got == 0 else '5000' if got == 5000 else 'between'}")
    if ref.monotone():
        # Then the valid alphas are [0, exact]: the ladder finds its floor.
        assert got == min(math.floor(exact), 5000)
    # The shape at the ladder's alpha is the shape geoalpha builds there.
    shape = alpha_shapes(
        q, holes=holes, components=components, search="ladder"
    ).geometry[0]
    assert shape.equals(alpha_shape(q, got, holes=holes))


def test_ladder_in_metres_is_the_convex_hull():
    # Integer alphas in 1/metre: a set spread over kilometres only passes 0.
    p = np.random.default_rng(3).uniform(0, 5000, (40, 2))
    assert optimal_alpha(p, search="ladder") == 0
    hull = shapely.convex_hull(shapely.multipoints(p))
    assert alpha_shape(p, search="ladder").equals(hull)
    assert 0 < optimal_alpha(p) < 1


# --------------------------------------------------------------------------
# search="bisect"
# --------------------------------------------------------------------------


@HOLES_COMPONENTS
@examples(40)
@given(p=unit_sets(), target=st.integers(1, 390).map(lambda i: i / 100))
def test_bisect_below_4_converges_to_the_optimum(p, target, holes, components):
    q = scaled_to(p, target, holes, components)
    exact = optimal_alpha(q, holes=holes, components=components)
    assume(exact < 4)
    with warnings.catch_warnings():
        warnings.simplefilter("error", SearchWarning)
        got = optimal_alpha(q, holes=holes, components=components, search="bisect")
    # The bisection returns the lower end of its final bracket [lo, hi],
    # hi - lo <= 2 eps: lo is valid, hi is not. The solid test has a slack of
    # 8 eps (relative) so that alpha = 1 / r keeps triangle r, hence lo may
    # exceed the exact optimum by that slack, never by more.
    assert abs(got - exact) <= 1e-12
    assert exact - 2 * EPS <= got <= exact * (1 + 8 * EPS) + 2 * EPS
    expected = alpha_shape(q, holes=holes, components=components)
    assert alpha_shape(q, got, holes=holes).equals(expected)


@pytest.mark.parametrize("target", [4.0, 4.5, 100.0, 3000.0])
def test_bisect_from_4_up_gives_up_with_warning(target):
    p = np.random.default_rng(7).uniform(0, 1, (12, 2))
    q = p * (reference.graph_optimum(p) / target)
    assert optimal_alpha(q) == pytest.approx(target, rel=1e-12)
    with pytest.warns(
        SearchWarning, match=r"did not converge within max_iterations=10000"
    ) as rec:
        got = optimal_alpha(q, search="bisect")
    assert got == 0
    assert "gave them alpha 0, the convex hull" in str(rec[0].message)
    assert rec[0].filename == __file__
    # alpha=0 really is the convex hull.
    with pytest.warns(SearchWarning):
        shape = alpha_shape(q, search="bisect")
    assert shape.equals(shapely.convex_hull(shapely.multipoints(q)))


def test_bisect_warning_names_only_the_groups_that_gave_up():
    rng = np.random.default_rng(11)
    sets = [rng.uniform(0, 1, (10, 2)) for _ in range(4)]
    targets = [0.5, 40.0, 2.0, 7.0]
    sets = [
        p * (reference.graph_optimum(p) / t) for p, t in zip(sets, targets, strict=True)
    ]
    points = np.concatenate(sets)
    codes = np.repeat(np.arange(4), 10)
    with pytest.warns(SearchWarning, match=r"for 2 group\(s\) \(codes 1, 3\)"):
        res = alpha_shapes(points, codes, search="bisect", max_iterations=2000)
    assert res.alpha[[1, 3]].tolist() == [0.0, 0.0]
    assert res.alpha[[0, 2]] == pytest.approx([0.5, 2.0], rel=1e-12)


@pytest.mark.parametrize("n_jobs", [1, 2])
def test_hull_bisect_warning_names_the_groups_by_key_once(n_jobs):
    import geopandas as gpd
    import pandas as pd

    rng = np.random.default_rng(11)
    sets = [rng.uniform(0, 1, (10, 2)) for _ in range(4)]
    targets = [0.5, 40.0, 2.0, 7.0]  # in 1/metre: the bisection gives up >= 4
    sets = [
        p * (reference.graph_optimum(p) / t) for p, t in zip(sets, targets, strict=True)
    ]
    xy = np.concatenate(sets)
    frame = gpd.GeoDataFrame(
        {"site": np.repeat(["north", "east", "south", "west"], 10)},
        geometry=gpd.points_from_xy(xy[:, 0], xy[:, 1]),
        crs="EPSG:27700",
    )
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        hulls = frame.alpha.hull(
            by="site", search="bisect", max_iterations=2000, n_jobs=n_jobs
        )
    messages = [str(w.message) for w in caught if w.category is SearchWarning]
    assert messages == [
        "search='bisect' did not converge within max_iterations=2000 for 2 "
        "group(s) ('east' (10 rows); 'west' (10 rows)) and gave them alpha 0, "
        "the convex hull, as alphashape does; use search='exact'"
    ]
    alpha = pd.Series(hulls["alpha"].to_numpy(), index=hulls["site"])
    assert alpha[["east", "west"]].tolist() == [0.0, 0.0]
    assert alpha[["north", "south"]].tolist() == pytest.approx([0.5, 2.0], rel=1e-12)


def test_name_groups_must_be_a_function():
    with pytest.raises(InvalidInputError, match="name_groups must be a function"):
        alpha_shapes(np.eye(3), name_groups=["a"])


def test_bisect_max_iterations_is_passed_on():
    p = np.random.default_rng(5).uniform(0, 1, (10, 2))
    q = p * (reference.graph_optimum(p) / 0.5)
    # From 0 to the largest float, ~1,075 halvings reach an optimum < 4.
    with pytest.warns(SearchWarning, match="max_iterations=500"):
        assert optimal_alpha(q, search="bisect", max_iterations=500) == 0
    with warnings.catch_warnings():
        warnings.simplefilter("error", SearchWarning)
        assert optimal_alpha(q, search="bisect", max_iterations=1100) == pytest.approx(
            0.5, rel=1e-12
        )


# --------------------------------------------------------------------------
# search.ladder_alpha / search.bisect_alpha with synthetic oracles
# --------------------------------------------------------------------------


class ThresholdOracle:
    """valid(g, a) = a <= t[g], counting calls and tests."""

    def __init__(self, thresholds):
        self.t = np.asarray(thresholds, dtype=float)
        self.calls = 0
        self.tests = np.zeros(len(self.t), dtype=int)

    def __call__(self, groups, alphas):
        groups, alphas = np.asarray(groups), np.asarray(alphas, dtype=float)
        assert groups.shape == alphas.shape
        self.calls += 1
        np.add.at(self.tests, groups, 1)
        return alphas <= self.t[groups]


@given(st.lists(st.floats(0, 1e5), min_size=1, max_size=20))
def test_ladder_alpha_with_threshold_oracle(thresholds):
    oracle = ThresholdOracle(thresholds)
    alpha, tests = ladder_alpha(oracle, len(thresholds))
    expected = np.minimum(np.floor(thresholds), 5000)
    np.testing.assert_array_equal(alpha, expected)
    # tests: what the sequential ladder of the slowest group needs.
    assert tests == max(brute_ladder(lambda a, t=t: a <= t)[1] for t in thresholds)
    # Vectorised over groups: one call per round, not per group.
    assert oracle.calls <= 1 + math.ceil(math.log2(2000)) + 1


def test_ladder_alpha_counts_tests():
    # 7: rungs 5000..10 fail, 5 passes (11 tests), then 7 ok, 8 not (13).
    oracle = ThresholdOracle([7.5])
    alpha, tests = ladder_alpha(oracle, 1)
    assert alpha.tolist() == [7.0] and tests == 13


def test_ladder_alpha_misses_a_higher_valid_window():
    # Valid for a <= 2 and for 7 <= a <= 8: the ladder stops at 2 (the true
    # maximum is 8), which is why search="exact" tests every spectrum value.
    def valid(groups, alphas):
        return (alphas <= 2) | ((alphas >= 7) & (alphas <= 8))

    alpha, _ = ladder_alpha(valid, 1)
    assert alpha.tolist() == [2.0]


def test_ladder_alpha_top_rung_and_custom_rungs():
    alpha, tests = ladder_alpha(ThresholdOracle([1e9]), 1)
    assert alpha.tolist() == [5000.0] and tests == 1
    alpha, _ = ladder_alpha(ThresholdOracle([37.2, 0.5]), 2, rungs=(64, 16, 0))
    assert alpha.tolist() == [37.0, 0.0]


@given(st.lists(st.floats(0, 3.99), min_size=1, max_size=10))
def test_bisect_alpha_converges_below_4(thresholds):
    oracle = ThresholdOracle(thresholds)
    alpha, gave_up, tests = bisect_alpha(oracle, len(thresholds), max_iterations=2000)
    t = np.asarray(thresholds)
    assert not gave_up.any()
    assert (alpha <= t).all()  # the lower end of the bracket is valid
    assert (t - alpha <= 2 * EPS).all()
    assert 1000 <= tests <= 1100  # ~1,075 halvings from 0 to 1.8e308


@given(st.lists(st.floats(4, 1e300), min_size=1, max_size=10))
def test_bisect_alpha_gives_up_from_4(thresholds):
    alpha, gave_up, _ = bisect_alpha(
        ThresholdOracle(thresholds), len(thresholds), max_iterations=1500
    )
    assert gave_up.all()
    assert (alpha == 0).all()


def test_bisect_alpha_valid_at_upper_bound_is_zero_without_giving_up():
    alpha, gave_up, _ = bisect_alpha(ThresholdOracle([sys.float_info.max]), 1)
    assert alpha.tolist() == [0.0] and gave_up.tolist() == [False]


def test_bisect_alpha_custom_bracket():
    alpha, gave_up, tests = bisect_alpha(
        ThresholdOracle([0.3]), 1, lower=0.0, upper=1.0
    )
    assert alpha[0] == pytest.approx(0.3, abs=2 * EPS) and not gave_up[0]
    assert tests <= 60
