"""The pictures of issue #35: plot_curve() and plot_why() (the ``[plot]`` extra).

What a user sees: one axes per group, in order (the flagged groups first),
titled with the group; on the map, the hulls, the critical triangles and the
flagged location.
"""

from __future__ import annotations

import warnings

import geopandas as gpd
import numpy as np
import pandas as pd
import pytest
import shapely
from compat import HAS_MATPLOTLIB, require_for_module

import geoalpha
from geoalpha import datasets
from geoalpha.errors import GeoAlphaWarning, InvalidInputError

require_for_module(HAS_MATPLOTLIB, "geoalpha[plot] (matplotlib)")

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

STATES = ["CO", "RI", "UT", "DE"]


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


def quiet(function, *args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", GeoAlphaWarning)
        return function(*args, **kwargs)


@pytest.fixture(scope="module")
def with_hawaii():
    """Four states' airports, and Hawaii with 50 rows at one spot 700 km west."""
    a = datasets.load("us_airports")
    some = a[a["state"].isin([*STATES, "HI"])]
    wrong = gpd.GeoDataFrame(
        {"state": ["HI"] * 50},
        geometry=shapely.points(np.full((50, 2), (-168.02, 24.86))),
        crs=4326,
        index=pd.RangeIndex(9000, 9050),
    )
    return pd.concat([some, wrong])


def test_plot_curve_one_axes_per_group_flagged_first(with_hawaii):
    curve = quiet(
        geoalpha.curve,
        with_hawaii,
        by="state",
        max_left_out=3,
        outlier_unit="locations",
    )
    why = quiet(geoalpha.explain, with_hawaii, by="state")
    assert why.loc[why["suspicious"], "state"].tolist() == ["HI"]
    fig = geoalpha.plot_curve(curve, why)
    titles = [ax.get_title() for ax in fig.axes]
    assert len(titles) == 5
    assert titles[0] == "HI (flagged)"
    assert sorted(titles[1:]) == sorted(STATES)
    # after the flagged one: the largest fall of area first
    # (a group's curve stops where 3 locations are left: DE's at k = 2)
    fall = {
        state: 1 - rows["area_m2"].iloc[-1] / rows["area_m2"].iloc[0]
        for state, rows in curve.sort_values("k").groupby("state")
    }
    assert titles[1:] == sorted(STATES, key=lambda s: -fall[s])
    area = curve.pivot(index="k", columns="state", values="area_m2")
    # each plot: area (km²) against k = 0..3
    hi = fig.axes[0].lines[0]
    assert hi.get_xdata().tolist() == [0, 1, 2, 3]
    np.testing.assert_allclose(hi.get_ydata(), area["HI"] / 1e6)
    assert fig.axes[0].get_ylabel() == "area (km²)"
    assert "5 group(s); 1 flagged, first" in fig.texts[0].get_text()


def test_plot_curve_without_why_and_a_limit(with_hawaii):
    curve = quiet(
        geoalpha.curve,
        with_hawaii,
        by="state",
        max_left_out=2,
        outlier_unit="locations",
    )
    fig = geoalpha.plot_curve(curve, max_groups=2, columns=1)
    assert len(fig.axes) == 2
    assert not any("flagged" in ax.get_title() for ax in fig.axes)
    assert "5 group(s) (2 shown)" in fig.texts[0].get_text()


def test_plot_curve_one_group_without_by():
    a = datasets.load("us_airports")
    curve = quiet(geoalpha.curve, a[a["state"] == "RI"], max_left_out=1)
    fig = geoalpha.plot_curve(curve)
    assert [ax.get_title() for ax in fig.axes] == ["all points"]


def test_plot_curve_of_planar_degrees_says_the_unit(with_hawaii):
    # crs=None on lon/lat: the curve has area and unit (degree), not area_m2
    curve = quiet(geoalpha.curve, with_hawaii, by="state", crs=None, max_left_out=2)
    fig = geoalpha.plot_curve(curve)
    assert {ax.get_ylabel() for ax in fig.axes} == {"area (degree²)"}
    hi = fig.axes[[ax.get_title() for ax in fig.axes].index("HI")]
    want = curve.loc[curve["state"] == "HI", "area"].to_numpy()
    np.testing.assert_array_equal(hi.lines[0].get_ydata(), want)


def test_plot_curve_refuses_another_table():
    with pytest.raises(InvalidInputError, match=r"expected a table of geoalpha\.curve"):
        geoalpha.plot_curve(pd.DataFrame({"a": [1]}))


def test_plot_why_draws_hulls_triangles_and_the_flagged_location(with_hawaii):
    hulls = quiet(geoalpha.hull, with_hawaii, by="state")
    why = quiet(geoalpha.explain, with_hawaii, by="state")
    fig = geoalpha.plot_why(why, hulls, with_hawaii)
    ax = fig.axes[0]
    assert ax.get_title() == (
        "5 hulls, their critical triangles and 1 flagged location"
    )
    # the flagged location: a red cross at the wrong spot, named
    crosses = [line for line in ax.lines if line.get_marker() == "x"]
    assert len(crosses) == 1
    assert (crosses[0].get_xdata()[0], crosses[0].get_ydata()[0]) == (-168.02, 24.86)
    assert [t.get_text() for t in ax.texts] == ["HI: 50 row(s)"]
    # the hulls (filled) and the triangles (outlined): 5 + 5 patches
    polygons = [c for c in ax.collections if len(c.get_paths()) == 5]
    assert len(polygons) == 2


def test_plot_why_on_given_axes_without_points(with_hawaii):
    why = quiet(geoalpha.explain, with_hawaii, by="state")
    fig, ax = plt.subplots()
    assert geoalpha.plot_why(why, ax=ax) is fig
    assert ax.get_title().endswith("and 1 flagged location (1 not drawn: pass points=)")
    assert not [line for line in ax.lines if line.get_marker() == "x"]
