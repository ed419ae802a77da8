"""The case study's stored outputs come from the current version (issue #36).

The notebook is committed with its outputs, which GitHub and the docs show
as they are; CI runs it again (nbmake) but does not save that run. These
checks read the stored outputs without running anything: the version it
printed, and a warning whose text this version must still give word for
word. Re-run with ``jupyter execute --inplace`` (notebooks/README.md).
"""

from __future__ import annotations

import json
import re
import warnings
from pathlib import Path

import geoalpha
from geoalpha import datasets

NOTEBOOK = (
    Path(__file__).resolve().parent.parent
    / "notebooks"
    / "uk_accidents_case_study.ipynb"
)


def stored_text() -> list[str]:
    """Every stored text output (streams and plain-text results), in order."""
    cells = json.loads(NOTEBOOK.read_text(encoding="utf-8"))["cells"]
    out = []
    for cell in cells:
        for output in cell.get("outputs", []):
            text = output.get("text") or output.get("data", {}).get("text/plain", "")
            out.append("".join(text))
    return out


def test_the_stored_outputs_name_the_current_version():
    versions = [t for t in stored_text() if t.startswith("geoalpha ")]
    assert len(versions) == 1
    assert versions[0].splitlines()[0].split() == ["geoalpha", geoalpha.__version__]


def test_the_stored_degenerate_warning_is_what_this_version_says():
    shown = [
        line.split("DegenerateGroupWarning: ", 1)[1]
        for text in stored_text()
        for line in text.splitlines()
        if "DegenerateGroupWarning: " in line
    ]
    stats = datasets.load("stats19")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        stats.alpha.hull(by="Local_Authority_(Highway)", degenerate="empty")
    now = [
        str(w.message)
        for w in caught
        if issubclass(w.category, geoalpha.DegenerateGroupWarning)
    ]
    assert len(now) == 1 and now[0] in shown
    assert re.search(r"'E06000047' \(1 row, 1 distinct point\)", now[0])


def test_the_notebook_group_can_open_jupyter():
    import importlib.util
    import os
    import subprocess
    import sys

    import pytest

    try:
        import tomllib
    except ImportError:  # Python 3.10
        import tomli as tomllib

    groups = tomllib.loads(
        NOTEBOOK.parent.parent.joinpath("pyproject.toml").read_text()
    )
    assert "notebook>=7" in groups["dependency-groups"]["notebook"]
    if importlib.util.find_spec("notebook") is None:
        if os.environ.get("GEOALPHA_TEST_ALL") == "1":
            raise RuntimeError("GEOALPHA_TEST_ALL=1 but the notebook group is missing")
        pytest.skip("needs the notebook group (pip install --group notebook)")
    done = subprocess.run(
        [sys.executable, "-m", "jupyter", "notebook", "--version"],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    assert re.fullmatch(r"7\.\d+\.\d+\s*", done.stdout)
