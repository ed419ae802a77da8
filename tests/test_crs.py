"""Tests of geoalpha._frame.crs: parsing, lon/lat checks, antimeridian, metric CRSs."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pyproj
import pytest
import shapely
from example_counts import examples
from hypothesis import given
from hypothesis import strategies as st
from shapely.geometry import MultiPolygon, Polygon, box

from geoalpha import datasets
from geoalpha._arrays.lonlat import crosses_antimeridian, unwrap_lon
from geoalpha._crs_parsing import crs_name, parse_crs
from geoalpha._frame.crs import check_lonlat, metric_crs, split_antimeridian
from geoalpha.errors import InvalidInputError

GEOD = pyproj.Geod(ellps="WGS84")


def distance_errors(lon, lat, xy, rows, n_pairs=2000, seed=0):
    """Relative error of projected vs geodesic distances on random pairs."""
    rng = np.random.default_rng(seed)
    i = rng.choice(rows, n_pairs)
    j = rng.choice(rows, n_pairs)
    keep = (lon[i] != lon[j]) | (lat[i] != lat[j])
    i, j = i[keep], j[keep]
    _, _, geodesic = GEOD.inv(lon[i], lat[i], lon[j], lat[j])
    projected = np.hypot(*(xy[i] - xy[j]).T)
    return np.abs(projected / geodesic - 1.0)


# --- parse_crs / crs_name ----------------------------------------------------


class HasWkt:
    def to_wkt(self):
        return pyproj.CRS.from_epsg(27700).to_wkt()


@pytest.mark.parametrize(
    "value",
    [
        32630,
        "EPSG:32630",
        "epsg:32630",
        pyproj.CRS.from_epsg(32630).to_wkt(),
        "+proj=utm +zone=30 +datum=WGS84 +units=m +no_defs",
    ],
)
def test_parse_crs_accepts_user_inputs(value):
    crs = parse_crs(value)
    assert isinstance(crs, pyproj.CRS)
    assert crs.equals(pyproj.CRS.from_epsg(32630))


def test_parse_crs_none_crs_and_to_wkt_objects():
    assert parse_crs(None) is None
    crs = pyproj.CRS.from_epsg(3857)
    assert parse_crs(crs) is crs
    assert parse_crs(HasWkt()).equals(pyproj.CRS.from_epsg(27700))


@pytest.mark.parametrize("value", ["EPSG:99999999", "not a crs", 3.5, [1, 2]])
def test_parse_crs_error_says_expected_and_got(value):
    with pytest.raises(InvalidInputError, match="expected a CRS") as info:
        parse_crs(value)
    message = str(info.value)
    assert repr(value) in message
    assert type(value).__name__ in message
    assert info.value.__cause__ is not None


def test_crs_name():
    assert crs_name(32630) == "EPSG:32630"
    assert crs_name(pyproj.CRS.from_epsg(27700)) == "EPSG:27700"
    laea = "+proj=laea +lat_0=62 +lon_0=-153 +datum=WGS84 +units=m +no_defs"
    assert crs_name(laea) == laea


# --- check_lonlat ------------------------------------------------------------


def test_check_lonlat_accepts_valid_degrees():
    check_lonlat([-180.0, 0.0, 180.0], [-90.0, 0.0, 90.0])


def test_check_lonlat_names_latitude_rows_and_hints_swap():
    lat = np.full(15, 50.0)
    lat[[4, 9, 12]] = [100.0, 120.0, -95.0]
    lon = np.zeros(15)
    with pytest.raises(InvalidInputError) as info:
        check_lonlat(lon, lat)
    message = str(info.value)
    assert "latitude outside [-90, 90] in 3 rows (positions 4, 9, 12)" in message
    assert "latitude and longitude look swapped (x holds latitudes?)" in message


def test_check_lonlat_swapped_real_dataset_gets_hint():
    frame = datasets.load("us_airports")
    with pytest.raises(InvalidInputError) as info:
        check_lonlat(frame["latitude"], frame["longitude"])  # x holds latitudes
    message = str(info.value)
    assert "latitude outside [-90, 90] in " in message
    assert "look swapped (x holds latitudes?)" in message


def test_check_lonlat_no_swap_hint_when_swap_would_not_help():
    with pytest.raises(InvalidInputError) as info:
        check_lonlat([100.0, 10.0], [95.0, 10.0])
    message = str(info.value)
    assert "latitude outside [-90, 90] in 1 row (position 0)" in message
    assert "swapped" not in message


def test_check_lonlat_longitude_and_many_rows():
    lon = np.full(10, 500.0)
    lon[0] = 1.0
    with pytest.raises(InvalidInputError) as info:
        check_lonlat(lon, np.zeros(10))
    assert "longitude outside [-180, 180] in 9 rows (positions 1, 2, 3, 4, 5, ...)" in (
        str(info.value)
    )


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_check_lonlat_non_finite(bad):
    lat = np.array([1.0, bad, 2.0, bad])
    with pytest.raises(InvalidInputError, match=r"2 rows \(positions 1, 3\)"):
        check_lonlat(np.zeros(4), lat)


def test_check_lonlat_length_mismatch():
    with pytest.raises(InvalidInputError, match="same length"):
        check_lonlat([1.0, 2.0], [1.0])


# --- antimeridian ------------------------------------------------------------


def fiji_and_others():
    rng = np.random.default_rng(3)
    fiji_east = rng.uniform(177.0, 179.9, 30)
    fiji_west = rng.uniform(-179.9, -178.0, 20)
    groups = {
        0: np.concatenate([fiji_east, fiji_west]),  # Fiji: crosses
        1: rng.uniform(10.0, 12.0, 20),  # Italy
        2: rng.uniform(-179.9, -170.0, 20),  # west of the line only
        3: rng.uniform(170.0, 179.9, 20),  # east of the line only
        4: np.array([179.5]),  # one point
        5: np.array([-170.0, 170.0]),  # 20 degrees apart across the line
        6: np.array([-80.0, 80.0]),  # 160 degrees apart across 0
        7: np.array([-100.0, 100.0]),  # 160 degrees apart across 180
    }
    lon = np.concatenate(list(groups.values()))
    codes = np.repeat(list(groups), [len(v) for v in groups.values()])
    return lon, codes, len(groups)


def test_crosses_antimeridian_fiji_and_not_others():
    lon, codes, n_groups = fiji_and_others()
    crossing = crosses_antimeridian(lon, codes, n_groups)
    assert crossing.dtype == bool
    assert crossing.tolist() == [True, False, False, False, False, True, False, True]


def test_crosses_antimeridian_is_order_independent():
    lon, codes, n_groups = fiji_and_others()
    perm = np.random.default_rng(0).permutation(lon.size)
    assert np.array_equal(
        crosses_antimeridian(lon[perm], codes[perm], n_groups),
        crosses_antimeridian(lon, codes, n_groups),
    )


def brute_crossing(lon):
    """Reference: try every point as the west end of the covering arc.

    The group crosses when, laid out along its smallest covering arc, some
    point sits 360 degrees east of its longitude (-180 counts as 180 then).
    """
    widths = [np.max((lon - start) % 360.0) for start in lon]
    start = lon[int(np.argmin(widths))]
    return bool(np.any(start + (lon - start) % 360.0 - lon > 1.0))


@examples(60, deadline=None)
@given(
    st.lists(
        st.lists(
            st.floats(-180, 180, allow_nan=False, allow_subnormal=False),
            min_size=1,
            max_size=8,
            unique=True,
        ),
        min_size=1,
        max_size=5,
    )
)
def test_crosses_antimeridian_matches_brute_force(groups):
    lon = np.concatenate([np.array(g) for g in groups])
    codes = np.repeat(np.arange(len(groups)), [len(g) for g in groups])
    expected = [brute_crossing(np.array(g)) for g in groups]
    got = crosses_antimeridian(lon, codes, len(groups))
    # ties between two equally small arcs are decided either way: skip them
    for k, g in enumerate(groups):
        widths = sorted(np.max((np.array(g) - s) % 360.0) for s in g)
        if len(widths) < 2 or widths[1] - widths[0] > 1e-9:
            assert got[k] == expected[k], g


def test_unwrap_lon_makes_crossing_groups_continuous():
    lon, codes, n_groups = fiji_and_others()
    crossing = crosses_antimeridian(lon, codes, n_groups)
    unwrapped = unwrap_lon(lon, codes, crossing)
    fiji = unwrapped[codes == 0]
    assert fiji.min() >= 177.0 and fiji.max() <= 182.0
    others = ~crossing[codes]
    assert np.array_equal(unwrapped[others], lon[others])


def test_split_antimeridian_polygon_178_to_182():
    poly = Polygon([(178, -18), (182, -17), (181, -15), (179, -16), (178, -18)])
    result = split_antimeridian(poly)
    assert isinstance(result, MultiPolygon)
    assert result.is_valid
    parts = list(result.geoms)
    assert len(parts) == 2
    west, east = sorted(parts, key=lambda p: -p.bounds[0])
    assert west.bounds[0] == 178.0 and west.bounds[2] == 180.0
    assert east.bounds[0] == -180.0 and east.bounds[2] == -178.0
    assert result.area == pytest.approx(poly.area, rel=1e-12)


def test_split_antimeridian_keeps_holes_and_multipolygons():
    shell = box(176, -20, 184, -10)
    poly = shell.difference(box(179, -16, 181, -14))
    other = box(185, 0, 186, 1)  # entirely east of the line
    result = split_antimeridian(MultiPolygon([poly, other]))
    assert result.is_valid
    assert result.area == pytest.approx(poly.area + other.area)
    assert -180.0 <= result.bounds[0] and result.bounds[2] <= 180.0
    assert result.contains(shapely.Point(-174.5, 0.5))


def test_split_antimeridian_leaves_others_unchanged():
    poly = box(10, 0, 11, 1)
    assert split_antimeridian(poly) is poly
    edge = box(170, 0, 180, 1)
    assert split_antimeridian(edge) is edge


def test_split_antimeridian_vectorised():
    geoms = np.array(
        [box(178, 0, 182, 1), None, shapely.Polygon(), box(0, 0, 1, 1)], dtype=object
    )
    result = split_antimeridian(geoms)
    assert isinstance(result, np.ndarray) and result.shape == (4,)
    assert result[0].geom_type == "MultiPolygon" and len(result[0].geoms) == 2
    assert result[1] is None
    assert result[2].is_empty
    assert result[3] is geoms[3]
    assert split_antimeridian(list(geoms))[0].equals(result[0])


# --- metric_crs --------------------------------------------------------------


def test_uk_clusters_get_one_utm_zone_30n():
    frame = datasets.load("uk_clusters")
    codes, groups = pd.factorize(frame["Cluster"])
    lon, lat = frame["Longitude"].to_numpy(), frame["Latitude"].to_numpy()
    xy, crs_list, crs_index = metric_crs(lon, lat, codes, len(groups))
    assert [crs_name(c) for c in crs_list] == ["EPSG:32630"]
    assert crs_index.shape == (len(groups),) and not crs_index.any()
    assert xy.shape == (len(frame), 2) and xy.dtype == np.float64
    expected = pyproj.Transformer.from_crs(4326, 32630, always_xy=True).transform(
        lon, lat
    )
    np.testing.assert_allclose(xy, np.column_stack(expected))


@pytest.fixture(scope="module")
def us_airports():
    frame = datasets.load("us_airports")
    frame = frame[frame["state"].notna()]
    assert len(frame) == 3376 - 12
    codes, states = pd.factorize(frame["state"])
    lon, lat = frame["longitude"].to_numpy(), frame["latitude"].to_numpy()
    xy, crs_list, crs_index = metric_crs(lon, lat, codes, len(states))
    return lon, lat, codes, list(states), xy, crs_list, crs_index


def test_us_airports_get_local_crs_per_state(us_airports):
    _, _, _, states, xy, crs_list, crs_index = us_airports
    names = {s: crs_name(crs_list[k]) for s, k in zip(states, crs_index, strict=True)}
    assert len(crs_list) > 10
    assert len({names["CA"], names["TX"], names["NY"], names["AK"]}) == 4
    assert names["AK"].startswith("+proj=laea")  # far too wide for one UTM zone
    assert names["CO"] == "EPSG:32613"
    assert np.isfinite(xy).all()


def test_us_airports_alaska_distances_match_geodesics(us_airports):
    lon, lat, codes, states, xy, _, _ = us_airports
    alaska = np.flatnonzero(codes == states.index("AK"))
    errors = distance_errors(lon, lat, xy, alaska)
    assert errors.max() < 0.01
    assert np.median(errors) < 0.002


def test_us_airports_every_state_is_metric(us_airports):
    lon, lat, codes, states, xy, _, _ = us_airports
    worst = {
        s: distance_errors(lon, lat, xy, np.flatnonzero(codes == k), 300).max()
        for k, s in enumerate(states)
        if (codes == k).sum() > 2
    }
    assert max(worst.values()) < 0.01, worst


def test_fiji_group_is_projected_in_one_piece():
    lon, codes, n_groups = fiji_and_others()
    lat = np.random.default_rng(5).uniform(-19.0, -16.0, lon.size)
    xy, _, _ = metric_crs(lon, lat, codes, n_groups)
    fiji = np.flatnonzero(codes == 0)
    width = np.ptp(xy[fiji, 0])
    assert width < 600_000  # ~5 degrees, not ~360 degrees
    assert distance_errors(lon, lat, xy, fiji).max() < 0.005


def test_polar_group_gets_a_polar_laea():
    rng = np.random.default_rng(7)
    lon = rng.uniform(-180, 180, 200)
    lat = rng.uniform(80, 89.9, 200)
    xy, crs_list, _ = metric_crs(lon, lat, np.zeros(200, dtype=int), 1)
    assert crs_name(crs_list[0]).startswith("+proj=laea +lat_0=90 ")
    assert distance_errors(lon, lat, xy, np.arange(200)).max() < 0.005


def test_forced_crs_is_used_for_every_group():
    frame = datasets.load("uk_clusters")
    codes, groups = pd.factorize(frame["Cluster"])
    xy, crs_list, crs_index = metric_crs(
        frame["Longitude"], frame["Latitude"], codes, len(groups), crs=27700
    )
    assert [crs_name(c) for c in crs_list] == ["EPSG:27700"]
    assert not crs_index.any()
    assert 0 < xy[:, 0].min() and xy[:, 0].max() < 700_000


def test_forced_geographic_crs_is_refused():
    with pytest.raises(
        InvalidInputError,
        match=r"crs= must be a projected \(metric\) CRS, got EPSG:4326 \(geographic\)",
    ):
        metric_crs([0.0], [0.0], [0], 1, crs="EPSG:4326")


def test_forced_crs_in_feet_comes_back_in_metres():
    lon, lat = [-74.0, -73.9], [40.7, 40.8]
    xy, crs_list, _ = metric_crs(lon, lat, [0, 0], 1, crs=2263)
    assert [crs_name(c) for c in crs_list] == ["EPSG:2263"]
    feet = pyproj.Transformer.from_crs(4326, 2263, always_xy=True).transform(lon, lat)
    np.testing.assert_allclose(xy, np.column_stack(feet) * 1200 / 3937, rtol=1e-12)


def test_points_the_forced_crs_cannot_project_are_named():
    ortho = "+proj=ortho +lat_0=0 +lon_0=0 +datum=WGS84 +units=m"
    with pytest.raises(InvalidInputError, match=r"could not project 2 rows"):
        metric_crs([10.0, 150.0, 170.0], [0.0, 0.0, 1.0], [0, 0, 0], 1, crs=ortho)


def test_metric_crs_rejects_bad_codes_and_coordinates():
    with pytest.raises(InvalidInputError, match=r"1 row \(position 1\)"):
        metric_crs([0.0, 1.0], [0.0, 1.0], [0, -1], 1)
    with pytest.raises(InvalidInputError, match="latitude outside"):
        metric_crs([0.0, 1.0], [0.0, 91.0], [0, 0], 1)


def test_metric_crs_source_crs():
    _, crs_list, _ = metric_crs(
        [-3.0, -2.0, -2.5], [51.0, 52.0, 53.0], [0, 0, 0], 1, source_crs=4258
    )
    assert crs_name(crs_list[0]) == "EPSG:32630"
    with pytest.raises(InvalidInputError, match="source_crs= must be a geographic"):
        metric_crs([0.0], [0.0], [0], 1, source_crs=32630)
