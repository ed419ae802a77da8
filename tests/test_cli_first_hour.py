"""A new user's first hour with the command: CRS, messages, files, summary."""

from __future__ import annotations

import re
import sqlite3
import warnings
from pathlib import Path

import geopandas as gpd
import numpy as np
import pandas as pd
import pyproj
import pytest
import shapely
from cli_runner import run
from compat import HAS_TQDM
from progress_output import assert_bar_covers
from reference import ellipsoid_areas

import geoalpha
from geoalpha import datasets
from geoalpha._io.files import read_points
from geoalpha.errors import CRSWarning, DegenerateGroupWarning, InvalidInputError

GROUP = "Local_Authority_(Highway)"
PYTHON_TERMS = re.compile(
    r"\b(x|y|crs|overwrite|progress|by|layer|vertices|dropna|n_jobs)=|hull\("
)


@pytest.fixture
def stats19():
    pts = datasets.load("stats19")
    keep = ["E09000033", "E09000013", "E09000030", "E08000020"]
    return pts[pts[GROUP].isin(keep)].reset_index(drop=True)


@pytest.fixture
def lonlat_csv(tmp_path, stats19):
    path = tmp_path / "accidents.csv"
    stats19[["Longitude", "Latitude", GROUP]].to_csv(path, index=False)
    return path


@pytest.fixture
def planar_gpkg(tmp_path, stats19):
    """Points in kilometres of British National Grid, stored without a CRS."""
    bng = stats19.to_crs("EPSG:27700")
    scaled = bng.geometry.scale(1e-3, 1e-3, origin=(0, 0))
    km = gpd.GeoDataFrame(bng[[GROUP]], geometry=list(scaled), crs=None)
    path = tmp_path / "km.gpkg"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # pyogrio: 'crs' was not provided
        km[[GROUP, "geometry"]].to_file(path, layer="km")
    return path


# --------------------------------------------------------------------------
# 1. the CRS is never guessed silently


def test_input_without_crs_is_an_error_naming_crs_in_none(planar_gpkg, tmp_path):
    result = run("hull", planar_gpkg, tmp_path / "h.gpkg", "--by", GROUP)
    assert result.exit_code == 1
    assert result.stderr == (
        f"Error: the points of {planar_gpkg} have no CRS, and geoalpha does not "
        "guess: give it "
        "with --crs-in, e.g. --crs-in EPSG:4326 for longitude/latitude degrees or "
        "--crs-in EPSG:27700 for British National Grid metres, or --crs-in none to "
        "use the coordinates as planar numbers without a CRS (then alpha, radius "
        "and area are in their unit)\n"
    )
    with pytest.raises(InvalidInputError, match=r"crs=None to use the coordinates"):
        read_points(planar_gpkg)  # the Python equivalent


def test_csv_with_x_y_columns_needs_its_crs(tmp_path):
    path = tmp_path / "xy.csv"
    path.write_text("x,y\n0.5,0.5\n2,0\n1,3\n")
    result = run("hull", path, tmp_path / "h.gpkg")
    assert result.exit_code == 1
    assert "the coordinate columns 'x', 'y' of" in result.stderr
    assert "--crs-in none" in result.stderr


@pytest.mark.parametrize("flag", ["--crs-in", "--crs"])
def test_planar_input_says_its_unit(planar_gpkg, stats19, tmp_path, flag):
    out = tmp_path / "h.gpkg"
    result = run("hull", planar_gpkg, out, "--by", GROUP, flag, "none")
    assert result.exit_code == 0, result.stderr
    assert "'crs' was not provided" not in result.stderr  # no pyogrio noise
    assert (
        "Computed in the input coordinates as they are (alpha in 1/coordinate "
        "unit, radius in coordinate unit, area in square coordinate unit): 4 groups"
    ) in result.stdout
    back = gpd.read_file(out)
    assert back.crs is None
    assert "area_m2" not in back.columns
    assert set(back["unit"]) == {"coordinate unit"}
    # the area is in km², as the coordinates are: the planar area of the
    # same polygons in British National Grid metres (area_m2 is on the
    # ellipsoid instead)
    with pytest.warns(DegenerateGroupWarning, match="E08000020"):
        metres = geoalpha.hull(stats19.to_crs("EPSG:27700"), by=GROUP)
    shaped = metres["alpha"].notna()
    assert back.loc[shaped, "area"].to_numpy() * 1e6 == pytest.approx(
        metres.loc[shaped].area.to_numpy(), rel=1e-6
    )


def test_lonlat_values_under_a_projected_crs_in_warn(lonlat_csv, tmp_path):
    result = run(
        "hull", lonlat_csv, tmp_path / "h.gpkg", "--by", GROUP, "--crs-in", "EPSG:27700"
    )
    assert (
        "Warning: every point of "
        f"{lonlat_csv} has Longitude within [-180, 180] and Latitude within "
        "[-90, 90], as longitude/latitude degrees do, but --crs-in EPSG:27700 says "
        "they are in metres; if they are longitude/latitude, use --crs-in EPSG:4326"
    ) in result.stderr.splitlines()
    with pytest.warns(CRSWarning, match=r"crs= EPSG:27700 says .* use crs=EPSG:4326"):
        read_points(lonlat_csv, crs="EPSG:27700")


def test_forced_web_mercator_warns_about_areas(lonlat_csv, tmp_path):
    result = run(
        "-q", "hull", lonlat_csv, tmp_path / "q.gpkg", "--by", GROUP, "--crs", "3857"
    )
    assert result.stderr == ""
    result = run(
        "hull", lonlat_csv, tmp_path / "h.gpkg", "--by", GROUP, "--crs", "3857"
    )
    assert result.exit_code == 0, result.stderr
    (line,) = [x for x in result.stderr.splitlines() if "stretches" in x]  # once
    assert line.startswith(
        "Warning: the shapes are computed in EPSG:3857 (--crs), which stretches "
        "areas 2.5"
    )
    assert "so 'radius' and 'alpha' are not in true metres ('area_m2' is" in line
    assert "leave out --crs" in line


def test_projected_input_far_from_its_zone_warns(stats19, tmp_path):
    path = tmp_path / "utm33.gpkg"
    stats19.to_crs("EPSG:32633").to_file(path)  # UK data in a zone for Italy
    result = run("hull", path, tmp_path / "h.gpkg", "--by", GROUP)
    assert result.exit_code == 0, result.stderr
    (line,) = [x for x in result.stderr.splitlines() if "stretches" in x]
    assert "computed in EPSG:32633 (the input's CRS)" in line
    assert "e.g. --crs EPSG:32630" in line
    quiet = run(
        "hull", stats19.pipe(_to_file, tmp_path / "bng.gpkg"), tmp_path / "b.gpkg"
    )
    assert "stretches" not in quiet.stderr  # British National Grid is fine
    mercator = tmp_path / "3857.gpkg"
    stats19.to_crs("EPSG:3857").to_file(mercator)  # computed in a UTM zone
    assert "stretches" not in run("hull", mercator, tmp_path / "m.gpkg").stderr


def _to_file(gdf, path: Path) -> Path:
    gdf.to_crs("EPSG:27700").to_file(path)
    return path


# --------------------------------------------------------------------------
# 6. messages in the command's terms


def test_quiet_and_verbose_after_the_command(lonlat_csv, tmp_path):
    quiet = run("hull", lonlat_csv, tmp_path / "h.gpkg", "--by", GROUP, "-q")
    assert quiet.exit_code == 0
    assert quiet.stderr == ""
    verbose = run("hull", tmp_path / "nope.csv", tmp_path / "x.gpkg", "-v")
    assert verbose.exit_code == 1
    assert verbose.stderr.startswith("Traceback (most recent call last):")


@pytest.mark.parametrize(
    ("args", "hint"),
    [
        (
            ["--by", "local_authority_(highway)"],
            "(did you mean 'Local_Authority_(Highway)'?)",
        ),
        (["--by", "Local_Authority"], "(did you mean 'Local_Authority_(Highway)'?)"),
        (["--x", "Longitud", "--y", "Latitude"], "(did you mean 'Longitude'?)"),
    ],
)
def test_wrong_column_gets_did_you_mean(lonlat_csv, tmp_path, args, hint):
    result = run("hull", lonlat_csv, tmp_path / "h.gpkg", *args)
    assert result.exit_code == 1
    assert hint in result.stderr


def test_swapped_lon_lat_get_a_hint(tmp_path):
    path = tmp_path / "airports.csv"
    path.write_text("lon,lat\n40.6,-73.8\n33.9,-118.4\n41.9,-87.9\n")
    result = run("hull", path, tmp_path / "h.gpkg")
    assert result.exit_code == 1
    assert (
        "longitude and latitude look swapped: lon holds latitudes? Give the "
        "longitude column as --x and the latitude column as --y"
    ) in result.stderr


@pytest.mark.parametrize(
    "make_args",
    [
        lambda d, csv: [csv, d / "h.gpkg", "--x", "Longitude"],
        lambda d, csv: [csv, d / "h.gpkg", "--by", "Nope"],
        lambda d, csv: [d / "p.gpkg", d / "h.gpkg", "--x", "a", "--y", "b"],
        lambda d, csv: [csv, d / "exists.gpkg"],
        lambda d, csv: [csv, d / "h.gpkg", "--crs", "EPSG:4326"],
        lambda d, csv: [csv, d / "h.gpkg", "--crs-in", "EPSG:27700", "--crs", "none"],
        lambda d, csv: [csv, d / "h.gpkg", "-j", "0"],
        lambda d, csv: [csv, d / "h.csv"],
        lambda d, csv: [csv, d / "h.shp", "--output-layer", "a"],
    ],
)
def test_messages_name_options_not_python_keywords(
    lonlat_csv, stats19, tmp_path, make_args
):
    stats19.to_file(tmp_path / "p.gpkg")
    (tmp_path / "exists.gpkg").write_text("x")
    result = run("hull", *make_args(tmp_path, lonlat_csv))
    assert not PYTHON_TERMS.search(result.stderr), result.stderr
    assert "Error: " in result.stderr or "Warning: " in result.stderr


# --------------------------------------------------------------------------
# 3. GeoPackage 1.2, which the QGIS LTRs open silently


@pytest.mark.parametrize("engine", ["pyogrio", "fiona"])
def test_geopackage_is_version_1_2(lonlat_csv, tmp_path, engine):
    out = tmp_path / "h.gpkg"
    result = run("-q", "hull", lonlat_csv, out, "--by", GROUP, "--engine", engine)
    assert result.exit_code == 0, result.stderr
    with sqlite3.connect(out) as db:
        assert db.execute("PRAGMA application_id").fetchone()[0] == 0x47504B47  # GPKG
        assert db.execute("PRAGMA user_version").fetchone()[0] == 10200
    assert len(gpd.read_file(out)) == 4


# --------------------------------------------------------------------------
# 7. what happened, in a few lines; a preview


def test_summary_after_a_run(lonlat_csv, tmp_path):
    out = tmp_path / "h.gpkg"
    result = run("hull", lonlat_csv, out, "--by", GROUP)
    assert result.exit_code == 0, result.stderr
    lines = result.stdout.splitlines()
    assert lines[-4:-1] == [
        f"Read 55 points of {lonlat_csv} (columns Longitude/Latitude, EPSG:4326)",
        "Computed in EPSG:32630: 4 groups, 1 without alpha shape",
        lines[-2],
    ]
    hulls = gpd.read_file(out)
    shaped = hulls[hulls["alpha"].notna()]
    radius = shaped["radius"].median()
    geoms = shaped.geometry.array
    share = np.median(shapely.area(geoms) / shapely.area(shapely.convex_hull(geoms)))
    assert lines[-2] == (
        f"Median radius {radius:,.4g} m; median area {share:.0%} of the convex hull"
    )
    assert lines[-1] == f"Wrote 4 hulls of 55 points to {out} (layer 'h')"


def test_preview_draws_hulls_over_points(lonlat_csv, tmp_path):
    pytest.importorskip("matplotlib")  # the plot extra; CI installs it
    import matplotlib.image

    picture = tmp_path / "hulls.png"
    result = run(
        "hull", lonlat_csv, tmp_path / "h.gpkg", "--by", GROUP, "--preview", picture
    )
    assert result.exit_code == 0, result.stderr
    assert result.stdout.splitlines()[-1] == f"Wrote a preview to {picture}"
    image = matplotlib.image.imread(picture)
    colours = pd.DataFrame(image[..., :3].reshape(-1, 3).round(2)).drop_duplicates()
    assert len(colours) > 10  # hulls in several colours, points, axes
    if HAS_TQDM:  # drawing is the progress bar's last phase
        again = run(
            *("hull", lonlat_csv, tmp_path / "h.gpkg", "--by", GROUP, "--overwrite"),
            *("--preview", picture, "--progress"),
        )
        assert_bar_covers(again.stderr, [*CLI_PHASES, "preview"])


def test_bad_preview_name_is_refused_before_computing(lonlat_csv, tmp_path):
    result = run(
        "hull", lonlat_csv, tmp_path / "h.gpkg", "--preview", tmp_path / "p.txt"
    )
    assert result.exit_code == 1
    assert result.stderr.startswith("Error: --preview needs a .png")
    assert not (tmp_path / "h.gpkg").exists()


# --------------------------------------------------------------------------
# 5. many groups: one transformer per CRS, cached; a warning for a wrong --by


def test_many_degenerate_groups_build_no_transformer_per_group(monkeypatch):
    import pyproj

    rng = np.random.default_rng(5)
    n = 600  # 300 groups of 2 points 20 degrees apart: ~300 local LAEA CRSs
    lon = np.repeat(rng.uniform(-170, 150, n // 2), 2) + np.tile([0, 20], n // 2)
    lat = np.repeat(rng.uniform(-60, 60, n // 2), 2)
    points = gpd.GeoDataFrame(
        {"k": np.arange(n) // 2},
        geometry=gpd.points_from_xy(lon, lat),
        crs="EPSG:4326",
    )
    calls = []
    from_crs = pyproj.Transformer.from_crs

    def counting(*args, **kwargs):
        calls.append(args)
        return from_crs(*args, **kwargs)

    monkeypatch.setattr(pyproj.Transformer, "from_crs", counting)
    with pytest.warns(DegenerateGroupWarning):
        hulls = geoalpha.hull(points, by="k")
    assert hulls["crs_used"].nunique() > 250
    assert len(calls) < 20  # was one per local CRS, each way
    # The buffers came back to the right place: each covers its two points.
    covered = shapely.covers(
        np.repeat(np.asarray(hulls.geometry.array, dtype=object), 2),
        np.asarray(points.sort_values("k").geometry.array, dtype=object),
    )
    assert covered.all()


def test_laea_pipeline_back_equals_the_database_transform():
    from geoalpha._frame import crs as gcrs

    laea = "+proj=laea +lat_0=62 +lon_0=-153 +datum=WGS84 +units=m +no_defs"
    x = np.array([-5e5, 0.0, 3e5])
    y = np.array([2e5, 0.0, -4e5])
    fast = gcrs._transformer(laea, "EPSG:4326").transform(x, y)
    slow = pyproj.Transformer.from_crs(laea, "EPSG:4326", always_xy=True).transform(
        x, y
    )
    np.testing.assert_allclose(fast, slow, rtol=0, atol=1e-9)


def test_by_with_nearly_one_group_per_row_warns(lonlat_csv, tmp_path):
    result = run("hull", lonlat_csv, tmp_path / "h.gpkg", "--by", "Latitude")
    assert result.exit_code == 0, result.stderr
    assert [x for x in result.stderr.splitlines() if "groups of" in x] == [
        "Warning: --by Latitude makes 47 groups of 55 rows; groups of 1-2 points "
        "have no alpha shape, so is this the right column?"
    ]  # once, in the command's terms
    both = run("hull", lonlat_csv, tmp_path / "h2.gpkg", "--by", "Latitude,Longitude")
    assert (
        "Warning: --by Latitude,Longitude makes 47 groups of 55 rows; groups of "
        "1-2 points have no alpha shape, so are these the right columns?"
    ) in both.stderr.splitlines()


# --------------------------------------------------------------------------
# 2. points on the boundary: --grow puts every point strictly inside


def test_grow_puts_every_point_strictly_inside(tmp_path):
    exact, grown = tmp_path / "exact.gpkg", tmp_path / "grown.gpkg"
    assert run("-q", "demo", exact).exit_code == 0
    result = run("-q", "hull", exact, grown, "--layer", "points", "--by", "state")
    assert result.exit_code == 0, result.stderr
    result = run(
        "-q", "hull", exact, tmp_path / "g.gpkg", "--layer", "points", "--by", "state",
        "--grow", "1",
    )  # fmt: skip
    assert result.exit_code == 0, result.stderr
    points = gpd.read_file(exact, layer="points").dropna(subset=["state"])
    before = gpd.read_file(grown)
    after = gpd.read_file(tmp_path / "g.gpkg")

    def strictly_inside(hulls):
        pairs = points.merge(
            hulls[["state", "geometry"]].rename(columns={"geometry": "hull"}),
            on="state",
        )
        return shapely.contains_properly(
            np.asarray(pairs["hull"]), np.asarray(pairs.geometry.array)
        )

    assert 0.5 < strictly_inside(before).mean() < 0.6  # vertices, edges: boundary
    assert strictly_inside(after).all()
    assert after["alpha"].equals(before["alpha"])  # the optimum is unchanged
    growth = (after["area_m2"] - before["area_m2"]) / before["area_m2"]
    shaped = before["alpha"].notna()
    assert (growth[shaped] > 0).all()
    assert growth[shaped].median() < 1e-4  # 1 m around states
    assert (growth[~shaped] == 0).all()  # degenerate buffers are not grown


def test_grow_must_be_a_distance():
    points = datasets.load("stats19").iloc[:30]
    with pytest.raises(InvalidInputError, match="grow must be a distance >= 0"):
        geoalpha.hull(points, grow=-1.0)


# --------------------------------------------------------------------------
# 8. islands: --components splits the bridges (the README's picture)


def test_components_split_hawaii_as_the_readme_shows(tmp_path):
    airports = datasets.load("us_airports")
    path = tmp_path / "hi.csv"
    airports[airports["state"] == "HI"].drop(columns="geometry").to_csv(path)
    areas = {}
    for n in (1, 4):
        out = tmp_path / f"hi{n}.gpkg"
        result = run("-q", "hull", path, out, "--by", "state", "--components", n)
        assert result.exit_code == 0, result.stderr
        back = gpd.read_file(out)
        row = back.iloc[0]
        assert row["n_parts"] == n
        areas[n] = row["area_m2"] / 1e6
        # on the WGS84 ellipsoid: pyproj's area of the polygon written
        assert row["area_m2"] == pytest.approx(ellipsoid_areas(back)[0], rel=1e-9)
    # (18,667 and 9,487 km² planar in UTM zone 4N, whose scale is 0.9996 there)
    assert round(areas[1]) == 18653
    assert round(areas[4]) == 9477  # half the area: no sea between the pieces


CLI_PHASES = ["read", "group", "project", "compute", "check", "write"]


@pytest.mark.parametrize(
    "command",
    [
        lambda csv, d: ["hull", csv, d / "h.gpkg", "--by", "Latitude"],
        lambda csv, d: ["demo", d / "h.gpkg", "--dataset", "stats19"],
    ],
    ids=["hull", "demo"],
)
def test_progress_bar_covers_every_phase_from_read_to_write(
    lonlat_csv, tmp_path, command
):
    pytest.importorskip("tqdm")  # the progress extra; CI installs it
    result = run(*command(lonlat_csv, tmp_path), "--progress")
    assert result.exit_code == 0, result.stderr
    # one bar through every phase, never backwards, full at the end of writing
    # (here 47 groups, most of 1-2 points that are never triangulated)
    assert_bar_covers(result.stderr, CLI_PHASES)
    segments = re.split(r"[\r\n]", result.stderr)
    # warnings are written above the bar, not into its line
    assert all(x.startswith("Warning: ") for x in segments if "Warning: " in x)
    # the bar closes full; the summary is on stdout, not in the bar's stream
    last_bar = max(i for i, x in enumerate(segments) if "geoalpha hull: " in x)
    assert segments[last_bar].startswith("geoalpha hull: write 100%")
    assert not any(x.startswith("Read ") for x in segments)
    assert result.stdout.startswith("Read ")
    quiet = run(*command(lonlat_csv, tmp_path), "--overwrite")  # not a terminal
    assert "geoalpha hull: " not in quiet.stderr
