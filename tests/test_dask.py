"""Tests of hull() on dask-geopandas frames (GitHub issue #6).

The promise: ``geoalpha.hull(ddf, by).compute()`` is the GeoDataFrame that
``geoalpha.hull(ddf.compute(), by)`` gives, even when a group's points are
spread over many partitions and when one partition alone would pick another
metric CRS; the result is lazy; ``import geoalpha`` does not import dask.
"""

from __future__ import annotations

import re
import subprocess
import sys
import textwrap
import warnings

import geopandas as gpd
import numpy as np
import pandas as pd
import pytest
import shapely
from compat import HAS_DASK, require_for_module
from geopandas.testing import assert_geodataframe_equal

require_for_module(HAS_DASK, "geoalpha[dask] (dask-geopandas, distributed)")

import dask  # noqa: E402
import dask.dataframe  # noqa: E402
import dask_geopandas  # noqa: E402
import distributed  # noqa: E402

import geoalpha  # noqa: E402
import geoalpha.dask  # noqa: E402
from geoalpha import datasets  # noqa: E402
from geoalpha.errors import (  # noqa: E402
    CRSWarning,
    DroppedRowsWarning,
    GroupingWarning,
    InvalidInputError,
    OutlierWarning,
    SuspiciousHullWarning,
)

pytestmark = pytest.mark.filterwarnings(
    "ignore::geoalpha.errors.DegenerateGroupWarning",
    "ignore::geoalpha.errors.DroppedRowsWarning",
    "ignore::geoalpha.errors.AntimeridianWarning",
)


def spread(gdf, npartitions: int, seed: int = 6):
    """A dask frame of ``gdf``'s rows in random order (groups span partitions)."""
    shuffled = gdf.sample(frac=1.0, random_state=seed)
    return dask_geopandas.from_geopandas(shuffled, npartitions=npartitions, sort=False)


def partitions_per_group(ddf, by) -> pd.Series:
    parts = [
        ddf.partitions[i].compute()[by].drop_duplicates().to_frame().assign(part=i)
        for i in range(ddf.npartitions)
    ]
    return pd.concat(parts).groupby(by)["part"].nunique()


def assert_same_hulls(lazy, eager):
    """The lazy result computes to the eager one (values, order, geometry)."""
    got = lazy.compute()
    # dask may store text columns as pyarrow strings: compare the values.
    assert_geodataframe_equal(got, eager, check_dtype=False, check_index_type=False)
    assert got.geom_equals_exact(eager, tolerance=0).all()
    return got


def assert_eager_hulls(ddf, by, original, **kwargs):
    """Same as eager on ``ddf.compute()``; same CRS choice as on ``original``."""
    got = assert_same_hulls(
        geoalpha.hull(ddf, by=by, **kwargs), geoalpha.hull(ddf.compute(), by, **kwargs)
    )
    assert got["crs_used"].tolist() == original["crs_used"].tolist()
    return got


@pytest.fixture(scope="module")
def airports():
    gdf = datasets.load("us_airports")
    return gdf[gdf["state"].notna()].reset_index(drop=True)


@pytest.fixture(scope="module")
def clusters():
    return datasets.load("uk_clusters")


def points_at(centres, per_group=40, seed=0, sigma=0.05):
    """Lon/lat points around the given (lon, lat) group centres."""
    rng = np.random.default_rng(seed)
    lon = np.repeat([c[0] for c in centres], per_group)
    lat = np.repeat([c[1] for c in centres], per_group)
    lon = lon + rng.normal(0.0, sigma, lon.size)
    lat = lat + rng.normal(0.0, sigma, lat.size)
    lon = (lon + 180.0) % 360.0 - 180.0
    group = np.repeat([f"g{i:02d}" for i in range(len(centres))], per_group)
    return gpd.GeoDataFrame(
        {"group": group}, geometry=gpd.points_from_xy(lon, lat), crs=4326
    )


# --- same hulls as the eager call ------------------------------------------------


def test_result_is_lazy_with_a_meta_that_matches(clusters):
    lazy = geoalpha.hull(spread(clusters, 4), by="Cluster")
    assert isinstance(lazy, dask_geopandas.GeoDataFrame)
    assert lazy.crs == clusters.crs
    got = lazy.compute()
    assert isinstance(got, gpd.GeoDataFrame)
    assert got.dtypes.to_dict() == lazy._meta.dtypes.to_dict()


def test_uk_clusters_spread_over_partitions(clusters):
    ddf = spread(clusters, 5)
    assert (partitions_per_group(ddf, "Cluster") > 1).mean() > 0.5
    got = assert_same_hulls(
        geoalpha.hull(ddf, by="Cluster"), geoalpha.hull(ddf.compute(), by="Cluster")
    )
    # The order of the rows of a group does not change a hull beyond the last
    # bits, and neither does the partitioning: same as the original frame.
    eager = clusters.alpha.hull(by="Cluster")
    np.testing.assert_allclose(got["alpha"], eager["alpha"], rtol=1e-12)
    assert got.geom_equals(eager).all()
    assert (got["crs_used"] == "EPSG:32630").all()


def test_us_airports_by_state(airports):
    ddf = spread(airports, 6)
    assert (partitions_per_group(ddf, "state") > 1).sum() > 40
    got = assert_same_hulls(
        ddf.alpha.hull(by="state"), geoalpha.hull(ddf.compute(), by="state")
    )
    assert got["crs_used"].nunique() > 10  # one metric CRS per state


def test_accessor_and_function_agree(airports):
    ddf = spread(airports, 3)
    assert_geodataframe_equal(
        ddf.alpha.hull(by="state", holes=True).compute(),
        geoalpha.hull(ddf, "state", holes=True).compute(),
    )


def test_options_reach_the_partitions(clusters):
    ddf = spread(clusters, 4)
    kwargs = {"components": 2, "holes": True, "degenerate": "drop"}
    assert_same_hulls(
        geoalpha.hull(ddf, by="Cluster", **kwargs),
        geoalpha.hull(ddf.compute(), by="Cluster", **kwargs),
    )


def test_two_key_columns_and_missing_keys(airports):
    gdf = airports.assign(big=airports["name"].str.contains("Intl"))
    gdf.loc[gdf.index[::50], "state"] = None
    ddf = spread(gdf, 4)
    for dropna in (True, False):
        assert_same_hulls(
            geoalpha.hull(ddf, by=["state", "big"], dropna=dropna),
            geoalpha.hull(ddf.compute(), by=["state", "big"], dropna=dropna),
        )


def test_sort_false_keeps_the_partitions(clusters):
    ddf = spread(clusters, 4)
    lazy = geoalpha.dask.hull(ddf, by="Cluster", sort=False, npartitions=3)
    assert lazy.npartitions == 3
    got = lazy.compute().sort_values("Cluster").reset_index(drop=True)
    assert_geodataframe_equal(got, clusters.alpha.hull(by="Cluster"), check_dtype=False)


def test_the_shuffle_carries_every_geometry_exactly():
    # 2D points travel as x/y floats, the rest as WKB: both exact, None stays None.
    nan = float("nan")
    geoms = [
        shapely.Point(0.1, 1 / 3),
        shapely.Point(-179.99999999999997, 89.5, 7.0),
        shapely.MultiPoint([(0, 0), (1e-300, 5e300)]),
        shapely.Point(),
        None,
        shapely.Point(nan, 2.0),
    ]
    frame = gpd.GeoDataFrame({"g": list("abcdef")}, geometry=geoms, crs=None)
    plain = geoalpha.dask._for_shuffle(frame.copy(), "geometry")
    assert plain["__geoalpha_point__"].tolist() == [1, 0, 0, 0, 0, 1]
    assert plain["__geoalpha_x__"][0] == 0.1 and plain["__geoalpha_y__"][0] == 1 / 3
    back = geoalpha.dask._from_shuffle(plain, "geometry")
    assert back[4] is None
    assert (
        shapely.to_wkb(back, hex=True).tolist()
        == shapely.to_wkb(np.array(geoms, dtype=object), hex=True).tolist()
    )


@pytest.fixture(scope="module")
def mixed(clusters):
    """The clusters with 3D points, MultiPoints and missing geometries."""
    gdf = clusters.copy()
    xy = shapely.get_coordinates(gdf.geometry.to_numpy())
    geoms = gdf.geometry.to_numpy().copy()
    geoms[::7] = shapely.points(xy[::7, 0], xy[::7, 1], np.full(len(xy[::7]), 5.0))
    geoms[3::11] = [shapely.MultiPoint([p, (p[0] + 1e-4, p[1])]) for p in xy[3::11]]
    geoms[5::13] = None
    return gdf.set_geometry(gpd.GeoSeries(geoms, index=gdf.index, crs=gdf.crs))


def test_mixed_geometries_through_the_shuffle_as_the_eager_call(mixed):
    ddf = spread(mixed, 4)
    assert_same_hulls(
        geoalpha.hull(ddf, by="Cluster"), geoalpha.hull(ddf.compute(), by="Cluster")
    )


def test_no_by_gives_one_hull(clusters):
    ddf = spread(clusters, 3)
    assert_same_hulls(geoalpha.hull(ddf), geoalpha.hull(ddf.compute()))


def test_geometry_column_of_another_name_and_a_second_geometry(clusters):
    # Only the keys and the active geometry move through the shuffle; the
    # result names its geometry column after the input's, as the eager call.
    gdf = clusters.rename_geometry("where").assign(
        other=clusters.geometry.buffer(1.0), note="x"
    )
    ddf = spread(gdf, 3)
    got = assert_same_hulls(
        geoalpha.hull(ddf, by="Cluster"), geoalpha.hull(ddf.compute(), by="Cluster")
    )
    assert got.geometry.name == "where" and "other" not in got.columns


def outcome(call):
    """What a user sees of ``call()``: ("error", message) or (result, dropped rows)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            result = call()
        except InvalidInputError as err:
            return "error", str(err)
    # (the partitions' warnings about their groups are the partitions' own)
    return result, [str(w.message) for w in caught if w.category is DroppedRowsWarning]


@pytest.mark.parametrize("by", [None, "Cluster"])
def test_points_read_as_floats_drop_and_refuse_the_eager_rows(clusters, by):
    # Every row a 2D point: the partitions read the shuffled floats, never a
    # geometry; NaN coordinates and missing keys are dropped and named as by
    # the eager call, infinite ones refused naming the row.
    bad = clusters.copy()
    nan = [shapely.Point(np.nan, 51.5), shapely.Point(-0.1, np.nan)]
    bad.loc[bad.index[[4, 900]], "geometry"] = nan
    bad.loc[bad.index[[7]], "Cluster"] = None
    ddf = spread(bad, 3)
    got, shown = outcome(lambda: geoalpha.hull(ddf, by).compute(scheduler="sync"))
    eager, eager_shown = outcome(lambda: geoalpha.hull(ddf.compute(), by))
    assert shown == eager_shown and len(shown) == 1
    dropped = 2 if by is None else 3
    assert shown[0].startswith(f"hull() dropped {dropped} of {len(bad)} rows")
    assert all(f"{row}" in shown[0] for row in (4, 900))
    assert_geodataframe_equal(got, eager, check_dtype=False, check_index_type=False)
    assert got.geom_equals_exact(eager, tolerance=0).all()
    bad.loc[bad.index[[11]], "geometry"] = [shapely.Point(np.inf, 51.5)]
    ddf = spread(bad, 3)
    got = outcome(lambda: geoalpha.hull(ddf, by).compute(scheduler="sync"))
    eager = outcome(lambda: geoalpha.hull(ddf.compute(), by))
    assert got[0] == "error" and got == eager
    assert "infinite values in 1 row(s) (index 11)" in got[1]


def test_projected_input_and_forced_crs(clusters):
    ddf = spread(clusters.to_crs(27700), 3)
    assert_same_hulls(
        geoalpha.hull(ddf, by="Cluster"), geoalpha.hull(ddf.compute(), by="Cluster")
    )
    ddf = spread(clusters, 3)
    assert_same_hulls(
        geoalpha.hull(ddf, by="Cluster", crs=27700),
        geoalpha.hull(ddf.compute(), by="Cluster", crs=27700),
    )


def test_crs_none_on_degrees_gives_area_and_unit_as_eager(clusters):
    ddf = spread(clusters, 3)
    lazy = geoalpha.hull(ddf, by="Cluster", crs=None)
    assert "area_m2" not in lazy.columns and "unit" in lazy.columns
    got = assert_same_hulls(lazy, geoalpha.hull(ddf.compute(), by="Cluster", crs=None))
    assert set(got["unit"]) == {"degree"}


def test_dask_geoseries_gives_one_hull(clusters):
    series = dask_geopandas.from_geopandas(clusters.geometry, npartitions=3)
    assert_same_hulls(series.alpha.hull(), clusters.geometry.alpha.hull())


# --- the whole-dataset CRS decision ------------------------------------------------


def test_dataset_fits_one_zone_but_a_partition_alone_would_not():
    # Groups from 1 degree W to 2.5 degrees E: together they fit UTM zone 31;
    # the western groups alone fit zone 30, which "auto" would pick for a
    # partition holding only them.
    centres = [(-0.9, 50.0 + i / 10) for i in range(6)] + [
        (2.3, 50.0 + i / 10) for i in range(6)
    ]
    gdf = points_at(centres)
    west = gdf[gdf["group"] < "g06"]
    assert set(west.alpha.hull(by="group")["crs_used"]) == {"EPSG:32630"}
    eager = gdf.alpha.hull(by="group")
    assert set(eager["crs_used"]) == {"EPSG:32631"}
    assert_eager_hulls(spread(gdf, 6), "group", eager)


def test_dataset_too_wide_so_every_group_decides_alone():
    # Spain (groups in UTM zones 29 and 31) and Japan: no single zone. A
    # partition holding only Spanish groups would fit zone 30 as a whole; each
    # group must still get its own zone.
    spain = [(-6.5, 40.0 + i / 3) for i in range(5)] + [
        (1.2, 40.0 + i / 3) for i in range(5)
    ]
    gdf = points_at([*spain, (139.7, 35.7)])
    only_spain = gdf[gdf["group"] != "g10"]
    assert set(only_spain.alpha.hull(by="group")["crs_used"]) == {"EPSG:32630"}
    eager = gdf.alpha.hull(by="group")
    assert set(eager["crs_used"]) == {"EPSG:32629", "EPSG:32631", "EPSG:32654"}
    for n in (1, 2, 3):
        ddf = spread(gdf, n)
        if n == 2:  # a partition gets groups of both zones but not Japan's
            parts = ddf.shuffle(on="group")
            held = [set(parts.partitions[i].compute()["group"]) for i in range(n)]
            west = {f"g{i:02d}" for i in range(5)}
            east = {f"g{i:02d}" for i in range(5, 10)}
            assert any("g10" not in g and g & west and g & east for g in held)
        assert_eager_hulls(ddf, "group", eager)


def test_dataset_across_the_antimeridian():
    gdf = points_at([(178.6, -17.8), (179.6, -16.6), (-179.6, -16.9), (-178.9, -18.0)])
    eager = gdf.alpha.hull(by="group")
    assert eager["crs_used"].nunique() == 1  # the data fit one zone across 180
    assert_eager_hulls(spread(gdf, 4), "group", eager)


@pytest.mark.parametrize("npartitions", [1, 2, 5])
def test_decision_is_the_eager_one_on_many_layouts(npartitions):
    rng = np.random.default_rng(npartitions)
    centres = list(zip(rng.uniform(-20, 20, 8), rng.uniform(-60, 60, 8), strict=True))
    gdf = points_at(centres, per_group=25, seed=npartitions, sigma=0.5)
    assert_eager_hulls(spread(gdf, npartitions), "group", gdf.alpha.hull(by="group"))


# --- errors ---------------------------------------------------------------------------


def test_errors(clusters):
    ddf = spread(clusters, 2)
    with pytest.raises(InvalidInputError, match="no column 'nope'"):
        geoalpha.hull(ddf, by="nope")
    with pytest.raises(InvalidInputError, match="needs column names"):
        geoalpha.hull(ddf, by=clusters["Cluster"].to_numpy())
    with pytest.raises(InvalidInputError, match="dask spreads the partitions"):
        geoalpha.hull(ddf, by="Cluster", n_jobs=2)
    with pytest.raises(InvalidInputError, match="method must be one of"):
        geoalpha.hull(ddf, by="Cluster", method="nope")
    with pytest.raises(InvalidInputError, match="unknown option"):
        geoalpha.dask.hull(ddf, by="Cluster", colour="red")


def test_data_errors_are_raised_by_compute(clusters):
    bad = clusters.copy()
    bad.geometry = bad.to_crs(27700).buffer(10.0).to_crs(4326)
    lazy = geoalpha.hull(spread(bad, 2), by="Cluster")
    with pytest.raises(InvalidInputError, match="needs point geometries"):
        lazy.compute()


# --- warnings about the set-up, progress ----------------------------------------


def setup_warnings(call) -> list[tuple[type, str]]:
    """The CRSWarnings and GroupingWarnings of ``call()``.

    Computed with ``scheduler="sync"``: Python's warning filters are global
    to the process, so a task that sets its own (pandas does) in another
    thread can hide a warning of this one for a moment.
    """
    with warnings.catch_warnings(record=True) as found:
        warnings.simplefilter("always")
        call()
    return [
        (w.category, str(w.message))
        for w in found
        if issubclass(w.category, CRSWarning | GroupingWarning)
    ]


@pytest.mark.parametrize(
    "options",
    [
        {"by": "Latitude"},
        {"by": "Latitude", "sort": False},  # no gathering step at the end
        {"by": "Local_Authority_(Highway)", "crs": "EPSG:3857"},
    ],
    ids=["many groups", "many groups unsorted", "web mercator"],
)
def test_setup_warnings_once_for_the_whole_dataset(options):
    points = datasets.load("stats19")
    lazy = setup_warnings(lambda: geoalpha.hull(spread(points, 4), **options))
    assert lazy == []  # nothing computed yet
    computed = setup_warnings(
        lambda: geoalpha.hull(spread(points, 4), **options).compute(scheduler="sync")
    )
    eager = setup_warnings(lambda: geoalpha.hull(points, **options))
    assert len(computed) == len(eager) == 1  # not once per partition
    category, message = computed[0]
    assert category is eager[0][0]
    if category is GroupingWarning:  # the counts of the whole dataset
        assert message == eager[0][1]
    else:  # from a sample of the points: the same stretch, about
        assert message.startswith("the shapes are computed in EPSG:3857 (crs=)")
        lazy_stretch, eager_stretch = (
            float(re.search(r"areas ([\d.]+)", m)[1]) for m in (message, eager[0][1])
        )
        assert lazy_stretch == pytest.approx(eager_stretch, rel=0.01)


@pytest.mark.parametrize("dropna", [True, False])
def test_grouping_warning_counts_every_row_as_the_eager_call(dropna):
    points = datasets.load("stats19")
    points.loc[:149, "Latitude"] = np.nan
    ddf = dask_geopandas.from_geopandas(points, npartitions=10, sort=False)
    assert ddf.partitions[0].compute()["Latitude"].isna().all()  # no key at all
    lazy = setup_warnings(
        lambda: geoalpha.hull(ddf, by="Latitude", dropna=dropna).compute(
            scheduler="sync"
        )
    )
    eager = setup_warnings(lambda: geoalpha.hull(points, by="Latitude", dropna=dropna))
    assert lazy == eager
    assert len(lazy) == 1 and "groups of 1,017 rows" in lazy[0][1]


def test_progress_bar_does_not_apply(clusters, capsys):
    with pytest.raises(InvalidInputError, match="progress=True does not apply"):
        geoalpha.hull(spread(clusters, 2), by="Cluster", progress=True)
    geoalpha.hull(spread(clusters, 2), by="Cluster").compute()
    assert "geoalpha hull" not in capsys.readouterr().err


# --- explain() and curve(): per partition, as the eager calls (#35) -----------------

#: The columns of explain()/curve() that hold lists of index labels.
LISTS = ["critical_rows", "rows_without_1", "left_out"]


def assert_same_table(lazy, eager):
    """``lazy.compute()`` is ``eager``: values, order, dtypes, labels as lists."""
    got = lazy.compute()
    assert got.dtypes.to_dict() == lazy._meta.dtypes.to_dict()
    assert list(got.columns) == list(eager.columns)
    lists = [c for c in LISTS if c in eager.columns]
    for column in lists:  # lists of the input's index labels, element by element
        assert got[column].tolist() == eager[column].tolist(), column
    if isinstance(eager, gpd.GeoDataFrame):
        assert got.crs == eager.crs
        # the critical triangles, exactly (None for a degenerate group)
        assert got.geometry.to_wkb().tolist() == eager.geometry.to_wkb().tolist()
        got, eager = pd.DataFrame(got), pd.DataFrame(eager)
        lists.append("geometry")
    pd.testing.assert_frame_equal(
        got.drop(columns=lists), eager.drop(columns=lists), check_dtype=False
    )
    return got


def with_hawaii_like(airports) -> gpd.GeoDataFrame:
    """The airports and 50 rows of Hawaii geocoded at one spot 700 km west."""
    wrong = gpd.GeoDataFrame(
        {"state": ["HI"] * 50, "iata": [f"Z{i:02d}" for i in range(50)]},
        geometry=shapely.points(np.full((50, 2), (-168.02, 24.86))),
        crs=4326,
        index=pd.RangeIndex(9000, 9050),
    )
    return pd.concat([airports, wrong])


@pytest.fixture(scope="module")
def hawaii(airports):
    return with_hawaii_like(airports)


def test_explain_is_lazy_and_equals_the_eager_table(clusters):
    ddf = spread(clusters, 5)
    lazy = geoalpha.explain(ddf, by="Cluster", suspicious=False)
    assert isinstance(lazy, dask_geopandas.GeoDataFrame)
    assert lazy.crs == clusters.crs
    eager = geoalpha.explain(ddf.compute(), by="Cluster", suspicious=False)
    got = assert_same_table(lazy, eager)
    assert len(got) == 691 and set(got["limited_by"]) <= {
        "coverage",
        "connection",
        "degenerate",
    }
    # the critical triangles' corners are the input's rows, by their labels
    named = got.loc[got["limited_by"] == "coverage", "critical_rows"]
    assert all(set(rows) <= set(clusters.index) for rows in named)


def test_explain_names_the_hawaii_like_location_as_eager(hawaii):
    ddf = spread(hawaii, 4)
    with dask.config.set(scheduler="sync"):  # the partitions' warnings, here
        with pytest.warns(SuspiciousHullWarning, match="group 'HI'"):
            lazy = geoalpha.explain(ddf, by="state")
            got = lazy.compute()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SuspiciousHullWarning)
        eager = geoalpha.explain(ddf.compute(), by="state")
    assert_same_table(lazy, eager)
    hi = got[got["state"] == "HI"].iloc[0]
    assert hi["suspicious"] and hi["limited_by"] == "coverage"
    assert sorted(hi["rows_without_1"]) == list(range(9000, 9050))
    assert hi["radius_without_1"] < hi["radius"] / 4
    assert (
        got.loc[got["state"] != "HI", "suspicious"].sum()
        == eager.loc[eager["state"] != "HI", "suspicious"].sum()
    )


@pytest.mark.parametrize("unit", ["rows", "locations"])
def test_curve_is_lazy_and_equals_the_eager_table(hawaii, unit):
    ddf = spread(hawaii, 3)
    kwargs = dict(by="state", max_left_out=3, outlier_unit=unit, suspicious=False)
    lazy = geoalpha.curve(ddf, **kwargs)
    assert isinstance(lazy, dask.dataframe.DataFrame)
    assert not isinstance(lazy, dask_geopandas.GeoDataFrame)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutlierWarning)  # groups of < 4 places
        eager = geoalpha.curve(ddf.compute(), **kwargs)
        got = assert_same_table(lazy, eager)
    hi = got[got["state"] == "HI"].set_index("k")
    assert hi.index.tolist() == [0, 1, 2, 3]
    if unit == "locations":  # one location out: its 50 rows, and a smaller area
        assert sorted(hi.loc[1, "left_out"]) == list(range(9000, 9050))
        assert hi.loc[1, "area_m2"] < hi.loc[0, "area_m2"] / 2
    else:  # 3 of the 50 rows out cannot move the far location
        assert hi.loc[3, "radius"] == pytest.approx(hi.loc[0, "radius"], rel=1e-12)


def test_accessor_explain_and_curve_are_the_functions(clusters):
    some = clusters[clusters["Cluster"] < 40]
    ddf = spread(some, 2)
    eager = ddf.compute()
    assert_same_table(
        ddf.alpha.explain(by="Cluster", suspicious=False),
        geoalpha.explain(eager, by="Cluster", suspicious=False),
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutlierWarning)
        assert_same_table(
            ddf.alpha.curve(by="Cluster", max_left_out=2, suspicious=False),
            geoalpha.curve(eager, by="Cluster", max_left_out=2, suspicious=False),
        )


def test_explain_and_curve_sort_false_keep_the_partitions(clusters):
    some = clusters[clusters["Cluster"] < 60]
    ddf = spread(some, 3)
    eager = geoalpha.explain(ddf.compute(), by="Cluster", suspicious=False)
    lazy = geoalpha.explain(ddf, by="Cluster", sort=False, suspicious=False)
    assert lazy.npartitions == 3  # not gathered into one
    got = lazy.compute().sort_values("Cluster").reset_index(drop=True)
    assert got["Cluster"].tolist() == eager["Cluster"].tolist()
    assert got["critical_rows"].tolist() == eager["critical_rows"].tolist()
    np.testing.assert_array_equal(got["radius"], eager["radius"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutlierWarning)
        table = geoalpha.curve(ddf, by="Cluster", sort=False, max_left_out=1)
        got = table.compute().sort_values(["Cluster", "k"], kind="stable")
        want = geoalpha.curve(ddf.compute(), by="Cluster", max_left_out=1)
    assert (
        got[["Cluster", "k"]].values.tolist() == want[["Cluster", "k"]].values.tolist()
    )
    assert got["left_out"].tolist() == want["left_out"].tolist()


def test_explain_and_curve_without_by_and_with_crs_none(clusters):
    some = clusters[clusters["Cluster"] < 3]
    ddf = spread(some, 3)
    eager = ddf.compute()
    assert len(assert_same_table(geoalpha.explain(ddf), geoalpha.explain(eager))) == 1
    # planar areas in degrees: named area and unit, as hull() does
    lazy = geoalpha.explain(ddf, by="Cluster", crs=None)
    assert "area_m2_without_1" not in lazy.columns
    got = assert_same_table(lazy, geoalpha.explain(eager, by="Cluster", crs=None))
    assert set(got["unit"]) == {"degree"}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutlierWarning)
        lazy = geoalpha.curve(ddf, by="Cluster", crs=None, max_left_out=1)
        got = assert_same_table(
            lazy, geoalpha.curve(eager, by="Cluster", crs=None, max_left_out=1)
        )
    assert "area_m2" not in got.columns and set(got["unit"]) == {"degree"}


def test_explain_and_curve_errors_as_eager(clusters):
    ddf = spread(clusters, 2)
    eager = clusters.head(50)
    for call, kwargs, match in [
        (geoalpha.explain, dict(method="convex"), "use it with method='alpha'"),
        (geoalpha.curve, dict(max_left_out=-1), "max_left_out must be an integer"),
        (geoalpha.curve, dict(outlier_unit="sites"), "outlier_unit must be one of"),
        (geoalpha.curve, dict(outliers=2), "use it without outliers"),
    ]:
        with pytest.raises(InvalidInputError, match=match):
            call(eager, by="Cluster", **kwargs)
        with pytest.raises(InvalidInputError, match=match):  # at the call, not compute
            call(ddf, by="Cluster", **kwargs)
    with pytest.raises(InvalidInputError, match="no column 'nope'"):
        ddf.alpha.explain(by="nope")
    with pytest.raises(InvalidInputError, match="dask spreads the partitions"):
        ddf.alpha.curve(by="Cluster", n_jobs=2)
    bad = clusters.copy()
    bad.geometry = bad.to_crs(27700).buffer(10.0).to_crs(4326)
    lazy = geoalpha.explain(spread(bad, 2), by="Cluster")
    with pytest.raises(InvalidInputError, match="needs point geometries"):
        lazy.compute()


# --- a real cluster -------------------------------------------------------------


@pytest.fixture(scope="module")
def client():
    with (
        distributed.LocalCluster(
            n_workers=2,
            processes=True,
            threads_per_worker=1,
            dashboard_address=None,
            silence_logs=50,
        ) as cluster,
        distributed.Client(cluster, set_as_default=False) as client,
    ):
        yield client


def test_local_cluster_gives_the_eager_hulls(client, clusters, airports, mixed):
    # (the p2p shuffle between worker processes: points as floats, WKB, None)
    for gdf, by in ((clusters, "Cluster"), (airports, "state"), (mixed, "Cluster")):
        ddf = spread(gdf, 4)
        lazy = geoalpha.hull(ddf, by=by)
        got = client.compute(lazy).result()
        eager = geoalpha.hull(ddf.compute(), by=by)
        assert_geodataframe_equal(got, eager, check_dtype=False)
        assert got.geom_equals_exact(eager, tolerance=0).all()


def test_local_cluster_gives_the_eager_explain_and_curve(client, hawaii):
    ddf = spread(hawaii, 4)
    eager = ddf.compute()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", (SuspiciousHullWarning, OutlierWarning))
        why = geoalpha.explain(ddf, by="state")
        got = client.compute(why).result()
        want = geoalpha.explain(eager, by="state")
        table = client.compute(geoalpha.curve(ddf, by="state", max_left_out=2)).result()
        curve = geoalpha.curve(eager, by="state", max_left_out=2)
    assert got["rows_without_1"].tolist() == want["rows_without_1"].tolist()
    assert got["critical_rows"].tolist() == want["critical_rows"].tolist()
    assert got["suspicious"].tolist() == want["suspicious"].tolist()
    np.testing.assert_array_equal(got["radius_without_1"], want["radius_without_1"])
    assert got.geometry.to_wkb().tolist() == want.geometry.to_wkb().tolist()
    assert table["left_out"].tolist() == curve["left_out"].tolist()
    np.testing.assert_array_equal(table["area_m2"], curve["area_m2"])


# --- imports --------------------------------------------------------------------------


def run_python(code: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)],
        capture_output=True,
        text=True,
        timeout=120,
    )


def test_import_geoalpha_does_not_import_dask():
    done = run_python(
        """
        import sys
        import geoalpha
        assert "dask" not in sys.modules and "dask_geopandas" not in sys.modules
        import dask_geopandas
        assert "alpha" not in vars(dask_geopandas.GeoDataFrame)
        import geoalpha.dask
        assert "alpha" in vars(dask_geopandas.GeoDataFrame)
        """
    )
    assert done.returncode == 0, done.stderr


def test_accessor_registered_when_dask_geopandas_came_first():
    done = run_python(
        """
        import dask_geopandas
        import geoalpha
        assert "alpha" in vars(dask_geopandas.GeoDataFrame)
        assert "alpha" in vars(dask_geopandas.GeoSeries)
        """
    )
    assert done.returncode == 0, done.stderr


def test_missing_dask_says_what_to_install():
    done = run_python(
        """
        import sys
        sys.modules["dask_geopandas"] = None
        import geoalpha.dask
        """
    )
    assert done.returncode != 0
    assert 'pip install "geoalpha[dask]"' in done.stderr
