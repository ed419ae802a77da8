"""The command's GeoPackages opened by real QGIS (3.22 LTR on Debian 12).

QGIS runs headless (``QT_QPA_PLATFORM=offscreen``) through the system Python
(``/usr/bin/python3`` with ``python3-qgis``), which CI installs; locally the
tests are skipped when QGIS is absent unless ``GEOALPHA_REQUIRE_QGIS=1``.
"""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

import geopandas as gpd
import pytest
import shapely
from cli_runner import run

from geoalpha import datasets

SYSTEM_PYTHON = "/usr/bin/python3"

# Open every layer of a GeoPackage with QGIS; print what QGIS sees as JSON.
OPEN_IN_QGIS = """
import json, os, sys
from qgis.core import QgsApplication, QgsVectorLayer, QgsProviderRegistry
app = QgsApplication([], False)
app.initQgis()
path = sys.argv[1]
meta = QgsProviderRegistry.instance().providerMetadata("ogr")
layers = {}
for sub in meta.querySublayers(path):
    layer = QgsVectorLayer(f"{path}|layername={sub.name()}", sub.name(), "ogr")
    layers[sub.name()] = {
        "valid": layer.isValid(),
        "features": layer.featureCount(),
        "crs": layer.crs().authid(),
        "fields": [f.name() for f in layer.fields()],
    }
    del layer
print(json.dumps(layers), flush=True)
os._exit(0)  # exitQgis() with the provider registry alive can segfault
"""


def _has_qgis() -> bool:
    if not os.path.exists(SYSTEM_PYTHON):
        return False
    done = subprocess.run(
        [SYSTEM_PYTHON, "-c", "import qgis.core"],
        capture_output=True,
        timeout=120,
        check=False,
    )
    return done.returncode == 0


HAS_QGIS = _has_qgis()
pytestmark = pytest.mark.skipif(
    not HAS_QGIS and os.environ.get("GEOALPHA_REQUIRE_QGIS") != "1",
    reason="QGIS (python3-qgis) not installed; CI installs it",
)


def open_in_qgis(path: Path) -> tuple[dict, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTHON")}
    env["QT_QPA_PLATFORM"] = "offscreen"
    env["HOME"] = str(path.parent)  # QGIS writes its profile there
    done = subprocess.run(
        [SYSTEM_PYTHON, "-c", OPEN_IN_QGIS, str(path)],
        capture_output=True,
        text=True,
        env=env,
        timeout=180,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.strip().splitlines()[-1]), done.stderr


@pytest.mark.parametrize("engine", ["pyogrio", "fiona"])
def test_demo_geopackage_opens_in_qgis_silently_with_both_layers(tmp_path, engine):
    out = tmp_path / "hulls.gpkg"
    result = run("-q", "demo", out, "--engine", engine)
    assert result.exit_code == 0, result.stderr
    layers, messages = open_in_qgis(out)
    assert layers["hulls"]["valid"] and layers["points"]["valid"]
    assert layers["hulls"]["features"] == 56
    assert layers["points"]["features"] == 3376
    assert layers["hulls"]["crs"] == "EPSG:4326"
    assert {"state", "alpha", "area_m2", "n_points"} <= set(layers["hulls"]["fields"])
    assert "may only be partially supported" not in messages


def test_qgis_check_sees_the_version_warning_of_gdal_default(tmp_path):
    # The check above can fail: GDAL's default GeoPackage 1.4 makes QGIS warn.
    path = tmp_path / "v14.gpkg"
    gpd.GeoDataFrame(
        {"a": [1]}, geometry=[shapely.box(0, 0, 1, 1)], crs="EPSG:4326"
    ).to_file(path, layer="h", engine="pyogrio", dataset_options={"VERSION": "1.4"})
    layers, messages = open_in_qgis(path)
    assert layers["h"]["valid"]
    assert "may only be partially supported" in messages


# Count points with QGIS's own processing algorithms.
COUNT_IN_QGIS = """
import json, os, sys
from qgis.core import QgsApplication
app = QgsApplication([], False)
app.initQgis()
sys.path.append("/usr/share/qgis/python/plugins")
import processing
from processing.core.Processing import Processing
Processing.initialize()
path, hulls = sys.argv[1], sys.argv[2]
polygons, points = f"{path}|layername={hulls}", f"{path}|layername=points"
counted = processing.run(
    "native:countpointsinpolygon",
    {"POLYGONS": polygons, "POINTS": points, "FIELD": "N", "OUTPUT": "memory:"},
)["OUTPUT"]
out = {"count": int(sum(f["N"] for f in counted.getFeatures()))}
for code, name in [(0, "intersect"), (5, "within")]:
    joined = processing.run(
        "native:joinattributesbylocation",
        {"INPUT": points, "JOIN": polygons, "PREDICATE": [code], "METHOD": 1,
         "DISCARD_NONMATCHING": True, "OUTPUT": "memory:"},
    )["OUTPUT"]
    out[name] = joined.featureCount()
print(json.dumps(out), flush=True)
os._exit(0)
"""


def count_in_qgis(path: Path, layer: str) -> dict:
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTHON")}
    env["QT_QPA_PLATFORM"] = "offscreen"
    env["HOME"] = str(path.parent)
    done = subprocess.run(
        [SYSTEM_PYTHON, "-c", COUNT_IN_QGIS, str(path), layer],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_qgis_counts_boundary_points_only_with_grow(tmp_path):
    # The README's QGIS section quotes these numbers.
    exact = tmp_path / "exact.gpkg"
    assert run("-q", "demo", exact).exit_code == 0
    counts = count_in_qgis(exact, "exact")
    assert counts == {"count": 1970, "intersect": 3370, "within": 1968}
    grown = tmp_path / "grown.gpkg"
    assert run("-q", "demo", grown, "--grow", "1").exit_code == 0
    counts = count_in_qgis(grown, "grown")
    assert counts["count"] >= 3364  # every grouped airport, strictly inside
    assert counts["within"] == counts["intersect"] == 3370


def test_hulls_added_to_the_points_geopackage_open_beside_the_points(tmp_path):
    # The newcomer's command (#36): the hulls become a layer of the points'
    # own GeoPackage, the points layer keeps every row, QGIS opens both.
    both = tmp_path / "both.gpkg"
    from geoalpha import datasets

    datasets.load("us_airports").to_file(
        both, layer="zips", engine="pyogrio", dataset_options={"VERSION": "1.2"}
    )
    result = run(
        "-q", "hull", both, both, "--layer", "zips", "--by", "state",
        "--output-layer", "state_hulls",
    )  # fmt: skip
    assert result.exit_code == 0, result.stderr
    layers, messages = open_in_qgis(both)
    assert set(layers) == {"zips", "state_hulls"}
    assert layers["zips"]["valid"] and layers["state_hulls"]["valid"]
    assert layers["zips"]["features"] == 3376
    assert layers["state_hulls"]["features"] == 56
    assert "may only be partially supported" not in messages


def test_qgis_copies_a_shapefile_without_value_not_written_warnings(tmp_path):
    # QGIS's "Save Features As" copies the fields as declared; GDAL's default
    # N(24, 15) for area_m2 made it warn "Value 2368535149646.89844 of field
    # area_m2 ... not successfully written" for Alaska (and write nothing).
    import shutil

    out = tmp_path / "us.shp"
    assert run("-q", "demo", out).exit_code == 0
    # (Debian 12's qgis_process wrapper passes a flag its 3.22 binary refuses)
    qgis_process = shutil.which("qgis_process.bin") or shutil.which("qgis_process")
    assert qgis_process, "QGIS is installed but not qgis_process"
    env = {
        "PATH": "/usr/bin:/bin",
        "HOME": str(tmp_path),
        "QT_QPA_PLATFORM": "offscreen",
    }
    copy = tmp_path / "copy.shp"
    done = subprocess.run(
        [qgis_process, "run", "native:savefeatures", f"--INPUT={out}",
         f"--OUTPUT={copy}"],
        capture_output=True, text=True, env=env, timeout=300, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    assert "not successfully written" not in done.stdout + done.stderr
    ours, theirs = gpd.read_file(out), gpd.read_file(copy)
    assert theirs["area_m2"].max() == pytest.approx(ours["area_m2"].max(), rel=1e-9)
    assert ours["area_m2"].max() > 1e12  # Alaska: the value that did not fit


def test_explain_layers_open_in_qgis(tmp_path):
    # geoalpha hull --explain (issue #35): the hulls, 'why' and 'left_out'
    out = tmp_path / "hulls.gpkg"
    points = tmp_path / "airports.gpkg"
    airports = datasets.load("us_airports")
    airports[airports["state"].isin(["HI", "CO", "RI"])].to_file(points)
    result = run(
        "-q", "hull", points, out, "--by", "state", "--explain", "--outliers", "2"
    )
    assert result.exit_code == 0, result.stderr
    layers, messages = open_in_qgis(out)
    assert set(layers) == {"hulls", "why", "left_out"}
    assert all(layer["valid"] for layer in layers.values())
    assert layers["why"]["features"] == 3 and layers["why"]["crs"] == "EPSG:4326"
    # the rows the hulls count as left out, no more, no fewer (at most 2 each)
    n_outliers = gpd.read_file(out, layer="hulls")["n_outliers"]
    assert layers["left_out"]["features"] == n_outliers.sum() > 0
    assert n_outliers.max() <= 2
    assert {"state", "limited_by", "critical_rows", "suspicious"} <= set(
        layers["why"]["fields"]
    )
    assert {"iata", "name", "state"} <= set(layers["left_out"]["fields"])
    assert "may only be partially supported" not in messages
