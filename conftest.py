"""Collection rules for ``python -m pytest`` with or without the optional extras.

- ``geoalpha/dask.py`` is imported for its doctests only when dask-geopandas
  is installed (importing it without dask is an ImportError by design).
- ``geoalpha/progress.py``'s doctests draw a bar, so they run only when tqdm
  (``geoalpha[progress]``) is installed; CI installs it.
- The notebooks run (nbmake, 600 s per cell) only when nbmake is installed;
  ``.[test]`` alone runs the unit tests and doctests.
"""

from __future__ import annotations

import importlib.util

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
