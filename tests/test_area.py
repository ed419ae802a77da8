"""``area_m2`` is geodesic, on the WGS84 ellipsoid, for every ``crs=`` (issue #26).

The reference is pyproj's ``Geod(ellps="WGS84").geometry_area_perimeter`` of
the returned polygon, moved to EPSG:4326 by geopandas in the test
(:func:`reference.ellipsoid_areas`), and closed forms of the ellipsoid's zones.
"""

from __future__ import annotations

import warnings

import geopandas as gpd
import numpy as np
import pytest
import shapely
from reference import AREA_ATOL, AREA_RTOL, ellipsoid_areas

import geoalpha
from geoalpha import _kernel, datasets
from geoalpha._arrays.area import geodesic_areas
from geoalpha.errors import AntimeridianWarning

A, F = 6_378_137.0, 1 / 298.257223563  # WGS84


def zone(lat_deg: float) -> float:
    """Area (m²) of the ellipsoid between the equator and ``lat_deg``, all round."""
    e2 = F * (2 - F)
    e = np.sqrt(e2)
    s = np.sin(np.radians(lat_deg))
    b2 = A * A * (1 - e2)
    return 2 * np.pi * b2 * (s / (2 * (1 - e2 * s * s)) + np.arctanh(e * s) / (2 * e))


def assert_geodesic(hulls):
    np.testing.assert_allclose(
        hulls["area_m2"], ellipsoid_areas(hulls), rtol=AREA_RTOL, atol=AREA_ATOL
    )


def frame(lonlat, crs=4326):
    xy = np.asarray(lonlat)
    return gpd.GeoDataFrame(
        {"g": ["a"] * len(xy)}, geometry=gpd.points_from_xy(*xy.T), crs=crs
    )


@pytest.fixture(scope="module")
def clusters():
    return datasets.load("uk_clusters")


@pytest.mark.parametrize(
    "to, crs",
    [
        (None, "auto"),
        (None, "sphere"),
        (27700, "auto"),  # British National Grid, used as it is
        (27700, "sphere"),
        (None, "EPSG:3857"),  # stretches areas 2.6 times: not area_m2
        (4277, "auto"),  # OSGB36 longitude/latitude: another datum
    ],
)
def test_area_m2_is_the_geodesic_area_of_the_returned_polygon(clusters, to, crs):
    points = clusters if to is None else clusters.to_crs(to)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # Web Mercator's stretch
        hulls = geoalpha.hull(points, by="Cluster", crs=crs)
    assert len(hulls) == 691
    assert (hulls["area_m2"] > 0).all()
    assert_geodesic(hulls)


def test_the_crs_changes_the_shape_not_how_it_is_measured(clusters):
    # convex hulls are nearly the same polygons whatever the (planar) CRS
    # (up to a vertex nearly on an edge, kept in one CRS and not in the
    # other: 2e-5 of a few hundred m² here): so are their areas, while their
    # planar areas in the two CRS differ by the scale of British National
    # Grid against UTM zone 30 (about 1e-3 here)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the degenerate group
        auto = geoalpha.hull(clusters, by="Cluster", method="convex")
        bng = geoalpha.hull(clusters.to_crs(27700), by="Cluster", method="convex")
    np.testing.assert_allclose(bng["area_m2"], auto["area_m2"], rtol=1e-4)
    planar = bng.area.to_numpy() / auto.to_crs(32630).area.to_numpy()
    assert np.median(np.abs(planar - 1)) > 1e-4


def test_an_antimeridian_group_gets_the_area_of_both_parts():
    # a cap 400 km across at Fiji, and the same points 10 degrees west: on
    # the sphere the same shape, split at 180 degrees or not
    rng = np.random.default_rng(4)
    lon = rng.uniform(178.0, 181.0, 120)
    lat = rng.uniform(-18.5, -15.5, 120)
    across = np.column_stack([np.where(lon > 180, lon - 360, lon), lat])
    west = np.column_stack([lon - 10.0, lat])
    for crs in ("auto", "sphere"):
        with pytest.warns(AntimeridianWarning):
            split = geoalpha.hull(frame(across), by="g", crs=crs)
        assert split.geometry.iloc[0].geom_type == "MultiPolygon"
        assert_geodesic(split)
    whole = geoalpha.hull(frame(west), by="g", crs="sphere")
    assert whole.geometry.iloc[0].geom_type == "Polygon"
    # the cut adds vertices on the straight line in lon/lat at 180, where
    # the geodesic edge passes some metres away: 1e-6 of the area
    assert split["area_m2"].iloc[0] == pytest.approx(whole["area_m2"].iloc[0], rel=1e-5)


@pytest.mark.parametrize("south, north", [(78.0, 89.5), (-89.5, -78.0)])
def test_a_polar_group_gets_the_area_of_its_cap_not_of_the_rest(south, north):
    rng = np.random.default_rng(3)
    pts = np.column_stack([rng.uniform(-180, 180, 400), rng.uniform(south, north, 400)])
    hulls = geoalpha.hull(frame(pts), by="g", crs="sphere")
    assert hulls.geometry.iloc[0].geom_type == "Polygon"
    assert_geodesic(hulls)
    # between the caps beyond 81 and beyond 78 degrees (the boundary runs
    # between the lowest latitudes, notched), about a 100th of the ellipsoid
    # (the rest would be 99 100ths)
    area = hulls["area_m2"].iloc[0]
    assert zone(90) - zone(81.0) < area < zone(90) - zone(78.0)


def test_grown_and_buffered_hulls_are_measured_on_the_ellipsoid(clusters):
    few = clusters[clusters["Cluster"].isin([0, 1, 2])]
    lonely = few.iloc[:1].assign(Cluster=-1)
    pts = gpd.GeoDataFrame(gpd.pd.concat([few, lonely]), crs=few.crs)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the degenerate group
        grown = geoalpha.hull(pts, by="Cluster", grow=5.0, buffer=20.0)
        sphere = geoalpha.hull(pts, by="Cluster", crs="sphere", buffer=20.0)
    for hulls in (grown, sphere):
        assert_geodesic(hulls)
    # a 20 m buffer (a 32-gon) around one point
    assert grown.set_index("Cluster")["area_m2"][-1] == pytest.approx(
        np.pi * 400, rel=0.01
    )


def test_planar_computation_keeps_the_planar_area(clusters):
    # crs=None: no ellipsoid (input without a CRS), or computed in the input
    # coordinates as they are: the area is the polygon's, in their units
    # (`area_m2` in metres; without a CRS `area` next to its `unit`)
    bng = clusters.to_crs(27700)
    for points, column in (
        (bng, "area_m2"),
        (bng.set_crs(None, allow_override=True), "area"),
    ):
        hulls = geoalpha.hull(points, by="Cluster", crs=None)
        np.testing.assert_allclose(hulls[column], hulls.area, rtol=1e-12)


def test_the_array_function_takes_holes_parts_and_collections_out_and_in():
    cell = shapely.box(0, 0, 1, 1)
    ring = shapely.box(0, 0, 3, 3).difference(shapely.box(1, 1, 2, 2))
    mixed = shapely.GeometryCollection([cell, shapely.Point(5, 5)])
    got = geodesic_areas([cell, ring, shapely.MultiPolygon([cell, cell]), mixed])
    # pyproj's value for the one-degree cell at the equator
    assert got[0] == pytest.approx(12308778361.469452, rel=1e-12)
    big, hole = geodesic_areas([shapely.box(0, 0, 3, 3), shapely.box(1, 1, 2, 2)])
    assert got[1] == pytest.approx(big - hole, rel=1e-12)
    assert got[2] == pytest.approx(2 * got[0], rel=1e-12)
    assert got[3] == pytest.approx(got[0], rel=1e-12)
    assert geodesic_areas([None, shapely.Polygon(), shapely.Point(0, 0)]).tolist() == [
        0.0,
        0.0,
        0.0,
    ]


def test_bad_kernel_input_is_a_value_error_not_a_crash():
    lon, lat = np.array([0.0, 1.0, 1.0]), np.array([0.0, 0.0, 91.0])
    one = np.array([0, 1], dtype=np.int64)
    with pytest.raises(ValueError, match="vertex 2 is no longitude/latitude"):
        _kernel.geodesic_areas(lon, lat, np.array([0, 3]), one, one)
    with pytest.raises(ValueError, match="ring_offsets: must end at 3"):
        _kernel.geodesic_areas(lon, lat, np.array([0, 2]), one, one)
    with pytest.raises(ValueError, match="the same length"):
        _kernel.geodesic_areas(lon, lat[:2], np.array([0, 3]), one, one)


def test_a_group_wider_than_180_degrees_is_measured_on_its_hull_vertices():
    # a convex hull across the Pacific (200 degrees of longitude, 0-30 N): no
    # faithful lon/lat polygon, so area_m2 is that of the hull's vertices
    # joined by geodesics: the band it spans and the bulge of its long
    # northern edges (their planar area in the polar LAEA CRS it is computed
    # in is twice that)
    rng = np.random.default_rng(1)
    lon = rng.uniform(100, 300, 300)
    lat = rng.uniform(0, 30, 300)
    gdf = frame(np.column_stack([np.where(lon > 180, lon - 360, lon), lat]))
    with pytest.warns(geoalpha.GeoAlphaWarning, match="is that of their hull's"):
        hulls = geoalpha.hull(gdf, by="g", method="convex")
    band = (zone(30.0) - zone(0.0)) * 200 / 360
    assert band < hulls["area_m2"].iloc[0] < 1.2 * band
