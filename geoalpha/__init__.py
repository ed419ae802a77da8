"""geoalpha: exact optimal alpha shapes for GeoPandas.

Importing geoalpha registers the ``.alpha`` accessor on GeoPandas frames (as
soon as geopandas is imported). The public functions are loaded on first use,
so that ``import geoalpha`` and ``geoalpha --help`` stay fast.
"""

from __future__ import annotations

import importlib
import sys
from typing import TYPE_CHECKING

from geoalpha.errors import (
    AntimeridianWarning,
    DegenerateGroupWarning,
    DroppedRowsWarning,
    GeoAlphaError,
    GeoAlphaWarning,
    InvalidInputError,
    OutlierWarning,
    SearchWarning,
    SharedLocationWarning,
    SuspiciousHullWarning,
)

if TYPE_CHECKING:  # pragma: no cover - for type checkers and IDEs
    from geoalpha.arrays.optimal import (
        AlphaShapes,
        alpha_shape,
        alpha_shapes,
        optimal_alpha,
    )
    from geoalpha.hulls import curve, explain, hull, outlier_rows
    from geoalpha.plot import plot_curve, plot_why

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
    "SharedLocationWarning",
    "SuspiciousHullWarning",
    "__version__",
    "alpha_shape",
    "alpha_shapes",
    "curve",
    "explain",
    "hull",
    "optimal_alpha",
    "outlier_rows",
    "plot_curve",
    "plot_why",
]

#: Public names loaded on first use, and the module that defines each.
_LAZY = {
    "AlphaShapes": "geoalpha.arrays.optimal",
    "alpha_shape": "geoalpha.arrays.optimal",
    "alpha_shapes": "geoalpha.arrays.optimal",
    "optimal_alpha": "geoalpha.arrays.optimal",
    "curve": "geoalpha.hulls",
    "explain": "geoalpha.hulls",
    "hull": "geoalpha.hulls",
    "outlier_rows": "geoalpha.hulls",
    "plot_curve": "geoalpha.plot",
    "plot_why": "geoalpha.plot",
}


def __getattr__(name: str):
    if name == "__version__":  # on first use: it costs more than the import
        from importlib.metadata import PackageNotFoundError, version

        try:
            value = version("geoalpha")
        except PackageNotFoundError:  # pragma: no cover - running from a source tree
            value = "0+unknown"
    elif name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name]), name)
    elif name == "datasets":  # ``from geoalpha import datasets``: in io since 0.3
        return importlib.import_module("geoalpha.io.datasets")
    else:
        raise AttributeError(f"module 'geoalpha' has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


class _RegisterOnImport:
    """Import hook: wrap geopandas' loader to register the accessor once it has run."""

    _finding = False

    def find_spec(self, name, path=None, target=None):
        if name != "geopandas" or self._finding:
            return None
        self._finding = True
        try:
            from importlib.util import find_spec

            spec = find_spec(name)
        finally:
            self._finding = False
        if spec is None or spec.loader is None:  # pragma: no cover - no geopandas
            return None
        exec_module = spec.loader.exec_module

        def exec_and_register(module):
            exec_module(module)
            if self in sys.meta_path:
                sys.meta_path.remove(self)
            importlib.import_module("geoalpha.accessor").register()

        spec.loader.exec_module = exec_and_register
        return spec


if "geopandas" in sys.modules:
    importlib.import_module("geoalpha.accessor").register()
elif not any(isinstance(f, _RegisterOnImport) for f in sys.meta_path):
    sys.meta_path.insert(0, _RegisterOnImport())
