"""``hull()``: one tight polygon per group of points (``docs/architecture.md``)."""

from __future__ import annotations

import sys
import warnings
from typing import Any, NamedTuple

import pandas as pd

from geoalpha import _options as _options
from geoalpha._frame.pipeline import as_frame, run, run_all
from geoalpha._frame.schema import RESULT_COLUMNS
from geoalpha._frame.why import (
    curve_frame,
    curve_options,
    explain_asked,
    explain_frame,
    why_options,
)
from geoalpha._options import DEGENERATE_POLICIES, METHODS, Options
from geoalpha.errors import InvalidInputError, OutlierWarning

__all__ = [
    "DEGENERATE_POLICIES",
    "METHODS",
    "RESULT_COLUMNS",
    "Explained",
    "curve",
    "explain",
    "hull",
    "hull_and_why",
    "outlier_rows",
]


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
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     hulls = points.alpha.hull(by="Cluster")
    >>> sorted(w.category.__name__ for w in caught)  # a 2-point cluster; 5 far-off
    ['DegenerateGroupWarning', 'SuspiciousHullWarning']
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


def explain(gdf, by=None, **options):
    """Why each group's hull got its radius: the critical triangle and the alternative.

    Runs :func:`hull` with the same options and says, per group, what set
    the optimum (:doc:`/user_guide/why`). Also ``gdf.alpha.explain(...)``.

    Parameters
    ----------
    gdf, by, **options
        As for :func:`hull` (``method="alpha"``). A
        ``dask_geopandas.GeoDataFrame`` gives a lazy result: see
        :func:`geoalpha.dask.explain`.

    Returns
    -------
    GeoDataFrame
        In the input CRS, one row per group of :func:`hull`'s result: the key
        column(s); ``radius`` and ``alpha`` as :func:`hull` gives them;
        ``limited_by`` (``"coverage"``, ``"connection"``, ``"outliers"``,
        ``"alpha given"`` or ``"degenerate"``); ``critical_rows`` (index labels
        of the critical triangle's three corners, then, for ``"coverage"``,
        of the point(s) covered last); ``radius_without_1``,
        ``area_m2_without_1`` and ``rows_without_1`` (the optimum with one
        location, a distinct point with all its rows, left out, and those
        rows' labels); ``suspicious`` (what :class:`SuspiciousHullWarning`
        flags); the critical triangle as ``geometry``. With ``crs=None`` on
        input not in metres, ``area_without_1`` and ``unit`` instead of
        ``area_m2_without_1``, as :func:`hull`.

    Raises
    ------
    InvalidInputError
        As :func:`hull`; for ``method`` other than ``"alpha"``.

    .. versionadded:: 0.3.0

    Examples
    --------
    >>> import geopandas as gpd
    >>> import shapely
    >>> pts = [(0, 0), (4, 0), (4, 4), (0, 4), (2, 3.5), (30, 30)]
    >>> gdf = gpd.GeoDataFrame(geometry=shapely.points(pts), crs="EPSG:32631")
    >>> why = explain(gdf, suspicious=False)
    >>> why[["limited_by", "critical_rows", "rows_without_1"]].iloc[0].tolist()
    ['coverage', [1, 5, 2, 5], [5]]
    >>> round(why["radius_without_1"].item(), 4)
    2.3214
    """
    if _is_dask(gdf):
        from geoalpha.dask import explain as dask_explain

        return dask_explain(gdf, by, **options)  # which checks the options
    return explain_frame(as_frame(gdf), by, why_options(options, "explain()"))


explain.__signature__ = _options.signature(explain)


def curve(
    gdf, by=None, *, max_left_out: int = 5, outlier_unit: str = "rows", **options
):
    """Compute the exact optimum with 0, 1, ..., ``max_left_out`` rows/locations out.

    One kernel call: every group's optima for every ``k`` (:doc:`/user_guide/why`).
    Also ``gdf.alpha.curve(...)``.

    Parameters
    ----------
    gdf, by
        As for :func:`hull`. A ``dask_geopandas.GeoDataFrame`` gives a lazy
        result: see :func:`geoalpha.dask.curve`.
    max_left_out : int, default 5
        The largest ``k``; a group keeps at least 3 locations, so a smaller
        group's curve stops earlier (with an :class:`OutlierWarning`).
    outlier_unit : {"rows", "locations"}, default "rows"
        What ``k`` counts.
    **options
        As for :func:`hull` (``method="alpha"``; not ``outliers``: ``k`` is the
        budget).

    Returns
    -------
    pandas.DataFrame
        One row per group with a shape and ``k`` (0 first): the key column(s),
        ``k``, ``radius``, ``alpha``, ``area_m2``, ``n_parts`` and ``left_out``
        (the index labels of the rows left out), each row the exact outlier
        optimum with at most ``k`` rows (locations) left out. ``k = 0`` is
        :func:`hull`'s result. With ``crs=None`` on input not in metres,
        ``area`` and ``unit`` instead of ``area_m2``, as :func:`hull`.

    Raises
    ------
    InvalidInputError
        ``max_left_out`` not an integer >= 0, an unknown ``outlier_unit``,
        ``outliers`` given, or as :func:`explain`.

    .. versionadded:: 0.3.0

    Examples
    --------
    >>> import geopandas as gpd
    >>> import shapely
    >>> pts = [(0, 0), (4, 0), (4, 4), (0, 4), (2, 3.5), (30, 30)]
    >>> gdf = gpd.GeoDataFrame(geometry=shapely.points(pts), crs="EPSG:32631")
    >>> table = curve(gdf, max_left_out=2, suspicious=False)
    >>> table[["k", "n_parts", "left_out"]].values.tolist()
    [[0, 1, []], [1, 1, [5]], [2, 1, [5]]]
    """
    if _is_dask(gdf):
        from geoalpha.dask import curve as dask_curve

        return dask_curve(
            gdf, by, max_left_out=max_left_out, outlier_unit=outlier_unit, **options
        )
    opts, k, unit = curve_options(options, max_left_out, outlier_unit)
    return curve_frame(as_frame(gdf), by, opts, k, unit)


class Explained(NamedTuple):
    """What :func:`hull_and_why` returns: one run's three tables."""

    #: :func:`hull`'s result
    hulls: Any
    #: :func:`explain`'s result (one row per row of ``hulls``)
    why: Any
    #: :func:`outlier_rows`'s result (True: left out by ``outliers``)
    left_out: Any


def hull_and_why(gdf, by=None, **options) -> Explained:
    """Run :func:`hull`, :func:`explain` and :func:`outlier_rows` as one run.

    The faces that write all three (``geoalpha hull --explain``, the QGIS
    plugin's WHY and LEFT_OUT layers) call this: the kernel runs once, with
    the warnings of :func:`hull` (:class:`SuspiciousHullWarning` included).

    Parameters
    ----------
    gdf, by, **options
        As for :func:`explain` (``method="alpha"``, an eager GeoDataFrame).

    Returns
    -------
    Explained
        ``(hulls, why, left_out)``: the GeoDataFrames of :func:`hull` and
        :func:`explain`, and the boolean Series of :func:`outlier_rows` on
        ``gdf``'s index.

    Raises
    ------
    InvalidInputError
        As :func:`explain`.

    .. versionadded:: 0.3.0

    Examples
    --------
    >>> import geopandas as gpd
    >>> import shapely
    >>> pts = [(0, 0), (4, 0), (4, 4), (0, 4), (2, 3.5), (30, 30)]
    >>> gdf = gpd.GeoDataFrame(geometry=shapely.points(pts), crs="EPSG:32631")
    >>> import warnings
    >>> with warnings.catch_warnings(record=True):  # OutlierWarning: 1 row out
    ...     hulls, why, left_out = hull_and_why(gdf, outliers=1)
    >>> int(hulls["n_outliers"].item()), why["limited_by"].item(), left_out.tolist()
    (1, 'outliers', [False, False, False, False, False, True])
    """
    if _is_dask(gdf):
        raise InvalidInputError(
            "hull_and_why() needs an eager GeoDataFrame; call .compute() first"
        )
    opts = why_options(options, "explain()")
    from geoalpha._frame.why import explain_table

    frame = as_frame(gdf)
    ran = run_all(frame, by, opts, **explain_asked(opts))
    left_out = pd.Series(ran.left_out, index=frame.index, name="outlier")
    return Explained(ran.table, explain_table(ran), left_out)


hull_and_why.__signature__ = _options.signature(hull_and_why)
