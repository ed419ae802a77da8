"""Writing never deletes what the user did not name (issue #36, item 2).

The newcomer's habit: add the hulls as a layer of the points' own GeoPackage,
``geoalpha hull both.gpkg both.gpkg --layer zips --by state --output-layer
state_hulls``. The input layer keeps all its rows; ``--overwrite`` replaces
only the layer named; the layer being read is never the target; a write
killed half-way leaves the old file, and nothing beside it.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import geopandas as gpd
import pandas as pd
import pyogrio
import pytest
import shapely
from cli_runner import run

from geoalpha import datasets
from geoalpha._io.files import check_output, geopackage_layers, write_hulls

REPO = Path(__file__).resolve().parents[1]
GROUP = "Local_Authority_(Highway)"
AUTHORITIES = ["E09000033", "E09000013", "E09000030", "E09000007"]


def layer_counts(path: Path) -> dict[str, int]:
    return {
        name: pyogrio.read_info(path, layer=name)["features"]
        for name, _ in pyogrio.list_layers(path)
    }


@pytest.fixture
def both(tmp_path) -> Path:
    """A GeoPackage with the points (layer ``zips``) and one more layer."""
    points = datasets.load("stats19")
    points = points[points[GROUP].isin(AUTHORITIES)].reset_index(drop=True)
    path = tmp_path / "both.gpkg"
    points.to_file(path, layer="zips", engine="pyogrio")
    notes = gpd.GeoDataFrame(
        {"note": ["keep me"]}, geometry=[shapely.Point(-0.1, 51.5)], crs=4326
    )
    notes.to_file(path, layer="notes", engine="pyogrio")
    return path


def zips_of(path: Path) -> pd.DataFrame:
    return pyogrio.read_dataframe(path, layer="zips").drop(columns="geometry")


def newcomer(both: Path, *more: str):
    return run(
        "-q", "hull", both, both, "--layer", "zips", "--by", GROUP,
        "--output-layer", "state_hulls", *more,
    )  # fmt: skip


@pytest.mark.parametrize("overwrite", [False, True], ids=["plain", "--overwrite"])
def test_newcomers_command_adds_a_layer_and_keeps_the_points(both, overwrite):
    points = zips_of(both)
    result = newcomer(both, *(["--overwrite"] if overwrite else []))
    assert result.exit_code == 0, result.stderr
    assert layer_counts(both) == {
        "zips": len(points),
        "notes": 1,
        "state_hulls": len(AUTHORITIES),
    }
    pd.testing.assert_frame_equal(zips_of(both), points)  # every row, as it was
    hulls = gpd.read_file(both, layer="state_hulls")
    assert sorted(hulls[GROUP]) == sorted(AUTHORITIES)
    assert hulls["n_points"].sum() == len(points)


def test_a_second_output_layer_is_added_beside_the_first(both):
    assert newcomer(both).exit_code == 0
    result = run(
        "-q", "hull", both, both, "--layer", "zips", "--by", GROUP,
        "--output-layer", "grown_hulls", "--grow", "1",
    )  # fmt: skip
    assert result.exit_code == 0, result.stderr
    assert set(layer_counts(both)) == {"zips", "notes", "state_hulls", "grown_hulls"}
    assert layer_counts(both)["grown_hulls"] == len(AUTHORITIES)


def test_an_existing_layer_is_refused_then_only_it_is_replaced(both):
    assert newcomer(both).exit_code == 0
    first = gpd.read_file(both, layer="state_hulls")
    again = newcomer(both)
    assert again.exit_code == 1
    assert again.stderr == (
        f"Error: layer 'state_hulls' of output {both} already exists; use "
        "--overwrite to replace that layer (its other layers are kept), or "
        "another --output-layer\n"
    )
    grown = newcomer(both, "--overwrite", "--grow", "1")
    assert grown.exit_code == 0, grown.stderr
    replaced = gpd.read_file(both, layer="state_hulls")
    assert (replaced["area_m2"].to_numpy() > first["area_m2"].to_numpy()).all()
    assert layer_counts(both)["zips"] == len(zips_of(both)) > 0
    assert layer_counts(both)["notes"] == 1


@pytest.mark.parametrize("flags", [[], ["--overwrite"]], ids=["plain", "--overwrite"])
def test_the_layer_being_read_is_never_the_target(both, flags):
    before = both.read_bytes()
    result = run(
        "hull", both, both, "--layer", "zips", "--by", GROUP, "--output-layer", "zips",
        *flags,
    )  # fmt: skip
    assert result.exit_code == 1
    assert result.stderr == (
        f"Error: OUTPUT {both} is INPUT and its layer 'zips' is the layer read: "
        "geoalpha does not write over its input; give another --output-layer, "
        "e.g. --output-layer zips_hulls, to add the hulls beside the points\n"
    )
    assert both.read_bytes() == before


def test_default_output_layer_is_the_file_name_and_is_added(both):
    result = run("-q", "hull", both, both, "--layer", "zips", "--by", GROUP)
    assert result.exit_code == 0, result.stderr
    assert set(layer_counts(both)) == {"zips", "notes", "both"}


def test_an_open_geopackage_is_not_replaced(both):
    wal = Path(f"{both}-wal")
    wal.write_bytes(b"")
    before = both.read_bytes()
    result = newcomer(both)
    assert result.exit_code == 1
    assert result.stderr == (
        f"Error: output {both} is open in another program or was not closed "
        "(both.gpkg-wal exists beside it); close it (e.g. in QGIS) and run again\n"
    )
    assert both.read_bytes() == before


# --------------------------------------------------------------------------
# write_hulls in Python


def small_hulls(n: int = 2) -> gpd.GeoDataFrame:
    return gpd.GeoDataFrame(
        {"key": [f"k{i}" for i in range(n)]},
        geometry=[shapely.box(i, 0, i + 1, 1) for i in range(n)],
        crs=4326,
    )


@pytest.mark.parametrize("engine", ["pyogrio", "fiona"])
def test_write_hulls_adds_and_replaces_only_the_named_layer(both, engine):
    points = zips_of(both)
    write_hulls(small_hulls(2), both, layer="state_hulls", engine=engine)
    assert layer_counts(both) == {"zips": len(points), "notes": 1, "state_hulls": 2}
    with pytest.raises(FileExistsError) as err:
        write_hulls(small_hulls(3), both, layer="STATE_HULLS", engine=engine)
    assert str(err.value) == (
        f"layer 'state_hulls' of output {both} already exists; use overwrite=True "
        "to replace that layer (its other layers are kept), or another layer="
    )
    write_hulls(small_hulls(3), both, layer="state_hulls", overwrite=True)
    assert layer_counts(both) == {"zips": len(points), "notes": 1, "state_hulls": 3}
    pd.testing.assert_frame_equal(zips_of(both), points)
    assert geopackage_layers(both) == ["zips", "notes", "state_hulls"]


def test_check_output_looks_at_the_layer_of_a_geopackage(both):
    check_output(both, layer="new")  # adding a layer: fine
    with pytest.raises(FileExistsError, match="layer 'zips' of output"):
        check_output(both, layer="zips")
    check_output(both, layer="zips", overwrite=True)


def test_a_file_that_is_not_a_geopackage_is_a_file(tmp_path):
    path = tmp_path / "h.gpkg"
    path.write_text("precious")
    with pytest.raises(FileExistsError, match="already exists; use overwrite=True"):
        write_hulls(small_hulls(), path, layer="h")
    assert path.read_text() == "precious"


def test_a_geopackage_that_changed_while_writing_is_left_as_it_is(both, monkeypatch):
    to_file = gpd.GeoDataFrame.to_file

    def meanwhile(self, filename, *args, **kwargs):
        to_file(self, filename, *args, **kwargs)
        pyogrio.write_dataframe(small_hulls(1), both, layer="by_someone_else")

    monkeypatch.setattr(gpd.GeoDataFrame, "to_file", meanwhile)
    with pytest.raises(OSError, match="changed while geoalpha was writing it"):
        write_hulls(small_hulls(), both, layer="state_hulls")
    monkeypatch.undo()
    assert set(layer_counts(both)) == {"zips", "notes", "by_someone_else"}


# --------------------------------------------------------------------------
# killed half-way: the old file, and nothing beside it

KILLED_WRITER = """
import sys, time, pathlib
import geopandas as gpd, shapely
from geoalpha._io.files import write_hulls
to_file = gpd.GeoDataFrame.to_file
def slow(self, filename, *args, **kwargs):
    to_file(self, filename, *args, **kwargs)
    marker = pathlib.Path(sys.argv[2])  # written, not yet moved (said atomically)
    marker.with_suffix(".part").write_text(str(filename))
    marker.with_suffix(".part").replace(marker)
    time.sleep(120)
gpd.GeoDataFrame.to_file = slow
hulls = gpd.GeoDataFrame({"k": ["a"]}, geometry=[shapely.box(0, 0, 1, 1)], crs=4326)
write_hulls(hulls, sys.argv[1], layer=sys.argv[3], overwrite=True)
"""


def child_env(tmp: Path) -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(
        p for p in (str(REPO), env.get("PYTHONPATH")) if p
    )
    env["TMPDIR"] = str(tmp)  # where tempfile stages (the same file system)
    return env


@pytest.mark.parametrize("layer", ["zips", "state_hulls"], ids=["replace", "add"])
def test_sigkill_mid_write_leaves_the_old_file_and_nothing_beside_it(both, layer):
    folder, tmp = both.parent, both.parent.parent / f"{both.parent.name}-tmp"
    tmp.mkdir()
    before = both.read_bytes()
    listing = sorted(p.name for p in folder.iterdir())
    marker = tmp / "written.txt"
    child = subprocess.Popen(
        [sys.executable, "-c", KILLED_WRITER, str(both), str(marker), layer],
        env=child_env(tmp),
    )
    deadline = time.monotonic() + 120
    while not marker.exists() and child.poll() is None and time.monotonic() < deadline:
        time.sleep(0.02)
    assert marker.exists(), "the writer never reached its staged file"
    staged = Path(marker.read_text())
    assert staged.parent.parent == tmp  # staged in TMPDIR, not beside the output
    child.send_signal(signal.SIGKILL)
    assert child.wait(timeout=60) == -signal.SIGKILL
    assert sorted(p.name for p in folder.iterdir()) == listing  # nothing left
    assert both.read_bytes() == before  # the old layers, every byte
    assert staged.exists()  # left where the next run (or the OS) cleans
    done = subprocess.run(
        [sys.executable, "-c", KILLED_WRITER.replace("time.sleep(120)", "pass"),
         str(both), str(marker), "more"],
        env=child_env(tmp), capture_output=True, text=True, timeout=120, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert not staged.parent.exists()  # the next run removed the dead run's folder
    assert sorted(p.name for p in tmp.iterdir()) == ["written.txt"]
    assert set(layer_counts(both)) == {"zips", "notes", "more"}


def test_the_point_layer_chosen_without_layer_is_not_the_target(points_first, tmp_path):
    before = points_first.read_bytes()
    result = run(
        "hull", points_first, points_first, "--by", GROUP, "--output-layer", "zips",
        "--overwrite",
    )  # fmt: skip
    assert result.exit_code == 1
    assert "is INPUT and its layer 'zips' is the layer read" in result.stderr
    assert points_first.read_bytes() == before


@pytest.fixture
def points_first(both) -> Path:
    """``both.gpkg`` with a polygon layer first and one point layer, ``zips``."""
    path = both.parent / "poly_first.gpkg"
    pyogrio.write_dataframe(small_hulls(1), path, layer="areas")
    pyogrio.write_dataframe(
        pyogrio.read_dataframe(both, layer="zips"), path, layer="zips"
    )
    return path


def test_a_rename_across_mount_points_goes_through_a_copy(both, monkeypatch):
    # The temporary folder on the same file system but another mount: EXDEV.
    import errno

    replace = os.replace
    calls = []

    def cross_device(source, destination):
        calls.append(Path(source).parent)
        if Path(source).parent.parent != Path(destination).parent:
            raise OSError(errno.EXDEV, "Invalid cross-device link")
        replace(source, destination)

    monkeypatch.setattr(os, "replace", cross_device)
    write_hulls(small_hulls(2), both, layer="state_hulls")
    monkeypatch.undo()
    assert len(calls) == 2  # refused, then from beside the output
    assert layer_counts(both)["state_hulls"] == 2
    assert sorted(p.name for p in both.parent.iterdir()) == ["both.gpkg"]


def test_a_layer_that_appears_while_computing_is_not_replaced(both, monkeypatch):
    import geoalpha._io.files as files

    check = files._check_target

    def racing_check(*args, **kwargs):
        checked = check(*args, **kwargs)  # the layer is free here ...
        pyogrio.write_dataframe(small_hulls(1), both, layer="state_hulls")
        return checked  # ... and taken by another run before the copy

    monkeypatch.setattr(files, "_check_target", racing_check)
    with pytest.raises(FileExistsError) as err:
        write_hulls(small_hulls(3), both, layer="state_hulls")
    assert str(err.value) == (
        f"layer 'state_hulls' of output {both} appeared while geoalpha was "
        "computing (another run writing the same layer?) and was not replaced; "
        "use overwrite=True to replace it"
    )
    monkeypatch.undo()
    assert layer_counts(both)["state_hulls"] == 1  # the other run's
