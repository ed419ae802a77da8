"""The ``.alpha`` accessor on GeoDataFrame and GeoSeries.

Importing :mod:`geoalpha` registers it. It only delegates: ``gdf.alpha.hull``
is :func:`geoalpha.hull` with ``gdf`` as its first argument. On
dask-geopandas frames ``.alpha`` is :class:`geoalpha.dask.DaskAlphaAccessor`.
"""

from __future__ import annotations

import functools
import sys

from geoalpha import hulls
from geoalpha.registration import attach

__all__ = ["AlphaAccessor", "register"]


class AlphaAccessor:
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
    def hull(self, by=None, **options):  # noqa: D102 - documented by hulls.hull
        return hulls.hull(self._obj, by, **options)


def register(name: str = "alpha") -> None:
    """Register :class:`AlphaAccessor` as ``name`` on GeoDataFrame and GeoSeries.

    Called on ``import geoalpha``. A column of the same name is still
    reachable with ``gdf[name]``; ``gdf.<name>`` is the accessor. The
    dask-geopandas GeoDataFrame and GeoSeries get theirs
    (:func:`geoalpha.dask.register`) too when ``dask_geopandas`` is already
    imported (importing :mod:`geoalpha.dask` registers it there in any case),
    so that ``import geoalpha`` does not import dask.

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
