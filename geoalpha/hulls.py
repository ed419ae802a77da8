"""``hull()``: one tight polygon per group of points (``docs/architecture.md``)."""

from __future__ import annotations

import sys
import warnings

import pandas as pd

from geoalpha import options as _options
from geoalpha.errors import InvalidInputError, OutlierWarning
from geoalpha.frame.pipeline import as_frame, run
from geoalpha.frame.schema import RESULT_COLUMNS
from geoalpha.options import DEGENERATE_POLICIES, METHODS, Options

__all__ = ["DEGENERATE_POLICIES", "METHODS", "RESULT_COLUMNS", "hull", "outlier_rows"]


def _is_dask(data) -> bool:
    """Tell whether ``data`` is a dask-geopandas frame (without importing dask)."""
    dgpd = sys.modules.get("dask_geopandas")
    return dgpd is not None and isinstance(data, dgpd.GeoDataFrame | dgpd.GeoSeries)


def hull(gdf, by=None, **options):
    """Tightest single polygon around each group of points.

    The alpha shape at each group's exact optimal alpha: the largest alpha whose
    shape is one polygon holding every point. Also ``gdf.alpha.hull(...)``.

    Parameters
    ----------
    gdf : GeoDataFrame or GeoSeries
        Point geometries (MultiPoints count as their points). A
        ``dask_geopandas.GeoDataFrame`` gives a lazy result: see
        :func:`geoalpha.dask.hull`.
    by : str, list of str, or array_like, optional
        Group the rows by these columns, index levels or values, as in
        :meth:`GeoDataFrame.dissolve`; None gives one hull of all points.
    {options}

    Returns
    -------
    GeoDataFrame
        In the input CRS, one row per group: the key column(s),
        :data:`RESULT_COLUMNS` and ``geometry``, a Polygon whose vertices are
        input points (:doc:`/user_guide/hulls`). With ``crs=None`` on input
        not in metres, ``area`` and ``unit`` instead of ``area_m2``.

    Raises
    ------
    InvalidInputError
        Non-point geometries (without ``vertices=True``), a missing ``by`` column,
        no CRS (without ``crs=None``), coordinates out of range, bad options.

    Warns
    -----
    OutlierWarning, DroppedRowsWarning, DegenerateGroupWarning, AntimeridianWarning
        Points left out (``outliers``), rows dropped, groups without alpha
        shape, groups split at +-180 degrees.
    GroupingWarning, CRSWarning
        ``by`` makes more groups than half the rows (a wrong column?); the
        computation CRS stretches areas by more than 2 % where the points are.

    Notes
    -----
    On a result, ``hulls["alpha"]`` is the column, ``hulls.alpha`` the accessor.

    .. versionadded:: 0.1.0

    Examples
    --------
    >>> import geoalpha
    >>> from geoalpha import datasets
    >>> points = datasets.load("uk_clusters")
    >>> import warnings
    >>> with warnings.catch_warnings(record=True) as caught:  # one 2-point cluster
    ...     hulls = points.alpha.hull(by="Cluster")
    >>> caught[0].category.__name__
    'DegenerateGroupWarning'
    >>> len(hulls), int(hulls["n_points"].sum()) == len(points)
    (691, True)
    >>> hulls.geom_type.unique().tolist(), hulls.crs.to_epsg()
    (['Polygon'], 4326)
    """
    if _is_dask(gdf):
        from geoalpha.dask import hull as dask_hull

        return dask_hull(gdf, by, **options)  # which checks the options
    return run(as_frame(gdf), by, Options.from_kwargs(options))[0]


hull.__signature__ = _options.signature(hull)
hull.__doc__ = _options.docstring(hull.__doc__, indent="    ")


def outlier_rows(gdf, by=None, **options):
    """Mark the input rows that :func:`hull` leaves out with ``outliers=``.

    Parameters
    ----------
    gdf, by, **options
        As for :func:`hull` (``outliers`` included).

    Returns
    -------
    pandas.Series of bool
        On ``gdf``'s index: True for the rows left out of their group's hull
        (a MultiPoint: if one of its points is), False for the others.

    Raises
    ------
    InvalidInputError
        As :func:`hull`; also for a dask-geopandas frame (compute it first).

    .. versionadded:: 0.2.0

    Examples
    --------
    >>> import geopandas as gpd
    >>> import shapely
    >>> pts = [(0, 0), (4, 0), (4, 4), (0, 4), (2, 3.5), (30, 30)]
    >>> gdf = gpd.GeoDataFrame(geometry=shapely.points(pts), crs="EPSG:32631")
    >>> outlier_rows(gdf, outliers=1).tolist()
    [False, False, False, False, False, True]
    >>> gdf[~outlier_rows(gdf, outliers=1)].alpha.hull()["n_points"].item()
    5
    """
    if _is_dask(gdf):
        raise InvalidInputError(
            "outlier_rows() needs an eager GeoDataFrame; call .compute() first "
            "(the lazy hull() has the n_outliers column)"
        )
    opts = Options.from_kwargs(options, caller="outlier_rows()")
    frame = as_frame(gdf)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutlierWarning)
        _, left_out = run(frame, by, opts)
    return pd.Series(left_out, index=frame.index, name="outlier")
