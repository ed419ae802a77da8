"""Every install and build command of the README and the docs works as written.

The commands are read from README.md, docs/*.md and docs/user_guide/*.md:
every ```bash block that runs ``pip install`` (one block is one user's
session: its lines run one after the other, each of them must exit 0), and
every ``pip install ...`` written inline in the text. Each runs in a new
virtual environment made by ``python3 -m venv`` (with the pip that Python
bundles, 23.2 on Python 3.11), in a copy of this clone, with no
``GEOALPHA_*`` or ``PYTHONPATH`` of the test run leaking in; whatever
``pyproject.toml``'s build backend is, ``pip install .`` builds it.

- ``pip install "geoalpha[x]"`` (the spelling for the published package) runs
  after the README's set-up, ``pip install .``: pip finds geoalpha installed
  from the clone and adds the extra.
- ``python -m pytest ...`` in a block is collected (``--collect-only``), not
  run: the suite itself is CI's ``python -m pytest`` step (.ci/run).
- A Sphinx HTML build must write its ``index.html``, ``geoalpha demo OUT``
  its file, and pip must not warn that an extra does not exist.
- docs/user_guide/qgis_plugin.md is left out: its commands run with QGIS's
  own Python, which tests/test_qgis_plugin.py and .ci/run's
  ``install_geoalpha.py`` step cover.
- ``pip install ./geoalpha-...whl`` (a downloaded release wheel) is left out
  here: .ci/run installs the wheel it builds that way in a venv without Rust
  and runs the demo (tests/test_release.py checks that step is there).

These tests install from the network and take minutes: they carry the
``install`` marker, deselected by default; CI runs them with
``python -m pytest -m install tests/test_install_commands.py`` from the
source checkout. The checks of the commands' text (extras that exist, pip new
enough for ``--group``) run by default.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import tempfile
from pathlib import Path

import pytest

try:
    import tomllib
except ImportError:  # Python 3.10: pytest depends on tomli there
    import tomli as tomllib

ROOT = Path(__file__).resolve().parent.parent
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
PAGES = [
    ROOT / "README.md",
    *sorted((ROOT / "docs").glob("*.md")),
    *sorted((ROOT / "docs" / "user_guide").glob("*.md")),
]
#: Pages whose commands are for another Python, with the test that runs them.
ELSEWHERE = {
    "docs/user_guide/qgis_plugin.md": "QGIS's own Python: tests/test_qgis_plugin.py",
}
FENCE = re.compile(r"^```(?P<lang>[^\n]*)\n(?P<code>.*?)^```[ \t]*$", re.S | re.M)
INLINE = re.compile(r"`((?:python -m )?pip install [^`]+)`")
SUITE = re.compile(r"\bpython -m pytest\b")
#: A downloaded wheel's file name (not in the clone: .ci/run installs its own).
WHEEL_FILE = re.compile(r"\bgeoalpha-[\w.-]+\.whl\b")
#: What a block's pytest command becomes: collected in this process (-n 0).
COLLECT = "python -m pytest --collect-only -q -n 0"
#: pip's warning for `.[name]` when the project has no extra `name`.
NO_EXTRA = "does not provide the extra"


def documented_commands():
    """``(page, commands)``: each block's lines, or one inline command."""
    found = []
    for page in PAGES:
        name = page.relative_to(ROOT).as_posix()
        if name in ELSEWHERE:
            continue
        text = page.read_text(encoding="utf-8")
        for block in FENCE.finditer(text):
            if (
                block["lang"] in ("bash", "sh", "shell")
                and "pip install" in block["code"]
            ):
                lines = block["code"].replace("\\\n", " ").splitlines()
                found.append((name, tuple(line for line in lines if line.strip())))
        prose = FENCE.sub("", text)
        for command in INLINE.findall(prose.replace("\n", " ")):
            if not WHEEL_FILE.search(command):  # .ci/run's no-Rust step
                found.append((name, (command,)))
    # The same command on several pages runs once, under its first page.
    seen, unique = set(), []
    for name, lines in found:
        if lines not in seen:
            seen.add(lines)
            unique.append((name, lines))
    return unique


COMMANDS = documented_commands()


def pip_commands():
    for _, lines in COMMANDS:
        for line in lines:
            for part in re.split(r"&&|;", line):
                if "pip install" in part:
                    yield part.split("#")[0].strip()


# --------------------------------------------------------------------------
# The commands' text (default run)
# --------------------------------------------------------------------------


def test_the_documented_commands_are_found():
    flat = [line for _, lines in COMMANDS for line in lines]
    assert "pip install . && geoalpha demo hulls.gpkg" in flat
    assert 'pip install -e ".[test]" && python -m pytest' in flat
    assert any("sphinx -b html docs docs/_build/html" in line for line in flat)
    assert any('pip install "geoalpha[dask]"' in line for line in flat)


def test_the_wheel_command_is_the_one_ci_runs_without_rust():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert (
        "A release wheel needs no Rust ([how to get it](docs/getting_started.md))"
        in (readme.replace("\n", " "))
    )
    assert re.search(r"`pip install \./geoalpha-[^`]+\.whl`", readme)
    page = (ROOT / "docs" / "getting_started.md").read_text(encoding="utf-8")
    wheel = re.search(r"`pip install (\./geoalpha-[^`]+\.whl)`", page)
    assert wheel is not None
    assert re.fullmatch(
        r"\./geoalpha-[\d.]+-cp310-abi3-manylinux_2_17_x86_64\.whl", wheel[1]
    )
    assert PYPROJECT["project"]["version"] in wheel[1]
    assert 'pip install --quiet "$wheel"' in (ROOT / ".ci" / "run").read_text()


def test_the_extras_in_the_clone_keep_the_editable_install():
    # after `pip install -e ".[test]"`, `pip install ".[dask]"` would replace
    # the in-place install with a copy: getting started keeps -e
    text = (ROOT / "docs" / "getting_started.md").read_text(encoding="utf-8")
    assert 'pip install -e ".[test,dask]"' in text
    assert not re.search(r'pip install "\.\[', text)


def test_every_documented_extra_exists():
    extras = set(PYPROJECT["project"]["optional-dependencies"])
    wrong = []
    for command in pip_commands():
        for names in re.findall(r"(?:\.|geoalpha)\[([\w,-]+)\]", command):
            wrong += [(command, n) for n in names.split(",") if n not in extras]
    assert not wrong, f"pip install of extras pyproject.toml does not have: {wrong}"


def test_every_documented_group_exists_and_pip_is_new_enough():
    groups = set(PYPROJECT["dependency-groups"])
    for _, lines in COMMANDS:
        for line in lines:
            for group in re.findall(r"--group[ =](\S+)", line):
                assert group in groups, line
                # A new venv's pip (23.2) has no --group: "no such option".
                upgrade = 'python -m pip install --upgrade "pip>=25.1" && '
                assert line.startswith(upgrade), line


# --------------------------------------------------------------------------
# The commands themselves, in new virtual environments (-m install)
# --------------------------------------------------------------------------


def copy_of_the_clone(dest: Path) -> Path:
    """The clone's files, without builds, caches or virtual environments."""
    ignore = shutil.ignore_patterns(
        ".git", "_build", "build", "dist", "target", "*.egg-info", "__pycache__",
        ".venv", ".hypothesis", ".pytest_cache", ".ruff_cache", "*.so",
    )  # fmt: skip
    shutil.copytree(ROOT, dest, ignore=ignore, symlinks=False)
    return dest


@pytest.fixture(scope="module")
def cargo_target(tmp_path_factory):
    # One Cargo build folder for all copies, should the backend compile Rust.
    return tmp_path_factory.mktemp("cargo-target")


def new_venv(path: Path) -> dict:
    """A venv made by ``python3 -m venv``; the environment of a shell in it."""
    python3 = shutil.which("python3")
    assert python3, "python3 is not on PATH"
    subprocess.run([python3, "-m", "venv", str(path)], check=True, timeout=300)
    env = {
        k: v
        for k, v in os.environ.items()
        if not k.startswith(("GEOALPHA_", "PYTHON", "PIP_REQUIRE", "HYPOTHESIS_"))
        and k not in ("VIRTUAL_ENV", "CONDA_PREFIX")
    }
    env["VIRTUAL_ENV"] = str(path)
    env["PATH"] = os.pathsep.join([str(path / "bin"), env.get("PATH", "")])
    return env


def run(line: str, cwd: Path, env: dict) -> str:
    done = subprocess.run(
        ["bash", "-c", line],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=3600,
        check=False,
    )
    out = done.stdout + done.stderr
    assert done.returncode == 0, f"`{line}` exited {done.returncode}:\n{out[-6000:]}"
    assert NO_EXTRA not in out, f"`{line}`:\n{out[-6000:]}"
    return out


@pytest.mark.install
@pytest.mark.parametrize(
    "lines",
    [pytest.param(lines, id=f"{name}#{k}") for k, (name, lines) in enumerate(COMMANDS)],
)
def test_command_works_in_a_new_venv(lines, tmp_path, cargo_target):
    clone = copy_of_the_clone(tmp_path / "geoalpha")
    env = new_venv(tmp_path / "venv")
    env["CARGO_TARGET_DIR"] = str(cargo_target)
    if any("geoalpha[" in line for line in lines):
        run("pip install .", clone, env)  # the README's set-up
    for line in lines:
        out = run(SUITE.sub(COLLECT, line), clone, env)
        if SUITE.search(line):
            assert re.search(r"\d+ tests? collected", out), out[-3000:]
        for html in re.findall(r"-b html(?: -\S+ \S+)* \S+ (\S+)", line):
            assert (clone / html / "index.html").is_file(), f"`{line}`: no index.html"
        for written in re.findall(r"\bgeoalpha demo (\S+)", line):
            assert (clone / written).is_file(), f"`{line}` wrote no {written}"


#: The README's test command, and the extras it must pass without.
README_TESTS = 'pip install -e ".[test]" && python -m pytest'
EXTRA_MODULES = ("tqdm", "matplotlib", "pyarrow", "dask_geopandas", "sqlalchemy")


@pytest.mark.install
def test_readme_test_command_passes_without_the_extras(cargo_target):
    # Run, not collected: the README's command in a venv with only [test]; the
    # tests of the missing extras skip with their reason (none fails).
    assert any(README_TESTS in lines for _, lines in COMMANDS)
    # Readable by all, as .ci/run's: some tests run the command as an
    # unprivileged user (pytest's tmp_path is private to its user).
    shared = Path(tempfile.mkdtemp(prefix="geoalpha-readme-"))
    try:
        shared.chmod(0o755)
        clone = copy_of_the_clone(shared / "geoalpha")
        env = new_venv(shared / "venv")
        env["CARGO_TARGET_DIR"] = str(cargo_target)
        out = run(README_TESTS, clone, env)
        absent = run(
            'python -c "import importlib.util as u; print([m for m in '
            f'{list(EXTRA_MODULES)!r} if u.find_spec(m)])"',
            clone,
            env,
        )
    finally:
        shutil.rmtree(shared, ignore_errors=True)
    assert re.search(r"\d+ passed", out) and " failed" not in out, out[-3000:]
    assert re.search(r"SKIPPED \[\d+\] .*needs geoalpha\[dask\]", out), out[-3000:]
    assert "needs geoalpha[progress]" in out, out[-3000:]
    assert absent.strip() == "[]", absent  # the extras really were missing
