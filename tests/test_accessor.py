"""Tests of the ``.alpha`` accessor: the same hulls as ``geoalpha.hull()``."""

from __future__ import annotations

import os
import subprocess
import sys
import warnings
from pathlib import Path

import geopandas as gpd
import numpy as np
import pandas as pd
import pytest
import shapely
from geopandas.testing import assert_geodataframe_equal

import geoalpha
from geoalpha import datasets
from geoalpha._accessor import AlphaAccessor, register
from geoalpha.errors import DegenerateGroupWarning, InvalidInputError

pytestmark = pytest.mark.filterwarnings(
    "ignore::geoalpha.errors.DegenerateGroupWarning",
    "ignore::geoalpha.errors.DroppedRowsWarning",
)

LA = "Local_Authority_(Highway)"


@pytest.fixture(scope="module")
def stats19():
    return datasets.load("stats19")


@pytest.fixture(scope="module")
def airports():
    return datasets.load("us_airports")


@pytest.mark.parametrize(
    "kwargs",
    [
        {},
        {"holes": True},
        {"components": 2},
        {"method": "convex"},
        {"method": "concave", "ratio": 0.5},
        {"degenerate": "drop"},
        {"crs": "EPSG:27700"},
        {"sort": False},
    ],
    ids=lambda kw: ",".join(f"{k}={v}" for k, v in kw.items()) or "defaults",
)
def test_accessor_equals_function(stats19, kwargs):
    assert_geodataframe_equal(
        stats19.alpha.hull(by=LA, **kwargs), geoalpha.hull(stats19, by=LA, **kwargs)
    )


def test_accessor_by_is_positional_as_in_dissolve(airports):
    assert_geodataframe_equal(
        airports.alpha.hull("state"), geoalpha.hull(airports, by="state")
    )


def test_geoseries_accessor_gives_one_hull(stats19):
    points = stats19.geometry
    hulls = points.alpha.hull()
    assert isinstance(hulls, gpd.GeoDataFrame)
    assert len(hulls) == 1
    assert hulls["n_points"].item() == len(points)
    assert hulls.crs == points.crs
    assert shapely.covers(hulls.geometry.item(), points.to_numpy()).all()
    assert_geodataframe_equal(hulls, stats19.alpha.hull())


def test_geoseries_accessor_with_an_array(stats19):
    points = stats19.geometry
    hulls = points.alpha.hull(by=stats19[LA].to_numpy())
    assert hulls["group"].tolist() == sorted(stats19[LA].unique())
    reference = stats19.alpha.hull(by=LA)
    assert (hulls["alpha"].fillna(-1) == reference["alpha"].fillna(-1)).all()
    assert shapely.equals(
        hulls.geometry.to_numpy(), reference.geometry.to_numpy()
    ).all()


def test_geoseries_accessor_with_a_named_series(stats19):
    hulls = stats19.geometry.alpha.hull(by=stats19[LA])
    assert hulls.columns[0] == LA
    assert hulls[LA].tolist() == sorted(stats19[LA].unique())


def test_alpha_column_and_alpha_accessor(stats19):
    hulls = stats19.alpha.hull(by=LA)
    column = hulls["alpha"]
    assert isinstance(column, pd.Series)
    assert column.dtype == np.float64
    assert column.notna().sum() == 6
    assert isinstance(hulls.alpha, AlphaAccessor)
    # The accessor works on the output too: the hull of all hull vertices.
    again = hulls.alpha.hull(vertices=True)
    assert len(again) == 1
    assert again["n_points"].item() == len(hulls)
    vertices = shapely.points(hulls.get_coordinates().to_numpy())
    assert shapely.covers(again.geometry.item(), vertices).all()
    # Item access is how to reach the column, attribute access is the accessor.
    assert not hasattr(hulls.alpha, "mean")
    assert hulls["alpha"].max() == pytest.approx(column.max())


def test_accessor_on_the_class_is_the_accessor_type():
    assert gpd.GeoDataFrame.alpha is AlphaAccessor
    assert gpd.GeoSeries.alpha is AlphaAccessor


def test_register_again_does_not_warn():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        register()
    assert gpd.GeoDataFrame.alpha is AlphaAccessor


@pytest.mark.parametrize(
    "code",
    [
        # geopandas first: registered by import geoalpha
        "import geopandas as gpd; import geoalpha",
        # geoalpha first: registered when geopandas is imported, which
        # import geoalpha alone does not do (nor numpy, pandas, pyproj)
        "import sys; import geoalpha; "
        "assert not {'geopandas', 'pandas', 'numpy', 'pyproj'} & set(sys.modules); "
        "import geopandas as gpd",
        # a look-up of geopandas that does not import it changes nothing
        "import importlib.util; import geoalpha; "
        "importlib.util.find_spec('geopandas'); import geopandas as gpd",
    ],
    ids=["geopandas first", "geoalpha first", "find_spec in between"],
)
def test_import_geoalpha_registers_the_accessor(code):
    check = (
        "; from geoalpha._accessor import AlphaAccessor; "
        "assert gpd.GeoDataFrame.alpha is AlphaAccessor; "
        "assert gpd.GeoSeries.alpha is AlphaAccessor"
    )
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1])}
    done = subprocess.run(
        [sys.executable, "-c", code + check],
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
        check=False,
    )
    assert done.returncode == 0, done.stderr


def test_accessor_passes_errors_through(stats19):
    with pytest.raises(InvalidInputError, match="no column 'nope'"):
        stats19.alpha.hull(by="nope")
    with pytest.raises(InvalidInputError, match="method must be one of"):
        stats19.alpha.hull(by=LA, method="foo")


def test_accessor_warnings_point_at_the_caller(stats19):
    with pytest.warns(DegenerateGroupWarning, match="E06000047") as record:
        stats19.alpha.hull(by=LA)
    assert record[0].filename == __file__
    with pytest.warns(DegenerateGroupWarning) as record:
        stats19.geometry.alpha.hull(by=stats19[LA])
    assert record[0].filename == __file__


def test_the_alpha_column_of_a_hull_table_is_named_when_used_as_the_accessor(
    stats19,
):
    hulls = stats19.alpha.hull(by=LA)
    column = r'the \'alpha\' column: write hulls\["alpha"\]'
    with pytest.raises(AttributeError, match=column + r"\.mean\(\.\.\.\)"):
        hulls.alpha.mean()
    with pytest.raises(TypeError, match=column + r" == \.\.\."):
        hulls.alpha == 0.5  # noqa: B015 - the comparison is what raises
    with pytest.raises(TypeError, match=column + r" > \.\.\."):
        hulls[hulls.alpha > 0.1]
    with pytest.raises(TypeError, match=column + r" \* \.\.\."):
        2 * hulls.alpha
    with pytest.raises(TypeError, match=column + r"\.to_numpy\(\)"):
        np.asarray(hulls.alpha, dtype=float)
    # the column itself, and the accessor's own method, work as before
    assert hulls["alpha"].mean() == pytest.approx(np.nanmean(hulls["alpha"]))
    assert len(hulls.alpha.hull(by=LA, vertices=True)) == len(hulls)
    # on points without an 'alpha' column it says so
    with pytest.raises(AttributeError, match=r"no 'alpha' column"):
        stats19.alpha.mean()
