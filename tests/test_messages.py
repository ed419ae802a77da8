"""Messages that say plainly what happened (issue #24, item 4)."""

from __future__ import annotations

import re
import sys
import warnings

import geopandas as gpd
import numpy as np
import pandas as pd
import pytest
import shapely
from cli_runner import run
from compat import requires_dask

import geoalpha
from geoalpha._frame.schema import RESULT_COLUMNS
from geoalpha._io.files import read_points
from geoalpha.errors import (
    AntimeridianWarning,
    DegenerateGroupWarning,
    InvalidInputError,
)

#: One city on every continent and ocean: one group spanning the globe.
CITIES = {
    "London": (-0.13, 51.51), "Moscow": (37.62, 55.76), "Cairo": (31.24, 30.04),
    "Lagos": (3.38, 6.52), "Nairobi": (36.82, -1.29), "Cape Town": (18.42, -33.92),
    "Dakar": (-17.45, 14.69), "New York": (-74.01, 40.71),
    "Los Angeles": (-118.24, 34.05), "Mexico City": (-99.13, 19.43),
    "Anchorage": (-149.9, 61.22), "Havana": (-82.37, 23.11), "Lima": (-77.04, -12.05),
    "Sao Paulo": (-46.63, -23.55), "Buenos Aires": (-58.38, -34.6),
    "Santiago": (-70.67, -33.45), "Tokyo": (139.69, 35.69), "Beijing": (116.41, 39.9),
    "Mumbai": (72.88, 19.08), "Bangkok": (100.5, 13.76), "Jakarta": (106.85, -6.21),
    "Dubai": (55.27, 25.2), "Sydney": (151.21, -33.87), "Perth": (115.86, -31.95),
    "Auckland": (174.76, -36.85), "Honolulu": (-157.86, 21.31),
    "Reykjavik": (-21.94, 64.15), "Ushuaia": (-68.3, -54.8),
}  # fmt: skip


@pytest.fixture
def cities_csv(tmp_path):
    path = tmp_path / "cities.csv"
    table = pd.DataFrame(
        [(name, lon, lat) for name, (lon, lat) in CITIES.items()],
        columns=["name", "lon", "lat"],
    )
    table.to_csv(path, index=False)
    return path


def test_swapped_column_names_get_the_swap_hint_not_the_crs_error(tmp_path):
    # --x latitude --y longitude used to say "have no CRS": the names say
    # what is wrong.
    path = tmp_path / "airports.csv"
    path.write_text("code,longitude,latitude\nJFK,-73.8,40.6\nLAX,-118.4,33.9\n")
    result = run(
        "hull", path, tmp_path / "h.gpkg", "--x", "latitude", "--y", "longitude"
    )
    assert result.exit_code == 1
    assert result.stderr == (
        f"Error: --x 'latitude' and --y 'longitude' of {path}: longitude and "
        "latitude look swapped: latitude holds latitudes? Give the longitude "
        "column as --x and the latitude column as --y\n"
    )
    with pytest.raises(InvalidInputError, match=r"^x='latitude' and y='longitude'"):
        read_points(path, x="latitude", y="longitude")
    # named the right way round, they are longitude/latitude (EPSG:4326)
    assert read_points(path, x="longitude", y="latitude").crs.to_epsg() == 4326


def test_one_group_around_the_globe_says_plainly_what_happened(cities_csv, tmp_path):
    # The warnings used to contradict each other: "no valid polygon ... their
    # shapes fold there", then "'alpha' is right" for a group
    # whose alpha is NaN.
    out = tmp_path / "h.gpkg"
    result = run("hull", cities_csv, out)
    assert result.exit_code == 0, result.stderr
    shown = [line for line in result.stderr.splitlines() if "Warning" in line]
    assert len(shown) == 2, shown
    assert shown[0].startswith(
        "Warning: 1 group(s) span more than 180 degrees of longitude, so their "
        "hull has no valid longitude/latitude polygon holding all their points "
        "and they have no alpha: 'all points' (28 rows) (split the group, "
        "e.g. by continent, or give the points in a projected CRS that holds them)"
    )
    assert "is right" not in result.stderr
    assert shown[0].endswith("(--degenerate buffer)")
    # its widest gap is not at +-180: the polygon is split there
    assert shown[1] == (
        "Warning: 1 group(s) cross the antimeridian (+-180 degrees): all points; "
        "their hulls are MultiPolygons split at +-180 degrees (RFC 7946)"
    )
    hulls = gpd.read_file(out)
    assert hulls["alpha"].isna().all()
    assert hulls["method"].tolist() == ["buffer"]  # a buffer, not an alpha shape
    points = read_points(cities_csv)
    assert shapely.covers(hulls.geometry[0], points.geometry.array).all()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        geoalpha.hull(points)
    assert [w.category for w in caught] == [
        DegenerateGroupWarning,
        AntimeridianWarning,
    ]


def test_a_wide_group_is_told_its_alpha_is_right_only_when_it_has_one():
    # Across the Pacific: the convex hull has its alpha (0) and area in
    # crs_used, only its lon/lat polygon is unfaithful; the alpha shape has no
    # valid lon/lat polygon at all, so no alpha.
    lonlat = [(-109.48, 37.58), (-64.8, 17.7), (-64.7, 17.75), (101.38, 14.08)]
    lonlat += [(134.54, 7.37), (138.1, 9.52), (145.62, 15.0), (-80, 30), (-90, 35)]
    xy = np.array(lonlat)
    frame = gpd.GeoDataFrame(geometry=gpd.points_from_xy(xy[:, 0], xy[:, 1]), crs=4326)
    shown = {}
    for method in ("convex", "alpha"):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            hulls = geoalpha.hull(frame, method=method)
        shown[method] = " ".join(str(w.message) for w in caught)
        assert "span more than 180 degrees of longitude" in shown[method]
    assert hulls["alpha"].isna().all()
    assert (
        "their 'alpha' is right (in 'crs_used'), and 'area_m2' is that of"
        in (shown["convex"])
    )
    assert "is right" not in shown["alpha"]
    assert "they have no alpha" in shown["alpha"]


def test_demo_summary_counts_agree(tmp_path):
    # It said "12 rows left out", then "Wrote 56 hulls of 3,376 points".
    out = tmp_path / "demo.gpkg"
    result = run("demo", out)
    assert result.exit_code == 0, result.stderr
    lines = result.stdout.splitlines()
    assert lines[-3] == (
        "Computed in 30 CRSs (one chosen per group): 56 groups, 2 without alpha "
        "shape; 12 of 3,376 rows left out: 12 without a --by value (--no-dropna "
        "keeps them)"
    )
    assert lines[-1] == (
        f"Wrote 56 hulls of 3,364 points to {out} (layer 'demo', 'points')"
    )
    assert gpd.read_file(out, layer="demo")["n_points"].sum() == 3364


def test_summary_names_every_reason_rows_were_left_out(tmp_path):
    path = tmp_path / "p.csv"
    rows = ["x,y,g", "0,0,a", "1,0,a", "0,1,a", "1,1,a", ",,a", "5,5,", "9,9,b"]
    path.write_text("\n".join(rows) + "\n")
    result = run(
        "hull", path, tmp_path / "h.gpkg", "--by", "g", "--crs-in", "none",
        "--degenerate", "drop",
    )  # fmt: skip
    assert result.exit_code == 0, result.stderr
    lines = result.stdout.splitlines()
    assert lines[-3].endswith(
        "1 group; 3 of 7 rows left out: 1 without a point (a missing, empty or NaN "
        "geometry), 1 without a --by value (--no-dropna keeps them), 1 in groups "
        "without alpha shape (--degenerate drop)"
    )
    assert lines[-1] == f"Wrote 1 hull of 4 points to {tmp_path / 'h.gpkg'} (layer 'h')"


def test_missing_tqdm_hint_is_a_command_to_paste(tmp_path, monkeypatch):
    # "pip install geoalpha[progress]" unquoted is a glob in zsh.
    monkeypatch.setitem(sys.modules, "tqdm.auto", None)  # import fails
    path = tmp_path / "p.csv"
    path.write_text("x,y\n0,0\n1,0\n0,1\n")
    result = run("hull", path, tmp_path / "h.gpkg", "--crs-in", "none", "--progress")
    assert result.exit_code == 1
    assert result.stderr.endswith('needs tqdm: pip install "geoalpha[progress]"\n'), (
        result.stderr
    )


def test_help_lists_every_result_column_from_the_schema():
    result = run("hull", "--help")
    text = " ".join(result.stdout.split())
    listed = re.search(r"the --by columns, (.*?), and the polygon", text)[1]
    assert [c.split(" (")[0] for c in listed.split(", ")] == list(RESULT_COLUMNS)
    assert "n_parts" in listed
    assert "alpha (1/metre), radius (metres)" in listed


@pytest.fixture
def states():
    return gpd.GeoDataFrame(
        {"state": ["a"] * 3, "code": [1, 2, 3]},
        geometry=shapely.points([[0, 0], [1, 0], [0, 1]]),
        crs="EPSG:32630",
    )


@pytest.mark.parametrize(
    ("by", "message"),
    [
        ("stat", "hull(by='stat'): no column 'stat' (did you mean 'state'?); the "
         "columns are state, code, geometry"),
        ("CODE", "hull(by='CODE'): no column 'CODE' (did you mean 'code'?); the "
         "columns are state, code, geometry"),
        (["state", "geom"], "hull(by=['state', 'geom']): no column 'geom'; the "
         "columns are state, code, geometry"),
    ],
)  # fmt: skip
def test_wrong_by_column_in_python_gets_did_you_mean(states, by, message):
    # The command had a "did you mean"; hull() had none. One helper now.
    with pytest.raises(InvalidInputError) as caught:
        geoalpha.hull(states, by=by)
    assert str(caught.value) == message


@requires_dask
def test_wrong_by_column_on_dask_gets_did_you_mean(states):
    import dask_geopandas

    ddf = dask_geopandas.from_geopandas(states, npartitions=1)
    with pytest.raises(InvalidInputError, match=r"\(did you mean 'state'\?\)"):
        geoalpha.hull(ddf, by="stat")


def test_wrong_by_column_on_the_command_line_gets_did_you_mean(tmp_path):
    path = tmp_path / "p.csv"
    path.write_text("lon,lat,state\n0,0,a\n1,0,a\n0,1,a\n")
    result = run("hull", path, tmp_path / "h.gpkg", "--by", "stat")
    assert result.exit_code == 1
    assert result.stderr == (
        f"Error: --by column 'stat' not found in {path} (did you mean 'state'?); "
        "its columns are: lon, lat, state\n"
    )
