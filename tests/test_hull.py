"""Tests of geoalpha.hull() on GeoDataFrames (GitHub issue #3, "Must show").

Every test asserts something a user of ``hull()`` would notice: points outside
their polygon, a row too many or too few, a wrong CRS or unit, a file that does
not round-trip, a warning or error that does not say what happened.
"""

from __future__ import annotations

import io
import re
import sys
import warnings

import geopandas as gpd
import numpy as np
import pandas as pd
import pytest
import shapely
from compat import requires_fiona, requires_pyogrio, requires_tqdm
from progress_output import assert_bar_covers, bar_states
from reference import AREA_ATOL
from shapely.geometry import LineString, Point, Polygon

import geoalpha
import geoalpha._frame.progress
from geoalpha import datasets
from geoalpha.errors import (
    AntimeridianWarning,
    CRSWarning,
    DegenerateGroupWarning,
    DroppedRowsWarning,
    GeoAlphaError,
    GeoAlphaWarning,
    InvalidInputError,
    SuspiciousHullWarning,
)

pytestmark = pytest.mark.filterwarnings(
    "ignore::geoalpha.errors.DegenerateGroupWarning",
    "ignore::geoalpha.errors.DroppedRowsWarning",
)

#: Bundled dataset -> the column its README groups by.
BY = {
    "us_airports": "state",
    "uk_clusters": "Cluster",
    "stats19": "Local_Authority_(Highway)",
}
LA = BY["stats19"]
RESULT_COLUMNS = [
    "alpha",
    "radius",
    "n_points",
    "n_outliers",
    "n_parts",
    "area_m2",
    "crs_used",
    "method",
    "geometry",
]
#: A place in England, in EPSG:32630 metres.
UTM30_ORIGIN = np.array([500_000.0, 5_700_000.0])


# --- helpers -----------------------------------------------------------------


def _keys(by) -> list:
    return [by] if isinstance(by, str) else list(by)


def uncovered(points, hulls, by) -> pd.DataFrame:
    """Input rows not covered by their group's hull (in the input CRS)."""
    keys = _keys(by)
    pairs = pd.DataFrame(points[[*keys, "geometry"]]).merge(
        pd.DataFrame(hulls[[*keys, "geometry"]]),
        on=keys,
        how="left",
        suffixes=("_point", "_hull"),
    )
    hull_geoms = pairs["geometry_hull"].to_numpy()
    point_geoms = pairs["geometry_point"].to_numpy()
    ok = ~shapely.is_missing(hull_geoms) & shapely.covers(hull_geoms, point_geoms)
    return pairs.loc[~ok, [*keys, "geometry_point"]]


def assert_covers(points, hulls, by) -> None:
    missed = uncovered(points, hulls, by)
    assert missed.empty, f"{len(missed)} points outside their hull:\n{missed.head()}"


def foreign_vertices(points, hulls, by) -> pd.DataFrame:
    """Hull vertices that are not an input point of the hull's group."""
    keys = _keys(by)
    coords, row = shapely.get_coordinates(hulls.geometry.to_numpy(), return_index=True)
    vertices = (
        pd.DataFrame(hulls[keys])
        .iloc[row]
        .reset_index(drop=True)
        .assign(x=coords[:, 0], y=coords[:, 1])
    )
    pts = shapely.get_coordinates(points.geometry.to_numpy())
    inputs = (
        pd.DataFrame(points[keys])
        .reset_index(drop=True)
        .assign(x=pts[:, 0], y=pts[:, 1])
        .drop_duplicates()
    )
    merged = vertices.merge(inputs, on=[*keys, "x", "y"], how="left", indicator=True)
    return merged[merged["_merge"] == "left_only"]


def widest_part(geoms) -> float:
    """Largest longitude width of any single polygon among (Multi)Polygons."""
    parts = shapely.get_parts(np.asarray(geoms, dtype=object))
    bounds = shapely.bounds(parts[~shapely.is_empty(parts)])
    return float((bounds[:, 2] - bounds[:, 0]).max())


def len_parts(geom) -> int:
    return shapely.get_num_geometries(geom)


def unpromote(geoms: np.ndarray) -> np.ndarray:
    """Single-part MultiPolygons (GPKG promotes mixed layers) back to Polygons."""
    single = (shapely.get_type_id(geoms) == 6) & (
        shapely.get_num_geometries(geoms) == 1
    )
    out = geoms.copy()
    out[single] = shapely.get_geometry(geoms[single], 0)
    return out


def expected_degenerate(points, by) -> list:
    """Groups with no 2-D convex hull (< 3 distinct points or collinear)."""
    convex = points.dissolve(by=by).convex_hull
    return convex.index[convex.geom_type != "Polygon"].tolist()


def frame(xy, groups=None, crs="EPSG:32630", index=None) -> gpd.GeoDataFrame:
    xy = np.asarray(xy, dtype=float)
    data = {"g": groups if groups is not None else ["x"] * len(xy)}
    return gpd.GeoDataFrame(
        data, geometry=gpd.points_from_xy(xy[:, 0], xy[:, 1]), crs=crs, index=index
    )


def group_points(points, by, key) -> np.ndarray:
    return shapely.get_coordinates(points.loc[points[by] == key].geometry.to_numpy())


# --- fixtures ------------------------------------------------------------------


@pytest.fixture(scope="module")
def loaded():
    cache: dict[str, gpd.GeoDataFrame] = {}

    def load(name: str) -> gpd.GeoDataFrame:
        if name not in cache:
            cache[name] = datasets.load(name)
        return cache[name].copy()

    return load


@pytest.fixture(scope="module", params=list(BY), ids=list(BY))
def bundled(request, loaded):
    """(points, by, hulls, recorded warnings) for each bundled dataset."""
    name = request.param
    points, by = loaded(name), BY[name]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        hulls = geoalpha.hull(points, by=by)
    return points, by, hulls, caught


@pytest.fixture(scope="module")
def stats19(loaded):
    return loaded("stats19")


@pytest.fixture(scope="module")
def stats19_osgr(stats19):
    """STATS19 with its own British National Grid coordinates (EPSG:27700)."""
    return gpd.GeoDataFrame(
        stats19.drop(columns="geometry"),
        geometry=gpd.points_from_xy(
            stats19["Location_Easting_OSGR"], stats19["Location_Northing_OSGR"]
        ),
        crs="EPSG:27700",
    )


@pytest.fixture(scope="module")
def small():
    """30 lon/lat points in two groups near 10E 50N, string index labels."""
    rng = np.random.default_rng(0)
    xy = rng.uniform(0.0, 0.1, (30, 2)) + np.array([10.0, 50.0])
    return frame(xy, ["a"] * 15 + ["b"] * 15, "EPSG:4326", [f"r{i}" for i in range(30)])


# --- bundled real data ---------------------------------------------------------


def test_every_point_is_covered_by_its_group_hull(bundled):
    points, by, hulls, _ = bundled
    assert_covers(points.dropna(subset=[by]), hulls, by)


def test_hulls_are_valid_polygons(bundled):
    _, _, hulls, _ = bundled
    assert hulls.is_valid.all()
    assert not hulls.is_empty.any()
    assert set(hulls.geom_type) <= {"Polygon", "MultiPolygon"}
    assert widest_part(hulls.geometry) < 180.0


def test_one_row_per_group_in_key_order(bundled):
    points, by, hulls, _ = bundled
    assert hulls.columns.tolist() == [by, *RESULT_COLUMNS]
    assert hulls[by].tolist() == sorted(points[by].dropna().unique())


def test_n_points_adds_up_to_the_kept_rows(bundled):
    points, by, hulls, _ = bundled
    assert hulls["n_points"].sum() == points[by].notna().sum()
    expected = points.groupby(by).size()
    assert hulls.set_index(by)["n_points"].to_dict() == expected.to_dict()


def test_output_crs_is_input_crs(bundled):
    points, _, hulls, _ = bundled
    assert hulls.crs == points.crs
    assert hulls.crs.to_epsg() == 4326


def test_polygon_vertices_are_input_points(bundled):
    points, by, hulls, _ = bundled
    shaped = hulls[hulls["alpha"].notna()]
    assert len(shaped) > 0
    extra = foreign_vertices(points.dropna(subset=[by]), shaped, by)
    assert extra.empty, f"hull vertices that are no input point:\n{extra.head()}"


def test_alpha_radius_and_area_are_consistent(bundled):
    _, _, hulls, _ = bundled
    shaped = hulls[hulls["alpha"].notna()]
    assert (shaped["alpha"] > 0).all()
    np.testing.assert_allclose(shaped["radius"], 1.0 / shaped["alpha"])
    assert (hulls["area_m2"] > 0).all()
    assert (hulls["n_parts"] == 1).all()
    # the degenerate groups' rows hold a buffer, and say so
    assert (hulls["method"] == "alpha").tolist() == hulls["alpha"].notna().tolist()
    assert set(hulls.loc[hulls["alpha"].isna(), "method"]) <= {"buffer"}


def test_degenerate_groups_are_named_in_a_warning(bundled):
    points, by, hulls, caught = bundled
    names = expected_degenerate(points, by)
    assert names, "every bundled dataset has degenerate groups"
    degenerate = [w for w in caught if issubclass(w.category, DegenerateGroupWarning)]
    assert len(degenerate) == 1
    message = str(degenerate[0].message)
    assert f"{len(names)} group(s)" in message
    for name in names[:10]:
        assert f"'{name}'" in message
    assert "degenerate='buffer'" in message
    # Their rows hold a small polygon around their points, alpha is unknown.
    rows = hulls[hulls[by].isin(names)]
    assert len(rows) == len(names)
    assert rows["alpha"].isna().all()
    assert rows.geom_type.eq("Polygon").all()


def test_no_other_warnings(bundled):
    _, by, _, caught = bundled
    expected = {DegenerateGroupWarning}
    if by == "state":
        expected.add(DroppedRowsWarning)
    if by == "Cluster":  # 5 clusters with one location far off (user_guide/why)
        expected.add(SuspiciousHullWarning)
    assert {w.category for w in caught} == expected
    assert all(w.filename == __file__ for w in caught)  # points at the caller


@pytest.mark.parametrize("name", list(BY))
def test_degenerate_warning_with_pytest_warns(loaded, name):
    points, by = loaded(name), BY[name]
    first = re.escape(f"'{expected_degenerate(points, by)[0]}'")
    with pytest.warns(DegenerateGroupWarning, match=f"no alpha shape: {first}"):
        geoalpha.hull(points, by=by)


def test_airports_rows_without_state_are_counted(loaded):
    airports = loaded("us_airports")
    assert airports["state"].isna().sum() == 12
    with pytest.warns(
        DroppedRowsWarning, match=r"dropped 12 of 3376 rows: 12 with a missing group"
    ):
        hulls = geoalpha.hull(airports, by="state")
    assert {"AK", "HI"} <= set(hulls["state"])


def test_airports_alaska_and_hawaii(loaded):
    airports = loaded("us_airports")
    hulls = geoalpha.hull(airports, by="state").set_index("state")
    for state in ("AK", "HI"):
        points = airports[airports["state"] == state]
        hull = hulls.loc[state, "geometry"]
        assert shapely.covers(hull, points.geometry.to_numpy()).all()
        # Tight: much smaller than the convex hull (AK: Aleutians; HI: islands).
        utm = points.to_crs(points.estimate_utm_crs())
        assert hulls.loc[state, "area_m2"] < 0.9 * utm.union_all().convex_hull.area
    # Alaska is too wide for one UTM zone: it gets a local equal-area CRS.
    assert hulls.loc["AK", "crs_used"].startswith("+proj=laea")
    assert hulls.loc["HI", "crs_used"] == "EPSG:32604"


# --- round trip through files ----------------------------------------------------


@pytest.fixture(scope="module")
def written_hulls(loaded):
    """Hulls to write: airports by state, UK clusters as MultiPolygons."""
    return {
        "us_airports": (geoalpha.hull(loaded("us_airports"), by="state"), "state"),
        "uk_clusters_2": (
            geoalpha.hull(loaded("uk_clusters"), by="Cluster", components=2),
            "Cluster",
        ),
    }


@pytest.mark.parametrize(
    "engine",
    [
        pytest.param("pyogrio", marks=requires_pyogrio),
        pytest.param("fiona", marks=requires_fiona),
    ],
)
@pytest.mark.parametrize("ext", ["shp", "gpkg"])
@pytest.mark.parametrize("case", ["us_airports", "uk_clusters_2"])
def test_round_trip_through_files(written_hulls, tmp_path, engine, ext, case):
    hulls, by = written_hulls[case]
    path = tmp_path / f"hulls.{ext}"
    hulls.to_file(path, engine=engine)
    back = gpd.read_file(path, engine=engine)

    assert len(back) == len(hulls)
    assert back.crs == hulls.crs
    assert back[by].tolist() == hulls[by].tolist()
    assert back["n_points"].tolist() == hulls["n_points"].tolist()
    assert back["n_parts"].tolist() == hulls["n_parts"].tolist()
    # DBF keeps 15 decimals: alpha ~1e-6 1/m keeps ~10 significant digits.
    rtol = 1e-6 if ext == "shp" else 0.0
    np.testing.assert_allclose(back["alpha"], hulls["alpha"], rtol=rtol)
    assert back["crs_used"].tolist() == hulls["crs_used"].tolist()
    same = shapely.equals_exact(
        shapely.normalize(unpromote(back.geometry.to_numpy())),
        shapely.normalize(hulls.geometry.to_numpy()),
        tolerance=1e-9,
    )
    assert same.all(), back.loc[~same, by].tolist()
    assert back.is_valid.all()
    if case == "uk_clusters_2":
        assert (back.geometry.apply(len_parts) == 2).sum() > 100


# --- by variants (as in dissolve) -------------------------------------------------


def test_by_two_columns(stats19):
    by = [LA, "Day_of_Week"]
    hulls = geoalpha.hull(stats19, by=by)
    assert hulls.columns.tolist()[:2] == by
    expected = stats19.dissolve(by=by).index.tolist()
    assert list(zip(hulls[LA], hulls["Day_of_Week"], strict=True)) == expected
    assert hulls["n_points"].sum() == len(stats19)
    assert_covers(stats19, hulls, by)


def test_by_list_of_two_names_the_pairs_in_the_warning(stats19):
    with pytest.warns(
        DegenerateGroupWarning, match=r"'E06000047, 3' \(1 row, 1 distinct point\)"
    ):
        geoalpha.hull(stats19, by=[LA, "Day_of_Week"])


@pytest.mark.parametrize("kind", ["array", "series"])
def test_by_values(stats19, kind):
    values = stats19[LA].to_numpy()
    if kind == "series":
        by = pd.Series(values, index=stats19.index, name="authority")
    else:
        by = values
    hulls = geoalpha.hull(stats19, by=by)
    column = "authority" if kind == "series" else "group"
    reference = geoalpha.hull(stats19, by=LA)
    assert hulls.columns.tolist() == [column, *RESULT_COLUMNS]
    assert hulls[column].tolist() == reference[LA].tolist()
    assert shapely.equals(
        hulls.geometry.to_numpy(), reference.geometry.to_numpy()
    ).all()


def test_by_none_gives_one_row(stats19):
    hulls = geoalpha.hull(stats19)
    assert len(hulls) == 1
    assert hulls.columns.tolist() == RESULT_COLUMNS
    assert hulls["n_points"].item() == len(stats19)
    assert shapely.covers(hulls.geometry.item(), stats19.geometry.to_numpy()).all()
    assert geoalpha.hull(stats19, by=None).geom_equals(hulls.geometry).all()


def test_dropna_false_keeps_a_nan_group(stats19):
    points = stats19.copy()
    points.loc[points.index[::25], LA] = None
    with pytest.warns(DroppedRowsWarning, match="41 with a missing group key"):
        dropped = geoalpha.hull(points, by=LA)
    assert dropped[LA].notna().all()
    with warnings.catch_warnings():
        warnings.simplefilter("error", DroppedRowsWarning)
        kept = geoalpha.hull(points, by=LA, dropna=False)
    assert len(kept) == len(dropped) + 1
    assert kept[LA].tolist()[:-1] == dropped[LA].tolist()
    assert pd.isna(kept[LA].iloc[-1])  # last, as in dissolve(dropna=False)
    assert pd.isna(points.dissolve(by=LA, dropna=False).index[-1])
    assert kept["n_points"].iloc[-1] == 41
    assert kept["n_points"].sum() == len(points)
    assert_covers(points, kept, LA)


def test_dropna_false_on_airports_warns_about_the_wide_group(loaded):
    # The 12 stateless airports run from Thailand to Pennsylvania across the
    # Pacific: no lon/lat polygon can hold their hull, and the user is told
    # (and that the hull is split at the antimeridian it crosses).
    airports = loaded("us_airports")
    with (
        pytest.warns(GeoAlphaWarning, match=r"more than 180 degrees of longitude"),
        pytest.warns(AntimeridianWarning, match=r"1 group\(s\) cross .*: nan"),
    ):
        hulls = geoalpha.hull(airports, by="state", dropna=False)
    assert pd.isna(hulls["state"].iloc[-1])
    assert hulls["n_points"].iloc[-1] == 12
    assert hulls.is_valid.all()


@pytest.mark.parametrize("name", ["us_airports", "stats19"])
def test_sort_false_keeps_first_appearance_order(loaded, name):
    points, by = loaded(name), BY[name]
    hulls = geoalpha.hull(points, by=by, sort=False)
    expected = points.dissolve(by=by, sort=False).index.tolist()
    assert hulls[by].tolist() == expected
    assert hulls[by].tolist() != sorted(expected)
    assert hulls[by].tolist() == points[by].dropna().unique().tolist()
    sorted_hulls = geoalpha.hull(points, by=by).set_index(by)
    assert np.allclose(
        hulls.set_index(by)["alpha"].reindex(sorted_hulls.index),
        sorted_hulls["alpha"],
        equal_nan=True,
    )


# --- CRS ---------------------------------------------------------------------------


def test_lonlat_alpha_is_in_inverse_metres(loaded):
    points = loaded("uk_clusters")
    hulls = geoalpha.hull(points, by="Cluster")
    assert set(hulls["crs_used"]) == {"EPSG:32630"}
    # Project ourselves to the British National Grid: close, not equal.
    bng = points.to_crs("EPSG:27700")
    codes, keys = pd.factorize(bng["Cluster"], sort=True)
    own = geoalpha.alpha_shapes(shapely.get_coordinates(bng.geometry.to_numpy()), codes)
    assert keys.tolist() == hulls["Cluster"].tolist()
    shaped = hulls["alpha"].notna().to_numpy()
    np.testing.assert_allclose(hulls["alpha"][shaped], own.alpha[shaped], rtol=0.02)
    # Radii are tens of metres around UK road-accident clusters.
    assert 1.0 < hulls["radius"].median() < 1000.0


@pytest.mark.parametrize("state", ["CO", "TX", "FL", "HI"])
def test_lonlat_airports_alpha_matches_own_utm(loaded, state):
    airports = loaded("us_airports")
    hulls = geoalpha.hull(airports, by="state").set_index("state")
    points = airports[airports["state"] == state]
    utm = points.to_crs(points.estimate_utm_crs())
    own = geoalpha.optimal_alpha(shapely.get_coordinates(utm.geometry.to_numpy()))
    assert hulls.loc[state, "alpha"] == pytest.approx(own, rel=0.02)
    used = hulls.loc[state, "crs_used"]
    if used.startswith("EPSG:"):  # same CRS as ours: exactly the same number
        mine = points.to_crs(used).geometry.to_numpy()
        assert hulls.loc[state, "alpha"] == geoalpha.optimal_alpha(
            shapely.get_coordinates(mine)
        )


def test_projected_input_is_used_as_is(stats19_osgr):
    hulls = geoalpha.hull(stats19_osgr, by=LA)
    assert hulls.crs.to_epsg() == 27700
    assert set(hulls["crs_used"]) == {"EPSG:27700"}
    shaped = hulls[hulls["alpha"].notna()]
    assert len(shaped) == 6
    for key, alpha in zip(shaped[LA], shaped["alpha"], strict=True):
        assert alpha == geoalpha.optimal_alpha(group_points(stats19_osgr, LA, key))
    assert_covers(stats19_osgr, hulls, LA)
    assert foreign_vertices(stats19_osgr, shaped, LA).empty


@pytest.mark.parametrize(("holes", "expected"), [(False, 361.415), (True, 349.063)])
def test_crs_none_keeps_degrees_as_the_seed_paper(stats19, holes, expected):
    hulls = geoalpha.hull(stats19, by=LA, crs=None, holes=holes).set_index(LA)
    assert hulls.loc["E09000020", "alpha"] == pytest.approx(expected, abs=5e-4)
    assert hulls.crs == stats19.crs


def test_input_without_crs_needs_crs_none(stats19):
    bare = stats19.set_crs(None, allow_override=True)
    with pytest.raises(InvalidInputError, match=r"no CRS.*set_crs.*crs=None"):
        geoalpha.hull(bare, by=LA)
    hulls = geoalpha.hull(bare, by=LA, crs=None).set_index(LA)
    assert hulls.crs is None
    assert hulls.loc["E09000020", "alpha"] == pytest.approx(361.415, abs=5e-4)


def test_crs_none_names_the_area_unit_as_the_cli(stats19, stats19_osgr):
    # Degrees or bare numbers: `area` in that unit squared and a `unit` column,
    # never an `area_m2` that does not hold square metres (as `geoalpha hull`).
    degrees = geoalpha.hull(stats19, by=LA, crs=None)
    assert "area_m2" not in degrees.columns
    assert degrees.columns[degrees.columns.get_loc("area") + 1] == "unit"
    assert set(degrees["unit"]) == {"degree"}
    row = degrees.set_index(LA).loc["E09000020"]
    assert row["area"] == pytest.approx(row["geometry"].area, rel=1e-12)
    assert row["area"] < 1  # square degrees, not m2
    bare = geoalpha.hull(stats19.set_crs(None, allow_override=True), by=LA, crs=None)
    assert set(bare["unit"]) == {"coordinate unit"}
    # Metres stay `area_m2` (then planar square metres), and so does crs="auto".
    metres = geoalpha.hull(stats19_osgr, by=LA, crs=None)
    assert "area_m2" in metres.columns and "unit" not in metres.columns
    assert "area_m2" in geoalpha.hull(stats19, by=LA).columns


def test_forced_metric_crs(stats19):
    hulls = geoalpha.hull(stats19, by=LA, crs="EPSG:27700")
    assert set(hulls["crs_used"]) == {"EPSG:27700"}
    assert hulls.crs == stats19.crs  # computed in 27700, returned in lon/lat
    bng = stats19.to_crs("EPSG:27700")
    alpha = hulls.set_index(LA).loc["E09000020", "alpha"]
    own = geoalpha.optimal_alpha(group_points(bng, LA, "E09000020"))
    assert alpha == pytest.approx(own, rel=1e-9)
    assert_covers(stats19, hulls, LA)


@pytest.mark.parametrize("crs", ["EPSG:4326", 4326])
def test_forced_geographic_crs_is_an_error(stats19, crs):
    with pytest.raises(InvalidInputError, match=r"projected \(metric\) CRS.*4326"):
        geoalpha.hull(stats19, by=LA, crs=crs)


def test_unparsable_crs_is_an_error(stats19):
    with pytest.raises(InvalidInputError, match="expected a CRS"):
        geoalpha.hull(stats19, by=LA, crs="not a crs")


def test_projected_input_in_feet_gives_alpha_in_inverse_metres(stats19_osgr):
    points = stats19_osgr[stats19_osgr[LA] == "E09000020"]
    metres = geoalpha.hull(points)
    with pytest.warns(CRSWarning, match="stretches areas 1.0"):  # not in New York
        feet = geoalpha.hull(points.to_crs("EPSG:2263"))  # New York, US survey feet
    assert feet["alpha"].item() == pytest.approx(metres["alpha"].item(), rel=0.05)
    assert feet["area_m2"].item() == pytest.approx(metres["area_m2"].item(), rel=0.05)


# --- antimeridian --------------------------------------------------------------------


@pytest.fixture(scope="module")
def fiji():
    rng = np.random.default_rng(1)
    lon = np.concatenate([rng.uniform(179.5, 180.0, 20), rng.uniform(-180, -179.4, 20)])
    lat = rng.uniform(-17.5, -16.5, 40)
    return frame(np.column_stack([lon, lat]), ["fiji"] * 40, "EPSG:4326")


def test_antimeridian_group_is_split_at_180(fiji):
    with pytest.warns(AntimeridianWarning, match=r"1 group\(s\) cross.*fiji"):
        hulls = geoalpha.hull(fiji, by="g")
    hull = hulls.geometry.item()
    assert hull.geom_type == "MultiPolygon"
    assert hull.is_valid
    assert hulls["n_parts"].item() == 2
    assert widest_part(hulls.geometry) < 180.0
    west, east = sorted(hull.geoms, key=lambda p: p.bounds[0])
    assert east.bounds[2] == 180.0 and west.bounds[0] == -180.0
    assert_covers(fiji, hulls, "g")
    # Not the band around the globe a naive polygon in lon/lat would be.
    assert hull.area < 2.0


def test_antimeridian_group_next_to_an_ordinary_one(fiji):
    italy = frame([[10, 45], [12, 45], [11, 46.5], [11.2, 45.3]], ["italy"] * 4)
    both = pd.concat([fiji, italy.to_crs("EPSG:4326")], ignore_index=True)
    with pytest.warns(AntimeridianWarning) as record:
        hulls = geoalpha.hull(both, by="g")
    assert "italy" not in str(record[0].message)
    assert hulls.set_index("g").loc["italy", "geometry"].geom_type == "Polygon"
    assert widest_part(hulls.geometry) < 180.0
    assert_covers(both, hulls, "g")


@pytest.mark.parametrize("seed", range(6))
def test_wide_pacific_groups_keep_every_point_after_the_split(seed):
    """Groups reaching from ~175 E to ~100-130 W: their east vertices round-trip.

    Longitudes between -128 and 0 lose their last bits in ``lon + 360 - 360``;
    the split hulls must still have the input points as vertices and cover
    them, in EPSG:4326 (the audit found 126 of 200 such triangles missing a
    point by ~1e-14 degrees).
    """
    rng = np.random.default_rng(seed)
    n_groups, size = 8, rng.integers(3, 30)
    west = rng.uniform(160.0, 179.9, (n_groups, size))
    east = rng.uniform(-130.0, -100.0, (n_groups, size))
    lon = np.where(rng.random((n_groups, size)) < 0.5, west, east)
    lon[:, 0], lon[:, 1] = west[:, 0], east[:, 1]  # both sides in every group
    lat = rng.uniform(-40.0, 40.0, (n_groups, size))
    groups = np.repeat([f"pacific {i}" for i in range(n_groups)], size)
    points = frame(np.column_stack([lon.ravel(), lat.ravel()]), groups, "EPSG:4326")
    with pytest.warns(AntimeridianWarning, match=r"8 group\(s\) cross") as record:
        hulls = geoalpha.hull(points, by="g")
    assert "outside the split hull" not in str(record[0].message)
    assert shapely.is_valid(hulls.geometry.to_numpy()).all()
    assert_covers(points, hulls, "g")
    foreign = foreign_vertices(points, hulls, "g")
    assert (foreign["x"].abs() == 180.0).all(), foreign  # only the cut's ends
    assert widest_part(hulls.geometry) <= 180.0


def test_a_point_at_minus_180_is_named_when_its_hull_ends_at_plus_180():
    """-180 and +180 are one meridian, but not one coordinate: warned, not hidden."""
    lon = [179.998600178459, 179.998241542992, -180.0]
    lat = [9.136294549352, 9.132884092232, 9.133651947977]
    points = frame(np.column_stack([lon, lat]), ["fj"] * 3, "EPSG:4326")
    with pytest.warns(
        AntimeridianWarning,
        match=r"1 of their point\(s\) lie outside the split hull, on the other side "
        r"of the \+-180 line.*'fj' \(1 row\)",
    ):
        hulls = geoalpha.hull(points, by="g")
    hull = hulls.geometry.item()
    assert hull.is_valid
    assert shapely.covers(hull, points.geometry.to_numpy()).tolist() == [
        True,
        True,
        False,
    ]
    assert shapely.covers(hull, Point(180.0, lat[2]))  # the same place, at +180


# From the robustness audit: these raised GEOSException / ValueError.
POLE = [
    [142.02489423625292, -89.99999775284346],
    [-81.10458900516971, -89.99999588109698],
    [33.56149117146799, -89.99999930273424],
    [-5.504776546534686, -89.99999548269567],
    [174.6888167677531, -89.99999980261676],
    [-15.86057131002616, -89.99999578282613],
]
WORLD = [[-100.0, 77.0], [136.0, 17.0], [-5.0, -21.0], [-130.0, 61.0], [-34.0, 50.0]]


@pytest.mark.parametrize("method", ["knn", "concave"])
@pytest.mark.parametrize("where", ["pole", "world"])
def test_comparison_hulls_that_geos_cannot_grow_are_degenerate_not_errors(
    method, where
):
    points = frame(POLE if where == "pole" else WORLD, None, "EPSG:4326")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        hulls = geoalpha.hull(points, by="g", method=method)
    hull = hulls.geometry.item()
    assert hull.is_valid and not hull.is_empty
    messages = " ".join(str(w.message) for w in caught)
    assert "span more than 180 degrees" in messages or (
        "got no valid polygon holding all their points" in messages
    ), messages
    if where == "pole":  # not wide: every point is held
        assert_covers(points, hulls, "g")


def test_concave_hull_with_holes_falls_back_where_geos_fails():
    # Three nearly collinear points: GEOS's concave hull with holes raised
    # "CoverageUnion cannot process overlapping inputs".
    xy = [
        [400006.1816852308, 5700003.090842616],
        [400028.0481179391, 5700014.02405897],
        [400027.75328923936, 5700013.87664462],
    ]
    good = [[0.0, 0.0], [100.0, 0.0], [0.0, 100.0], [100.0, 100.0], [50.0, 40.0]]
    points = frame(
        np.r_[xy, np.asarray(good) + 400000.0],
        ["thin"] * 3 + ["good"] * 5,
        "EPSG:27700",
    )
    with pytest.warns(
        GeoAlphaWarning,
        match=r"concave hull with holes failed for 1 group\(s\): 'thin'",
    ):
        hulls = geoalpha.hull(points, by="g", method="concave", holes=True)
    method = hulls.set_index("g")["method"]
    assert method["thin"] == "concave ratio=0.3 (no holes)"
    assert method["good"] == "concave ratio=0.3"
    assert shapely.is_valid(hulls.geometry.to_numpy()).all()
    assert_covers(points, hulls, "g")


# --- methods -------------------------------------------------------------------------


METHODS = ["alpha", "convex", "concave", "knn"]


@pytest.fixture(scope="module")
def by_method(loaded):
    out = {}
    for name, by in BY.items():
        points = loaded(name)
        for method in METHODS:
            with warnings.catch_warnings():
                # concave/knn: "became invalid in the input CRS ... make_valid"
                warnings.simplefilter("ignore", GeoAlphaWarning)
                hulls = geoalpha.hull(points, by=by, method=method)
            out[name, method] = (points.dropna(subset=[by]), by, hulls)
    return out


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("name", list(BY))
def test_methods_give_the_same_table(by_method, name, method):
    points, by, hulls = by_method[name, method]
    reference = by_method[name, "alpha"][2]
    assert hulls.columns.tolist() == reference.columns.tolist()
    assert hulls[by].tolist() == reference[by].tolist()
    assert hulls["n_points"].tolist() == reference["n_points"].tolist()
    assert hulls.is_valid.all()
    assert hulls.crs == points.crs
    degenerate = reference["alpha"].isna().to_numpy()
    assert hulls["method"][~degenerate].str.startswith(method).all()
    assert (hulls["method"][degenerate] == "buffer").all()


@pytest.mark.parametrize("name", list(BY))
@pytest.mark.parametrize("method", METHODS)
def test_methods_cover_their_points(by_method, name, method):
    points, by, hulls = by_method[name, method]
    assert_covers(points, hulls, by)


@pytest.mark.parametrize("name", list(BY))
def test_alpha_shapes_are_never_larger_than_convex_hulls(by_method, name):
    _, _, alpha = by_method[name, "alpha"]
    _, _, convex = by_method[name, "convex"]
    # on the ellipsoid, to its rounding (an alpha shape equal to its convex
    # hull but for a vertex on an edge: 4e-6 m² of 19.5 m² more)
    assert (alpha["area_m2"] <= convex["area_m2"] * (1 + 1e-9) + AREA_ATOL).all()
    assert alpha["area_m2"].sum() < convex["area_m2"].sum()
    shaped = convex["alpha"].notna()
    assert (convex.loc[shaped, "alpha"] == 0.0).all()
    assert np.isinf(convex.loc[shaped, "radius"]).all()
    assert shaped.sum() == alpha["alpha"].notna().sum()


def test_concave_and_knn_have_no_alpha(by_method):
    for method in ("concave", "knn"):
        _, _, hulls = by_method["stats19", method]
        assert hulls["alpha"].isna().all()
    _, _, knn = by_method["stats19", "knn"]
    assert knn["method"].str.fullmatch(r"knn k=\d+").sum() == 6


def test_convex_hull_covers_montana_border_airports(loaded):
    # The user-visible symptom of the convex bug: Scobey airport (on the
    # Canadian border) lies outside Montana's convex hull in lon/lat.
    airports = loaded("us_airports")
    montana = airports[airports["state"] == "MT"]
    hull = geoalpha.hull(montana, method="convex").geometry.item()
    assert shapely.covers(hull, montana.geometry.to_numpy()).all()


# --- components and holes ----------------------------------------------------


def blobs(separation=10_000.0):
    rng = np.random.default_rng(2)
    west = rng.normal(0.0, 100.0, (40, 2))
    east = rng.normal(0.0, 100.0, (40, 2)) + np.array([separation, 0.0])
    return frame(np.vstack([west, east]) + UTM30_ORIGIN)


def test_components_two_gives_two_parts():
    points = blobs()
    hulls = geoalpha.hull(points, by="g", components=2)
    hull = hulls.geometry.item()
    assert hull.geom_type == "MultiPolygon"
    assert len(hull.geoms) == 2 == hulls["n_parts"].item()
    assert_covers(points, hulls, "g")
    one = geoalpha.hull(points, by="g")
    assert one.geometry.item().geom_type == "Polygon"
    # One piece must bridge the 10 km gap: a much smaller alpha.
    assert one["alpha"].item() < hulls["alpha"].item() / 10


def annulus():
    rng = np.random.default_rng(3)
    angle = rng.uniform(0.0, 2 * np.pi, 400)
    radius = rng.uniform(800.0, 1000.0, 400)
    xy = np.column_stack([radius * np.cos(angle), radius * np.sin(angle)])
    return frame(xy + UTM30_ORIGIN)


def test_holes_true_keeps_the_hole_of_an_annulus():
    points = annulus()
    centre = Point(500_000.0, 5_700_000.0)
    kept = geoalpha.hull(points, by="g", holes=True).geometry.item()
    assert kept.geom_type == "Polygon"
    assert len(kept.interiors) >= 1
    assert not kept.covers(centre)
    assert kept.area < 0.3 * np.pi * 1000.0**2
    filled = geoalpha.hull(points, by="g").geometry.item()
    assert len(filled.interiors) == 0
    assert filled.covers(centre)
    assert_covers(points, gpd.GeoDataFrame({"g": ["x"]}, geometry=[kept]), "g")


# --- degenerate groups -------------------------------------------------------


@pytest.fixture(scope="module")
def with_degenerate():
    rng = np.random.default_rng(4)
    good = rng.uniform(0.0, 500.0, (12, 2))
    one = [[2000.0, 0.0]]
    two = [[3000.0, 0.0], [3010.0, 5.0]]
    line = [[4000.0 + 10 * i, 20.0 * i] for i in range(5)]
    xy = np.vstack([good, one, two, line]) + UTM30_ORIGIN
    groups = ["good"] * 12 + ["one"] + ["two"] * 2 + ["line"] * 5
    return frame(xy, groups)


def test_a_degenerate_group_is_counted_in_rows_and_distinct_points():
    # 26 rows on 2 places: the warning says both, and the row says "buffer"
    rng = np.random.default_rng(26)
    good = rng.uniform(0.0, 500.0, (12, 2))
    two = np.repeat([[2000.0, 0.0], [2010.0, 5.0]], 13, axis=0)
    points = frame(np.vstack([good, two]) + UTM30_ORIGIN, ["good"] * 12 + ["x"] * 26)
    with pytest.warns(DegenerateGroupWarning) as caught:
        hulls = geoalpha.hull(points, by="g").set_index("g")
    message = str(caught[0].message)
    assert (
        "no alpha shape: 'x' (26 rows, 2 distinct points); their rows hold" in message
    )
    assert hulls["method"].to_dict() == {"good": "alpha", "x": "buffer"}
    assert hulls.loc["x", "n_points"] == 26


def test_a_group_at_the_pole_is_named_for_what_failed_and_its_buffer_holds_it():
    """Four points within ~1 m of the south pole in a 1.6 degree wedge.

    Not on a line (in metres or lon/lat), but their triangles fold in lon/lat
    (angles and distances from the pole), so no valid polygon holds them
    there; a 1 m buffer made in metres holds the pole, which no lon/lat
    polygon can. The warning names the real reason, and the buffer is made
    in lon/lat: valid, and holding every point.
    """
    lon = [-99.188080632377, -97.632198191021, -97.882326128132, -98.778124591588]
    lat = [-89.999989498677, -89.999997874933, -89.999995882057, -89.999992339958]
    pole = frame(np.column_stack([lon, lat]), ["pole"] * 4, "EPSG:4326")
    xy = np.column_stack([lon, lat])
    assert geoalpha._core.solve(xy, np.zeros(4, dtype=np.int64), 1).reason[0] == 0
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        hulls = geoalpha.hull(pole, by="g")
    messages = [str(w.message) for w in caught]
    assert any(
        "1 group(s) got no valid polygon holding all their points in the output "
        "CRS (their shapes fold there, near a pole"
        in m
        and "'pole' (4 rows)" in m
        for m in messages
    ), messages
    assert not any("on a line" in m or "make_valid" in m for m in messages)
    hull = hulls.geometry.item()
    assert hull.is_valid and hull.geom_type == "Polygon"
    assert_covers(pole, hulls, "g")
    assert hull.bounds[1] >= -90.0


@pytest.mark.parametrize("policy", ["buffer", "empty", "drop"])
def test_degenerate_policy(with_degenerate, tmp_path, policy):
    points = with_degenerate
    kwargs = {} if policy == "buffer" else {"degenerate": policy}
    message = (
        r"3 group\(s\) have fewer than 3 distinct points or all points on a "
        r"line, so no alpha shape: 'line' \(5 rows, 5 distinct points\); 'one' "
        r"\(1 row, 1 distinct point\); 'two' \(2 rows, 2 distinct points\); "
        rf".*degenerate='{policy}'"
    )
    with pytest.warns(DegenerateGroupWarning, match=message):
        hulls = geoalpha.hull(points, by="g", **kwargs)
    odd = ["line", "one", "two"]
    if policy == "drop":
        assert hulls["g"].tolist() == ["good"]
    else:
        assert hulls["g"].tolist() == ["good", "line", "one", "two"]
        rows = hulls[hulls["g"].isin(odd)]
        assert rows["alpha"].isna().all()
        assert rows.geom_type.eq("Polygon").all()
        method = "buffer" if policy == "buffer" else "alpha"
        assert (rows["method"] == method).all()
        if policy == "buffer":
            assert not rows.is_empty.any()
            assert_covers(points, hulls, "g")
            # 1 m around a point: pi m^2; around a segment of length L: 2 L + pi.
            areas = rows.set_index("g")["area_m2"]
            assert areas["one"] == pytest.approx(np.pi, rel=0.02)
            assert areas["two"] == pytest.approx(2 * np.hypot(10, 5) + np.pi, rel=0.02)
        else:
            assert rows.is_empty.all()
            assert (rows["area_m2"] == 0).all()
    assert hulls.set_index("g").loc["good", "geometry"].geom_type == "Polygon"

    path = tmp_path / "hulls.shp"
    hulls.to_file(path)  # one geometry type: a Shapefile holds it
    back = gpd.read_file(path)
    assert back["g"].tolist() == hulls["g"].tolist()


def test_buffer_width_is_in_metres(with_degenerate):
    hulls = geoalpha.hull(with_degenerate, by="g", buffer=10.0).set_index("g")
    assert hulls.loc["one", "area_m2"] == pytest.approx(np.pi * 100.0, rel=0.02)


def test_empty_rows_have_no_parts(with_degenerate):
    hulls = geoalpha.hull(with_degenerate, by="g", degenerate="empty")
    assert hulls.set_index("g").loc["one", "n_parts"] == 0


@pytest.mark.parametrize(
    "method",
    [
        "alpha",
        "convex",
        "concave",
        "knn",
    ],
)
def test_degenerate_policy_applies_to_every_method(with_degenerate, method):
    with pytest.warns(DegenerateGroupWarning, match="'one'"):
        hulls = geoalpha.hull(with_degenerate, by="g", method=method)
    assert not hulls.is_empty.any()
    assert_covers(with_degenerate, hulls, "g")


# --- bad input ---------------------------------------------------------------------


def test_non_point_geometries_name_count_and_labels(small):
    bad = small.copy()
    bad.loc["r3", "geometry"] = LineString([(10, 50), (10.01, 50.01)])
    bad.loc["r7", "geometry"] = LineString([(10, 50), (10.02, 50.01)])
    bad.loc["r9", "geometry"] = Polygon([(10, 50), (10.01, 50), (10.01, 50.01)])
    with pytest.raises(InvalidInputError, match="needs point geometries") as err:
        geoalpha.hull(bad, by="g")
    message = str(err.value)
    assert "(index 'r3', 'r7', 'r9')" in message
    assert "vertices=True" in message
    assert re.search(r"got 2 \w+, 1 \w+ row", message)


def test_non_point_geometries_name_their_type(small):
    bad = small.copy()
    bad.loc["r3", "geometry"] = LineString([(10, 50), (10.01, 50.01)])
    bad.loc["r7", "geometry"] = LineString([(10, 50), (10.02, 50.01)])
    bad.loc["r9", "geometry"] = Polygon([(10, 50), (10.01, 50), (10.01, 50.01)])
    with pytest.raises(InvalidInputError, match="got 2 LineString, 1 Polygon row"):
        geoalpha.hull(bad, by="g")


def test_vertices_true_uses_the_vertices(small):
    shapes = small.copy()
    square = Polygon([(10.2, 50.2), (10.3, 50.2), (10.3, 50.3), (10.2, 50.3)])
    shapes.loc["r3", "geometry"] = square
    shapes.loc["r7", "geometry"] = LineString([(9.9, 49.9), (9.95, 49.92)])
    hulls = geoalpha.hull(shapes, by="g", vertices=True).set_index("g")
    hull = hulls.loc["a", "geometry"]
    assert hull.covers(square)
    assert hull.covers(Point(9.9, 49.9))
    assert hulls.loc["a", "n_points"] == 15  # rows, not vertices
    corners = {tuple(c) for c in square.exterior.coords}
    assert corners & {tuple(c) for c in hull.exterior.coords}


def test_missing_and_empty_geometries_are_dropped_and_counted(small):
    holey = small.copy()
    holey.loc["r2", "geometry"] = None
    holey.loc["r5", "geometry"] = Point()
    with pytest.warns(
        DroppedRowsWarning,
        match=r"dropped 2 of 30 rows: 2 with a missing or empty geometry or NaN "
        r"coordinates \(index 'r2', 'r5'\)",
    ):
        hulls = geoalpha.hull(holey, by="g")
    assert hulls["n_points"].tolist() == [13, 15]


@pytest.mark.parametrize(
    "nan_point", [Point(np.nan, np.nan), Point(np.nan, 50.0), Point(10.0, np.nan)]
)
def test_nan_coordinates_are_dropped_as_missing_geometries(small, nan_point):
    # POINT (NaN NaN) is what WKB and a GeoPackage hold for an empty point and
    # what points_from_xy makes of a missing longitude/latitude: the dask path
    # and the command (which read it back as POINT EMPTY) drop it, so does
    # the eager call (it used to raise).
    bad = small.copy()
    bad.loc["r2", "geometry"] = None
    bad.loc["r6", "geometry"] = nan_point
    with pytest.warns(
        DroppedRowsWarning,
        match=r"^hull\(\) dropped 2 of 30 rows: 2 with a missing or empty geometry "
        r"or NaN coordinates \(index 'r2', 'r6'\)$",
    ):
        hulls = geoalpha.hull(bad, by="g")
    expected = geoalpha.hull(small.drop(index=["r2", "r6"]), by="g")
    assert hulls["n_points"].tolist() == expected["n_points"].tolist() == [13, 15]
    assert hulls.geom_equals_exact(expected, 0).all()


def test_latitude_out_of_range_names_the_rows(small):
    bad = small.copy()
    bad.loc["r4", "geometry"] = Point(10.0, 95.0)
    with pytest.raises(ValueError, match=r"latitude outside \[-90, 90\].*index r4"):
        geoalpha.hull(bad, by="g")
    with pytest.raises(GeoAlphaError):
        geoalpha.hull(bad, by="g")


def test_swapped_lonlat_gets_a_hint(loaded):
    airports = loaded("us_airports").dropna(subset=["state"])
    swapped = airports.set_geometry(
        gpd.points_from_xy(airports["latitude"], airports["longitude"]), crs=4326
    )
    off = airports.index[airports["longitude"].abs() > 90]
    with pytest.raises(InvalidInputError, match=r"look swapped") as err:
        geoalpha.hull(swapped, by="state")
    assert f"latitude outside [-90, 90] in {len(off)} rows (index {off[0]}, " in str(
        err.value
    )


def test_missing_by_column_lists_the_columns(small):
    with pytest.raises(
        InvalidInputError, match=r"no column 'state'; the columns are g, geometry"
    ):
        geoalpha.hull(small, by="state")
    with pytest.raises(InvalidInputError, match="no column 'state'"):
        geoalpha.hull(small, by=["g", "state"])


@pytest.mark.parametrize("value", [np.inf, -np.inf])
def test_infinite_lonlat_names_the_row(small, value):
    bad = small.copy()
    bad.loc["r6", "geometry"] = Point(value, 50.0)
    with pytest.raises(
        InvalidInputError,
        match=r"^hull\(\) needs finite coordinates; got infinite values in 1 "
        r"row\(s\) \(index 'r6'\)$",
    ):
        geoalpha.hull(bad, by="g")


def test_infinite_projected_coordinates_name_the_index_label(small):
    bad = small.to_crs("EPSG:32632")
    bad.loc["r1", "geometry"] = None
    bad.loc["r3", "geometry"] = Point(np.nan, 5_500_000.0)  # dropped
    bad.loc["r6", "geometry"] = Point(np.inf, 5_500_000.0)
    with pytest.warns(DroppedRowsWarning, match=r"index 'r1', 'r3'"):
        with pytest.raises(InvalidInputError, match=r"in 1 row\(s\) \(index 'r6'\)"):
            geoalpha.hull(bad, by="g")


@pytest.mark.parametrize(
    ("option", "value", "message"),
    [
        ("method", "foo", "method must be one of 'alpha', 'convex', 'concave', 'knn'"),
        ("degenerate", "foo", "degenerate must be one of 'buffer', 'empty', 'drop'"),
        ("components", 0, "components must be an integer >= 1"),
        ("holes", "yes", "holes must be True or False"),
    ],
)
def test_bad_options(small, option, value, message):
    with pytest.raises(InvalidInputError, match=re.escape(message) + ".*got"):
        geoalpha.hull(small, by="g", **{option: value})


def test_not_a_geodataframe(small):
    with pytest.raises(InvalidInputError, match="GeoDataFrame or GeoSeries; got"):
        geoalpha.hull(pd.DataFrame(small.drop(columns="geometry")), by="g")


# --- progress ------------------------------------------------------------------------


HULL_PHASES = ["group", "project", "compute", "check"]


@requires_tqdm
@pytest.mark.parametrize("method", ["alpha", "convex", "concave", "knn"])
def test_progress_bar_goes_through_every_phase_to_the_end(small, capsys, method):
    geoalpha.hull(small, by="g", progress=True, method=method)
    captured = capsys.readouterr()
    # one bar: group, project, compute, check, never backwards, ends at 100 %
    assert_bar_covers(captured.err, HULL_PHASES)
    assert "2 groups]" in captured.err
    assert captured.out == ""


@requires_tqdm
def test_progress_bar_of_a_run_with_many_degenerate_groups(capsys):
    # 300 groups, 200 of them of 1-2 points that are never triangulated
    rng = np.random.default_rng(3)
    xy = rng.random((1300, 2)) * 0.01 + np.array([10.0, 50.0])
    keys = np.concatenate([np.arange(1000) % 100, 100 + np.arange(300) % 200])
    with pytest.warns(DegenerateGroupWarning):
        geoalpha.hull(frame(xy, keys, "EPSG:4326"), by="g", progress=True)
    err = capsys.readouterr().err
    assert_bar_covers(err, HULL_PHASES)  # the 200 count too: the bar ends full
    assert "300 groups]" in err


@requires_tqdm
def test_progress_bar_by_default_on_a_terminal_from_many_groups(small, monkeypatch):
    class Terminal(io.StringIO):
        def isatty(self):
            return True

    for tty, least, shown in [(True, 2, True), (True, 3, False), (False, 2, False)]:
        monkeypatch.setattr(geoalpha._frame.progress, "PROGRESS_MIN_GROUPS", least)
        stderr = Terminal() if tty else io.StringIO()
        monkeypatch.setattr(sys, "stderr", stderr)
        geoalpha.hull(small, by="g")  # progress=None
        if shown:  # it appears once the groups are known, and ends full
            assert_bar_covers(stderr.getvalue(), HULL_PHASES)
        else:
            assert stderr.getvalue() == ""


@requires_tqdm
def test_progress_bar_stops_where_an_error_stops_the_run(small, capsys):
    bad = small.copy()
    bad.loc[bad.index[3], "geometry"] = LineString([(10, 50), (10.1, 50.1)])
    before = warnings.showwarning
    with pytest.raises(InvalidInputError, match="needs point geometries"):
        geoalpha.hull(bad, by="g", progress=True)
    assert warnings.showwarning is before
    states = bar_states(capsys.readouterr().err)
    assert states and set(states) == {("group", 0)}  # shown, not filled
    geoalpha.hull(small, by="g")  # and no bar left behind for the next run
    assert capsys.readouterr().err == ""


@requires_tqdm
def test_warnings_are_written_above_the_bar_not_into_it(small, capsys):
    shown = []

    def show(message, category, *args, **kwargs):
        shown.append(str(message))
        print(f"{category.__name__}: {message}", file=sys.stderr)

    small = small.copy()
    small.loc[small.index[-14:], "g"] = "c"  # a group of one point
    with warnings.catch_warnings():
        warnings.simplefilter("always")
        warnings.showwarning = show
        geoalpha.hull(small, by="g", progress=True)
        assert warnings.showwarning is show  # given back
    err = capsys.readouterr().err
    assert shown and all(
        line.startswith("DegenerateGroupWarning")
        for line in re.split(r"[\r\n]", err)
        if "Warning" in line
    )
    assert_bar_covers(err, HULL_PHASES)


@pytest.mark.parametrize("progress", [False, None])
def test_no_progress_bar(small, capsys, progress):
    geoalpha.hull(small, by="g", progress=progress)
    captured = capsys.readouterr()
    assert captured.err == ""
    assert captured.out == ""


@pytest.mark.parametrize("by", [None, "g"])
def test_empty_frame_gives_an_empty_table(by):
    empty = gpd.GeoDataFrame({"g": []}, geometry=gpd.GeoSeries([], crs=4326))
    hulls = geoalpha.hull(empty, by=by)
    assert len(hulls) == 0
    assert hulls.crs == empty.crs
    assert {"alpha", "n_points", "geometry"} <= set(hulls.columns)
