"""The QGIS plugin under real QGIS: qgis_process and PyQGIS, in QGIS's own Python.

QGIS's Python (``/usr/bin/python3`` on Debian, numpy 1.x) is not the Python
running these tests, so everything QGIS runs is a subprocess with a bounded
timeout; the results are compared here with ``geoalpha.hull`` on the same file.
Without QGIS (or without geoalpha installed for QGIS's Python by
``install_geoalpha.py``) the tests skip, except when ``GEOALPHA_REQUIRE_QGIS=1``
(set by CI), where they fail instead.
"""

from __future__ import annotations

import json
import os
import re
import shlex
import shutil
import subprocess
import sys
import warnings
import zipfile
from pathlib import Path
from types import SimpleNamespace

import geopandas as gpd
import numpy as np
import pytest
import shapely

import geoalpha
from geoalpha import datasets
from geoalpha._frame.schema import DTYPES, RESULT_COLUMNS
from geoalpha._frame.why import EXPLAIN_COLUMNS
from geoalpha._options import META, NAMES, Options

ROOT = Path(__file__).resolve().parents[1]
PLUGIN_DIR = ROOT / "qgis_plugin"
DRIVER = Path(__file__).parent / "qgis" / "pyqgis_driver.py"
ALG = "geoalpha:optimalalphahulls"
TIMEOUT = 240  # seconds for one QGIS subprocess (each takes a few seconds)
REQUIRED = os.environ.get("GEOALPHA_REQUIRE_QGIS") == "1"
STATES = ["NV", "UT", "HI", "DC", "GU", "VI", "AK"]
RESULT = list(RESULT_COLUMNS)  # the fields after the group fields, as hull()'s
#: QGIS's type name of a GeoPackage field, by dtype of the result table.
QGIS_TYPES = {
    "float64": "Real",
    "int64": "Integer",
    "int32": "Integer",
    "text": "String",
}
DOCS = ROOT / "docs" / "user_guide" / "qgis_plugin.md"

sys.path.insert(0, str(ROOT / "scripts"))
import build_qgis_plugin  # noqa: E402

sys.path.pop(0)


def _unavailable(reason: str):
    if REQUIRED:
        pytest.fail(f"{reason} (GEOALPHA_REQUIRE_QGIS=1: the QGIS tests must run)")
    pytest.skip(reason)


def _qgis_process() -> str | None:
    found = shutil.which("qgis_process")
    if found is None:
        return None
    # Debian's /usr/bin/qgis_process wrapper passes --noversioncheck, which
    # qgis_process 3.22 rejects ("Command --noversioncheck not known!").
    binary = Path(found).with_name("qgis_process.bin")
    return str(binary) if binary.exists() else found


@pytest.fixture(scope="module")
def qgis(tmp_path_factory):
    """QGIS's executables and an environment that runs this checkout's code."""
    process = _qgis_process()
    python = os.environ.get("GEOALPHA_QGIS_PYTHON", "/usr/bin/python3")
    if process is None or not Path(python).exists():
        _unavailable("QGIS is not installed (no qgis_process or /usr/bin/python3)")
    tmp = tmp_path_factory.mktemp("qgis")
    runtime = tmp / "runtime"
    runtime.mkdir(mode=0o700)
    env = {
        k: v
        for k, v in os.environ.items()
        if k not in ("VIRTUAL_ENV", "PYTHONHOME", "PYTHONPATH", "QGIS_PLUGINPATH")
    }
    env.update(
        # An embedded Python finds its home through the first python3 on PATH.
        PATH=os.pathsep.join([str(Path(python).parent), env.get("PATH", "")]),
        PYTHONPATH=str(ROOT),  # this checkout's geoalpha, ahead of any installed
        QT_QPA_PLATFORM="offscreen",
        QGIS_CUSTOM_CONFIG_PATH=str(tmp / "profile"),
        XDG_RUNTIME_DIR=str(runtime),
        PYTHONWARNINGS="ignore::DeprecationWarning",
    )
    check = subprocess.run(
        [
            python,
            "-c",
            "import sys; import qgis.core; sys.path.insert(0, sys.argv[1]); "
            "from geoalpha_qgis import dependencies; dependencies.load()",
            str(PLUGIN_DIR),
        ],
        env=env,
        capture_output=True,
        text=True,
        timeout=TIMEOUT,
    )
    if check.returncode != 0:
        _unavailable(
            "QGIS's Python cannot import qgis or geoalpha's dependencies; run "
            f"{python} qgis_plugin/geoalpha_qgis/install_geoalpha.py: "
            + check.stderr.strip().splitlines()[-1]
        )
    return SimpleNamespace(process=process, python=python, env=env, tmp=tmp)


@pytest.fixture(scope="module")
def points(qgis):
    """Airports of seven states (two of one point each) and rows with no state."""
    airports = datasets.load("us_airports")
    sub = airports[airports["state"].isin(STATES) | airports["state"].isna()].copy()
    sub["region"] = (sub["longitude"] > -110).astype("int64")
    sub.loc[sub.index[sub["state"].eq("NV")][0], "geometry"] = None  # no geometry
    path = qgis.tmp / "points.gpkg"
    sub[["iata", "name", "state", "region", "geometry"]].to_file(
        path, layer="points", dataset_options={"VERSION": "1.2"}
    )
    return path


def run_process(qgis, *args, env=None, check=True):
    done = subprocess.run(
        [qgis.process, *args],
        env=env or qgis.env,
        capture_output=True,
        text=True,
        timeout=TIMEOUT,
        cwd=qgis.tmp,
    )
    if check and done.returncode != 0:
        raise AssertionError(f"qgis_process {args} failed:\n{done.stdout}{done.stderr}")
    return done


@pytest.fixture(scope="module")
def installed(qgis):
    """The plugin installed from the built ZIP into the QGIS profile, enabled."""
    archive = build_qgis_plugin.build(qgis.tmp / "dist")
    plugins = qgis.tmp / "profile" / "profiles" / "default" / "python" / "plugins"
    plugins.mkdir(parents=True)
    with zipfile.ZipFile(archive) as zf:
        zf.extractall(plugins)
    listed = run_process(qgis, "plugins", "enable", "geoalpha_qgis")
    assert "* geoalpha_qgis" in listed.stdout
    return plugins / "geoalpha_qgis"


@pytest.fixture(scope="module")
def by_state(qgis, installed, points):
    """``qgis_process run geoalpha:optimalalphahulls -- INPUT= FIELD=state OUTPUT=``."""
    out = qgis.tmp / "hulls.gpkg"
    done = run_process(
        qgis,
        "--json",
        "run",
        ALG,
        "--",
        f"INPUT={points.name}",
        "FIELD=state",
        f"OUTPUT={out.name}",
    )
    report = json.loads(done.stdout[done.stdout.index("{") :])
    return SimpleNamespace(report=report, path=out)


@pytest.fixture(scope="module")
def pyqgis(qgis, points):
    """The PyQGIS driver's report (several runs in one QGIS session)."""
    out = qgis.tmp / "pyqgis"
    out.mkdir()
    env = dict(qgis.env, QGIS_PLUGINPATH=str(PLUGIN_DIR))
    done = subprocess.run(
        [qgis.python, str(DRIVER), str(points), str(out)],
        env=env,
        capture_output=True,
        text=True,
        timeout=TIMEOUT,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    return json.loads(done.stdout.split("JSON:", 1)[1])


def expected(points, by, **options):
    """``geoalpha.hull`` in this Python on the file QGIS read."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", geoalpha.GeoAlphaWarning)
        return geoalpha.hull(gpd.read_file(points), by=by, **options)


def same_geometries(actual, wanted):
    """Polygon by polygon, the same vertices (a Polygon equals a one-part Multi)."""
    a = shapely.normalize(shapely.multipolygons(shapely.get_parts(actual)))
    b = shapely.normalize(shapely.multipolygons(shapely.get_parts(wanted)))
    return bool(shapely.equals_exact(a, b, tolerance=0))


def test_the_install_message_names_what_to_install_from(tmp_path):
    # (stdlib only: runs without QGIS) A plugin in a clone names that clone; a
    # copied plugin names WHEEL and says what it is. `install_geoalpha.py`
    # with no argument would ask PyPI for geoalpha.
    sys.path.insert(0, str(PLUGIN_DIR))
    try:
        from geoalpha_qgis import dependencies
    finally:
        sys.path.pop(0)
    in_clone = dependencies.install_message()
    installer = PLUGIN_DIR / "geoalpha_qgis" / "install_geoalpha.py"
    assert f'/usr/bin/python3 "{installer}" "{ROOT}"' in in_clone
    assert f'python "{installer}" "{ROOT}"' in in_clone
    assert "needs Rust >= 1.88; a downloaded wheel file in its place needs none" in (
        in_clone.replace("\n", " ")
    )
    copy = tmp_path / "plugins" / "geoalpha_qgis"
    shutil.copytree(PLUGIN_DIR / "geoalpha_qgis", copy)
    copied = dependencies.install_message(here=copy)
    assert f'/usr/bin/python3 "{copy / "install_geoalpha.py"}" WHEEL' in copied
    assert "WHEEL: the geoalpha wheel for your platform" in copied
    assert "geoalpha-<version>-cp310-abi3-<platform>.whl; needs no" in copied
    assert "or the folder of a geoalpha clone (needs Rust >= 1.88)" in copied


def test_zip_holds_the_plugin_folder(tmp_path):
    archive = build_qgis_plugin.build(tmp_path)
    with zipfile.ZipFile(archive) as zf:
        names = zf.namelist()
        meta = zf.read("geoalpha_qgis/metadata.txt").decode()
    assert archive.name == "geoalpha_qgis-0.2.0.zip"
    assert {n.split("/")[0] for n in names} == {"geoalpha_qgis"}
    assert "geoalpha_qgis/install_geoalpha.py" in names
    assert "geoalpha_qgis/LICENSE" in names
    assert not [n for n in names if "__pycache__" in n or n.endswith(".pyc")]
    assert "hasProcessingProvider=yes" in meta
    assert build_qgis_plugin.build(tmp_path).read_bytes() == archive.read_bytes()


def test_qgis_process_one_feature_per_group_as_hull(by_state, points):
    got = gpd.read_file(by_state.path)
    want = expected(points, "state")
    assert list(got.columns) == ["state", *RESULT, "geometry"]
    assert got["state"].tolist() == want["state"].tolist()  # one row per group
    assert got.crs == want.crs == "EPSG:4326"
    for a, b in zip(got.geometry, want.geometry, strict=True):
        assert same_geometries(a, b)
    assert got["alpha"].dtype == np.float64
    np.testing.assert_allclose(got["alpha"], want["alpha"], rtol=1e-12)
    assert got["alpha"].isna().tolist() == want["state"].isin(["DC", "GU"]).tolist()
    assert_same_values(got, want)


def assert_same_values(got, want):
    """Every result column of ``want`` (hull()) in ``got`` (QGIS's layer), alike."""
    for column in want.columns.drop(want.geometry.name):
        if want[column].dtype == np.float64:
            np.testing.assert_allclose(got[column], want[column], rtol=1e-9)
        else:
            assert got[column].tolist() == want[column].tolist(), column


def test_qgis_process_logs_degenerate_groups_and_dropped_rows(by_state):
    log = by_state.report["log"]["warning"]
    assert any(w.startswith("DegenerateGroupWarning") and "'DC'" in w for w in log)
    dropped = [w for w in log if w.startswith("DroppedRowsWarning")]
    assert len(dropped) == 1
    assert "13 of 365 rows" in dropped[0]
    assert "12 with a missing group key" in dropped[0]
    assert by_state.report["results"]["OUTPUT"].endswith("hulls.gpkg")


def test_qgis_process_lines_and_polygons_need_use_vertices(qgis, by_state):
    refused = run_process(
        qgis, "run", ALG, "--", "INPUT=hulls.gpkg", "OUTPUT=x.gpkg", check=False
    )
    assert refused.returncode != 0
    assert "Use the vertices of lines and polygons" in refused.stdout + refused.stderr
    run_process(
        qgis, "run", ALG, "--", "INPUT=hulls.gpkg", "VERTICES=true", "OUTPUT=v.gpkg"
    )
    got = gpd.read_file(qgis.tmp / "v.gpkg")
    want = expected(by_state.path, None, vertices=True)
    assert len(got) == 1
    assert same_geometries(got.geometry[0], want.geometry[0])


def test_qgis_process_says_how_to_install_when_geoalpha_is_missing(
    qgis, installed, points
):
    env = dict(qgis.env, PYTHONPATH="", GEOALPHA_QGIS_ENV=str(qgis.tmp / "none"))
    done = run_process(
        qgis,
        "run",
        ALG,
        "--",
        "INPUT=points.gpkg",
        "OUTPUT=n.gpkg",
        env=env,
        check=False,
    )
    text = done.stdout + done.stderr
    assert done.returncode != 0
    assert "geoalpha Python library is not installed for QGIS's Python" in text
    assert f'/usr/bin/python3 "{installed / "install_geoalpha.py"}" WHEEL' in text
    assert "WHEEL: the geoalpha wheel for your platform, downloaded from the" in text
    assert "OSGeo4W Shell" in text
    assert "QGIS-LTR.app/Contents/MacOS/bin/python3" in text
    assert not (qgis.tmp / "n.gpkg").exists()
    # The dialog asks canExecute() before it runs, and shows its message.
    done = subprocess.run(
        [
            qgis.python,
            "-c",
            "import sys; sys.path.insert(0, sys.argv[1]); "
            "from geoalpha_qgis.algorithm import OptimalAlphaHulls; "
            "ok, message = OptimalAlphaHulls().canExecute(); print(ok); print(message)",
            str(PLUGIN_DIR),
        ],
        env=env,
        capture_output=True,
        text=True,
        timeout=TIMEOUT,
    )
    assert done.stdout.startswith("False\nThe geoalpha Python library is not installed")
    assert "OSGeo4W Shell" in done.stdout


def test_pyqgis_fields_keep_the_input_types(pyqgis):
    run = pyqgis["by2"]
    fields = dict(map(tuple, run["layer"]["fields"]))
    inputs = dict(map(tuple, run["input_fields"]))
    assert list(fields) == ["state", "region", *RESULT]
    assert fields["state"] == inputs["state"] == "String"
    assert fields["region"] == inputs["region"] == "Integer64"
    assert [fields[c] for c in RESULT] == [QGIS_TYPES[DTYPES[c]] for c in RESULT]
    assert run["layer"]["crs"] == "EPSG:4326"


def test_pyqgis_every_point_in_its_hull_by_qgis_spatial_join(pyqgis, points):
    join = pyqgis["by2"]["join"]
    frame = gpd.read_file(points)
    n_keyed = int((frame["state"].notna() & frame.geometry.notna()).sum())
    assert join["checked"] == n_keyed > 300
    assert join["outside"] == []


def test_pyqgis_two_fields_same_geometries_as_hull(pyqgis, points):
    features = pyqgis["by2"]["layer"]["features"]
    want = expected(points, ["state", "region"])
    keys = [(f["attributes"]["state"], f["attributes"]["region"]) for f in features]
    assert keys == list(zip(want["state"], want["region"], strict=True))
    for feature, geometry, alpha in zip(
        features, want.geometry, want["alpha"], strict=True
    ):
        got = shapely.from_wkb(bytes.fromhex(feature["wkb"]))
        assert got.geom_type == "MultiPolygon"
        assert same_geometries(got, geometry)
        if np.isnan(alpha):
            assert feature["attributes"]["alpha"] is None
        else:
            assert isinstance(feature["attributes"]["alpha"], float)
            assert feature["attributes"]["alpha"] == pytest.approx(alpha, rel=1e-12)


def test_pyqgis_feedback_progress_and_warnings(pyqgis):
    run = pyqgis["by2"]
    assert run["progress"][0] == 0 and run["progress"][-1] == 100
    assert run["progress"] == sorted(run["progress"])
    assert any(
        "DegenerateGroupWarning" in w and "'DC, 1'" in w for w in run["warnings"]
    )
    assert any("8 hulls written" in i for i in run["infos"])


def test_pyqgis_cancel_stops_without_output(pyqgis):
    cancel = pyqgis["cancel"]
    assert cancel.get("result", {}) == {}
    assert cancel["written"] is False
    assert cancel["progress"] == [0.0]  # stopped at the first check


def test_pyqgis_no_field_one_hull_in_a_temporary_layer(pyqgis):
    assert pyqgis["memory"] == {"count": 1, "fields": RESULT}


def test_model_runs_the_algorithm_like_hull(pyqgis, points, qgis, installed):
    want = expected(points, "state", method="convex")
    features = pyqgis["model"]["layer"]["features"]
    assert [f["attributes"]["state"] for f in features] == want["state"].tolist()
    methods = [f["attributes"]["method"] for f in features]
    assert methods == want["method"].tolist()  # "buffer" for degenerate states
    assert set(methods) == {"convex", "buffer"}
    for feature, geometry in zip(features, want.geometry, strict=True):
        assert same_geometries(
            shapely.from_wkb(bytes.fromhex(feature["wkb"])), geometry
        )
    # The saved .model3 runs headless too, as a user's model file would.
    out = qgis.tmp / "model_cli.gpkg"
    run_process(
        qgis,
        "run",
        pyqgis["model"]["file"],
        "--",
        f"points={points}",
        f"hulls:hulls_out={out}",
    )
    assert gpd.read_file(out)["state"].tolist() == want["state"].tolist()


def test_bad_parameter_is_refused(pyqgis):
    assert "Incorrect parameter value for COMPONENTS" in pyqgis["bad"]


@pytest.mark.parametrize(
    ("run", "options"),
    [
        ("holes", {"holes": True, "components": 3, "degenerate": "empty"}),
        ("concave", {"method": "concave", "degenerate": "drop"}),
    ],
)
def test_pyqgis_options_reach_hull(pyqgis, points, run, options):
    want = expected(points, "state", **options)
    features = pyqgis[run]["features"]
    assert [f["attributes"]["state"] for f in features] == want["state"].tolist()
    for feature, geometry in zip(features, want.geometry, strict=True):
        if geometry.is_empty:  # degenerate="empty": GeoPackage stores it empty
            assert shapely.from_wkb(bytes.fromhex(feature["wkb"])).is_empty
        else:
            got = shapely.from_wkb(bytes.fromhex(feature["wkb"]))
            assert same_geometries(got, geometry)
    methods = [f["attributes"]["method"] for f in features]
    assert methods == want["method"].tolist()
    if run == "concave":
        assert "DC" not in want["state"].tolist()
    else:
        assert max(f["attributes"]["n_parts"] for f in features) > 1


def test_installer_keeps_qgis_packages_and_matches_geos(monkeypatch):
    sys.path.insert(0, str(PLUGIN_DIR / "geoalpha_qgis"))
    try:
        import install_geoalpha as installer
    finally:
        sys.path.pop(0)
    pins = installer.constraints()
    assert f"numpy=={np.__version__}" in pins
    assert all(line.split("==")[0] in installer.PINNED for line in pins)
    assert not [p for p in installer.constraints(("NumPy",)) if p.startswith("numpy")]
    monkeypatch.setattr(sys, "platform", "linux")
    assert installer.shapely_pin((3, 11)) == (["shapely>=2.0,<2.1"], [])
    assert installer.shapely_pin((3, 13)) == ([], [])
    assert installer.shapely_pin((3, 12)) == ([], ["--no-binary", "shapely"])
    assert installer.shapely_pin(None) == ([], [])
    monkeypatch.setattr(sys, "platform", "win32")  # DLLs keep their own GEOS
    assert installer.shapely_pin((3, 11)) == ([], [])


def test_batch_dialog_runs_one_output_per_row(pyqgis, points):
    batch = pyqgis["batch"]
    assert batch["errors"] == []  # a row that raised: its traceback
    for field, method in (("state", "alpha"), ("region", "convex")):
        want = expected(points, field, method=method)
        features = batch[field]["features"]
        assert [f["attributes"][field] for f in features] == want[field].tolist()
        methods = [f["attributes"]["method"] for f in features]
        assert methods == want["method"].tolist()  # "buffer" for degenerate groups
        assert set(methods) <= {method, "buffer"} and method in methods
        for feature, geometry in zip(features, want.geometry, strict=True):
            got = shapely.from_wkb(bytes.fromhex(feature["wkb"]))
            assert same_geometries(got, geometry)


def test_plugin_warns_when_shapely_needs_a_newer_geos_than_qgis():
    sys.path.insert(0, str(PLUGIN_DIR))
    try:
        from geoalpha_qgis import dependencies
    finally:
        sys.path.pop(0)
    message = dependencies.geos_mismatch((3, 13, 1), "3.11.1-CAPI-1.17.1", "linux")
    assert message.startswith("shapely was built for GEOS 3.13, but QGIS runs GEOS")
    assert "install_geoalpha.py" in message
    assert dependencies.geos_mismatch((3, 11, 4), "3.11.1-CAPI-1.17.1", "linux") is None
    assert dependencies.geos_mismatch((3, 13, 1), "3.14.0-CAPI-1.20.0", "linux") is None
    assert dependencies.geos_mismatch((3, 13, 1), "3.11.1", "darwin") is None


# --- issue #24: the plugin at parity with hull() --------------------------


def test_options_file_is_generated_from_options():
    # The plugin's parameters are read from this file, which the plugin build
    # writes from geoalpha._options.Options: it must be what the build writes now.
    committed = build_qgis_plugin.OPTIONS_FILE.read_text(encoding="utf-8")
    assert committed == build_qgis_plugin.options_text(), (
        "run python scripts/build_qgis_plugin.py"
    )
    spec = json.loads(committed)
    assert sorted([*spec["options"], *spec["left_out"]]) == sorted(NAMES)
    assert spec["result_columns"] == DTYPES


def test_qgis_process_parameters_are_the_options_of_hull(qgis, installed):
    done = run_process(qgis, "--json", "help", ALG)
    report = json.loads(done.stdout[done.stdout.index("{") :])
    params = report["parameters"]
    left_out = build_qgis_plugin.LEFT_OUT
    offered = [name for name in NAMES if name not in left_out]
    assert "outliers" in offered and "grow" in offered
    assert set(params) == {
        "INPUT",
        "FIELD",
        "OUTPUT",
        "WHY",
        "LEFT_OUT",
        *map(str.upper, offered),
    }
    assert params["WHY"]["optional"] and params["LEFT_OUT"]["optional"]
    defaults = Options()
    for name in offered:
        param, meta = params[name.upper()], META[name]
        assert param["default_value"] == getattr(defaults, name), name
        if meta.choices:
            assert param["raw_definition"]["options"] == list(meta.choices), name
        if meta.low is not None:
            assert param["raw_definition"]["min"] == meta.low, name
        if meta.high is not None:
            assert param["raw_definition"]["max"] == meta.high, name
        assert param["optional"] == meta.optional, name
        # The option's help, in QGIS's terms (METHOD=concave, not --method).
        assert param["help"] and "--" not in param["help"], name
    # The help (beside the dialog) says what is left out and why.
    described = run_process(qgis, "help", ALG).stdout
    for name, why in left_out.items():
        assert f"<i>{name}</i>: {why}" in described
    assert ", ".join(RESULT) in described  # the output fields, from the schema


@pytest.mark.parametrize(
    "options",
    [{"outliers": 2}, {"outliers": 0.05, "grow": 1000.0}],
    ids=["outliers-count", "outliers-fraction-grow"],
)
def test_qgis_process_outliers_and_grow_reach_hull(qgis, installed, points, options):
    out = qgis.tmp / f"outliers_{len(options)}.gpkg"
    values = [f"{name.upper()}={value}" for name, value in options.items()]
    run_process(
        qgis,
        "run",
        ALG,
        "--",
        f"INPUT={points.name}",
        "FIELD=state",
        *values,
        f"OUTPUT={out.name}",
    )
    got = gpd.read_file(out)
    want = expected(points, "state", **options)
    assert list(got.columns) == ["state", *RESULT, "geometry"]
    assert got["n_outliers"].sum() == want["n_outliers"].sum() > 0
    assert_same_values(got, want)
    for a, b in zip(got.geometry, want.geometry, strict=True):
        if "grow" in options:  # a buffer: QGIS's GEOS may round differently
            assert shapely.hausdorff_distance(a, b) < 1e-9  # degrees
        else:
            assert same_geometries(a, b)


def test_qgis_process_overlap_split_reaches_hull(qgis, installed):
    # Airports of states whose hulls overlap (MD with DC, VA and WV; OH with WV).
    airports = datasets.load("us_airports")
    sub = airports[airports["state"].isin(["DC", "MD", "OH", "VA", "WV"])]
    points = qgis.tmp / "neighbours.gpkg"
    sub[["state", "geometry"]].to_file(points, layer="neighbours")
    out = qgis.tmp / "split.gpkg"
    run_process(
        qgis,
        "run",
        ALG,
        "--",
        f"INPUT={points.name}",
        "FIELD=state",
        "OVERLAP=split",
        f"OUTPUT={out.name}",
    )
    got = gpd.read_file(out)
    want = expected(points, "state", overlap="split")
    split = ["area_ceded_m2", "neighbours"]
    assert list(got.columns) == ["state", *RESULT, *split, "geometry"]
    assert got["area_ceded_m2"].sum() > 0  # the states' hulls overlapped
    # QGIS's GEOS (3.11 on Debian 12, loaded by QGIS) may round a cut otherwise
    # than this Python's: a vertex kept or dropped along a straight cut (the
    # edge's geodesic, and with it area_m2, differs by 1e-5 of West Virginia's)
    # or two pieces that touch kept apart (n_parts); the same ground.
    loose = ["area_m2", "area_ceded_m2", "n_parts"]
    assert_same_values(got.drop(columns=loose), want.drop(columns=loose))
    for column in loose[:2]:  # within 1e-3 of the group's area
        gap = (got[column] - want[column]).abs()
        assert (gap <= 1e-3 * want["area_m2"] + 1.0).all(), column
    for a, b in zip(got.geometry, want.geometry, strict=True):
        assert a.symmetric_difference(b).area <= 1e-6 * b.area
    # no hull overlaps another: their pairwise intersections have no area
    geoms = list(got.geometry)
    total = sum(g.area for g in geoms)
    assert (
        sum(a.intersection(b).area for i, a in enumerate(geoms) for b in geoms[i + 1 :])
        <= 1e-9 * total
    )


@pytest.fixture(scope="module")
def km_points(qgis):
    """Points in kilometres without a CRS, as a GeoPackage and a Shapefile.

    A GeoPackage without a CRS opens in QGIS with a valid "Undefined SRS"
    (no units); a Shapefile without .prj with an invalid CRS.
    """
    airports = datasets.load("us_airports")
    sub = airports[airports["state"].isin(["NV", "UT"])].to_crs("EPSG:32612")
    km = sub.geometry.scale(1e-3, 1e-3, origin=(0, 0))
    frame = gpd.GeoDataFrame(
        {"state": sub["state"].to_numpy()}, geometry=km.to_numpy(), crs=None
    )
    assert frame.crs is None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # "'crs' was not provided"
        frame.to_file(qgis.tmp / "km.gpkg", layer="km")
        frame.to_file(qgis.tmp / "km.shp")
    return frame


@pytest.mark.parametrize("name", ["km.gpkg", "km.shp"])
def test_qgis_process_refuses_a_layer_without_crs(qgis, installed, km_points, name):
    out = qgis.tmp / "km_refused.gpkg"
    done = run_process(
        qgis,
        "run",
        ALG,
        "--",
        f"INPUT={name}",
        "FIELD=state",
        f"OUTPUT={out.name}",
        check=False,
    )
    text = done.stdout + done.stderr
    assert done.returncode != 0
    assert "The input layer has no CRS" in text
    assert "geoalpha does not guess" in text
    assert "CRS=none in qgis_process" in text
    assert not out.exists()


def test_qgis_process_crs_none_writes_area_and_unit(qgis, installed, km_points):
    out = qgis.tmp / "km_planar.gpkg"
    run_process(
        qgis,
        "run",
        ALG,
        "--",
        "INPUT=km.gpkg",
        "FIELD=state",
        "CRS=none",
        f"OUTPUT={out.name}",
        "WHY=km_why.gpkg",
    )
    got = gpd.read_file(out)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", geoalpha.GeoAlphaWarning)
        want = geoalpha.hull(km_points, by="state", crs=None)
        explained = geoalpha.explain(km_points, by="state", crs=None)
    # the layer WHY: explain()'s area_without_1 (km²) and unit, as the hulls
    why = gpd.read_file(qgis.tmp / "km_why.gpkg").sort_values("state")
    assert "area_m2_without_1" not in why.columns
    assert set(why["unit"]) == {"coordinate unit"}
    explained = explained.sort_values("state")
    np.testing.assert_allclose(
        why["area_without_1"], explained["area_without_1"], rtol=1e-12
    )
    planar = [
        c for name in RESULT for c in ((name,), ("area", "unit"))[name == "area_m2"]
    ]
    assert list(got.columns) == ["state", *planar, "geometry"]
    assert set(got["unit"]) == {"coordinate unit"}
    np.testing.assert_allclose(got["area"], want["area"], rtol=1e-9)  # km2
    assert got["area"].max() < 1e6  # square km, not a value in square metres
    assert_same_values(got, want)
    for a, b in zip(got.geometry, want.geometry, strict=True):
        assert same_geometries(a, b)


def test_qgis_process_csv_path_says_it_has_no_geometry(qgis, installed, points):
    frame = gpd.read_file(points)
    frame = frame[frame["state"].notna() & frame.geometry.notna()]
    csv = qgis.tmp / "airports.csv"
    frame.assign(longitude=frame.geometry.x, latitude=frame.geometry.y)[
        ["state", "longitude", "latitude"]
    ].to_csv(csv, index=False)
    done = run_process(
        qgis,
        "run",
        ALG,
        "--",
        f"INPUT={csv.name}",
        "FIELD=state",
        "OUTPUT=csv.gpkg",
        check=False,
    )
    text = done.stdout + done.stderr
    assert done.returncode != 0
    assert f"The input layer ({csv}) has no geometry" in text
    assert "no CRS" not in text
    uri = (
        f"delimitedtext://file://{csv}?type=csv&xField=longitude&yField=latitude"
        "&crs=EPSG:4326"
    )
    assert uri in text
    # The form the message shows reads the file's points.
    run_process(
        qgis, "run", ALG, "--", f"INPUT={uri}", "FIELD=state", "OUTPUT=csv.gpkg"
    )
    got = gpd.read_file(qgis.tmp / "csv.gpkg")
    want = expected(points, "state")
    assert got["state"].tolist() == want["state"].tolist()
    for a, b in zip(got.geometry, want.geometry, strict=True):
        assert same_geometries(a, b)


def test_docs_qgis_process_command_runs_from_an_activated_venv(
    qgis, installed, points, tmp_path
):
    # The README leaves the user in a virtual environment (geoalpha's); there
    # qgis_process crashed (exit 139, "Couldn't load SIP module"). The first
    # qgis_process command of the plugin page must work from such a shell.
    page = DOCS.read_text(encoding="utf-8")
    command = next(
        line.split("#")[0].strip()
        for block in re.findall(r"^ *```bash\n(.*?)\n *```", page, re.S | re.M)
        for line in block.splitlines()
        if re.search(r"\bqgis_process(\.bin)? run ", line)
    )
    venv = tmp_path / "venv"
    subprocess.run(
        [sys.executable, "-m", "venv", "--without-pip", str(venv)],
        check=True,
        timeout=TIMEOUT,
    )
    env = dict(
        qgis.env,
        VIRTUAL_ENV=str(venv),  # as `source venv/bin/activate` leaves it
        PATH=os.pathsep.join([str(venv / "bin"), os.environ["PATH"]]),
    )
    shutil.copy(points, tmp_path / "points.gpkg")
    # This machine's qgis_process (the page names Debian's qgis_process.bin).
    command = re.sub(
        r"\bqgis_process(\.bin)?(?= run )", shlex.quote(qgis.process), command
    )
    done = subprocess.run(
        ["bash", "-c", command],
        env=env,
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=TIMEOUT,
    )
    assert done.returncode == 0, f"{command}\n{done.stdout}{done.stderr}"
    got = gpd.read_file(tmp_path / "hulls.gpkg")
    assert got["state"].tolist() == expected(points, "state")["state"].tolist()


def test_docs_list_every_parameter():
    page = DOCS.read_text(encoding="utf-8")
    table = page[page.index("| `INPUT`") :]
    table = table[: table.index("\n\n")]
    spec = json.loads(build_qgis_plugin.OPTIONS_FILE.read_text(encoding="utf-8"))
    for name in spec["options"]:
        assert f"| `{name.upper()}` | `{name}` |" in table, name
    for name in spec["left_out"]:
        assert f"`{name}`" in page[page.index("Not offered") :], name
    for column in RESULT:
        assert f"`{column}`" in page, column


def test_pyqgis_why_and_left_out_layers(pyqgis, points):
    got = pyqgis["why"]
    assert got["outputs"] == ["LEFT_OUT", "OUTPUT", "WHY"]
    options = dict(outliers=1, outlier_unit="locations")
    gdf = gpd.read_file(points)  # fid i + 1 is row i (as geopandas wrote it)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", geoalpha.GeoAlphaWarning)
        why = geoalpha.explain(gdf, by="state", **options)
        left = geoalpha.outlier_rows(gdf, by="state", **options)
    layer = got["why"]
    assert [name for name, _ in layer["fields"]] == ["state", *EXPLAIN_COLUMNS]
    assert layer["crs"] == "EPSG:4326"
    features = {f["attributes"]["state"]: f for f in layer["features"]}
    assert sorted(features) == sorted(why["state"])
    for row in why.itertuples():
        feature = features[row.state]["attributes"]
        if np.isnan(row.radius):  # a group without shape: NULL in QGIS
            assert feature["radius"] is None
        else:
            assert feature["radius"] == pytest.approx(row.radius, rel=1e-12)
        assert feature["limited_by"] == row.limited_by
        assert feature["critical_rows"] == ", ".join(
            str(label + 1) for label in row.critical_rows
        )
        assert bool(feature["suspicious"]) == bool(row.suspicious)
        wkb = features[row.state]["wkb"]
        if row.geometry is None:  # no triangle: a NULL or empty geometry
            assert wkb is None or shapely.from_wkb(bytes.fromhex(wkb)).is_empty
        else:
            assert shapely.equals_exact(
                shapely.from_wkb(bytes.fromhex(wkb)), row.geometry, tolerance=0
            )
    # the features left out, copied with every field
    rows = got["left_out"]
    assert [name for name, _ in rows["fields"]] == [
        name for name, _ in pyqgis["by2"]["input_fields"]
    ]
    assert sorted(f["attributes"]["iata"] for f in rows["features"]) == sorted(
        gdf.loc[left.to_numpy(), "iata"]
    )
    assert len(rows["features"]) == int(left.sum()) > 0
    assert "METHOD=alpha" in got["convex"]
