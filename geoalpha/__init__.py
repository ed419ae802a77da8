"""geoalpha: exact optimal alpha shapes for GeoPandas."""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

from geoalpha.accessor import register as _register_accessor
from geoalpha.errors import (
    AntimeridianWarning,
    DegenerateGroupWarning,
    DroppedRowsWarning,
    GeoAlphaError,
    GeoAlphaWarning,
    InvalidInputError,
    OutlierWarning,
    SearchWarning,
)
from geoalpha.optimal import AlphaShapes, alpha_shape, alpha_shapes, optimal_alpha
from geoalpha.tools import hull, outlier_rows

try:
    __version__ = version("geoalpha")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0+unknown"

__all__ = [
    "AlphaShapes",
    "AntimeridianWarning",
    "DegenerateGroupWarning",
    "DroppedRowsWarning",
    "GeoAlphaError",
    "GeoAlphaWarning",
    "InvalidInputError",
    "OutlierWarning",
    "SearchWarning",
    "__version__",
    "alpha_shape",
    "alpha_shapes",
    "hull",
    "optimal_alpha",
    "outlier_rows",
]

_register_accessor()
