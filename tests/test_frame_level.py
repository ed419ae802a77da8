"""Frame-level regressions of GitHub issue #10 (item 7) in ``hull()``.

Each test is one defect that a user met: an IndexError, an integer area, an
area in pseudo-metres, a dropped group that kept its row, a NaN buffer taken,
an alpha in 1/foot, an index level refused as ``by``.
"""

from __future__ import annotations

import warnings

import geopandas as gpd
import numpy as np
import pandas as pd
import pyproj
import pytest
import shapely
from reference import AREA_ATOL, AREA_RTOL, ellipsoid_areas

import geoalpha
from geoalpha.errors import (
    CRSWarning,
    DegenerateGroupWarning,
    DroppedRowsWarning,
    InvalidInputError,
)

LONDON = np.array([-0.1276, 51.5072])


@pytest.fixture
def london():
    """Two groups of 40 points each around London, lon/lat."""
    rng = np.random.default_rng(7)
    xy = LONDON + rng.random((80, 2)) * [0.08, 0.05]
    return gpd.GeoDataFrame(
        {"g": np.repeat(["a", "b"], 40)}, geometry=shapely.points(xy), crs=4326
    )


def test_every_geometry_missing_gives_empty_rows_not_an_index_error():
    frame = gpd.GeoDataFrame({"g": ["a", "a", "b"]}, geometry=[None] * 3, crs=4326)
    with pytest.warns(DroppedRowsWarning, match="dropped 3 of 3 rows"):
        with pytest.warns(
            DegenerateGroupWarning, match=r"'a' \(0 rows, 0 distinct points\); 'b'"
        ):
            hulls = geoalpha.hull(frame, by="g")
    assert hulls["g"].tolist() == ["a", "b"]
    assert hulls["n_points"].tolist() == [0, 0]
    assert hulls.geometry.is_empty.all()
    assert hulls["area_m2"].tolist() == [0.0, 0.0]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        dropped = geoalpha.hull(frame, by="g", degenerate="drop")
    assert len(dropped) == 0
    assert dropped.columns.tolist() == hulls.columns.tolist()


def test_area_stays_float_when_every_group_is_degenerate():
    pts = shapely.points([[0.0, 51.0], [0.0001, 51.0], [1.0, 51.0]])
    frame = gpd.GeoDataFrame({"g": ["a", "a", "b"]}, geometry=pts, crs=4326)
    with pytest.warns(DegenerateGroupWarning):
        hulls = geoalpha.hull(frame, by="g", buffer=12.0)
    assert hulls["area_m2"].dtype == np.float64
    # a 1-point group: a 12 m buffer (a 32-gon) is 451.2 m², not 451
    assert hulls["area_m2"][1] == pytest.approx(np.pi * 144, rel=0.01)
    assert hulls["area_m2"][1] != round(hulls["area_m2"][1])


def test_web_mercator_input_is_computed_in_true_metres(london):
    lonlat = geoalpha.hull(london, by="g")
    mercator = london.to_crs(3857)
    hulls = geoalpha.hull(mercator, by="g")
    # The same numbers as from lon/lat, not 1/cos(51.5)^2 = 2.6 times the area
    np.testing.assert_allclose(hulls["area_m2"], lonlat["area_m2"], rtol=1e-9)
    np.testing.assert_allclose(hulls["alpha"], lonlat["alpha"], rtol=1e-9)
    assert hulls["crs_used"].tolist() == ["EPSG:32630", "EPSG:32630"]
    # in the input CRS, with the input points as vertices
    assert hulls.crs.to_epsg() == 3857
    vertices = shapely.get_coordinates(hulls.geometry.array)
    inputs = shapely.get_coordinates(mercator.geometry.array)
    assert {tuple(v) for v in vertices} <= {tuple(p) for p in inputs}
    assert shapely.covers(hulls.geometry.array[0], mercator.geometry.array[:40]).all()


def test_a_group_without_points_is_dropped_by_degenerate_drop(london):
    frame = london.copy()
    frame.loc[frame["g"] == "b", "geometry"] = None
    with pytest.warns(DroppedRowsWarning, match="dropped 40 of 80 rows"):
        with pytest.warns(
            DegenerateGroupWarning,
            match=r"^1 group\(s\).*'b' \(0 rows, 0 distinct points\)",
        ):
            hulls = geoalpha.hull(frame, by="g", degenerate="drop")
    assert hulls["g"].tolist() == ["a"]


@pytest.mark.parametrize("buffer", [np.nan, np.inf, 0.0, -1.0, "1", None])
def test_buffer_must_be_a_positive_finite_number(london, buffer):
    with pytest.raises(InvalidInputError, match="buffer must be a finite number > 0"):
        geoalpha.hull(london, by="g", buffer=buffer)


def test_crs_in_feet_gives_alpha_in_metres_for_every_input(london):
    feet = "EPSG:2263"  # NAD83 / New York Long Island (ftUS), here just a CRS
    # so far from London that it stretches areas by 4 %, and says so
    with pytest.warns(CRSWarning, match=r"EPSG:2263 \(crs=\), which stretches"):
        from_lonlat = geoalpha.hull(london, by="g", crs=feet)
        from_utm = geoalpha.hull(london.to_crs(32630), by="g", crs=feet)
    with pytest.warns(CRSWarning, match=r"EPSG:2263 \(the input's CRS\)"):
        from_feet = geoalpha.hull(london.to_crs(feet), by="g")  # crs="auto"
    # the reference: the points in the CRS in feet, scaled to metres
    xy = shapely.get_coordinates(london.to_crs(feet).geometry.array)[:40]
    factor = pyproj.CRS(feet).axis_info[0].unit_conversion_factor  # m per ftUS
    expected = geoalpha.optimal_alpha(xy * factor)
    for hulls in (from_lonlat, from_utm, from_feet):
        assert hulls["alpha"][0] == pytest.approx(expected, rel=1e-9)
        assert hulls["crs_used"][0] == "EPSG:2263"
    np.testing.assert_allclose(from_utm["area_m2"], from_lonlat["area_m2"], rtol=1e-9)
    # square metres on the ellipsoid, not the 4 % larger area of the polygon
    # in the CRS in feet, times (m/ft)^2
    for hulls in (from_lonlat, from_utm, from_feet):
        np.testing.assert_allclose(
            hulls["area_m2"], ellipsoid_areas(hulls), rtol=AREA_RTOL, atol=AREA_ATOL
        )
    area_ft2 = from_lonlat.to_crs(feet).area.to_numpy()
    stretch = area_ft2 * factor**2 / from_lonlat["area_m2"].to_numpy()
    assert ((stretch > 1.03) & (stretch < 1.05)).all(), stretch


def test_by_an_index_level_name(london):
    expected = geoalpha.hull(london, by="g")
    by_level = geoalpha.hull(london.set_index("g"), by="g")
    assert by_level["g"].tolist() == ["a", "b"]
    np.testing.assert_array_equal(by_level["alpha"], expected["alpha"])
    multi = london.assign(h=1).set_index(["g", "h"])
    assert geoalpha.hull(multi, by=["g", "h"])["n_points"].tolist() == [40, 40]
    with pytest.raises(InvalidInputError, match=r"no column 'k'.*index levels g"):
        geoalpha.hull(london.set_index("g"), by="k")


KEY_COLUMNS = {
    "int": [3, 1, 3, 2, 1, 2, 3, 1],
    "float_nan": [2.5, np.nan, 0.5, 2.5, np.nan, 0.5, 1.0, 1.0],
    "str": ["b", "a", "c", "a", "b", "c", "a", "b"],
    "object_none": ["b", None, "c", "a", None, "c", "a", "b"],
    "bool": [True, False, True, False, True, False, True, False],
    "nullable_int": pd.array([2, None, 1, 2, None, 1, 3, 3], dtype="Int64"),
    "datetime_tz": pd.to_datetime(
        [
            "2024-01-02",
            "2024-01-01",
            None,
            "2024-01-02",
            "2024-01-03",
            "2024-01-01",
            None,
            "2024-01-03",
        ]
    ).tz_localize("UTC"),
}


@pytest.mark.parametrize("column", sorted(KEY_COLUMNS))
@pytest.mark.parametrize("sort", [True, False])
@pytest.mark.parametrize("dropna", [True, False])
def test_grouping_by_one_column_numbers_groups_as_pandas_groupby(column, sort, dropna):
    # hull() numbers the groups of one plain column without building a
    # GroupBy; the codes and the key table must be pandas' own.
    from geoalpha._frame import pipeline
    from geoalpha._options import Options

    frame = gpd.GeoDataFrame(
        {"k": KEY_COLUMNS[column]},
        geometry=gpd.points_from_xy(range(8), [0, 1, 0, 1, 0, 1, 0, 1]),
    )
    got = pipeline.group(frame, "k", Options(sort=sort, dropna=dropna))
    grouped = frame.groupby("k", sort=sort, dropna=dropna)
    expected_codes = grouped.ngroup().fillna(-1).to_numpy(dtype=np.int64)
    np.testing.assert_array_equal(got.codes, expected_codes)
    pd.testing.assert_frame_equal(
        got.keys, grouped.size().index.to_frame(index=False), check_dtype=True
    )
