"""The ``geoalpha`` command (geoalpha._cli), driven through click's CliRunner."""

from __future__ import annotations

import math
import os
import subprocess
import sys
import types
import warnings
from pathlib import Path

import geopandas as gpd
import pandas as pd
import pytest
import shapely
from cli_runner import run

import geoalpha
from geoalpha import datasets
from geoalpha.errors import DegenerateGroupWarning, InvalidInputError, SearchWarning

GROUP = "Local_Authority_(Highway)"
REPO = Path(__file__).resolve().parents[1]


@pytest.fixture
def points_csv(tmp_path):
    """Four local authorities of the 2014 STATS19 extract, as a CSV file."""
    pts = datasets.load("stats19")
    keep = ["E09000033", "E09000013", "E09000030", "E08000020"]  # last: 1 point
    table = pd.DataFrame(pts[pts[GROUP].isin(keep)].drop(columns="geometry"))
    path = tmp_path / "accidents.csv"
    table[["Accident_Index", "Longitude", "Latitude", GROUP]].to_csv(path, index=False)
    return path


@pytest.fixture
def fake_hull(monkeypatch):
    """Stand in for geoalpha._hulls.hull: convex hulls, and a record of the call."""
    calls = []

    def hull(gdf, by=None, **options):
        calls.append({"by": by, **options})
        keys = [by] if isinstance(by, str) else list(by or [])
        frame = gdf.assign(_all=0) if not keys else gdf
        groups = frame.dissolve(by=keys or "_all", as_index=False)
        sizes = frame.groupby(keys or "_all").size().to_numpy()
        if (sizes < 3).any():
            warnings.warn(
                "1 group has fewer than 3 distinct points\n(buffered)",
                DegenerateGroupWarning,
                stacklevel=2,
            )
        out = groups[[*keys, "geometry"]].copy()
        out["geometry"] = shapely.buffer(groups.geometry.convex_hull.array, 1e-4)
        out["alpha"] = 0.0
        out["radius"] = float("inf")
        out["n_points"] = sizes
        out["area_m2"] = 1.0
        out["crs_used"] = "EPSG:32630"
        out["method"] = "convex"
        return out

    module = types.ModuleType("geoalpha._hulls")
    module.hull = hull
    monkeypatch.setitem(sys.modules, "geoalpha._hulls", module)
    return calls


# --------------------------------------------------------------------------
# the group


def test_version():
    result = run("--version")
    assert result.exit_code == 0
    # The package, its kernel and the spade that Cargo.lock pins.
    lock = (REPO / "Cargo.lock").read_text()
    spade = lock.split('name = "spade"\nversion = "')[1].split('"')[0]
    cargo = (REPO / "Cargo.toml").read_text()
    kernel = cargo.split('version = "')[1].split('"')[0]
    assert result.stdout == (
        f"geoalpha {geoalpha.__version__} (kernel {kernel}, spade {spade})\n"
    )


def test_python_dash_m_geoalpha():
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(
        p for p in (str(REPO), env.get("PYTHONPATH")) if p
    )
    done = subprocess.run(
        [sys.executable, "-m", "geoalpha", "--version"],
        capture_output=True,
        text=True,
        env=env,
        timeout=60,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("geoalpha ")


@pytest.mark.parametrize(
    ("args", "expected"),
    [
        ([], ["geoalpha demo hulls.gpkg", "demo", "hull", "--verbose", "--quiet"]),
        (["hull"], ["INPUT OUTPUT", "--by COL[,COL...]", "--crs-in", "--overwrite"]),
        (["demo"], ["uk_clusters", "Local_Authority_(Highway)", "--dataset"]),
    ],
)
def test_help(args, expected):
    result = run(*args, "--help")
    assert result.exit_code == 0
    for text in expected:
        assert text in result.stdout


# --------------------------------------------------------------------------
# options reach hull(); output is reported


def test_options_are_passed_to_hull(fake_hull, points_csv, tmp_path):
    result = run(
        "hull", points_csv, tmp_path / "h.gpkg", "--by", f"Accident_Index,{GROUP}",
        "--alpha", "0.5", "--holes", "--components", "2", "--method", "concave",
        "--search", "ladder", "--max-iterations", "9", "--ratio", "0.5", "--k", "7",
        "--crs", "EPSG:27700",
        "--degenerate", "drop", "--buffer", "2.5", "--grow", "0.5", "--vertices",
        "--no-dropna", "--no-sort", "-j", "2", "--no-progress",
        "--outlier-unit", "locations", "--no-suspicious",
    )  # fmt: skip
    assert result.exit_code == 0, result.stderr
    assert fake_hull == [
        {
            "by": ["Accident_Index", GROUP],
            "alpha": 0.5,
            "holes": True,
            "components": 2,
            "outliers": 0,
            "crs": "EPSG:27700",
            "method": "concave",
            "search": "ladder",
            "max_iterations": 9,
            "ratio": 0.5,
            "k": 7,
            "degenerate": "drop",
            "buffer": 2.5,
            "grow": 0.5,
            "overlap": "keep",
            "vertices": True,
            "dropna": False,
            "sort": False,
            "n_jobs": 2,
            "progress": False,
            "outlier_unit": "locations",
            "suspicious": False,
        }
    ]


def test_defaults_passed_to_hull(fake_hull, points_csv, tmp_path):
    result = run("hull", points_csv, tmp_path / "h.gpkg", "--by", GROUP)
    assert result.exit_code == 0, result.stderr
    assert fake_hull == [
        {
            "by": GROUP,
            "alpha": None,
            "holes": False,
            "components": 1,
            "outliers": 0,
            "crs": "auto",
            "method": "alpha",
            "search": "exact",
            "max_iterations": 10_000,
            "ratio": 0.3,
            "k": 3,
            "degenerate": "buffer",
            "buffer": 1.0,
            "grow": 0.0,
            "overlap": "keep",
            "vertices": False,
            "dropna": True,
            "sort": True,
            "n_jobs": None,
            "progress": None,
            "outlier_unit": "rows",
            "suspicious": True,
        }
    ]


def test_by_repeated_and_absent(fake_hull, points_csv, tmp_path):
    run("hull", points_csv, tmp_path / "a.gpkg", "--by", GROUP, "--by", "Latitude")
    run("hull", points_csv, tmp_path / "b.gpkg")
    assert [call["by"] for call in fake_hull] == [[GROUP, "Latitude"], None]
    assert len(gpd.read_file(tmp_path / "b.gpkg")) == 1


def test_summary_warnings_and_shapefile_fields(fake_hull, points_csv, tmp_path):
    out = tmp_path / "h.shp"
    result = run("hull", points_csv, out, "--by", GROUP)
    assert result.exit_code == 0, result.stderr
    # the summary on stdout, warnings on stderr
    assert result.stderr.splitlines() == [
        "Warning: 1 group has fewer than 3 distinct points (buffered)",
    ]
    assert result.stdout.splitlines() == [
        f"Read 55 points of {points_csv} (columns Longitude/Latitude, EPSG:4326)",
        "Computed in EPSG:32630: 4 groups",
        "Median area 100% of the convex hull",
        f"Shapefile field '{GROUP}' written as 'Local_Auth'",
        f"Wrote 4 hulls of 55 points to {out}",
    ]
    assert sorted(gpd.read_file(out)["Local_Auth"]) == [
        "E08000020",
        "E09000013",
        "E09000030",
        "E09000033",
    ]


def test_quiet_prints_nothing(fake_hull, points_csv, tmp_path):
    result = run("-q", "hull", points_csv, tmp_path / "h.shp", "--by", GROUP)
    assert result.exit_code == 0
    assert result.stderr == result.stdout == ""
    assert fake_hull[0]["progress"] is False  # no progress bar either


def test_geopackage_layer_in_summary(fake_hull, points_csv, tmp_path):
    out = tmp_path / "h.gpkg"
    result = run("hull", points_csv, out, "--by", GROUP, "--output-layer", "la")
    assert (
        result.stdout.splitlines()[-1]
        == f"Wrote 4 hulls of 55 points to {out} (layer 'la')"
    )
    assert gpd.read_file(out, layer="la").crs == "EPSG:4326"


def test_projected_csv_with_explicit_columns(fake_hull, tmp_path):
    pts = datasets.load("stats19").iloc[:30]
    path = tmp_path / "bng.csv"
    pts[["Location_Easting_OSGR", "Location_Northing_OSGR", GROUP]].to_csv(path)
    out = tmp_path / "h.fgb"
    result = run(
        "hull", path, out, "--by", GROUP, "--x", "Location_Easting_OSGR",
        "--y", "Location_Northing_OSGR", "--crs-in", "EPSG:27700",
        "--engine", "fiona",
    )  # fmt: skip
    assert result.exit_code == 0, result.stderr
    assert gpd.read_file(out).crs == "EPSG:27700"


def test_planar_coordinates_with_crs_in_none(fake_hull, tmp_path):
    path = _write(tmp_path / "trees.csv", "x,y,species\n1,2,oak\n500,9,oak\n")
    result = run("hull", path, tmp_path / "t.gpkg", "--crs-in", "none")
    assert result.exit_code == 0, result.stderr
    assert fake_hull[0]["crs"] is None
    assert gpd.read_file(tmp_path / "t.gpkg").crs is None


# --------------------------------------------------------------------------
# bad input: exit status 1 and one "Error:" line


def _write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


@pytest.mark.parametrize(
    ("make_args", "message"),
    [
        (
            lambda d, csv: [d / "nope.csv", d / "h.gpkg"],
            "Error: input file {d}/nope.csv does not exist",
        ),
        (
            lambda d, csv: [csv, d / "h.gpkg", "--by", "Borough"],
            "Error: --by column 'Borough' not found in {d}/accidents.csv; its "
            "columns are: Accident_Index, Longitude, Latitude, " + GROUP,
        ),
        (
            lambda d, csv: [_write(d / "s.csv", "site,n\na,1\n"), d / "h.gpkg"],
            "Error: no coordinate columns found in {d}/s.csv",
        ),
        (
            lambda d, csv: [_write(d / "bad.gpkg", "not a GeoPackage"), d / "h.gpkg"],
            "Error: cannot read {d}/bad.gpkg",
        ),
        (
            lambda d, csv: [csv, _write(d / "old.gpkg", "precious")],
            "Error: output {d}/old.gpkg already exists; use --overwrite",
        ),
        (
            lambda d, csv: [csv, d / "h.kml"],
            "Error: cannot tell the output format of {d}/h.kml",
        ),
        (
            lambda d, csv: [csv, d / "h.shp", "--output-layer", "x"],
            "Error: a layer name applies to GeoPackage (.gpkg) output only",
        ),
        (
            lambda d, csv: [csv, d / "h.gpkg", "--crs-in", "EPSG:0"],
            "Error: unknown CRS 'EPSG:0'",
        ),
        (
            lambda d, csv: [csv, d / "h.gpkg", "--x", "Latitude"],
            "Error: give both --x and --y for {d}/accidents.csv",
        ),
    ],
    ids=[
        "missing-file",
        "missing-column",
        "no-coordinates",
        "unreadable",
        "exists",
        "extension",
        "layer",
        "crs",
        "x-only",
    ],
)
def test_bad_input_gives_one_error_line(tmp_path, points_csv, make_args, message):
    args = make_args(tmp_path, points_csv)
    before = sorted(os.listdir(tmp_path))
    result = run("hull", *args)
    assert result.exit_code == 1
    lines = result.stderr.splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith(message.format(d=tmp_path))
    assert "Traceback" not in result.stderr
    assert sorted(os.listdir(tmp_path)) == before  # nothing written
    if (tmp_path / "old.gpkg").exists():
        assert (tmp_path / "old.gpkg").read_text() == "precious"


def test_verbose_adds_the_traceback(tmp_path):
    result = run("-v", "hull", tmp_path / "nope.csv", tmp_path / "h.gpkg")
    assert result.exit_code == 1
    assert result.stderr.startswith("Traceback (most recent call last):")
    assert result.stderr.splitlines()[-1].startswith("Error: input file")


def test_geoalpha_errors_from_hull_are_one_line(monkeypatch, points_csv, tmp_path):
    def hull(*args, **kwargs):
        raise InvalidInputError("hull() needs point geometries;\ngot 3 LineString")

    monkeypatch.setitem(
        sys.modules, "geoalpha._hulls", types.SimpleNamespace(hull=hull)
    )
    result = run("hull", points_csv, tmp_path / "h.gpkg")
    assert result.exit_code == 1
    assert result.stderr == ("Error: hull() needs point geometries; got 3 LineString\n")


def test_unexpected_errors_name_their_type(monkeypatch, points_csv, tmp_path):
    def broken(*args, **kwargs):
        raise ZeroDivisionError("division by zero")

    monkeypatch.setattr("geoalpha._io.files.read_input_points", broken)
    result = run("hull", points_csv, tmp_path / "h.gpkg")
    assert result.exit_code == 1
    assert result.stderr == (
        "Error: ZeroDivisionError: division by zero "
        "(rerun as 'geoalpha -v ...' for the traceback)\n"
    )


@pytest.mark.parametrize(
    "flag, value, reason",
    [
        (
            "--method",
            "magic",
            "one of 'alpha', 'convex', 'concave', 'knn'; got 'magic'",
        ),
        ("--degenerate", "nope", "one of 'buffer', 'empty', 'drop'; got 'nope'"),
        ("--outliers", "-1", "a fraction in [0, 1) or a count >= 0 (an int); got -1"),
        ("--outliers", "1.5", "a fraction in [0, 1) or a count >= 0 (an int); got 1.5"),
        ("--components", "2.5", "an integer >= 1; got 2.5"),
        ("--grow", "-3", "a distance >= 0 (metres); got -3"),
        ("--jobs", "0", "a positive integer, or -1 or None (every core); got 0"),
    ],
)
def test_bad_values_are_refused_at_the_flag(flag, value, reason):
    # The check of options.py, before INPUT is read: usage errors (exit 2).
    result = run("hull", "a.csv", "b.gpkg", flag, value)
    assert result.exit_code == 2
    named = "'-j' / '--jobs'" if flag == "--jobs" else f"'{flag}'"
    assert f"Error: Invalid value for {named}: {flag} must be {reason}\n" in (
        result.stderr
    )


@pytest.mark.parametrize(
    "crs, reason",
    [
        ("bogus", "unknown CRS 'bogus': expected a CRS: an EPSG code"),
        (
            "EPSG:4326",
            "--crs must be a projected (metric) CRS, got EPSG:4326 (geographic); "
            "pass --crs auto to let geoalpha choose a UTM zone or a local CRS per "
            "group, or --crs none to use the coordinates as they are",
        ),
    ],
)
def test_bad_crs_is_refused_at_the_flag(crs, reason):
    result = run("hull", "a.csv", "b.gpkg", "--crs", crs)
    assert result.exit_code == 2
    assert f"Error: Invalid value for '--crs': {reason}" in result.stderr


def test_demo_refuses_existing_output(tmp_path):
    (tmp_path / "d.gpkg").write_text("precious")
    result = run("demo", tmp_path / "d.gpkg")
    assert result.exit_code == 1
    assert result.stderr == (
        f"Error: output {tmp_path}/d.gpkg already exists; use --overwrite "
        "to replace it\n"
    )


# --------------------------------------------------------------------------
# end to end, with the real computation


@pytest.mark.parametrize(
    ("suffix", "engine", "group"),
    [(".gpkg", "pyogrio", GROUP), (".shp", "fiona", "Local_Auth")],
)
def test_hull_end_to_end(points_csv, tmp_path, suffix, engine, group):
    out = tmp_path / f"hulls{suffix}"
    result = run("hull", points_csv, out, "--by", GROUP, "--engine", engine)
    assert result.exit_code == 0, result.stderr
    assert result.stdout.splitlines()[-1].startswith(
        f"Wrote 4 hulls of 55 points to {out}"
    )
    with pytest.warns(DegenerateGroupWarning, match="E08000020"):
        expected = geoalpha.hull(_csv_points(points_csv), by=GROUP)
    back = gpd.read_file(out, engine=engine).sort_values(group, ignore_index=True)
    expected = expected.sort_values(GROUP, ignore_index=True)
    assert back[group].tolist() == expected[GROUP].tolist()
    assert back["n_points"].tolist() == expected["n_points"].tolist()
    assert back["alpha"].tolist() == pytest.approx(
        expected["alpha"].tolist(), nan_ok=True
    )
    assert back.crs == expected.crs
    assert back.geometry.geom_equals(expected.geometry).all()


def test_hull_of_polygon_vertices_with_more_options(points_csv, tmp_path):
    # --buffer widens the polygon of the 1-point authority (E08000020).
    first = tmp_path / "hulls.gpkg"
    result = run("-q", "hull", points_csv, first, "--by", GROUP, "--buffer", "25")
    assert result.exit_code == 0, result.stderr
    polygons = gpd.read_file(first)
    lonely = polygons.loc[polygons[GROUP] == "E08000020", "area_m2"]
    assert lonely.iloc[0] == pytest.approx(math.pi * 25**2, rel=0.02)
    # A second pass over those polygons: --vertices makes their vertices the
    # points; without it, polygons are refused with a message.
    out = tmp_path / "outer.geojson"
    refused = run("hull", first, out, "--by", GROUP)
    assert refused.exit_code == 1
    assert refused.stderr.startswith(
        "Error: geoalpha needs point geometries; got 4 Polygon row(s)"
    )
    assert "pass --vertices to use their vertices" in refused.stderr
    args = ["hull", first, out, "--by", GROUP, "--vertices", "--no-sort", "-j", "2"]
    result = run(*args)
    assert result.exit_code == 0, result.stderr
    expected = geoalpha.hull(polygons, by=GROUP, vertices=True, sort=False)
    back = gpd.read_file(out)
    assert back[GROUP].tolist() == polygons[GROUP].tolist()  # file order
    assert back["n_points"].tolist() == expected["n_points"].tolist()
    assert back.geometry.geom_equals_exact(expected.geometry, 1e-9).all()
    jobs = run("hull", points_csv, tmp_path / "h.gpkg", "-j", "0")
    assert jobs.exit_code == 2
    assert "--jobs': --jobs must be a positive integer, or -1" in jobs.stderr


def _csv_points(path):
    from geoalpha._io.files import read_points

    return read_points(path)


def test_max_iterations_reaches_the_bisection(points_csv, tmp_path):
    """``--search bisect --max-iterations 3``: ``search="bisect", max_iterations=3``.

    Three bisection steps from [0, 1.8e308] cannot find alphas of a few
    1/1000 m: the bisection gives up with the convex hull (alpha 0), where
    the exact search (and the bisection with its 10,000 steps) finds them.
    """
    points = _csv_points(points_csv)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DegenerateGroupWarning)
        exact = geoalpha.hull(points, by=GROUP)
        with pytest.warns(SearchWarning, match="max_iterations=3 for 3 group"):
            three = geoalpha.hull(points, by=GROUP, search="bisect", max_iterations=3)
    files = {}
    for name, steps in (("three", ["--max-iterations", "3"]), ("default", [])):
        files[name] = tmp_path / f"{name}.gpkg"
        result = run(
            "hull", points_csv, files[name], "--by", GROUP, "--search", "bisect",
            *steps,
        )  # fmt: skip
        assert result.exit_code == 0, result.stderr
    assert "did not converge" not in result.stderr  # the default: 10,000 steps
    back = {
        name: gpd.read_file(path).set_index(GROUP).loc[exact[GROUP]]
        for name, path in files.items()
    }
    assert back["three"]["alpha"].tolist() == pytest.approx(
        three["alpha"].tolist(), nan_ok=True
    )
    assert back["three"]["alpha"].tolist()[1:] == [0.0, 0.0, 0.0]  # convex hulls
    assert back["default"]["alpha"].tolist() == pytest.approx(
        exact["alpha"].tolist(), rel=1e-9, nan_ok=True
    )
    assert all(a > 4e-4 for a in exact["alpha"].tolist()[1:])  # E09000013, ...
    shaped = exact["alpha"].notna().to_numpy()
    grown = back["three"]["area_m2"].to_numpy() / exact["area_m2"].to_numpy()
    assert (grown[shaped] > 1.8).all()  # the convex hulls are twice as large


def test_max_iterations_warning_names_the_options(points_csv, tmp_path):
    result = run(
        "hull", points_csv, tmp_path / "h.gpkg", "--by", GROUP,
        "--search", "bisect", "--max-iterations", "3",
    )  # fmt: skip
    assert result.exit_code == 0, result.stderr
    # The groups by their --by value with their rows (not internal codes);
    # the result is worded as a result, not as an option (no "--alpha 0").
    rows = pd.read_csv(points_csv)[GROUP].value_counts()
    named = "; ".join(f"'{key}' ({rows[key]} rows)" for key in sorted(rows.index)[1:])
    assert result.stderr.splitlines()[0] == (
        "Warning: --search bisect did not converge within --max-iterations 3 for "
        f"3 group(s) ({named}) and gave them alpha 0, the convex hull, as "
        "alphashape does; use --search exact"
    )


def test_demo_default_dataset_is_visible_at_once(tmp_path):
    out = tmp_path / "demo.gpkg"
    result = run("demo", out)
    assert result.exit_code == 0, result.stderr
    assert result.stdout.splitlines()[-1] == (
        f"Wrote 56 hulls of 3,364 points to {out} (layer 'demo', 'points')"
    )
    hulls = gpd.read_file(out, layer="demo")
    points = gpd.read_file(out, layer="points")
    assert len(hulls) == 56
    assert len(points) == 3376
    assert hulls.crs == points.crs == "EPSG:4326"
    assert set(hulls.geom_type) <= {"Polygon", "MultiPolygon"}
    # Seen at full extent (QGIS zooms to it), the median hull is at least 1 %
    # of the map's width: some pixels, not a dot (UK clusters: 0.02 %).
    minx, _, maxx, _ = points.total_bounds
    widths = hulls.bounds["maxx"] - hulls.bounds["minx"]
    assert widths.median() > 0.01 * (maxx - minx)


def test_demo_stats19_warns_about_degenerate_groups(tmp_path):
    out = tmp_path / "la.shp"
    result = run("demo", out, "--dataset", "stats19")
    assert result.exit_code == 0, result.stderr
    assert any(line.startswith("Warning: ") for line in result.stderr.splitlines())
    lines = result.stdout.splitlines()
    assert f"Shapefile field '{GROUP}' written as 'Local_Auth'" in lines
    assert lines[-1] == f"Wrote 13 hulls of 1,017 points to {out}"
    assert len(gpd.read_file(out)) == 13
