"""``geoalpha hull --explain`` (issue #35): the layers 'why' and 'left_out'.

Run through the command on the bundled US airports, with a Hawaii-like group
(50 rows geocoded at one spot 700 km west of the islands, as in the real US
zip codes of the issue).
"""

from __future__ import annotations

import geopandas as gpd
import numpy as np
import pandas as pd
import pyogrio
import pytest
import shapely
from cli_runner import run

from geoalpha import datasets

STATES = ["HI", "CO", "RI", "DE", "VT"]
WRONG = (-168.02, 24.86)  # the spot of the issue


@pytest.fixture
def airports_csv(tmp_path):
    """Five states' airports, and 50 Hawaiian rows at one wrong spot, as a CSV."""
    pts = datasets.load("us_airports")
    table = pd.DataFrame(pts[pts["state"].isin(STATES)].drop(columns="geometry"))
    table["longitude"] = pts.geometry.x
    table["latitude"] = pts.geometry.y
    table = table.dropna(subset=["longitude"])
    wrong = pd.DataFrame(
        {
            "iata": [f"Z{i:02d}" for i in range(50)],
            "name": "geocoded at one spot",
            "state": "HI",
            "longitude": WRONG[0],
            "latitude": WRONG[1],
        }
    )
    table = pd.concat([table, wrong], ignore_index=True)
    path = tmp_path / "airports.csv"
    table.to_csv(path, index=False)
    return path


def _sorted(frame, column="state"):
    return frame.sort_values(column).reset_index(drop=True)


def test_explain_writes_why_and_names_the_flagged_group(airports_csv, tmp_path):
    out = tmp_path / "hulls.gpkg"
    result = run("hull", airports_csv, out, "--by", "state", "--explain")
    assert result.exit_code == 0, result.stderr
    # The summary names the flagged group; the warning says why.
    assert (
        "1 group flagged as suspicious (one location forces the shape far beyond "
        "the others; see the layer 'why'): 'HI'"
    ) in result.stdout
    assert "Warning: geoalpha: in 1 group(s) one location forces" in result.stderr
    assert "Wrote --explain: 5 rows to layer 'why' and 0 rows to layer" in (
        result.stdout
    )
    assert set(pyogrio.list_layers(out)[:, 0]) == {"hulls", "why", "left_out"}
    hulls = _sorted(gpd.read_file(out, layer="hulls"))
    why = _sorted(gpd.read_file(out, layer="why"))
    assert why.columns.tolist() == [
        "state",
        "radius",
        "alpha",
        "limited_by",
        "critical_rows",
        "radius_without_1",
        "area_m2_without_1",
        "rows_without_1",
        "suspicious",
        "geometry",
    ]
    assert why["state"].tolist() == sorted(STATES)
    np.testing.assert_allclose(why["radius"], hulls["radius"], rtol=1e-12)
    assert why.set_index("state")["suspicious"].to_dict() == {
        s: s == "HI" for s in STATES
    }
    hi = why.set_index("state").loc["HI"]
    # the CSV's rows (0-based, as read) of the 50 wrong ones, as text
    csv = pd.read_csv(airports_csv)
    wrong_rows = csv.index[csv["iata"].str.match(r"Z\d\d$")].tolist()
    assert hi["rows_without_1"] == ", ".join(map(str, wrong_rows))
    assert hi["radius_without_1"] < hi["radius"] / 4
    # the critical triangle: three input points whose circle has the radius
    corners = [int(c) for c in hi["critical_rows"].split(", ")[:3]]
    ring = shapely.get_coordinates(hi.geometry)[:3]
    expected = csv.loc[corners, ["longitude", "latitude"]].to_numpy()
    np.testing.assert_array_equal(ring, expected)
    assert len(gpd.read_file(out, layer="left_out")) == 0
    # --no-suspicious: no warning, no line; the column stays
    quiet = run(
        "hull", airports_csv, tmp_path / "q.gpkg", "--by", "state", "--explain",
        "--no-suspicious",
    )  # fmt: skip
    assert quiet.exit_code == 0, quiet.stderr
    assert "suspicious" not in quiet.stderr
    flags = gpd.read_file(tmp_path / "q.gpkg", layer="why")["suspicious"]
    assert flags.sum() == 1


def test_explain_left_out_holds_the_rows_with_their_columns(airports_csv, tmp_path):
    out = tmp_path / "hulls.gpkg"
    result = run(
        "hull",
        airports_csv,
        out,
        "--by",
        "state",
        "--explain",
        "--outliers",
        "1",
        "--outlier-unit",
        "locations",
    )
    assert result.exit_code == 0, result.stderr
    assert "flagged as suspicious" not in result.stderr  # the wrong spot is out
    left = gpd.read_file(out, layer="left_out")
    csv = pd.read_csv(airports_csv)
    assert {"iata", "name", "city", "state"} <= set(left.columns)
    assert set(left.loc[left["state"] == "HI", "iata"]) == {
        f"Z{i:02d}" for i in range(50)
    }
    hulls = gpd.read_file(out, layer="hulls").set_index("state")
    # one row per point the hulls leave out, no other
    assert len(left) == int(hulls["n_outliers"].sum())
    spots = shapely.get_coordinates(left.geometry[left["state"] == "HI"])
    assert (spots == WRONG).all()
    assert left.crs.to_epsg() == 4326
    why = gpd.read_file(out, layer="why").set_index("state")
    assert (why["limited_by"] == "outliers").all()
    assert len(csv) == int(hulls["n_points"].sum())  # n_points counts them too


def test_explain_beside_a_shapefile(airports_csv, tmp_path):
    out = tmp_path / "hulls.shp"
    args = ["hull", airports_csv, out, "--by", "state", "--explain"]
    result = run(*args, "--outliers", "1", "--outlier-unit", "locations")
    assert result.exit_code == 0, result.stderr
    why = gpd.read_file(tmp_path / "hulls_why.shp")
    left = gpd.read_file(tmp_path / "hulls_left_out.shp")
    assert len(why) == len(STATES)
    assert len(left) == int(gpd.read_file(out)["n_outliers"].sum())
    assert (left["state"] == "HI").sum() == 50
    assert "Shapefile field 'radius_without_1' of 'why' written as" in result.stdout
    assert f"Wrote --explain: 5 rows to {tmp_path / 'hulls_why.shp'}" in result.stdout
    # run again: every file exists, nothing is replaced without --overwrite
    before = {p.name: p.stat().st_mtime_ns for p in tmp_path.glob("hulls*")}
    again = run(*args)
    assert again.exit_code != 0
    assert "already exists; use --overwrite" in again.stderr
    assert {p.name: p.stat().st_mtime_ns for p in tmp_path.glob("hulls*")} == before
    assert run(*args, "--overwrite").exit_code == 0
    assert len(gpd.read_file(tmp_path / "hulls_left_out.shp")) == 0


def test_explain_refuses_an_existing_side_file(airports_csv, tmp_path):
    side = tmp_path / "hulls_left_out.geojson"
    side.write_text("mine")
    result = run(
        "hull", airports_csv, tmp_path / "hulls.geojson", "--by", "state", "--explain"
    )
    assert result.exit_code != 0
    assert f"output {side} already exists; use --overwrite" in result.stderr
    assert side.read_text() == "mine"
    assert not (tmp_path / "hulls.geojson").exists()
    assert not (tmp_path / "hulls_why.geojson").exists()


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (
            ["--method", "convex"],
            "--explain explains the optimal alpha shape: use it with --method alpha",
        ),
        (["--output-layer", "why"], "name the hulls' layer otherwise"),
    ],
)
def test_explain_bad_combinations(airports_csv, tmp_path, extra, message):
    out = tmp_path / "hulls.gpkg"
    result = run("hull", airports_csv, out, "--by", "state", "--explain", *extra)
    assert result.exit_code != 0
    assert message in result.stderr
    assert not out.exists()


def test_explain_refuses_postgis_output(airports_csv):
    url = "postgresql://nobody@localhost:1/none"
    result = run("hull", airports_csv, url, "--output-layer", "public.h", "--explain")
    assert result.exit_code != 0
    assert "--explain writes its layers 'why' and 'left_out' to files only" in (
        result.stderr
    )


def test_demo_explain_adds_the_layers(tmp_path):
    out = tmp_path / "demo.gpkg"
    result = run("-q", "demo", out, "--explain")
    assert result.exit_code == 0, result.stderr
    layers = set(pyogrio.list_layers(out)[:, 0])
    assert layers == {"demo", "points", "why", "left_out"}
    assert len(gpd.read_file(out, layer="why")) == 56


def test_explain_planar_input_names_the_area_without_m2(tmp_path):
    # --crs-in none: the hulls have area and unit, the layer 'why' area_without_1
    path = tmp_path / "plane.csv"
    square = [(0, 0), (4, 0), (4, 4), (0, 4), (2, 3.5), (30, 30)]
    pd.DataFrame(square, columns=["x", "y"]).to_csv(path, index=False)
    out = tmp_path / "plane.gpkg"
    result = run("hull", path, out, "--crs-in", "none", "--explain")
    assert result.exit_code == 0, result.stderr
    why = gpd.read_file(out, layer="why")
    assert "area_m2_without_1" not in why.columns
    assert why["rows_without_1"].item() == "5"  # the far point, row 5
    # without the far point: inside the square of the other five, not empty
    assert 0 < why["area_without_1"].item() <= 16
    hulls = gpd.read_file(out, layer="plane")
    assert hulls["unit"].item() == "coordinate unit"


@pytest.mark.parametrize("unit, factor", [("km", 1000.0), ("ft", 0.3048)])
def test_explain_with_unit_writes_why_in_metres_as_the_hulls(tmp_path, unit, factor):
    # --unit: planar coordinates in km (ft); the hulls and 'why' in m and m²
    path = tmp_path / "plane.csv"
    square = [(0, 0), (4, 0), (4, 4), (0, 4), (2, 3.5), (30, 30)]
    pd.DataFrame(square, columns=["x", "y"]).to_csv(path, index=False)
    out = tmp_path / "plane.gpkg"
    args = ("hull", path, out, "--crs-in", "none", "--unit", unit, "--explain")
    result = run(*args)
    assert result.exit_code == 0, result.stderr
    why = gpd.read_file(out, layer="why")
    hulls = gpd.read_file(out, layer="plane")
    assert "unit" not in why.columns and "area_without_1" not in why.columns
    assert "area_m2" in hulls.columns and "unit" not in hulls.columns
    # the same run in the coordinates' own unit, as numbers to convert
    plain = tmp_path / "plain.gpkg"
    assert run("hull", path, plain, "--crs-in", "none", "--explain").exit_code == 0
    own = gpd.read_file(plain, layer="why")
    assert why["radius"].item() == pytest.approx(own["radius"].item() * factor)
    assert why["radius"].item() == pytest.approx(hulls["radius"].item())
    assert why["alpha"].item() == pytest.approx(hulls["alpha"].item())
    assert why["radius_without_1"].item() == pytest.approx(
        own["radius_without_1"].item() * factor
    )
    assert why["area_m2_without_1"].item() == pytest.approx(
        own["area_without_1"].item() * factor**2
    )
    # the far point left out: inside the 4 x 4 square, in m²
    assert 0 < why["area_m2_without_1"].item() <= 16 * factor**2
    assert why.columns.tolist()[:8] == [
        "radius",
        "alpha",
        "limited_by",
        "critical_rows",
        "radius_without_1",
        "area_m2_without_1",
        "rows_without_1",
        "suspicious",
    ]
