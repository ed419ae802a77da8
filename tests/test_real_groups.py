"""Every group of the real datasets against the brute-force reference (issue #2).

One batched ``alpha_shapes`` call per dataset must give, for every group with
a triangle, the alpha ``reference.graph_optimum`` finds by trying every
spectrum value, with valid polygons that cover all the group's points.
``graph_optimum`` is one union-find sweep over the spectrum, O(m log m) per
group (m triangles; the largest groups are the Lansing hickories, 703 trees,
and STATS19 E09000020, 673 accidents), so no group needs to be left out.
"""

from __future__ import annotations

import math
from functools import cache
from pathlib import Path

import numpy as np
import pandas as pd
import pyproj
import pytest
import reference
import shapely
from scipy.spatial import QhullError

from geoalpha import alpha_shapes, datasets, optimal_alpha

LANSING = Path(__file__).parent / "data" / "lansing_trees_spatstat.csv"


def utm_epsg(lon, lat) -> int:
    zone = int((np.median(lon) + 180) // 6) % 60 + 1
    return (32600 if np.median(lat) >= 0 else 32700) + zone


@cache
def real_dataset(name: str):
    """(metric points, group codes, group names) of a real dataset."""
    if name == "stats19":
        gdf = datasets.load("stats19")
        xy = gdf[["Location_Easting_OSGR", "Location_Northing_OSGR"]].to_numpy(float)
        codes, names = pd.factorize(gdf["Local_Authority_(Highway)"])
    elif name == "uk_clusters":
        gdf = datasets.load("uk_clusters")
        to_bng = pyproj.Transformer.from_crs(4326, 27700, always_xy=True)
        xy = np.column_stack(to_bng.transform(gdf["Longitude"], gdf["Latitude"]))
        codes, names = pd.factorize(gdf["Cluster"])
    elif name == "us_airports":
        gdf = datasets.load("us_airports")
        gdf = gdf[gdf["state"].notna()]
        codes, names = pd.factorize(gdf["state"])
        lon, lat = gdf["longitude"].to_numpy(), gdf["latitude"].to_numpy()
        xy = np.empty((len(gdf), 2))
        for g in range(len(names)):  # each state in its own UTM zone
            rows = codes == g
            utm = pyproj.Transformer.from_crs(
                4326, utm_epsg(lon[rows], lat[rows]), always_xy=True
            )
            xy[rows] = np.column_stack(utm.transform(lon[rows], lat[rows]))
    elif name == "lansing":
        frame = pd.read_csv(LANSING)
        xy = frame[["x", "y"]].to_numpy(float)
        codes, names = pd.factorize(frame["species"])
    assert np.isfinite(xy).all()
    return xy, codes, list(names)


#: name -> (groups, groups with a triangle per scipy/reference).
EXPECTED_GROUPS = {
    "stats19": (13, 6),  # 5 authorities with 1 accident, 2 with 2
    "uk_clusters": (691, 690),  # cluster 530: 17 accidents at 2 places
    "us_airports": (56, 54),  # DC and GU have 1 airport each
    "lansing": (6, 6),
}


@pytest.mark.parametrize("holes", [False, True], ids=["filled", "holes"])
@pytest.mark.parametrize("name", list(EXPECTED_GROUPS))
def test_every_group_matches_graph_reference(name, holes):
    xy, codes, names = real_dataset(name)
    n_groups, n_with_triangles = EXPECTED_GROUPS[name]
    assert len(names) == n_groups
    res = alpha_shapes(xy, codes, holes=holes)
    assert len(res.alpha) == len(names)

    mismatches, checked = [], 0
    for g, group in enumerate(names):
        p = xy[codes == g]
        assert res.n_points[g] == len(p)
        try:
            expected = reference.graph_optimum(p, holes=holes)
        except (QhullError, ValueError):  # no triangle: < 3 points or collinear
            assert res.degenerate[g], group
            assert math.isnan(res.alpha[g]) and res.geometry[g].is_empty
            continue
        assert not res.degenerate[g], group
        checked += 1
        if res.alpha[g] != pytest.approx(expected, rel=1e-9, abs=0):
            mismatches.append((group, res.alpha[g], expected))
    assert not mismatches, (
        f"{len(mismatches)} of {checked} groups differ: {mismatches[:5]}"
    )
    assert checked == n_with_triangles

    ok = ~res.degenerate
    geoms = res.geometry[ok]
    assert shapely.is_valid(geoms).all()
    assert {g.geom_type for g in geoms} == {"Polygon"}
    assert (res.n_parts[ok] == 1).all()
    # Every point is covered by its group's polygon.
    rows = np.flatnonzero(ok[codes])
    covered = shapely.covers(res.geometry[codes[rows]], shapely.points(xy[rows]))
    assert covered.all(), f"{(~covered).sum()} points outside their group's polygon"
    # Every polygon vertex is a point of its group.
    coords, index = shapely.get_coordinates(geoms, return_index=True)
    group_of_vertex = np.flatnonzero(ok)[index]
    inputs = set(zip(codes.tolist(), map(tuple, xy.tolist()), strict=True))
    stray = [
        (g, c)
        for g, c in zip(
            group_of_vertex.tolist(), map(tuple, coords.tolist()), strict=True
        )
        if (g, c) not in inputs
    ]
    assert not stray, stray[:5]


# --------------------------------------------------------------------------
# DESIGN.md: STATS19 local authority E09000020 in lon/lat degrees
# --------------------------------------------------------------------------


@cache
def e09000020_degrees() -> np.ndarray:
    gdf = datasets.load("stats19")
    rows = gdf["Local_Authority_(Highway)"] == "E09000020"
    return gdf.loc[rows, ["Longitude", "Latitude"]].to_numpy(float)


def test_e09000020_has_586_distinct_points():
    p = e09000020_degrees()
    assert len(np.unique(p, axis=0)) == 586
    res = alpha_shapes(p)
    assert res.n_points[0] == len(p) and res.n_distinct[0] == 586


@pytest.mark.parametrize(
    ("holes", "expected"), [(False, 361.415), (True, 349.063)], ids=["filled", "holes"]
)
def test_e09000020_exact_optimum_in_degrees(holes, expected):
    p = e09000020_degrees()
    alpha = optimal_alpha(p, holes=holes)
    assert round(alpha, 3) == expected
    assert alpha == pytest.approx(reference.graph_optimum(p, holes=holes), rel=1e-9)


def test_e09000020_ladder_returns_361():
    assert optimal_alpha(e09000020_degrees(), search="ladder") == 361
