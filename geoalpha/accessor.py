"""The ``.alpha`` accessor on GeoDataFrame and GeoSeries.

Importing :mod:`geoalpha` registers it. It only delegates: ``gdf.alpha.hull``
is :func:`geoalpha.hull` with ``gdf`` as its first argument.
"""

from __future__ import annotations

import functools
import sys
import warnings

from geoalpha import tools

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

    @functools.wraps(tools.hull)
    def hull(self, by=None, **kwargs):  # noqa: D102 - documented by tools.hull
        return tools.hull(self._obj, by, **kwargs)


class _CachedAccessor:
    """Descriptor that builds the accessor on attribute access (as pandas does)."""

    def __init__(self, name: str, accessor: type):
        self._name = name
        self._accessor = accessor

    def __get__(self, obj, cls):
        if obj is None:
            return self._accessor
        return self._accessor(obj)


def register(name: str = "alpha") -> None:
    """Register :class:`AlphaAccessor` as ``name`` on GeoDataFrame and GeoSeries.

    Called on ``import geoalpha``. A column of the same name is still
    reachable with ``gdf[name]``; ``gdf.<name>`` is the accessor. The
    dask-geopandas GeoDataFrame and GeoSeries get it too when
    ``dask_geopandas`` is already imported (importing :mod:`geoalpha.dask`
    registers it there in any case), so that ``import geoalpha`` does not
    import dask.

    Examples
    --------
    >>> import geopandas as gpd
    >>> register()
    >>> gpd.GeoDataFrame.alpha is AlphaAccessor
    True
    """
    import geopandas as gpd

    classes = [gpd.GeoDataFrame, gpd.GeoSeries]
    dgpd = sys.modules.get("dask_geopandas")
    if dgpd is not None:
        classes += [dgpd.GeoDataFrame, dgpd.GeoSeries]
    for cls in classes:
        existing = getattr(cls, name, None)
        if existing is not None and not isinstance(
            cls.__dict__.get(name), _CachedAccessor
        ):
            warnings.warn(
                f"registering the geoalpha accessor {name!r} overrides an existing "
                f"attribute of {cls.__name__}",
                UserWarning,
                stacklevel=2,
            )
        setattr(cls, name, _CachedAccessor(name, AlphaAccessor))
