"""Collection rules for ``python -m pytest`` with or without the optional extras.

- The doctests of a module whose examples need an extra are skipped, with the
  extra to install as the reason, when that extra is missing:
  ``geoalpha/dask.py`` (importing it without dask-geopandas is an ImportError
  by design; its doctests become one skipped item) and
  ``geoalpha/_frame/progress.py`` (its examples draw a bar with tqdm,
  ``geoalpha[progress]``) and ``geoalpha/plot.py`` (matplotlib,
  ``geoalpha[plot]``). With ``GEOALPHA_TEST_ALL=1`` (CI, which installs
  every extra) a missing extra fails these items instead.
- The notebooks run (nbmake, 600 s per cell) only when nbmake is installed,
  and carry the ``notebook`` marker, which ``python -m pytest`` deselects (the
  case study times the searches: minutes); CI runs them with
  ``-m "exhaustive or hypothesis or notebook"``.
"""

from __future__ import annotations

import importlib.util
import os
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent


def _missing(*modules: str) -> bool:
    return any(importlib.util.find_spec(m) is None for m in modules)


#: Module (relative to the tree) -> what its doctests need, when it is missing.
NEEDS = {
    "geoalpha/dask.py": (
        _missing("dask_geopandas", "distributed"),
        'geoalpha[dask] (pip install "geoalpha[dask]")',
    ),
    "geoalpha/_frame/progress.py": (
        _missing("tqdm"),
        'geoalpha[progress] (pip install "geoalpha[progress]")',
    ),
    "geoalpha/plot.py": (
        _missing("matplotlib"),
        'geoalpha[plot] (pip install "geoalpha[plot]")',
    ),
}


def _needs(path: Path) -> str | None:
    """Return the missing extra that the doctests of ``path`` need, or None."""
    try:
        name = path.resolve().relative_to(ROOT.resolve()).as_posix()
    except ValueError:
        # CI tests the installed wheel: geoalpha/ is a link to site-packages.
        name = "geoalpha/" + path.as_posix().rsplit("/geoalpha/", 1)[-1]
    missing, install = NEEDS.get(name, (False, ""))
    return install if missing else None


class MissingExtra(pytest.Item):
    """Stands for a module's doctests when the extra they need is missing."""

    def __init__(self, *, install: str, **kwargs):
        super().__init__(**kwargs)
        self.install = install

    def runtest(self):
        """Skip, or fail under ``GEOALPHA_TEST_ALL=1``."""
        if os.environ.get("GEOALPHA_TEST_ALL") == "1":
            pytest.fail(f"GEOALPHA_TEST_ALL=1 but {self.install} is not installed")
        pytest.skip(f"needs {self.install}")

    def reportinfo(self):
        """Name the module and what it needs."""
        return self.path, None, f"{self.name} (needs {self.install})"


class MissingExtraModule(pytest.File):
    """A module whose doctests cannot be imported: one :class:`MissingExtra`."""

    install = ""

    def collect(self):
        """Yield the one item that skips."""
        yield MissingExtra.from_parent(self, name="doctests", install=self.install)


@pytest.hookimpl(wrapper=True)
def pytest_collect_file(file_path, parent):
    """Replace the doctests of a module that cannot be imported by a skip."""
    collected = yield
    install = _needs(file_path) if file_path.suffix == ".py" else None
    if install is None or "dask" not in install:
        return collected
    module = MissingExtraModule.from_parent(parent, path=file_path)
    module.install = install
    return [module]


def pytest_configure(config):
    """Turn on nbmake for the notebooks when it is installed."""
    if config.pluginmanager.hasplugin("nbmake") and hasattr(config.option, "nbmake"):
        config.option.nbmake = True
        config.option.nbmake_timeout = 600


@pytest.hookimpl(tryfirst=True)  # before -m deselects by marker
def pytest_collection_modifyitems(config, items):
    """Mark the notebooks ``notebook``; skip doctests whose extra is missing."""
    for item in items:
        if item.path.suffix == ".ipynb":
            item.add_marker(pytest.mark.notebook)
        elif isinstance(item, pytest.DoctestItem) and (install := _needs(item.path)):
            if os.environ.get("GEOALPHA_TEST_ALL") == "1":
                raise pytest.UsageError(
                    f"GEOALPHA_TEST_ALL=1 but {install} is not installed"
                )
            item.add_marker(pytest.mark.skip(reason=f"needs {install}"))
