"""The ``geoalpha`` command under faults: races, kills, bad folders, secrets."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import types
from pathlib import Path

import geopandas as gpd
import pytest
import shapely
from cli_runner import run

from geoalpha import datasets
from geoalpha._io.files import check_output, remove_stale_staging, write_hulls
from geoalpha._io.redact import redact, secrets_in

REPO = Path(__file__).resolve().parents[1]
GROUP = "Local_Authority_(Highway)"
SECRET = "s3cr3t-Pw"


def staging_dirs(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if ".geoalpha-" in p.name)


def env() -> dict[str, str]:
    out = dict(os.environ)
    out["PYTHONPATH"] = os.pathsep.join(
        p for p in (str(REPO), out.get("PYTHONPATH")) if p
    )
    return out


def geoalpha_command(*args) -> list[str]:
    return [sys.executable, "-m", "geoalpha", *map(str, args)]


@pytest.fixture
def small_csv(tmp_path):
    pts = datasets.load("stats19")
    pts = pts[pts[GROUP].isin(["E09000033", "E09000013", "E09000030"])]
    path = tmp_path / "in.csv"
    pts[["Longitude", "Latitude", GROUP]].to_csv(path, index=False)
    return path


@pytest.fixture
def racing_hull(monkeypatch):
    """A fast hull(); while its result is written, another run creates files."""
    state = {"create": [], "calls": 0}
    to_file = gpd.GeoDataFrame.to_file

    def racing_to_file(self, filename, *args, **kwargs):
        to_file(self, filename, *args, **kwargs)
        for path in state["create"]:
            Path(path).write_text("written by another run")

    monkeypatch.setattr(gpd.GeoDataFrame, "to_file", racing_to_file)

    def hull(gdf, by=None, **options):
        state["calls"] += 1
        out = gdf.dissolve(by=by, as_index=False)[[by, "geometry"]]
        out["geometry"] = shapely.buffer(out.geometry.convex_hull.array, 1e-4)
        for column in ("alpha", "radius", "n_points", "area_m2"):
            out[column] = 1.0
        out["crs_used"], out["method"] = "EPSG:32630", "alpha"
        return out

    monkeypatch.setitem(
        sys.modules, "geoalpha._hulls", types.SimpleNamespace(hull=hull)
    )
    return state


# --------------------------------------------------------------------------
# two runs, one output


@pytest.mark.parametrize("suffix", [".gpkg", ".shp"])
def test_output_that_appears_while_computing_is_not_replaced(
    racing_hull, small_csv, tmp_path, suffix
):
    out = tmp_path / f"h{suffix}"
    racing_hull["create"] = [out]
    result = run("hull", small_csv, out, "--by", GROUP)
    assert result.exit_code == 1
    assert result.stderr == (
        f"Error: output {out} appeared while geoalpha was computing (another run "
        "writing the same file?) and was not replaced; use --overwrite to replace "
        "it\n"
    )
    assert out.read_text() == "written by another run"
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["in.csv", out.name])


def test_overwrite_replaces_a_file_that_appeared_meanwhile(
    racing_hull, small_csv, tmp_path
):
    out = tmp_path / "h.gpkg"
    racing_hull["create"] = [out]
    result = run("-q", "hull", small_csv, out, "--by", GROUP, "--overwrite")
    assert result.exit_code == 0, result.stderr
    assert len(gpd.read_file(out)) == 3


def test_shapefile_sidecar_that_appeared_meanwhile_rolls_back(
    racing_hull, small_csv, tmp_path
):
    out = tmp_path / "h.shp"
    racing_hull["create"] = [tmp_path / "h.dbf"]  # only a sidecar is taken
    result = run("hull", small_csv, out, "--by", GROUP)
    assert result.exit_code == 1
    assert "h.dbf appeared while geoalpha was computing" in result.stderr
    # nothing of this run is left: no .shp without its .dbf
    assert sorted(p.name for p in tmp_path.iterdir()) == ["h.dbf", "in.csv"]


def test_two_concurrent_runs_one_wins_the_other_fails(small_csv, tmp_path):
    out = tmp_path / "h.gpkg"
    args = geoalpha_command("hull", small_csv, out, "--by", GROUP)
    runs = [
        subprocess.Popen(
            args, env=env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
        )
        for _ in range(2)
    ]
    results = [(p.wait(timeout=120), p.stderr.read()) for p in runs]
    for p in runs:
        p.stdout.close()
        p.stderr.close()
    codes = sorted(code for code, _ in results)
    assert codes == [0, 1], results
    loser = next(err for code, err in results if code == 1)
    assert "use --overwrite" in loser
    assert "already exists" in loser or "appeared while geoalpha" in loser
    assert len(gpd.read_file(out)) == 3
    assert staging_dirs(tmp_path) == []


# --------------------------------------------------------------------------
# killed runs leave nothing for good


def test_staging_folder_of_a_killed_run_is_removed_by_the_next_run(tmp_path):
    # Staged in the temporary folder (same file system), never beside OUTPUT.
    folder, temporary = tmp_path / "out", tmp_path / "tmp"
    folder.mkdir()
    temporary.mkdir()
    out = folder / "uk.gpkg"
    args = geoalpha_command("-q", "demo", out, "--dataset", "uk_clusters")
    killed_env = env() | {"TMPDIR": str(temporary)}
    left = []
    for _ in range(6):  # bounded: kill while the file is being staged
        process = subprocess.Popen(
            args, env=killed_env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
        )
        deadline = time.monotonic() + 120
        while process.poll() is None and time.monotonic() < deadline:
            if list(temporary.glob("geoalpha-*/uk.gpkg")):
                process.send_signal(signal.SIGKILL)
                break
            time.sleep(0.002)
        process.wait(timeout=60)
        left = sorted(p.name for p in temporary.iterdir())
        if left and process.returncode == -signal.SIGKILL:
            break
        out.unlink(missing_ok=True)
    assert left, "no run was killed while staging its output"
    assert list(folder.iterdir()) == []  # nothing beside the output
    # The next run removes the dead run's staging folder.
    done = subprocess.run(
        geoalpha_command("-q", "demo", out, "--dataset", "stats19"),
        env=killed_env,
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    assert list(temporary.iterdir()) == []
    assert sorted(p.name for p in folder.iterdir()) == ["uk.gpkg"]
    assert len(gpd.read_file(out, layer="uk")) == 13
    assert len(gpd.read_file(out, layer="points")) == 1017


def test_only_staging_folders_of_dead_processes_are_removed(tmp_path):
    finished = subprocess.run([sys.executable, "-c", "pass"], check=True)
    assert finished.returncode == 0
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait(timeout=60)
    from geoalpha._io.files import _host_tag

    host = _host_tag()
    stale = tmp_path / f".h.gpkg.geoalpha-{host}-{dead.pid}-abc"
    live = tmp_path / f".h.gpkg.geoalpha-{host}-{os.getpid()}-def"
    other_host = tmp_path / f".h.gpkg.geoalpha-00000000-{dead.pid}-ghi"
    unrelated = tmp_path / ".h.gpkg.backup"
    for folder in (stale, live, other_host, unrelated):
        folder.mkdir()
        (folder / "h.gpkg").write_bytes(b"x" * 1000)
    assert remove_stale_staging(tmp_path) == [stale]
    check_output(tmp_path / "h.gpkg")  # also cleans, and leaves no probe
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        p.name for p in (live, other_host, unrelated)
    )


# --------------------------------------------------------------------------
# refused before computing, never naming a temporary file


def test_upper_case_shp_is_refused_before_computing(racing_hull, small_csv, tmp_path):
    result = run("hull", small_csv, tmp_path / "OUT.SHP", "--by", GROUP)
    assert result.exit_code == 1
    assert result.stderr == (
        "Error: a Shapefile needs the lower-case extension .shp (GDAL writes "
        f"OUT.shp for OUT.SHP): use {tmp_path}/OUT.shp\n"
    )
    assert racing_hull["calls"] == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in.csv"]


def unprivileged() -> list[str]:
    """Prefix that runs a command as an ordinary user (root ignores modes)."""
    if os.geteuid() != 0:
        return []
    setpriv = shutil.which("setpriv")
    assert setpriv, "tests that need an ordinary user run as root need setpriv"
    return [setpriv, "--reuid=nobody", "--regid=nogroup", "--clear-groups"]


@pytest.fixture
def shared_dir():
    """A folder an ordinary user can enter (pytest's tmp_path is root-only)."""
    folder = Path(tempfile.mkdtemp(prefix="geoalpha-faults-"))
    folder.chmod(0o755)
    yield folder
    for path in [folder, *folder.rglob("*")]:
        path.chmod(0o755 if path.is_dir() else 0o644)
    shutil.rmtree(folder)


def test_read_only_output_folder_is_refused_before_computing(shared_dir):
    locked = shared_dir / "locked"
    locked.mkdir()
    locked.chmod(0o555)
    started = time.monotonic()
    done = subprocess.run(
        [
            *unprivileged(),
            *geoalpha_command("demo", locked / "h.gpkg", "--dataset", "stats19"),
        ],
        env=env(),
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 1, done.stderr
    # One line, before any computing (which would warn about 7 groups first).
    assert done.stderr == (
        f"Error: cannot write to the output folder {locked}: permission denied\n"
    )
    assert list(locked.iterdir()) == []
    assert time.monotonic() - started < 60


def test_unreadable_input_exits_1(shared_dir):
    source = shared_dir / "in.csv"
    source.write_text("lon,lat\n1,2\n3,4\n5,7\n")
    source.chmod(0o000)
    out = shared_dir / "out"
    out.mkdir()
    out.chmod(0o777)  # writable for the ordinary user
    done = subprocess.run(
        [*unprivileged(), *geoalpha_command("hull", source, out / "h.gpkg")],
        env=env(),
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 1
    assert done.stderr == f"Error: cannot read input file {source}: permission denied\n"


# --------------------------------------------------------------------------
# never print credentials


@pytest.mark.parametrize(
    "source",
    [
        f"PG:host=localhost port=1 user=me password={SECRET} dbname=gis",
        f"PG:host=localhost password='{SECRET} with space' dbname=gis",
        f"postgresql://me:{SECRET}@localhost:1/gis",
        f"http://me:{SECRET}@127.0.0.1:9/points.gpkg",
        f"/vsicurl/https://example.invalid/p.gpkg?token={SECRET}",
        f"MSSQL:server=localhost;database=gis;UID=me;PWD={SECRET};",
    ],
)
@pytest.mark.parametrize("verbose", [[], ["-v"], ["-vv"]])
def test_unopenable_input_never_shows_its_password(tmp_path, source, verbose):
    result = run(*verbose, "hull", source, tmp_path / "h.gpkg")
    assert result.exit_code == 1
    text = result.stdout + result.stderr
    assert SECRET not in text
    if not source.startswith(("PG:", "postgresql://")):
        # Named in the message, with the password masked. (PostGIS sources
        # are refused or reported without echoing the source at all.)
        assert "***" in text
    assert result.stderr.splitlines()[-1].startswith("Error: ")
    if verbose:
        assert "Traceback" in result.stderr


def test_secrets_stay_out_of_warnings_and_summaries(tmp_path, monkeypatch):
    import warnings

    def read(*args, **kwargs):
        warnings.warn(f"slow server for {kwargs} {args[0]}", UserWarning, stacklevel=1)
        raise RuntimeError(f"lost connection to {args[0]}")

    monkeypatch.setattr("geoalpha._io.files.read_input_points", read)
    source = f"PG:dbname=gis password={SECRET}"
    result = run("-v", "hull", source, tmp_path / "h.gpkg")
    assert result.exit_code == 1
    assert SECRET not in result.stderr
    assert "Warning: slow server" in result.stderr
    assert result.stderr.splitlines()[-1] == (
        "Error: RuntimeError: lost connection to PG:dbname=gis password=*** "
        "(rerun as 'geoalpha -v ...' for the traceback)"
    )


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        (
            f"PG:host=db user=me password={SECRET} dbname=gis",
            "PG:host=db user=me password=*** dbname=gis",
        ),
        (
            f"PG:host=db PASSWORD = '{SECRET} \\' x' dbname=gis",
            "PG:host=db PASSWORD = *** dbname=gis",
        ),
        (
            f"postgresql://me:{SECRET}@db:5432/gis?sslmode=require",
            "postgresql://me:***@db:5432/gis?sslmode=require",
        ),
        (
            f"https://host/a.gpkg?X-Amz-Signature={SECRET}&X-Amz-Date=1",
            "https://host/a.gpkg?X-Amz-Signature=***&X-Amz-Date=1",
        ),
        (f"Driver=x;UID=me;PWD={SECRET};", "Driver=x;UID=me;PWD=***;"),
        (
            "cannot read hulls.gpkg: no such file",
            "cannot read hulls.gpkg: no such file",
        ),
    ],
)
def test_redact(text, expected):
    assert redact(text) == expected


def test_known_secrets_are_redacted_out_of_context():
    source = f"https://me:{SECRET}@example.com/a.gpkg"
    assert secrets_in(source) == [SECRET]
    message = f"cannot read {source}: nonnumeric port: '{SECRET}@example.com'"
    assert redact(message, secrets_in(source)) == (
        "cannot read https://me:***@example.com/a.gpkg: nonnumeric port: "
        "'***@example.com'"
    )
    # a short password is removed where it stands alone, not inside words
    assert redact("user=ab pw: ab, table abc", ["ab"]) == "user=*** pw: ***, table abc"


_LONG_TOKEN = """
import sys
from geoalpha._io.redact import redact

secret = sys.argv[1]
token = "Ab1" * 1_700_000  # 5 MB of letters and digits: one field of a CSV
url = f"postgresql://me:{secret}@db/gis?token={secret}"
out = redact(f"no column 'g' in {token},x=1: {url}")
assert out == (
    f"no column 'g' in {token},x=1: postgresql://me:***@db/gis?token=***"
), out[-80:]
out = redact(f"cannot read https://me:{token}@host/a.csv?sig={token}&n=1")
assert out == "cannot read https://me:***@host/a.csv?sig=***&n=1", out[-80:]
"""


def test_redact_is_linear_in_a_long_token():
    # The URL pattern used to try every letter of a run of letters and digits
    # as the start of a scheme and scan the run from there: 100 KB took 10 s,
    # 5 MB did not finish in 300 s. Now a fraction of a second; run in a
    # process of its own so that a regression fails instead of hanging.
    done = subprocess.run(
        [sys.executable, "-c", _LONG_TOKEN, SECRET],
        env=env(),
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 0, done.stderr[-2000:]


def test_a_csv_header_of_megabytes_is_reported_in_seconds(tmp_path):
    # Each message is worded in the command's terms by ~50 patterns; each of
    # them scanned a 5 MB header ("its columns are: ...") position by
    # position (8 s), on top of the redaction (minutes).
    token = "Ab1" * 1_700_000
    path = tmp_path / "wide.csv"
    path.write_text(f"lon,lat,{token}\n0,0,a\n1,0,a\n0,1,a\n")
    done = subprocess.run(
        [sys.executable, "-m", "geoalpha", "hull", str(path), str(tmp_path / "h.gpkg"),
         "--by", "state"],
        env=env(), capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert done.returncode == 1
    assert done.stderr == (
        f"Error: --by column 'state' not found in {path}; its columns are: lon, "
        f"lat, {token}\n"
    )


def test_write_error_never_names_the_staging_folder(tmp_path, monkeypatch):
    hulls = gpd.GeoDataFrame(
        {"g": ["a"]}, geometry=[shapely.box(0, 0, 1, 1)], crs="EPSG:4326"
    )

    def fail(self, filename, *args, **kwargs):
        raise RuntimeError(f"{filename}: No space left on device")

    monkeypatch.setattr(gpd.GeoDataFrame, "to_file", fail)
    with pytest.raises(OSError) as err:
        write_hulls(hulls, tmp_path / "h.gpkg")
    assert str(err.value) == (
        f"cannot write {tmp_path / 'h.gpkg'}: {tmp_path / 'h.gpkg'}: No space left "
        "on device"
    )
    assert list(tmp_path.iterdir()) == []


def test_log_records_are_redacted(tmp_path, monkeypatch):
    import logging

    def read(*args, **kwargs):
        logging.getLogger("pyogrio").warning("opening %s", args[0])
        raise OSError("cannot open it")

    monkeypatch.setattr("geoalpha._io.files.read_input_points", read)
    for _ in range(2):  # the second run logs to its own stderr too
        result = run("hull", f"PG:dbname=gis password={SECRET}", tmp_path / "h.gpkg")
        assert result.exit_code == 1
        assert result.stderr.splitlines() == [
            "WARNING:pyogrio:opening PG:dbname=gis password=***",
            "Error: cannot open it",
        ]
