"""Reading point files and writing hull files (geoalpha._io.files)."""

from __future__ import annotations

import os

import geopandas as gpd
import pandas as pd
import pytest
from compat import requires_fiona, requires_pyarrow, requires_pyogrio
from shapely import MultiPolygon, box

from geoalpha import datasets
from geoalpha._io.files import check_output, read_points, write_hulls
from geoalpha.errors import InvalidInputError

GROUP = "Local_Authority_(Highway)"


FORMATS = [
    ".gpkg",
    ".shp",
    ".geojson",
    ".fgb",
    pytest.param(".parquet", marks=requires_pyarrow),
]
ENGINES = [
    pytest.param("pyogrio", marks=requires_pyogrio),
    pytest.param("fiona", marks=requires_fiona),
]


def make_hulls(crs="EPSG:4326") -> gpd.GeoDataFrame:
    """A small table shaped like the result of geoalpha.hull()."""
    if crs == "EPSG:4326":
        a, b, c = box(-0.2, 51.5, -0.1, 51.6), box(-1.6, 53.7, -1.5, 53.8), None
        c = MultiPolygon([box(-2.3, 53.4, -2.2, 53.5), box(-2.1, 53.4, -2.0, 53.5)])
    else:
        a, b = box(530000, 180000, 531000, 181500), box(430000, 433000, 431000, 434000)
        c = MultiPolygon([box(383000, 398000, 384000, 399000), box(0, 0, 10, 10)])
    return gpd.GeoDataFrame(
        {
            GROUP: ["E09000020", "E08000035", "E08000003"],
            "alpha": [0.0123456789, 0.5, 2.0],
            "radius": [81.0, 2.0, 0.5],
            "n_points": pd.array([586, 12, 3], dtype="int64"),
            "area_m2": [1.5e7, 3.2e5, 40.0],
            "crs_used": ["EPSG:32630"] * 3,
            "method": ["alpha"] * 3,
        },
        geometry=[a, b, c],
        crs=crs,
    )


def read_back(path, engine):
    if str(path).endswith(".parquet"):
        return gpd.read_parquet(path)
    return gpd.read_file(path, engine=engine)


def listing(directory):
    return sorted(os.listdir(directory))


# --------------------------------------------------------------------------
# write_hulls: round trips


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("suffix", FORMATS)
def test_round_trip_every_format_and_engine(tmp_path, suffix, engine):
    hulls = make_hulls()
    path = tmp_path / f"hulls{suffix}"
    mapping = write_hulls(hulls, path, engine=engine)
    back = read_back(path, engine)
    group = GROUP
    if suffix == ".shp":
        assert mapping == {GROUP: "Local_Auth"}
        group = "Local_Auth"
        assert set(back.columns) == {"Local_Auth", *hulls.columns[1:]}
    else:
        assert mapping == {}
        assert list(back.columns) == list(hulls.columns)
    assert back.crs == hulls.crs
    assert back.geometry.geom_equals(hulls.geometry).all()
    assert back[group].tolist() == hulls[GROUP].tolist()
    assert back["alpha"].tolist() == hulls["alpha"].tolist()
    assert back["n_points"].tolist() == [586, 12, 3]
    assert back["crs_used"].tolist() == ["EPSG:32630"] * 3
    assert listing(tmp_path) == sorted(
        [f"hulls{s}" for s in (".shp", ".shx", ".dbf", ".prj", ".cpg")]
        if suffix == ".shp"
        else [f"hulls{suffix}"]
    )


@pytest.mark.parametrize("suffix", [".shp", ".gpkg", ".fgb"])
def test_projected_crs_survives(tmp_path, suffix):
    hulls = make_hulls("EPSG:27700")
    write_hulls(hulls, tmp_path / f"h{suffix}")
    back = gpd.read_file(tmp_path / f"h{suffix}")
    assert back.crs == hulls.crs
    assert back.geometry.geom_equals(hulls.geometry).all()


def test_shapefile_writes_prj_and_utf8_cpg(tmp_path):
    write_hulls(make_hulls(), tmp_path / "h.shp")
    assert "GCS_WGS_1984" in (tmp_path / "h.prj").read_text()
    assert (tmp_path / "h.cpg").read_text().strip().upper() in {"UTF-8", "UTF8"}


def test_shapefile_truncation_avoids_collisions(tmp_path):
    hulls = make_hulls()
    hulls["Local_Authority_Name"] = ["Lambeth", "Leeds", "Manchester"]
    hulls["Local_Auth"] = [1, 2, 3]  # already fits: keeps its name
    mapping = write_hulls(hulls, tmp_path / "h.shp")
    assert mapping == {GROUP: "Local_Au_1", "Local_Authority_Name": "Local_Au_2"}
    back = gpd.read_file(tmp_path / "h.shp")
    assert back["Local_Auth"].tolist() == [1, 2, 3]
    assert back["Local_Au_1"].tolist() == hulls[GROUP].tolist()
    assert back["Local_Au_2"].tolist() == ["Lambeth", "Leeds", "Manchester"]


def test_shapefile_names_are_unique_ignoring_case_and_fit_in_10_bytes(tmp_path):
    hulls = make_hulls()[["alpha", "geometry"]]
    hulls["Area"] = 1.0
    hulls["area"] = 2.0
    hulls["Größenklasse"] = "a"  # 14 bytes in UTF-8
    mapping = write_hulls(hulls, tmp_path / "h.shp")
    assert mapping == {"area": "area_1", "Größenklasse": "Größenkl"}
    back = gpd.read_file(tmp_path / "h.shp")
    assert back["Area"].tolist() == [1.0] * 3
    assert back["area_1"].tolist() == [2.0] * 3
    assert back["Größenkl"].tolist() == ["a"] * 3


def test_named_index_is_written_as_a_column(tmp_path):
    hulls = make_hulls().set_index(GROUP)
    mapping = write_hulls(hulls, tmp_path / "h.shp")
    assert mapping == {GROUP: "Local_Auth"}
    back = gpd.read_file(tmp_path / "h.shp")
    assert back["Local_Auth"].tolist() == hulls.index.tolist()


@requires_pyogrio
def test_geopackage_layer_name_and_crs(tmp_path):
    import pyogrio

    write_hulls(make_hulls(), tmp_path / "uk.gpkg")
    write_hulls(make_hulls("EPSG:27700"), tmp_path / "bng.gpkg", layer="accidents")
    assert pyogrio.list_layers(tmp_path / "uk.gpkg")[:, 0].tolist() == ["uk"]
    info = pyogrio.read_info(tmp_path / "bng.gpkg", layer="accidents")
    assert info["crs"] == "EPSG:27700"
    assert info["features"] == 3


# --------------------------------------------------------------------------
# write_hulls: refusing, failing safely


@pytest.mark.parametrize(
    "suffix", [".gpkg", ".shp", pytest.param(".parquet", marks=requires_pyarrow)]
)
def test_existing_output_is_refused_unless_overwrite(tmp_path, suffix):
    path = tmp_path / f"h{suffix}"
    write_hulls(make_hulls(), path)
    with pytest.raises(FileExistsError, match="overwrite=True"):
        write_hulls(make_hulls().iloc[:1], path)
    assert len(read_back(path, None)) == 3
    write_hulls(make_hulls().iloc[:1], path, overwrite=True)
    assert len(read_back(path, None)) == 1


def test_a_lone_shapefile_sidecar_blocks_the_write(tmp_path):
    (tmp_path / "h.dbf").write_bytes(b"precious")
    with pytest.raises(FileExistsError, match=r"h\.dbf already exists"):
        write_hulls(make_hulls(), tmp_path / "h.shp")
    assert (tmp_path / "h.dbf").read_bytes() == b"precious"


def test_overwriting_a_shapefile_removes_its_stale_sidecars(tmp_path):
    write_hulls(make_hulls(), tmp_path / "h.shp")
    (tmp_path / "h.qix").write_bytes(b"old spatial index")
    write_hulls(make_hulls(), tmp_path / "h.shp", overwrite=True)
    assert not (tmp_path / "h.qix").exists()


@pytest.mark.parametrize("suffix", [".gpkg", ".shp"])
def test_failed_write_leaves_old_file_intact_and_no_temp_file(
    tmp_path, monkeypatch, suffix
):
    path = tmp_path / f"h{suffix}"
    write_hulls(make_hulls(), path)
    before = {name: (tmp_path / name).read_bytes() for name in listing(tmp_path)}

    def half_write(self, filename, *args, **kwargs):
        # a writer that dies after producing part of the output
        with open(filename, "wb") as handle:
            handle.write(b"half a file")
        with open(os.path.splitext(filename)[0] + ".dbf", "wb") as handle:
            handle.write(b"half a table")
        raise RuntimeError("disk full")

    monkeypatch.setattr(gpd.GeoDataFrame, "to_file", half_write)
    with pytest.raises(OSError, match=f"cannot write {path}: disk full") as err:
        write_hulls(make_hulls().iloc[:1], path, overwrite=True)
    assert "geoalpha-" not in str(err.value)  # never the staging folder
    after = {name: (tmp_path / name).read_bytes() for name in listing(tmp_path)}
    assert after == before  # same files, same bytes, no temporary left
    monkeypatch.undo()
    assert len(gpd.read_file(path)) == 3


@requires_pyarrow
def test_failed_first_write_leaves_nothing(tmp_path, monkeypatch):
    def fail(self, *args, **kwargs):
        raise RuntimeError("boom")

    monkeypatch.setattr(gpd.GeoDataFrame, "to_parquet", fail)
    with pytest.raises(OSError, match=r"h\.parquet: boom"):
        write_hulls(make_hulls(), tmp_path / "h.parquet")
    assert listing(tmp_path) == []


@pytest.mark.parametrize(
    ("kwargs", "error", "message"),
    [
        ({"path": "h.csv"}, InvalidInputError, "extension must be one of .gpkg"),
        ({"path": "h.shp", "layer": "x"}, InvalidInputError, "GeoPackage"),
        ({"path": "h.gpkg", "engine": "gdal"}, InvalidInputError, "unknown engine"),
        ({"path": "nowhere/h.gpkg"}, FileNotFoundError, "directory"),
    ],
)
def test_write_hulls_rejects_bad_arguments(tmp_path, kwargs, error, message):
    kwargs["path"] = tmp_path / kwargs["path"]
    with pytest.raises(error, match=message):
        write_hulls(make_hulls(), **kwargs)
    assert listing(tmp_path) == []


def test_write_hulls_needs_a_geodataframe(tmp_path):
    with pytest.raises(InvalidInputError, match="got DataFrame"):
        write_hulls(pd.DataFrame({"a": [1]}), tmp_path / "h.gpkg")


def test_check_output_checks_before_any_work(tmp_path):
    (tmp_path / "h.fgb").write_bytes(b"x")
    with pytest.raises(FileExistsError, match="overwrite=True"):
        check_output(tmp_path / "h.fgb")
    check_output(tmp_path / "h.fgb", overwrite=True)
    (tmp_path / "d.gpkg").mkdir()
    with pytest.raises(IsADirectoryError):
        check_output(tmp_path / "d.gpkg", overwrite=True)


# --------------------------------------------------------------------------
# read_points


@pytest.mark.parametrize(
    ("x", "y"),
    [
        ("Longitude", "Latitude"),
        ("lon", "lat"),
        ("LNG", "Lat"),
        ("long", "lat"),
    ],
)
def test_csv_coordinate_columns_are_detected(tmp_path, x, y):
    path = tmp_path / "p.csv"
    path.write_text(f"name,{x},{y}\na,-0.1,51.5\nb,-1.5,53.8\n")
    gdf = read_points(path)
    assert gdf.crs == "EPSG:4326"
    assert gdf.geometry.x.tolist() == [-0.1, -1.5]
    assert gdf.geometry.y.tolist() == [51.5, 53.8]
    assert gdf["name"].tolist() == ["a", "b"]


def test_easting_northing_with_their_crs(tmp_path):
    path = tmp_path / "p.csv"
    path.write_text("Easting;Northing;zone\n530000;180000;a\n430000;433000;b\n")
    gdf = read_points(path, crs="EPSG:27700")  # ';' delimiter detected
    assert gdf.crs == "EPSG:27700"
    assert gdf.geometry.x.tolist() == [530000, 430000]
    assert gdf["zone"].tolist() == ["a", "b"]


def test_projected_coordinates_in_lonlat_crs_are_refused(tmp_path):
    path = tmp_path / "p.csv"
    path.write_text("easting,northing\n530000,180000\n")
    with pytest.raises(InvalidInputError, match=r"1 points.*crs=, e\.g\. EPSG:27700"):
        read_points(path, crs="EPSG:4326")


def test_planar_coordinates_without_crs(tmp_path):
    path = tmp_path / "p.csv"
    path.write_text("x,y\n530000,180000\n")
    assert read_points(path, crs=None).crs is None


def test_explicit_coordinate_columns(tmp_path):
    path = tmp_path / "p.csv"
    path.write_text("lon,lat,gx,gy\n1,2,3,4\n")
    gdf = read_points(path, x="gx", y="gy", crs="EPSG:4326")
    assert (gdf.geometry.x[0], gdf.geometry.y[0]) == (3, 4)


def test_no_coordinate_columns_lists_the_columns(tmp_path):
    path = tmp_path / "p.csv"
    path.write_text("site,value\na,1\n")
    with pytest.raises(InvalidInputError, match=r"columns are: site, value"):
        read_points(path)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"x": "lon"}, "both x= and y="),
        ({"x": "lon", "y": "nope"}, r"'nope' not found.*columns are: lon, lat"),
        ({"crs": "EPSG:99999999"}, "unknown CRS"),
        ({"layer": "a"}, r"layer= applies to multi-layer files"),
    ],
)
def test_bad_csv_options(tmp_path, kwargs, message):
    path = tmp_path / "p.csv"
    path.write_text("lon,lat\n1,2\n")
    with pytest.raises(InvalidInputError, match=message):
        read_points(path, **kwargs)


def test_non_numeric_coordinates_are_named(tmp_path):
    path = tmp_path / "p.csv"
    path.write_text("lon,lat\n1,2\n3°E,4\n")
    with pytest.raises(InvalidInputError, match=r"'lon'.*1 non-numeric.*'3°E'"):
        read_points(path)


def test_missing_coordinates_give_missing_geometry(tmp_path):
    path = tmp_path / "p.csv"
    path.write_text("lon,lat\n1,2\n,4\n")
    gdf = read_points(path)
    assert gdf.geometry.isna().tolist() == [False, True]


def test_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError, match=r"nope\.csv does not exist"):
        read_points(tmp_path / "nope.csv")


@pytest.mark.parametrize(
    "name", ["bad.gpkg", "bad.csv", pytest.param("bad.parquet", marks=requires_pyarrow)]
)
def test_unreadable_file(tmp_path, name):
    path = tmp_path / name
    path.write_bytes(b"\xff\xfe\x00garbage\x00\x81" * 10)
    with pytest.raises(InvalidInputError, match=r"cannot read .*bad\."):
        read_points(path)


def test_vector_files_keep_their_crs_and_layers(tmp_path):
    pts = datasets.load("stats19").iloc[:20].to_crs("EPSG:27700")
    pts.to_file(tmp_path / "p.gpkg", layer="accidents")
    pts.iloc[:5].to_file(tmp_path / "p.gpkg", layer="few")
    gdf = read_points(tmp_path / "p.gpkg", layer="few")
    assert len(gdf) == 5
    assert gdf.crs == "EPSG:27700"
    with pytest.raises(InvalidInputError, match=r"x= and y= apply to tables"):
        read_points(tmp_path / "p.gpkg", x="Easting", y="Northing")
    with pytest.raises(InvalidInputError, match="cannot read"):
        read_points(tmp_path / "p.gpkg", layer="nope")


def test_shapefile_without_prj_gets_the_given_crs(tmp_path):
    pts = datasets.load("stats19").iloc[:10]
    pts[["Longitude", "geometry"]].to_file(tmp_path / "p.shp")
    (tmp_path / "p.prj").unlink()
    with pytest.raises(InvalidInputError, match=r"no CRS.*crs=None to use"):
        read_points(tmp_path / "p.shp")  # no guess
    assert read_points(tmp_path / "p.shp", crs=4258).crs == "EPSG:4258"
    assert read_points(tmp_path / "p.shp", crs=None).crs is None


@requires_pyarrow
def test_geoparquet_and_plain_parquet(tmp_path):
    pts = datasets.load("stats19").iloc[:10]
    pts.to_parquet(tmp_path / "geo.parquet")
    pd.DataFrame(pts.drop(columns="geometry")).to_parquet(tmp_path / "plain.parquet")
    geo = read_points(tmp_path / "geo.parquet")
    plain = read_points(tmp_path / "plain.parquet")
    assert geo.geometry.geom_equals(pts.geometry).all()
    assert plain.geometry.geom_equals(pts.geometry).all()
    assert plain.crs == geo.crs == "EPSG:4326"


def test_bundled_dataset_reads_like_datasets_load():
    gdf = read_points(datasets.path("stats19"))
    assert gdf.geometry.geom_equals(datasets.load("stats19").geometry).all()
