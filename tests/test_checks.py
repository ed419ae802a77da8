"""The warnings about a run's set-up come from ``hull()`` itself (issue #13, item 5).

A ``by`` that makes nearly one group per row (:class:`GroupingWarning`) and a
computation CRS that stretches areas (:class:`CRSWarning`) are said in Python
terms by ``hull()``, the accessor and ``n_jobs``; the command says them once
in its own terms (tests/test_cli_first_hour.py), dask once per computation
(tests/test_dask.py).
"""

from __future__ import annotations

import re
import warnings

import geopandas as gpd
import numpy as np
import pytest

import geoalpha
from geoalpha import datasets
from geoalpha.errors import CRSWarning, GroupingWarning

pytestmark = pytest.mark.filterwarnings(
    "ignore::geoalpha.errors.DegenerateGroupWarning"
)

LA = "Local_Authority_(Highway)"


@pytest.fixture(scope="module")
def stats19():
    """1,017 UK road accidents in longitude/latitude, by local authority."""
    return datasets.load("stats19")


def caught(call) -> list[warnings.WarningMessage]:
    """The CRSWarnings and GroupingWarnings of ``call()``."""
    with warnings.catch_warnings(record=True) as found:
        warnings.simplefilter("always")
        call()
    return [w for w in found if issubclass(w.category, CRSWarning | GroupingWarning)]


@pytest.mark.parametrize(
    "call",
    [
        lambda pts: geoalpha.hull(pts, by=LA, crs="EPSG:3857"),
        lambda pts: pts.alpha.hull(by=LA, crs="EPSG:3857"),
        lambda pts: geoalpha.hull(pts, by=LA, crs="EPSG:3857", n_jobs=2),
    ],
    ids=["hull", "accessor", "n_jobs"],
)
def test_web_mercator_on_uk_points_warns_of_the_stretch(stats19, call):
    found = caught(lambda: call(stats19))
    assert [w.category for w in found] == [CRSWarning]
    message = str(found[0].message)
    assert re.match(
        r"the shapes are computed in EPSG:3857 \(crs=\), which stretches areas "
        r"2\.\d+ times \(median at the points; 2\.\d+-\d\.\d+\), so 'radius' and "
        r"'alpha' are not in true metres \('area_m2' is: it is measured on the "
        r"WGS84 ellipsoid\): leave out crs= ",
        message,
    ), message
    assert found[0].filename == __file__  # points at the user's line


def test_the_stretch_is_the_true_one(stats19):
    (warning,) = caught(lambda: geoalpha.hull(stats19, by=LA, crs="EPSG:3857"))
    text = str(warning.message)
    median = float(re.search(r"stretches areas ([\d.]+) times", text)[1])
    # Web Mercator's areal scale is 1/cos(latitude)^2
    lat = np.median(stats19.geometry.y)
    assert median == pytest.approx(1 / np.cos(np.radians(lat)) ** 2, rel=0.05)


def test_projected_input_far_from_its_zone_warns_with_a_zone_to_use(stats19):
    italy = stats19.to_crs("EPSG:32633")  # UK points in a UTM zone for Italy
    (warning,) = caught(lambda: italy.alpha.hull(by=LA))
    assert warning.category is CRSWarning
    assert "computed in EPSG:32633 (the input's CRS)" in str(warning.message)
    assert str(warning.message).endswith("e.g. crs='EPSG:32630'")
    # the zone it names, or British National Grid, are fine
    assert caught(lambda: italy.alpha.hull(by=LA, crs="EPSG:32630")) == []
    assert caught(lambda: stats19.to_crs(27700).alpha.hull(by=LA)) == []


@pytest.mark.parametrize(
    ("by", "shown", "question"),
    [
        ("Latitude", "by='Latitude'", "is this the right column?"),
        (
            ["Latitude", "Longitude"],
            "by=['Latitude', 'Longitude']",
            "are these the right columns?",
        ),
        (
            lambda pts: pts["Latitude"].to_numpy(),
            "by=",
            "is this the right grouping?",
        ),
    ],
    ids=["column", "columns", "values"],
)
def test_by_with_nearly_one_group_per_row_warns(stats19, by, shown, question):
    by = by(stats19) if callable(by) else by
    found = caught(lambda: geoalpha.hull(stats19, by=by))
    assert [w.category for w in found] == [GroupingWarning]
    groups = stats19.groupby(by).ngroups
    assert groups > len(stats19) / 2
    assert str(found[0].message) == (
        f"{shown} makes {groups:,} groups of 1,017 rows; groups of 1-2 points "
        f"have no alpha shape, so {question}"
    )
    assert found[0].filename == __file__


def test_by_with_nearly_one_group_per_row_warns_with_n_jobs(stats19):
    found = caught(lambda: geoalpha.hull(stats19, by="Latitude", n_jobs=2))
    assert [w.category for w in found] == [GroupingWarning]


def test_few_rows_or_few_groups_do_not_warn(stats19):
    small = stats19.head(49)  # fewer than 50 rows: any grouping may be right
    assert caught(lambda: geoalpha.hull(small, by="Latitude")) == []
    assert caught(lambda: geoalpha.hull(stats19, by=LA)) == []


@pytest.mark.parametrize("name", ["us_airports", "uk_clusters", "stats19"])
def test_bundled_data_with_defaults_warn_of_neither(name):
    points = datasets.load(name)
    by = datasets.DATASETS[name][3]
    assert caught(lambda: geoalpha.hull(points, by=by)) == []


def test_planar_input_and_auto_chosen_crs_do_not_warn(stats19):
    planar = gpd.GeoDataFrame(stats19[[LA]], geometry=stats19.geometry, crs=None)
    assert caught(lambda: geoalpha.hull(planar, by=LA, crs=None)) == []
    # Web Mercator input with crs="auto" is computed in a UTM zone: no stretch
    assert caught(lambda: geoalpha.hull(stats19.to_crs(3857), by=LA)) == []


def test_the_suggested_crs_is_cheap_at_a_million_points():
    # Issue #37 item 10: it was computed from every point (0.3 s of a 0.9 s
    # hull() on 1M points); now from the extremes and a sample of 256.
    import time

    import pyproj

    from geoalpha._frame.checks import _suggestion

    rng = np.random.default_rng(37)
    lon, lat = rng.uniform(-7.5, 1.5, 1_000_000), rng.uniform(50, 58, 1_000_000)
    to_italy = pyproj.Transformer.from_crs(4326, 32633, always_xy=True)
    coords = np.column_stack(to_italy.transform(lon, lat))
    coords[5] = np.nan  # (left out)
    source = pyproj.CRS.from_epsg(32633)
    _suggestion(coords[:1000], source)  # (pyproj's caches)
    start = time.perf_counter()
    suggested = _suggestion(coords, source)
    assert time.perf_counter() - start < 0.1
    assert suggested == ", e.g. crs='EPSG:32630'"
