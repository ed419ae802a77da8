"""Optional dependencies of the test suite: one ``HAS_X`` flag and marker each.

``pip install ".[test]"`` is enough for ``python -m pytest``: the tests of an
optional feature carry its marker and are skipped when the package is
missing. CI installs every extra and sets ``GEOALPHA_TEST_ALL=1``, which turns
a missing package into an error instead of a skip, so nothing is skipped
there.
"""

from __future__ import annotations

import importlib.util
import os

import pytest

__all__ = [
    "HAS_DASK",
    "HAS_FIONA",
    "HAS_MATPLOTLIB",
    "HAS_PYARROW",
    "HAS_PYOGRIO",
    "HAS_TQDM",
    "require_for_module",
    "requires_dask",
    "requires_fiona",
    "requires_pyarrow",
    "requires_pyogrio",
    "requires_tqdm",
]


def _has(*modules: str) -> bool:
    return all(importlib.util.find_spec(m) is not None for m in modules)


HAS_DASK = _has("dask_geopandas", "distributed")
HAS_FIONA = _has("fiona")
HAS_MATPLOTLIB = _has("matplotlib")
HAS_PYARROW = _has("pyarrow")
HAS_PYOGRIO = _has("pyogrio")
HAS_TQDM = _has("tqdm")


def _requires(present: bool, install: str) -> pytest.MarkDecorator:
    if not present and os.environ.get("GEOALPHA_TEST_ALL") == "1":
        raise RuntimeError(f"GEOALPHA_TEST_ALL=1 but {install} is not installed")
    return pytest.mark.skipif(not present, reason=f"needs {install}")


requires_dask = _requires(HAS_DASK, "geoalpha[dask] (dask-geopandas, distributed)")
requires_fiona = _requires(HAS_FIONA, "fiona")
requires_pyarrow = _requires(HAS_PYARROW, "geoalpha[parquet] (pyarrow)")
requires_pyogrio = _requires(HAS_PYOGRIO, "pyogrio")
requires_tqdm = _requires(HAS_TQDM, "geoalpha[progress] (tqdm)")


def require_for_module(present: bool, install: str) -> None:
    """Skip the calling test module when a package is missing (error in CI)."""
    if not present:
        if os.environ.get("GEOALPHA_TEST_ALL") == "1":
            raise RuntimeError(f"GEOALPHA_TEST_ALL=1 but {install} is not installed")
        pytest.skip(f"needs {install}", allow_module_level=True)
