"""The result table: what :func:`geoalpha._frame.schema.result_frame` builds.

It makes the GeoDataFrame without going through ``set_geometry`` again; the
table must be the one the public constructor gives, and behave as one.
"""

from __future__ import annotations

import geopandas as gpd
import numpy as np
import pandas as pd
import pytest
import shapely
from geopandas.testing import assert_geodataframe_equal

from geoalpha._frame.schema import RESULT_COLUMNS, empty_result, result_frame

VALUES = dict(
    alpha=[0.5, 0.25],
    radius=[2.0, 4.0],
    n_points=[3, 4],
    n_outliers=[0, 1],
    n_parts=[1, 1],
    area_m2=[0.5, 1.0],
    crs_used=["EPSG:32630", "EPSG:32630"],
    method=["alpha", "alpha"],
)
GEOMETRY = [shapely.box(0, 0, 1, 1), shapely.box(1, 1, 3, 2)]


@pytest.mark.parametrize("name", ["geometry", "geom"])
@pytest.mark.parametrize("crs", ["EPSG:27700", None])
def test_result_frame_is_the_public_constructors_table(name, crs):
    keys = {"region": pd.array(["North", "South"], dtype="str")}
    got = result_frame(keys, VALUES, GEOMETRY, crs, name)

    expected = gpd.GeoDataFrame(
        {"region": ["North", "South"], **VALUES, name: GEOMETRY},
        geometry=name,
        crs=crs,
    )
    expected["n_parts"] = expected["n_parts"].astype("int32")
    assert isinstance(got, gpd.GeoDataFrame)
    assert got.geometry.name == name
    assert got.columns.tolist() == ["region", *RESULT_COLUMNS, name]
    assert_geodataframe_equal(got, expected)
    assert got.crs == expected.crs


def test_result_frame_behaves_as_a_geodataframe(tmp_path):
    got = result_frame({"g": np.array([1, 2])}, VALUES, GEOMETRY, "EPSG:27700", "geom")
    assert got.to_crs("EPSG:4326").crs.to_epsg() == 4326
    assert got.area.tolist() == [1.0, 2.0]
    assert got.iloc[[1]].geometry.name == "geom"
    got.to_file(tmp_path / "t.gpkg")
    back = gpd.read_file(tmp_path / "t.gpkg")
    assert back["g"].tolist() == [1, 2]
    assert back.geometry.geom_equals(got.geometry.set_axis(back.index)).all()


def test_empty_result_has_the_columns_and_dtypes_of_a_result():
    full = result_frame({"g": np.array([1, 2])}, VALUES, GEOMETRY, "EPSG:27700")
    meta = empty_result(pd.DataFrame({"g": np.array([], dtype=np.int64)}), "EPSG:27700")
    assert len(meta) == 0
    assert meta.dtypes.to_dict() == full.dtypes.to_dict()
    assert meta.crs == full.crs
