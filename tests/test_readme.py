"""The examples of the README and of the documentation pages run as written.

The README is a front page; the sections it had (command line, QGIS, outliers,
dask, ...) are pages of ``docs/`` now, read here in the order below.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner
from compat import require_for_module

from geoalpha._cli import main

#: Packages of the optional extras that an example may need.
OPTIONAL_MODULES = {
    "matplotlib",
    "dask",
    "dask_geopandas",
    "distributed",
    "pyarrow",
    "tqdm",
    "folium",
    "mapclassify",
    "sqlalchemy",
    "psycopg",
    "geoalchemy2",
}

REPO = Path(__file__).resolve().parents[1]
OTHER_PAGES = sorted(
    p
    for p in (REPO / "docs").rglob("*.md")
    if "_build" not in p.parts and p.name != "cli.md"
)
PAGES = [REPO / "README.md", REPO / "docs" / "cli.md", *OTHER_PAGES]
README = "\n\n".join(p.read_text() for p in PAGES)
NOT_RUN = "<!-- readme-test: not run"
WITH_PARQUET = "<!-- readme-test: with GeoParquet files of points in points/"
# Blocks that need a PostGIS database: run by tests/test_postgis.py on its own
# throwaway server.
WITH_POSTGIS = "<!-- readme-test: with a PostGIS database"
# Blocks for QGIS's Python console: run under real QGIS by test_qgis_plugin.py.
IN_QGIS = "<!-- readme-test: in QGIS's Python console"
# Excerpts of the source (docs/architecture.md), not examples to run.
EXCERPT = "<!-- readme-test: an excerpt of"
BLOCK = re.compile(r"(?P<before>[^\n]*)\n```(?P<lang>\w+)\n(?P<code>.*?)\n```", re.S)
# Data a block says it needs, made before it runs.
PARQUET_POINTS = """
from pathlib import Path
from geoalpha import datasets
points = datasets.load("us_airports")
Path("points").mkdir()
points.iloc[:2000].to_parquet("points/part.0.parquet")
points.iloc[2000:].to_parquet("points/part.1.parquet")
del points
"""


def python_blocks():
    for match in BLOCK.finditer(README):
        if match["lang"] == "python" and not match["before"].startswith(
            (NOT_RUN, WITH_POSTGIS, IN_QGIS, EXCERPT)
        ):
            line = README[: match.start("code")].count("\n") + 1
            setup = PARQUET_POINTS if match["before"].startswith(WITH_PARQUET) else ""
            yield pytest.param(setup + match["code"], id=f"line-{line}")


def test_only_the_cluster_block_is_not_run():
    # Connecting to a dask cluster needs one; every other block runs below
    # (or, marked so, under PostGIS or QGIS in their own tests).
    assert README.count(NOT_RUN) == 1
    assert "Client(" in README[README.index(NOT_RUN) :].split("```")[1]


@pytest.mark.parametrize("code", list(python_blocks()))
def test_python_example_runs(code, tmp_path):
    # A fresh interpreter, as a reader would run it (nothing imported before).
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(
        p for p in (str(REPO), env.get("PYTHONPATH")) if p
    )
    done = subprocess.run(
        [sys.executable, "-c", code],
        cwd=tmp_path,  # examples write files
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    missing = re.search(
        r"(?:No module named|Missing optional dependency) '([\w.]+)'", done.stderr
    )
    if done.returncode and missing and missing[1].split(".")[0] in OPTIONAL_MODULES:
        # An example of an optional extra (plotting, dask, ...), with only
        # ".[test]" installed: skipped here, an error where everything is.
        require_for_module(False, missing[1])
    assert done.returncode == 0, done.stderr


def test_demo_output_is_what_the_readme_shows(tmp_path, monkeypatch):
    block = README[README.index("$ geoalpha demo hulls.gpkg") :]
    shown = block[: block.index("```")].splitlines()[1:]
    monkeypatch.chdir(tmp_path)
    try:
        runner = CliRunner(mix_stderr=False)  # click < 8.2
    except TypeError:
        runner = CliRunner()
    result = runner.invoke(main, ["demo", "hulls.gpkg"])
    assert result.exit_code == 0, result.stderr
    # As a terminal shows them: the warnings (stderr), then the summary (stdout).
    assert result.stderr.splitlines() + result.stdout.splitlines() == shown
    assert all(line.startswith("Warning: ") for line in result.stderr.splitlines())


def test_cli_table_lists_every_option_of_hull():
    table = README[README.index("| `--by COL[,COL...]`") :]
    table = table[: table.index("\n\n")]
    names = [
        o for p in main.commands["hull"].params for o in [*p.opts, *p.secondary_opts]
    ]
    assert "--progress" in names
    for name in names:
        if name.startswith("--"):
            assert f"`{name}" in table or f"/{name}`" in table, name
