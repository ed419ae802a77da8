"""The I/O wing, which serves the faces: files, PostGIS, bundled data.

:mod:`~geoalpha.io.files` reads points from and writes hulls to files,
:mod:`~geoalpha.io.postgis` does the same with a database,
:mod:`~geoalpha.io.redact` keeps credentials out of messages and
:mod:`~geoalpha.io.datasets` loads the bundled datasets. ``read_points`` and
``write_hulls`` are importable from here (loaded on first use, so that
importing a light module of the wing does not import pandas).
"""

from __future__ import annotations

import importlib

__all__ = ["read_points", "write_hulls"]


def __getattr__(name: str):
    if name in __all__:
        return getattr(importlib.import_module("geoalpha.io.files"), name)
    raise AttributeError(f"module 'geoalpha.io' has no attribute {name!r}")
