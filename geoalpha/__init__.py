"""geoalpha: exact optimal alpha shapes for GeoPandas.

Importing geoalpha registers the ``.alpha`` accessor on GeoPandas frames (as
soon as geopandas is imported). The public functions are loaded on first use,
so that ``import geoalpha`` and ``geoalpha --help`` stay fast.

Everything a user calls is a name of this module (:data:`__all__`), plus
:mod:`geoalpha.dask` (the ``dask`` extra) and :mod:`geoalpha.datasets`. The
modules whose names start with an underscore are internal: their names may
change in any release (``docs/architecture.md`` is their map).
"""

from __future__ import annotations

import importlib
import sys
from typing import TYPE_CHECKING

from geoalpha.errors import (
    AntimeridianWarning,
    CRSWarning,
    DatabaseError,
    DegenerateGroupWarning,
    DroppedRowsWarning,
    GeoAlphaError,
    GeoAlphaWarning,
    GroupingWarning,
    InvalidInputError,
    OutlierWarning,
    SearchWarning,
    SharedLocationWarning,
    SuspiciousHullWarning,
)

if TYPE_CHECKING:  # pragma: no cover - for type checkers and IDEs
    from geoalpha import datasets
    from geoalpha._accessor import AlphaAccessor
    from geoalpha._arrays.optimal import (
        AlphaShapes,
        alpha_shape,
        alpha_shapes,
        optimal_alpha,
    )
    from geoalpha._core import Reason
    from geoalpha._hulls import curve, explain, hull, outlier_rows
    from geoalpha._io.files import read_points, write_hulls
    from geoalpha._io.postgis import read_postgis, write_postgis
    from geoalpha.plot import plot_curve, plot_why

#: What users call: the first ten are the everyday ones (the README's).
__all__ = [  # noqa: RUF022 - by use, not alphabetical
    "hull",
    "explain",
    "curve",
    "outlier_rows",
    "alpha_shapes",
    "optimal_alpha",
    "read_points",
    "write_hulls",
    "datasets",
    "__version__",
    # the rest
    "AlphaAccessor",
    "AlphaShapes",
    "Reason",
    "alpha_shape",
    "plot_curve",
    "plot_why",
    "read_postgis",
    "write_postgis",
    # errors and warnings
    "GeoAlphaError",
    "InvalidInputError",
    "DatabaseError",
    "GeoAlphaWarning",
    "AntimeridianWarning",
    "CRSWarning",
    "DegenerateGroupWarning",
    "DroppedRowsWarning",
    "GroupingWarning",
    "OutlierWarning",
    "SearchWarning",
    "SharedLocationWarning",
    "SuspiciousHullWarning",
]

#: Public names loaded on first use, and the module that defines each.
_LAZY = {
    "AlphaAccessor": "geoalpha._accessor",
    "AlphaShapes": "geoalpha._arrays.optimal",
    "Reason": "geoalpha._core",
    "alpha_shape": "geoalpha._arrays.optimal",
    "alpha_shapes": "geoalpha._arrays.optimal",
    "optimal_alpha": "geoalpha._arrays.optimal",
    "curve": "geoalpha._hulls",
    "explain": "geoalpha._hulls",
    "hull": "geoalpha._hulls",
    "outlier_rows": "geoalpha._hulls",
    "plot_curve": "geoalpha.plot",
    "plot_why": "geoalpha.plot",
    "read_points": "geoalpha._io.files",
    "write_hulls": "geoalpha._io.files",
    "read_postgis": "geoalpha._io.postgis",
    "write_postgis": "geoalpha._io.postgis",
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
    elif name == "datasets":  # ``from geoalpha import datasets``: a module since 0.3
        return importlib.import_module("geoalpha.datasets")
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
            importlib.import_module("geoalpha._accessor").register()

        spec.loader.exec_module = exec_and_register
        return spec


if "geopandas" in sys.modules:
    importlib.import_module("geoalpha._accessor").register()
elif not any(isinstance(f, _RegisterOnImport) for f in sys.meta_path):
    sys.meta_path.insert(0, _RegisterOnImport())
