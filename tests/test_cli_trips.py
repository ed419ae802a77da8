"""The newcomer's small trips with files and the command (issue #36, item 4)."""

from __future__ import annotations

from pathlib import Path

import geopandas as gpd
import pytest
import shapely
from cli_runner import run
from compat import requires_matplotlib, requires_tqdm

from geoalpha import datasets
from geoalpha._io.files import read_points
from geoalpha.errors import InvalidInputError

GROUP = "Local_Authority_(Highway)"


@pytest.fixture
def points() -> gpd.GeoDataFrame:
    pts = datasets.load("stats19")
    return pts[pts[GROUP].isin(["E09000033", "E09000013"])].reset_index(drop=True)


def polygons() -> gpd.GeoDataFrame:
    return gpd.GeoDataFrame(
        {"name": ["a"]}, geometry=[shapely.box(-0.2, 51.4, 0.0, 51.6)], crs=4326
    )


# --------------------------------------------------------------------------
# a multi-layer INPUT without --layer


def test_the_only_point_layer_is_read_and_named(points, tmp_path):
    path = tmp_path / "both.gpkg"
    polygons().to_file(path, layer="state_hulls")  # first: not the points
    points.to_file(path, layer="zips")
    out = tmp_path / "h.gpkg"
    result = run("hull", path, out, "--by", GROUP)
    assert result.exit_code == 0, result.stderr
    assert (
        f"Read {len(points)} points of {path} (layer 'zips', the only point "
        "layer, EPSG:4326)"
    ) in result.stdout
    assert len(gpd.read_file(out)) == 2
    assert len(read_points(path)) == len(points)  # Python reads the same layer


@pytest.mark.parametrize(
    ("layers", "which", "hint"),
    [
        (["zips", "more"], "more than one point layer", "--layer 'zips'"),
        ([], "no point layer", "--layer 'a' (with --vertices"),
    ],
)
def test_an_ambiguous_input_names_its_layers(points, tmp_path, layers, which, hint):
    path = tmp_path / "many.gpkg"
    polygons().to_file(path, layer="a")
    polygons().to_file(path, layer="b")
    for name in layers:
        points.to_file(path, layer=name)
    result = run("hull", path, tmp_path / "h.gpkg", "--by", GROUP)
    assert result.exit_code == 1
    listed = ", ".join(
        [f"{n} (Polygon)" for n in ("a", "b")] + [f"{n} (Point)" for n in layers]
    )
    assert result.stderr == (
        f"Error: {path} has {2 + len(layers)} layers and {which}: {listed}; "
        f"choose one with {hint}"
        + (" for lines or polygons)" if not layers else "")
        + "\n"
    )
    assert "needs point geometries" not in result.stderr
    assert not (tmp_path / "h.gpkg").exists()


def test_python_names_the_layers_with_its_own_words(points, tmp_path):
    path = tmp_path / "many.gpkg"
    points.to_file(path, layer="p1")
    points.to_file(path, layer="p2")
    with pytest.raises(InvalidInputError, match=r"choose one with layer='p1'$"):
        read_points(path)
    assert len(read_points(path, layer="p2")) == len(points)


def test_a_single_layer_file_is_read_as_before(points, tmp_path):
    path = Path(tmp_path / "one.gpkg")
    polygons().to_file(path, layer="only")
    assert read_points(path).geom_type.tolist() == ["Polygon"]  # hull() says so


# --------------------------------------------------------------------------
# the summary on stdout; nothing drawn before an output error


@requires_tqdm
def test_no_progress_bar_before_an_already_exists_error(points, tmp_path):
    csv = tmp_path / "p.csv"
    points[["Longitude", "Latitude", GROUP]].to_csv(csv, index=False)
    out = tmp_path / "h.fgb"
    out.write_bytes(b"precious")
    result = run("hull", csv, out, "--by", GROUP, "--progress")
    assert result.exit_code == 1
    assert result.stderr == (
        f"Error: output {out} already exists; use --overwrite to replace it\n"
    )
    assert result.stdout == ""
    assert out.read_bytes() == b"precious"


def test_summary_on_stdout_warnings_on_stderr(points, tmp_path):
    csv = tmp_path / "p.csv"
    points[["Longitude", "Latitude", GROUP]].to_csv(csv, index=False)
    with_blank = csv.read_text().replace(",E09000013\n", ",\n", 1)
    csv.write_text(with_blank)
    result = run("hull", csv, tmp_path / "h.gpkg", "--by", GROUP)
    assert result.exit_code == 0, result.stderr
    assert [line.split(" ")[0] for line in result.stdout.splitlines()] == [
        "Read",
        "Computed",
        "Median",
        "Wrote",
    ]
    assert result.stderr.startswith("Warning: geoalpha dropped 1 of ")
    assert all(line.startswith("Warning: ") for line in result.stderr.splitlines())


# --------------------------------------------------------------------------
# PG: strings are answered with the URL to give


@pytest.mark.parametrize(
    ("dsn", "answer"),
    [
        (
            "PG:host=127.0.0.1 port=5433 user=ga password='s3cr3t pw' dbname=gis",
            "postgresql://ga@127.0.0.1:5433/gis",
        ),
        (
            "PG:dbname=gis host=db.example tables=public.zips sslmode=require",
            "postgresql://db.example/gis?sslmode=require and --layer public.zips",
        ),
    ],
)
def test_pg_strings_are_answered_with_the_url(tmp_path, dsn, answer):
    result = run("hull", dsn, tmp_path / "h.gpkg", "--by", "zip")
    assert result.exit_code == 1
    assert result.stderr == (
        "Error: PG:... connection strings are not supported (the GDAL in the "
        f"Python wheels has no PostgreSQL driver); give the URL {answer} instead, "
        "with the password in PGPASSWORD or ~/.pgpass\n"
    )
    assert "s3cr3t" not in result.stderr
    assert list(tmp_path.iterdir()) == []


# --------------------------------------------------------------------------
# --preview at 42k points


@requires_matplotlib
def test_preview_of_42k_points_shows_the_hulls(tmp_path):
    import matplotlib.image
    import numpy as np
    import pandas as pd

    rng = np.random.default_rng(36)
    n = 42_000
    group = rng.integers(0, 50, n)
    lon = -100 + (group % 10) + rng.normal(0, 0.25, n)
    lat = 35 + (group // 10) + rng.normal(0, 0.25, n)
    csv = tmp_path / "zips.csv"
    zips = [f"{g:05d}" for g in group]
    pd.DataFrame({"lon": lon, "lat": lat, "zip": zips}).to_csv(csv, index=False)
    picture = tmp_path / "preview.png"
    result = run("-q", "hull", csv, tmp_path / "h.gpkg", "--by", "zip",
                 "--preview", picture)  # fmt: skip
    assert result.exit_code == 0, result.stderr
    image = matplotlib.image.imread(picture)[..., :3]
    # The points no longer paint the map black (12 % of the picture was dark,
    # hiding the hulls' colours); the hulls' colours are what one sees.
    dark = (image.max(axis=2) < 0.35).mean()
    assert dark < 0.04, dark
    colours = pd.DataFrame(image.reshape(-1, 3).round(1)).drop_duplicates()
    assert len(colours) > 20


# --------------------------------------------------------------------------
# CSV errors: the row, and the flags to give, in one message


def test_csv_without_known_columns_suggests_its_own(tmp_path):
    csv = tmp_path / "km.csv"
    csv.write_text("id,x_km,y_km\n1,0.5,0.5\n2,2,0\n3,1,3\n")
    result = run("hull", csv, tmp_path / "h.gpkg")
    assert result.exit_code == 1
    assert result.stderr == (
        f"Error: no coordinate columns found in {csv} (looked for "
        "longitude/latitude, lon/lat, lng/lat, long/lat, x/y, easting/northing); "
        "its columns are: id, x_km, y_km; name them, e.g. --x x_km --y y_km, "
        "with their CRS (--crs-in EPSG:...) or --crs-in none for planar numbers\n"
    )
    # ... and that command works
    again = run("-q", "hull", csv, tmp_path / "h.gpkg", "--x", "x_km", "--y",
                "y_km", "--crs-in", "none")  # fmt: skip
    assert again.exit_code == 0, again.stderr


def test_non_numeric_coordinates_are_named_by_row(tmp_path):
    csv = tmp_path / "bad.csv"
    csv.write_text("x,y\n0.5,0.5\nabc,0\n1,3\n2,n/a?\n")
    result = run("hull", csv, tmp_path / "h.gpkg", "--crs-in", "none")
    assert result.exit_code == 1
    assert result.stderr == (
        f"Error: coordinate column 'x' of {csv} has 1 non-numeric values (e.g. "
        "'abc' at index 1; the index counts data rows from 0)\n"
    )


# --------------------------------------------------------------------------
# Shapefile fields declared so that their values fit


def dbf_fields(path: Path) -> dict[str, tuple[str, int, int]]:
    raw = path.read_bytes()
    fields, offset = {}, 32
    while raw[offset] != 0x0D:
        field = raw[offset : offset + 32]
        name = field[:11].split(b"\0")[0].decode()
        fields[name] = (chr(field[11]), field[16], field[17])
        offset += 32
    return fields


@pytest.mark.parametrize("engine", ["pyogrio", "fiona"])
def test_shapefile_decimals_leave_room_for_the_largest_value(tmp_path, engine):
    out = tmp_path / "us.shp"
    assert run("-q", "demo", out, "--engine", engine).exit_code == 0
    fields = dbf_fields(out.with_suffix(".dbf"))
    back = gpd.read_file(out)
    for name in ("alpha", "radius", "area_m2"):
        kind, width, decimals = fields[name]
        digits = len(str(int(back[name].abs().max())))
        assert kind == "N" and digits + 1 + decimals <= width, (name, fields[name])
    assert fields["area_m2"][2] == 24 - 1 - 13  # Alaska: 2.4e12 m², 13 digits
    assert back["area_m2"].max() == pytest.approx(2.3685e12, rel=1e-4)


# --------------------------------------------------------------------------
# --unit km: planar km input gets area_m2

KM_CSV = "id,x_km,y_km,g\n1,0.5,0.5,a\n2,2,0,a\n3,1,3,a\n4,1.2,1.1,a\n"


def test_unit_km_writes_metres_and_area_m2(tmp_path):
    csv = tmp_path / "km.csv"
    csv.write_text(KM_CSV)
    plain, metres = tmp_path / "plain.gpkg", tmp_path / "metres.gpkg"
    flags = ["--x", "x_km", "--y", "y_km", "--crs-in", "none", "--by", "g"]
    assert run("-q", "hull", csv, plain, *flags).exit_code == 0
    result = run("hull", csv, metres, *flags, "--unit", "km")
    assert result.exit_code == 0, result.stderr
    assert (
        "Computed in the input coordinates, in km (--unit km), written in metres "
        "(alpha in 1/metre, radius in metres, area_m2): 1 group"
    ) in result.stdout
    km, m = gpd.read_file(plain).iloc[0], gpd.read_file(metres).iloc[0]
    assert "unit" not in gpd.read_file(metres).columns
    # the polygon (1.35 km² by the shoelace formula) in square metres
    assert km["area"] == pytest.approx(1.35) and km["unit"] == "coordinate unit"
    assert m["area_m2"] == pytest.approx(1.35e6)
    assert m["radius"] == pytest.approx(km["radius"] * 1000)
    assert m["alpha"] == pytest.approx(km["alpha"] / 1000)
    assert shapely.equals(m.geometry, km.geometry)  # the coordinates stay in km


def test_unit_km_takes_grow_in_metres(tmp_path):
    csv = tmp_path / "km.csv"
    csv.write_text(KM_CSV)
    flags = ["--x", "x_km", "--y", "y_km", "--crs-in", "none", "--by", "g"]
    out = tmp_path / "grown.gpkg"
    assert (
        run("-q", "hull", csv, out, *flags, "--unit", "km", "--grow", "100").exit_code
        == 0
    )
    exact = tmp_path / "exact.gpkg"
    assert run("-q", "hull", csv, exact, *flags, "--unit", "km").exit_code == 0
    grown, plain = gpd.read_file(out).geometry[0], gpd.read_file(exact).geometry[0]
    # 100 m is 0.1 km: the hull grows by about 0.1 on every side, not 100
    assert grown.bounds[2] - plain.bounds[2] == pytest.approx(0.1, rel=0.05)


def test_unit_is_refused_for_input_with_a_crs(tmp_path):
    result = run("hull", datasets.path("stats19"), tmp_path / "h.gpkg", "--unit", "km")
    assert result.exit_code == 1
    assert result.stderr == (
        f"Error: --unit km applies to planar coordinates without CRS (--crs-in "
        f"none); {datasets.path('stats19')} has a CRS, whose unit is used\n"
    )
