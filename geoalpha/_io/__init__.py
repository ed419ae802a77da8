"""The I/O wing, which serves the faces: files, PostGIS, redaction, bundled data.

``read_points`` and ``write_hulls`` import :mod:`~geoalpha._io.files` on first use.
"""

from __future__ import annotations

import importlib

__all__ = ["read_points", "write_hulls"]


def __getattr__(name: str):
    if name in __all__:
        return getattr(importlib.import_module("geoalpha._io.files"), name)
    raise AttributeError(f"module 'geoalpha._io' has no attribute {name!r}")
