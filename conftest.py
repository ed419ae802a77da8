"""Collection rules for ``python -m pytest`` with or without the optional extras.

- ``geoalpha/dask.py`` is imported for its doctests only when dask-geopandas
  is installed (importing it without dask is an ImportError by design).
- ``geoalpha/progress.py``'s doctests draw a bar, so they run only when tqdm
  (``geoalpha[progress]``) is installed; CI installs it.
- The notebooks run (nbmake, 600 s per cell) only when nbmake is installed,
  and carry the ``notebook`` marker, which ``python -m pytest`` deselects (the
  case study times the searches: minutes); CI runs them with
  ``-m "exhaustive or hypothesis or notebook"``.
"""

from __future__ import annotations

import importlib.util

import pytest

collect_ignore = []
if importlib.util.find_spec("dask_geopandas") is None:
    collect_ignore.append("geoalpha/dask.py")
if importlib.util.find_spec("tqdm") is None:
    collect_ignore.append("geoalpha/progress.py")


def pytest_configure(config):
    """Turn on nbmake for the notebooks when it is installed."""
    if config.pluginmanager.hasplugin("nbmake") and hasattr(config.option, "nbmake"):
        config.option.nbmake = True
        config.option.nbmake_timeout = 600


@pytest.hookimpl(tryfirst=True)  # before -m deselects by marker
def pytest_collection_modifyitems(config, items):
    """Mark the notebooks ``notebook``."""
    for item in items:
        if item.path.suffix == ".ipynb":
            item.add_marker(pytest.mark.notebook)
