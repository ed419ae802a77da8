"""geoalpha: exact optimal alpha shapes for GeoPandas."""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

from geoalpha.errors import (
    AntimeridianWarning,
    DegenerateGroupWarning,
    DroppedRowsWarning,
    GeoAlphaError,
    GeoAlphaWarning,
    InvalidInputError,
    SearchWarning,
)

try:
    __version__ = version("geoalpha")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0+unknown"

__all__ = [
    "AntimeridianWarning",
    "DegenerateGroupWarning",
    "DroppedRowsWarning",
    "GeoAlphaError",
    "GeoAlphaWarning",
    "InvalidInputError",
    "SearchWarning",
    "__version__",
]
