"""The ``.alpha`` accessor on GeoDataFrame and GeoSeries (``import geoalpha``)."""

from __future__ import annotations

import functools
import sys

from geoalpha import _hulls as hulls
from geoalpha._registration import ColumnHint, attach

__all__ = ["AlphaAccessor", "register"]


class AlphaAccessor(ColumnHint):
    """Optimal alpha shapes of the points of a GeoDataFrame or GeoSeries.

    Examples
    --------
    >>> import geoalpha
    >>> from geoalpha import datasets
    >>> hulls = datasets.load("stats19").alpha.hull(
    ...     by="Local_Authority_(Highway)", degenerate="drop"
    ... )  # doctest: +SKIP
    """

    def __init__(self, obj):
        self._obj = obj

    @functools.wraps(hulls.hull)
    def hull(self, by=None, **options):
        return hulls.hull(self._obj, by, **options)

    @functools.wraps(hulls.explain)
    def explain(self, by=None, **options):
        return hulls.explain(self._obj, by, **options)

    @functools.wraps(hulls.curve)
    def curve(self, by=None, **options):
        return hulls.curve(self._obj, by, **options)


def register(name: str = "alpha") -> None:
    """Register :class:`AlphaAccessor` as ``name`` on GeoDataFrame and GeoSeries.

    Called on ``import geoalpha``; a column ``name`` stays ``gdf[name]``.
    Registers on dask-geopandas frames too (:func:`geoalpha.dask.register`)
    if ``dask_geopandas`` is imported: ``import geoalpha`` never imports dask.

    Examples
    --------
    >>> import geopandas as gpd
    >>> register()
    >>> gpd.GeoDataFrame.alpha is AlphaAccessor
    True
    """
    import geopandas as gpd

    attach([gpd.GeoDataFrame, gpd.GeoSeries], name, AlphaAccessor)
    # (hasattr: not while dask_geopandas itself is being imported)
    if hasattr(sys.modules.get("dask_geopandas"), "GeoDataFrame"):
        from geoalpha import dask as gdask

        gdask.register(name)
