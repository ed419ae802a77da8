"""The kernel at its limits (issue #37): one group never takes the others down,
limits are checked at the edge, no entry point aborts the process, Ctrl-C works.

Each test is made from a reproducer of the issue and failed before its fix.
"""

from __future__ import annotations

import warnings

import geopandas as gpd
import numpy as np
import pytest
import shapely

import geoalpha
from geoalpha import DegenerateGroupWarning, kernel

GOOD = np.array([[10, 10], [14, 10], [14, 14], [10, 14], [12, 13.5]], float)
TRIANGLE = np.array([[0, 0], [1, 0], [0, 1]], float)
# (1e-60, 0) beside (0, 0): below 2^-142 of the extent, spade set it to 0 and
# merged the two points, and the kernel panicked (repro 01).
TINY = np.r_[TRIANGLE, [[1e-60, 0]]]
SUBNORMAL = np.r_[TRIANGLE, [[5e-324, 5e-324]]]


@pytest.mark.parametrize("bad", [TINY, SUBNORMAL], ids=["1e-60", "5e-324"])
def test_a_tiny_coordinate_beside_zero_is_one_point_with_it(bad):
    res = geoalpha.alpha_shapes(bad)
    assert res.reason.tolist() == [0]
    assert res.n_distinct.tolist() == [3]
    # The optimum of the triangle: its convex hull (radius sqrt(2) / 2).
    assert res.alpha[0] == pytest.approx(np.sqrt(2), rel=1e-12)
    assert shapely.covers(res.geometry[0], shapely.points(bad)).all()
    assert geoalpha.optimal_alpha(bad) == pytest.approx(np.sqrt(2), rel=1e-12)


def test_hull_by_group_returns_every_group_beside_a_tiny_coordinate():
    xy = np.r_[GOOD, TINY]
    frame = gpd.GeoDataFrame(
        {"g": np.repeat(["good", "tiny"], [5, 4])},
        geometry=shapely.points(xy),
        crs="EPSG:32630",
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error", DegenerateGroupWarning)
        out = frame.alpha.hull(by="g")
    assert sorted(out["g"]) == ["good", "tiny"]
    for key, rows in (("good", GOOD), ("tiny", TINY)):
        shape = out.loc[out["g"] == key].geometry.iloc[0]
        assert shape.is_valid and not shape.is_empty
        assert shapely.covers(shape, shapely.points(rows)).all()
    good = out.loc[out["g"] == "good"].geometry.iloc[0]
    assert good.equals(geoalpha.alpha_shape(GOOD))


def _fail_group(monkeypatch, failed: int):
    """Make the kernel fail on group ``failed`` as a caught panic does: reason 7,
    no alpha, no rings, each point its own representative."""
    real = kernel._kernel.alpha_shapes

    def alpha_shapes(xy, offsets, **kwargs):
        res = real(xy, offsets, **kwargs)
        if failed >= len(offsets) - 1:
            return res
        go, po, ro = res["group_offsets"], res["polygon_offsets"], res["ring_offsets"]
        p0, p1 = go[failed], go[failed + 1]
        r0, r1 = po[p0], po[p1]
        v0, v1 = ro[r0], ro[r1]
        out = dict(res)
        out["ring_vertex"] = np.r_[res["ring_vertex"][:v0], res["ring_vertex"][v1:]]
        out["ring_offsets"] = np.r_[ro[: r0 + 1], ro[r1 + 1 :] - (v1 - v0)]
        out["polygon_offsets"] = np.r_[po[: p0 + 1], po[p1 + 1 :] - (r1 - r0)]
        out["group_offsets"] = np.r_[go[: failed + 1], go[failed + 1 :] - (p1 - p0)]
        for key, value in (("reason", 7), ("alpha", np.nan), ("n_parts", 0)):
            out[key] = res[key].copy()
            out[key][failed] = value
        a, b = offsets[failed], offsets[failed + 1]
        out["rep"] = res["rep"].copy()
        out["rep"][a:b] = np.arange(a, b)
        return out

    monkeypatch.setattr(kernel._kernel, "alpha_shapes", alpha_shapes)


def test_a_group_the_kernel_failed_on_warns_with_its_rows_and_spares_the_others(
    monkeypatch,
):
    _fail_group(monkeypatch, 1)
    xy = np.r_[GOOD, GOOD + 100, GOOD + 200]
    with pytest.warns(DegenerateGroupWarning) as caught:
        res = geoalpha.alpha_shapes(xy, np.repeat([0, 1, 2], 5))
    message = str(caught[0].message)
    assert (
        "the kernel failed on 1 group(s) (codes 1; rows at positions 5, 6, 7" in message
    )
    assert res.reason.tolist() == [0, 7, 0]
    assert res.degenerate.tolist() == [False, True, False]
    assert res.geometry[1].is_empty and np.isnan(res.alpha[1])
    for g in (0, 2):
        assert res.geometry[g].equals(geoalpha.alpha_shape(GOOD + 100 * g))
    assert kernel.REASONS[7].startswith("the kernel failed on this group")


def test_hull_names_the_group_the_kernel_failed_on(monkeypatch):
    _fail_group(monkeypatch, 1)
    xy = np.r_[GOOD, GOOD + 100, GOOD + 200]
    frame = gpd.GeoDataFrame(
        {"g": np.repeat(["a", "b", "c"], 5)}, geometry=shapely.points(xy), crs=32630
    )
    with pytest.warns(
        DegenerateGroupWarning, match=r"kernel failed on 1 group.*'b' \(5 rows\)"
    ):
        out = frame.alpha.hull(by="g", degenerate="empty").set_index("g")
    assert np.isnan(out.loc["b", "alpha"]) and out.loc["b", "geometry"].is_empty
    for key, g in (("a", 0), ("c", 2)):
        shape = out.loc[key, "geometry"]
        assert shape.equals(geoalpha.alpha_shape(GOOD + 100 * g))
