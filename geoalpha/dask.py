"""Optimal alpha hulls of dask-geopandas frames: data larger than memory.

Importing this module imports dask-geopandas (``pip install geoalpha[dask]``)
and registers ``.alpha`` on its frames.
"""

from __future__ import annotations

import dataclasses
import functools
from typing import NamedTuple

import geopandas as gpd
import numpy as np
import pandas as pd
import shapely

from geoalpha import _options as _options
from geoalpha._arrays.overlap import overlapping_pairs, split_overlaps
from geoalpha._crs_parsing import crs_name, parse_crs
from geoalpha._frame import crs as gcrs
from geoalpha._frame.checks import check_distortion, check_grouping, computation_crs
from geoalpha._frame.pipeline import (
    Groups,
    group,
    merge_reports,
    report_rows,
    row_report,
    run,
    scan_xy,
    warn_split,
)
from geoalpha._frame.schema import (
    empty_result,
    planar_unit,
    result_geometry_name,
    with_area_unit,
)
from geoalpha._frame.why import (
    curve_frame,
    curve_options,
    explain_frame,
    why_options,
)
from geoalpha._options import Options
from geoalpha._registration import ColumnHint, attach
from geoalpha.errors import InvalidInputError, did_you_mean

try:
    import dask
    import dask_geopandas
except ImportError as err:  # pragma: no cover - the dask extra is installed in CI
    raise ImportError(
        "geoalpha on dask-geopandas frames needs dask-geopandas: "
        'pip install "geoalpha[dask]"'
    ) from err

__all__ = ["DaskAlphaAccessor", "curve", "explain", "hull"]

_EXTENT = ["west", "east", "west360", "east360", "south", "north"]
#: Column carrying each row's position in ``ddf.compute()`` through the shuffle.
_ROW = "__geoalpha_row__"
#: Row positions are ``partition << _ROW_BITS | row in partition``.
_ROW_BITS = 40
#: Columns carrying 2D points through the shuffle as x/y (``_POINT``: which).
_X, _Y, _POINT = "__geoalpha_x__", "__geoalpha_y__", "__geoalpha_point__"


def _key_names(frame, by) -> list:
    if by is None:
        return []
    names = by if isinstance(by, list) else [by]
    for name in names:
        if not isinstance(name, str | int | tuple) or isinstance(name, bool):
            raise InvalidInputError(
                f"hull(by=...) on a dask-geopandas frame needs column names; got "
                f"{type(name).__name__} (assign the values as a column first)"
            )
        if name not in frame.columns:
            raise InvalidInputError(
                f"hull(by={by!r}): no column {name!r}"
                f"{did_you_mean(name, frame.columns)}; the columns are "
                f"{', '.join(map(str, frame.columns))}"
            )
    return names


def _points_xy(plain) -> np.ndarray | None:
    """Return the coordinates of :func:`_for_shuffle`'s rows if all are 2D points.

    Else None (a row of another geometry, missing or empty: read it with
    :func:`_from_shuffle`).
    """
    if not plain[_POINT].to_numpy(dtype=bool).all():
        return None
    x = plain[_X].to_numpy(dtype=np.float64)
    return np.column_stack([x, plain[_Y].to_numpy(dtype=np.float64)])


def _finite_xy(plain, geometry: str, keep=None, xy=None) -> np.ndarray:
    """Return the finite coordinates of the rows of a partition that hull() keeps.

    ``plain``: the partition as :func:`_for_shuffle` wrote it; ``keep``: a row
    mask (the rows with a key), or None; ``xy``: :func:`_points_xy` of it.
    """
    keep = np.ones(len(plain), dtype=bool) if keep is None else keep
    if xy is not None:  # (a point's one coordinate pair: what get_coordinates reads)
        xy = xy[keep]
    else:
        geoms = _from_shuffle(plain, geometry)
        keep = keep & ~(shapely.is_missing(geoms) | shapely.is_empty(geoms))
        xy = shapely.get_coordinates(geoms[keep])
    return xy[np.isfinite(xy).all(axis=1)]  # hull() drops NaN rows, refuses inf


def _extent(xy: np.ndarray) -> list:
    """Longitude/latitude extent of points (``*360``: longitudes in [0, 360))."""
    if not len(xy):
        return [np.nan] * len(_EXTENT)
    lon, lat = xy[:, 0], xy[:, 1]
    shifted = np.mod(lon, 360.0)
    return [lon.min(), lon.max(), shifted.min(), shifted.max(), lat.min(), lat.max()]


def _decide_crs(summary: pd.DataFrame, source_crs):
    """Choose the partitions' ``crs``: the extreme points' UTM zone or "auto-group".

    ``summary``: :func:`_summary` of every partition (its extent columns).
    """
    e = summary[_EXTENT].astype(float).dropna()
    if e.empty:
        return "auto-group"
    lon = np.array([e.west.min(), e.east.max(), e.west360.min(), e.east360.max()])
    lon = np.where(lon >= 180.0, lon - 360.0, lon)
    lat = np.array([e.south.min(), e.north.max()] * 2)
    try:
        _, chosen, _ = gcrs.metric_crs(
            lon, lat, np.zeros(4, dtype=np.intp), 1, crs="auto", source_crs=source_crs
        )
    except InvalidInputError:  # the partitions raise it, naming the rows
        return "auto-group"
    # One group: "auto" gives the dataset's UTM zone (an EPSG code) when the
    # data fit one, else a local LAEA CRS (a PROJ string).
    return chosen[0] if crs_name(chosen[0]).startswith("EPSG:") else "auto-group"


#: Points per partition that the distortion check looks at.
_SAMPLE = 1000


def _sample(xy: np.ndarray) -> np.ndarray:
    """Up to :data:`_SAMPLE` evenly spaced points of ``xy``."""
    if len(xy) > _SAMPLE:
        xy = xy[np.linspace(0, len(xy) - 1, _SAMPLE).astype(np.intp)]
    return xy


class _Asked(NamedTuple):
    """What :func:`_summary` reads of every partition (what the call needs)."""

    names: list  #: the key columns: the distinct keys and the RowReport
    options: Options
    geometry: str
    extent: bool  #: for the ``crs="auto"`` decision
    sample: bool  #: for the distortion check


#: The columns of :func:`_summary`'s row (objects: a table, a report, points).
_SUMMARY = ["keys", "report", *_EXTENT, "sample"]


def _summary(plain, asked: _Asked) -> pd.DataFrame:
    """One row about a partition, before the shuffle: what the checks read.

    Its distinct keys and :class:`~geoalpha._frame.pipeline.RowReport` (with
    ``names``), its extent, a sample of its points; from the coordinates
    :func:`_for_shuffle` read (the geometries are read again only where a
    row is not a 2D point).
    """
    names, options, geometry = asked.names, asked.options, asked.geometry
    keys = report = sample = keyed = None
    extent = [np.nan] * len(_EXTENT)
    xy = _points_xy(plain)
    if names:
        keys = plain[names]
        if options.dropna:  # (as groupby(dropna=True): a row missing one has none)
            keyed = keys.notna().all(axis=1).to_numpy()
            keys = keys[keyed]
        keys = keys.drop_duplicates()
        if xy is not None:
            codes = np.zeros(len(plain), dtype=np.int64)
            if keyed is not None:
                codes[~keyed] = -1
            report = scan_xy(plain.index, xy, codes)[0]
        else:  # (row_report makes the same codes)
            frame = _geo(plain, geometry, None)
            report = row_report(
                frame, names, dropna=options.dropna, vertices=options.vertices
            )
    if asked.extent:
        extent = _extent(_finite_xy(plain, geometry, keyed, xy))
    if asked.sample:
        sample = _sample(_finite_xy(plain, geometry, None, xy))
    row = {"keys": [keys], "report": [report], "sample": [sample]}
    row.update((name, [value]) for name, value in zip(_EXTENT, extent, strict=True))
    return pd.DataFrame({c: pd.Series(row[c], dtype=_dtype(c)) for c in _SUMMARY})


def _dtype(column: str):
    return float if column in _EXTENT else object


def _check(summary, by, source_crs, crs, asked: _Asked) -> None:
    """Make the errors and warnings about the input, once, in the eager order."""
    if asked.names:
        keys = pd.concat(summary["keys"].tolist(), ignore_index=True)
        report = merge_reports(summary["report"].tolist())
        check_grouping(len(keys.drop_duplicates()), report.n_rows, by)
        report_rows(report)
    if asked.sample:
        sample = np.concatenate([np.reshape(s, (-1, 2)) for s in summary["sample"]])
        check_distortion(sample, source_crs, crs)


def _for_shuffle(part, geometry: str, partition_info=None) -> pd.DataFrame:
    """Plain rows for the shuffle: 2D points as x/y, other geometries as WKB.

    Both are exact; a point's two floats cost far less than its WKB to write,
    move and read back, and the partitions after the shuffle take them as
    they are, without building a geometry (the profile of
    ``benchmarks/bench_dask.py``). Plus each row's position in
    ``ddf.compute()``. The one pass over the input geometries: the checks
    (:func:`_summary`) read these columns too.
    """
    number = partition_info["number"] if partition_info else 0
    first = np.int64(number) << np.int64(_ROW_BITS)
    geoms = np.asarray(part[geometry].array, dtype=object)
    point = (shapely.get_type_id(geoms) == 0) & ~shapely.has_z(geoms)
    wkb = np.full(len(geoms), None, dtype=object)
    xy = shapely.get_coordinates(geoms) if point.all() else None
    if xy is None or len(xy) < len(geoms):  # (an empty point has no coordinate)
        point &= ~shapely.is_empty(geoms)
        xy = np.full((len(geoms), 2), np.nan)
        xy[point] = shapely.get_coordinates(geoms[point])
        wkb[~point] = shapely.to_wkb(_nan_kept(geoms[~point]))  # None stays None
    out = pd.DataFrame(part, copy=False)
    out[geometry] = wkb
    out[_X], out[_Y], out[_POINT] = xy[:, 0], xy[:, 1], point
    out[_ROW] = first + np.arange(len(part), dtype=np.int64)
    return out


def _from_shuffle(part, geometry: str):
    """Return the geometries :func:`_for_shuffle` wrote (numpy array of objects)."""
    wkb = np.asarray(part[geometry].to_numpy(), dtype=object)
    point = np.asarray(part[_POINT].to_numpy(), dtype=bool)
    geoms = np.full(len(wkb), None, dtype=object)
    geoms[~point] = shapely.from_wkb(wkb[~point])
    x = np.asarray(part[_X].to_numpy(), dtype=np.float64)
    y = np.asarray(part[_Y].to_numpy(), dtype=np.float64)
    geoms[point] = shapely.points(x[point], y[point])
    return geoms


def _nan_kept(array) -> np.ndarray:
    """Keep NaN points of multi-geometries through WKB: ``(NaN, NaN)`` as ``(NaN, 0)``.

    WKB drops the first and keeps the second, which hull() drops alike.
    """
    geoms = np.asarray(array, dtype=object)
    kind = shapely.get_type_id(geoms)
    multi = np.flatnonzero((kind == 4) | (kind == 7))
    xy, at = shapely.get_coordinates(geoms[multi], return_index=True)
    rows = np.unique(multi[at[np.isnan(xy).all(axis=1)]])
    if not len(rows):
        return geoms
    geoms = geoms.copy()
    geoms[rows] = shapely.transform(geoms[rows], _nan_y_zero)
    return geoms


def _nan_y_zero(xy: np.ndarray) -> np.ndarray:
    """Return ``(NaN, NaN)`` points as ``(NaN, 0)``."""
    return np.where(np.isnan(xy).all(axis=1, keepdims=True) & [False, True], 0.0, xy)


def _hull_partition(
    part, by, crs, meta, geometry, source_srs, options: Options, checked=None
):
    if len(part) == 0:
        return meta
    frame, xy = _restored(part, geometry, _crs_of(source_srs))
    # With ``by``, the dataset's bad rows were reported once (``checked``).
    opts = dataclasses.replace(options, crs=crs)
    out, _ = run(frame, by, opts, checks=False, rows=by is None, xy=xy)
    return _as_meta(out, meta.dtypes.drop(meta.geometry.name))


def _as_meta(out, dtypes: pd.Series):
    """Return ``out`` with ``dtypes`` (columns -> dtype): the columns that differ cast.

    Text may be stored as pyarrow strings by dask; lists of labels stay objects.
    """
    cast = {c: t for c, t in dtypes.items() if out[c].dtype != t}
    return out.astype(cast) if cast else out


def _involved(table, names: list) -> pd.DataFrame:
    """Return the keys of the groups whose hulls overlap another's (first pass)."""
    geoms = np.asarray(table.geometry.array, dtype=object)
    pairs = overlapping_pairs(geoms)
    return table[names].iloc[np.unique(pairs)].reset_index(drop=True)


def _points_of(part, involved, names, geometry, source_crs) -> pd.DataFrame:
    """Return the rows of a shuffled partition in the ``involved`` groups."""
    columns = [*names, geometry, _X, _Y, _POINT, _ROW]  # as :func:`_for_shuffle`
    if len(part) == 0 or len(involved) == 0:
        return part.iloc[:0][columns]
    index = pd.MultiIndex.from_frame(involved[names])
    mine = pd.MultiIndex.from_frame(part[names]).isin(index)
    return part.loc[mine, columns]


#: The area columns of the split table (with ``crs=None`` in another unit than
#: metres: ``area`` and ``area_ceded``, as :func:`~.schema.with_area_unit` names).
SPLIT_AREAS = ("area_m2", "area_ceded_m2")


def _split_table(table, near, names: list, options: Options, source_crs, geometry):
    """Split the hulls in ``table``: the second pass of ``overlap="split"``.

    ``near``: the rows (as shuffled: :func:`_for_shuffle`'s columns, row
    positions) of the groups whose hulls overlap; the same function as
    :func:`geoalpha.hull` on them. Without ``names``, one group: nothing to split.
    """
    if names:  # the groups in the eager call's order: the same cuts, bit for bit
        table = table.sort_values(names, kind="stable", na_position="last")
    table = table.reset_index(drop=True)
    n = len(table)
    geoms = np.asarray(table.geometry.array, dtype=object)
    if names and len(near):
        near = near.sort_values(_ROW, kind="stable")  # the eager order of the rows
        xy = _points_xy(near)
        if xy is not None:  # (get_coordinates: a point's one coordinate pair)
            at = np.arange(len(near))
        else:
            points = _from_shuffle(near, geometry)
            xy, at = shapely.get_coordinates(points, return_index=True)
    else:
        near, xy, at = near.iloc[:0], np.zeros((0, 2)), np.zeros(0, dtype=np.int64)
    if names and n and len(at):
        index = pd.MultiIndex.from_frame(table[names])
        codes = index.get_indexer(pd.MultiIndex.from_frame(near[names]))[at]
    else:
        codes = np.zeros(len(at), dtype=np.int64)
    ok = (codes >= 0) & np.isfinite(xy).all(axis=1)
    xy, codes = xy[ok], codes[ok]
    order = np.argsort(codes, kind="stable")
    split = split_overlaps(geoms, xy[order], codes[order])
    groups = Groups(
        np.zeros(0, dtype=np.int64),
        tuple(names) or ("group",),
        tuple(table[c].array for c in names),
        n,
    )
    warn_split(split, groups)
    planar = "area_m2" not in table  # crs=None in another unit: area and unit
    area_column, ceded_column = ("area", "area_ceded") if planar else SPLIT_AREAS
    area = table[area_column].to_numpy(dtype=np.float64).copy()
    ceded = np.zeros(n)
    changed = split.changed
    if changed.any():
        new = split.geometry[changed]
        if options.crs is None:
            after = shapely.area(new)
        else:
            after = gcrs.geodesic_areas(new, source_crs)
        ceded[changed] = np.maximum(area[changed] - after, 0.0)
        area[changed] = after
    out = table.copy()
    out[table.geometry.name] = gpd.GeoSeries(
        split.geometry, index=out.index, crs=table.crs
    )
    out["n_parts"] = np.where(
        shapely.is_empty(split.geometry), 0, shapely.get_num_geometries(split.geometry)
    ).astype(np.int32)
    out[area_column] = area
    out[ceded_column] = ceded
    out["neighbours"] = split.neighbours
    geometry = out.pop(table.geometry.name)
    out[table.geometry.name] = geometry  # the geometry column stays last
    return gpd.GeoDataFrame(out, geometry=table.geometry.name, crs=table.crs)


def _finish(part, keys: list, checked=None):
    """Return a result partition (sorted by ``keys``) after the lazy ``checked``."""
    if keys:
        part = part.sort_values(keys, kind="stable", na_position="last")
    return part.reset_index(drop=True)


def hull(ddf, by=None, *, npartitions: int | None = None, **options):
    """Optimal alpha hulls of the groups of a dask-geopandas frame (lazy).

    :func:`geoalpha.hull` on each partition of a shuffle by ``by`` (see
    :doc:`/dask`); also ``ddf.alpha.hull(by=...)``.

    Parameters
    ----------
    ddf : dask_geopandas.GeoDataFrame or dask_geopandas.GeoSeries
        Point geometries.
    by : str or list of str, optional
        Column name(s), not values (assign them as a column); None: one hull.
    npartitions : int, optional
        Partitions of the shuffle (default: as many as ``ddf`` has).
    **options
        The options of :func:`geoalpha.hull`, with these differences:

        - ``crs="auto"``: one UTM zone or not is decided for the whole dataset;
        - ``sort=True`` gathers the result into one partition (``sort=False``
          leaves it in the shuffle's partitions).

    Returns
    -------
    dask_geopandas.GeoDataFrame
        Lazy; its ``.compute()`` equals ``geoalpha.hull(ddf.compute(), by,
        ...)`` (with ``sort=True``).

    Raises
    ------
    InvalidInputError
        For ``by`` that is not a column, ``n_jobs`` other than None or 1,
        ``progress=True`` or bad options; on the data, by ``.compute()``.

    .. versionadded:: 0.1.0

    Examples
    --------
    >>> import dask_geopandas
    >>> import geoalpha
    >>> from geoalpha import datasets
    >>> points = datasets.load("uk_clusters")
    >>> ddf = dask_geopandas.from_geopandas(points, npartitions=4)
    >>> lazy = geoalpha.hull(ddf, by="Cluster")
    >>> hulls = lazy.compute()
    >>> len(hulls), hulls["crs_used"].unique().tolist()
    (691, ['EPSG:32630'])
    >>> hulls.geom_equals_exact(points.alpha.hull(by="Cluster"), 0).all()
    np.True_
    """
    ddf = _frame(ddf, "hull()")
    opts = Options.from_kwargs(options)
    if opts.n_jobs not in (None, 1):
        raise InvalidInputError(
            f"n_jobs={opts.n_jobs!r} does not apply to dask-geopandas input: dask "
            "spreads the partitions over its workers (choose them with the scheduler "
            "or a distributed.Client)"
        )
    if opts.progress:
        raise InvalidInputError(
            "progress=True does not apply to dask-geopandas input; use "
            "dask.diagnostics.ProgressBar or distributed.progress"
        )
    opts = dataclasses.replace(opts, progress=False, n_jobs=1)
    names = _key_names(ddf, by)
    keys = group(ddf._meta, by, opts).keys  # the eager result's columns and dtypes
    geometry_name = result_geometry_name(ddf._meta, keys)
    meta = empty_result(keys, ddf._meta.crs, geometry_name, opts.overlap)
    meta = with_area_unit(meta, planar_unit(ddf._meta.crs, opts.crs))
    # overlap="split": the partitions make the hulls as with "keep"; a second
    # pass over them (they are small) and the points of the groups that overlap.
    split = opts.overlap == "split"
    each = dataclasses.replace(opts, overlap="keep") if split else opts
    meta_each = meta
    if split:
        meta_each = empty_result(keys, ddf._meta.crs, geometry_name)
        meta_each = with_area_unit(meta_each, planar_unit(ddf._meta.crs, opts.crs))
    if names:  # the eager checks of the options, on the (empty) meta frame
        run(ddf._meta, by, opts, checks=False)
    grouped, crs, checked = _shuffled(ddf, names, by, opts, npartitions)
    out = _on_partitions(
        grouped, _hull_partition, ddf, by, crs, meta_each, each, checked
    )
    if split:
        out = _second_pass(out, grouped, names, opts, ddf, meta)
    keys = list(meta.columns[: meta.columns.get_loc("alpha")])
    return _finished(out, keys, checked, meta, opts.sort)


def _on_partitions(grouped, func, ddf, by, crs, meta, how, checked):
    """Map ``func(part, by, crs, meta, geometry, source, how, checked)`` lazily.

    ``how``: the options (hull) or the table to make (explain, curve);
    ``checked``: the input checks, which every partition waits for (their
    errors name every bad row).
    """
    source = _srs(ddf.crs)  # (each partition parses it once per worker)
    geometry = ddf.geometry.name
    args = (by, crs, meta, geometry, source, how, checked)
    return grouped.map_partitions(func, *args, meta=meta, enforce_metadata=False)


def _finished(out, keys: list, checked, meta, sort: bool):
    """Return the partitions after ``checked``: in one, by ``keys``, if ``sort``."""
    if sort:
        out = out.repartition(npartitions=1)
        return out.map_partitions(
            _finish, keys, checked, meta=meta, enforce_metadata=False
        )
    if checked is not None:  # the result depends on the checks, not the tables
        return out.map_partitions(
            _finish, [], checked, meta=meta, enforce_metadata=False
        )
    return out


def _second_pass(out, grouped, names: list, opts: Options, ddf, meta):
    """``overlap="split"`` on the hulls ``out``: one partition, lazy."""
    hulls = out.repartition(npartitions=1)
    geometry = ddf.geometry.name
    if names:
        involved = dask.delayed(_involved)(hulls, names)
        rows = grouped._meta[[*names, geometry, _X, _Y, _POINT, _ROW]]
        near = grouped.map_partitions(
            _points_of, involved, names, geometry, ddf.crs, meta=rows
        ).repartition(npartitions=1)
    else:  # one group: nothing to split
        near = grouped.map_partitions(lambda part: part.iloc[:0], meta=grouped._meta)
        near = near.repartition(npartitions=1)
    whole = dask.delayed(_split_table)(hulls, near, names, opts, ddf.crs, geometry)
    return dask.dataframe.from_delayed([whole], meta=meta, verify_meta=False)


hull.__signature__ = _options.signature(hull)


def _srs(crs) -> str | None:
    """Return the text of a CRS (what pickling keeps of it), for :func:`_crs_of`."""
    return None if crs is None else crs.srs


@functools.lru_cache(maxsize=16)
def _crs_of(srs: str | None):
    """Return the CRS ``srs`` (:func:`_srs`), parsed once per process.

    dask hands every task its own copy of a CRS argument, which parses its
    text again (some 15 ms) where it is first used: the partitions take the
    text and share one parsed CRS per worker.
    """
    return parse_crs(srs)


def _geo(plain, geometry: str, source_crs, geoms=None):
    """Return :func:`_for_shuffle`'s rows as a GeoDataFrame (``geoms``: its geometries).

    ``geoms`` None: read back from the shuffle's columns (:func:`_from_shuffle`).
    """
    if geoms is None:
        geoms = _from_shuffle(plain, geometry)
    frame = plain.drop(columns=[_ROW, _X, _Y, _POINT])
    frame[geometry] = gpd.GeoSeries(geoms, index=frame.index, crs=source_crs)
    return gpd.GeoDataFrame(frame, geometry=geometry, crs=source_crs)


def _restored(part, geometry: str, source_crs):
    """Return a shuffled partition as the eager input: its rows, order and points.

    Returns ``(frame, xy)``: when every row is a 2D point, ``xy`` holds their
    coordinates and the frame's geometries are not built (None: the pipeline
    reads ``xy``, :func:`~geoalpha._frame.pipeline.read_points`); else ``xy``
    is None and the frame holds the geometries.
    """
    # Back to the input order within every group: the triangulation works
    # relative to a group's first point, so its last bits depend on it.
    part = part.sort_values(_ROW, kind="stable")
    xy = _points_xy(part)
    geoms = np.full(len(part), None, dtype=object) if xy is not None else None
    return _geo(part, geometry, source_crs, geoms), xy


def _why_partition(part, by, crs, meta, geometry, source_srs, table, checked=None):
    """Return ``table(partition, crs)`` (explain's or curve's) in ``meta``'s dtypes."""
    if len(part) == 0:
        return meta
    frame, xy = _restored(part, geometry, _crs_of(source_srs))
    out = table(frame, crs, by, xy)
    # lists of labels stay objects; dask may store text as pyarrow strings
    dtypes = meta.dtypes
    if isinstance(meta, gpd.GeoDataFrame):  # (explain's; curve's is a DataFrame)
        dtypes = dtypes.drop(meta._geometry_column_name)
    return _as_meta(out, dtypes)


def _dask_options(opts: Options) -> Options:
    """Refuse what dask cannot do (as :func:`hull`); return the partitions' options."""
    if opts.n_jobs not in (None, 1):
        raise InvalidInputError(
            f"n_jobs={opts.n_jobs!r} does not apply to dask-geopandas input: dask "
            "spreads the partitions over its workers (choose them with the scheduler "
            "or a distributed.Client)"
        )
    if opts.progress:
        raise InvalidInputError(
            "progress=True does not apply to dask-geopandas input; use "
            "dask.diagnostics.ProgressBar or distributed.progress"
        )
    return dataclasses.replace(opts, progress=False, n_jobs=1)


def _frame(ddf, caller: str):
    """Return ``ddf`` as a dask-geopandas GeoDataFrame, or refuse it."""
    if isinstance(ddf, dask_geopandas.GeoSeries):
        ddf = ddf.to_frame(name="geometry")
    if not isinstance(ddf, dask_geopandas.GeoDataFrame):
        raise InvalidInputError(
            f"geoalpha.dask.{caller} needs a dask_geopandas.GeoDataFrame or "
            f"GeoSeries; got {type(ddf).__name__}"
        )
    return ddf


def _shuffled(ddf, names: list, by, opts: Options, npartitions):
    """Shuffle the rows by ``names``; check them once; decide the CRS once.

    Returns ``(grouped, crs, checked)``: the partitions (each group in one),
    the computation CRS (lazy where ``crs="auto"`` decides it from every
    partition's extent) and the lazy checks of the bad rows (or None).
    """
    crs, source, geometry = opts.crs, ddf.crs, ddf.geometry.name
    geographic = source is not None and parse_crs(source).is_geographic
    asked = _Asked(
        names=names,
        options=opts,
        geometry=geometry,
        extent=gcrs.auto_mode(crs) == "auto" and geographic,
        sample=computation_crs(source, crs)[0] is not None,
    )
    used = list(dict.fromkeys([*names, geometry]))
    if len(ddf.columns) > len(used):  # read and move only the columns hull() reads
        ddf = ddf[used]
    # One pass over the input geometries (the points to floats); the checks,
    # the CRS decision and the shuffle read its columns.
    plain = ddf.map_partitions(
        _for_shuffle, geometry, meta=_for_shuffle(ddf._meta, geometry)
    )
    checked = None
    if names or asked.extent or asked.sample:
        meta = pd.DataFrame({c: pd.Series(dtype=_dtype(c)) for c in _SUMMARY})
        summary = plain.map_partitions(
            _summary, asked, meta=meta, enforce_metadata=False
        )
        if names or asked.sample:
            checked = dask.delayed(_check)(summary, by, source, opts.crs, asked)
        if asked.extent:
            crs = dask.delayed(_decide_crs)(summary, source)
    if names:
        grouped = plain.shuffle(on=names, npartitions=npartitions)
    else:
        grouped = plain.repartition(npartitions=1)
    return grouped, crs, checked


def _per_group(ddf, by, npartitions, opts: Options, table, first: str, order: list):
    """Run ``table(partition, crs, by)`` on every group of ``ddf`` as :func:`hull` does.

    One shuffle by ``by``, one CRS decision, the input checks once; ``meta``
    is ``table`` of the empty frame (the eager code). ``first``: the first
    column after the keys; ``order``: the columns after the keys that order
    a group's rows (with ``sort=True``).
    """
    names = _key_names(ddf, by)
    meta = table(ddf._meta, opts.crs, by)  # the eager checks of the options too
    grouped, crs, checked = _shuffled(ddf, names, by, opts, npartitions)
    out = _on_partitions(grouped, _why_partition, ddf, by, crs, meta, table, checked)
    keys = list(meta.columns[: meta.columns.get_loc(first)])
    return _finished(out, keys + order, checked, meta, opts.sort)


class _Explain:
    """explain()'s table of a partition (a class: picklable for distributed)."""

    def __init__(self, opts: Options):
        self.opts = opts

    def __call__(self, frame, crs, by, xy=None):
        opts = dataclasses.replace(self.opts, crs=crs)
        # With ``by``, the dataset's bad rows were reported once (``checked``).
        return explain_frame(frame, by, opts, checks=False, rows=by is None, xy=xy)


class _Curve(_Explain):
    """curve()'s table of a partition."""

    def __init__(self, opts: Options, max_left_out: int, unit: str):
        super().__init__(opts)
        self.max_left_out, self.unit = max_left_out, unit

    def __call__(self, frame, crs, by, xy=None):
        opts = dataclasses.replace(self.opts, crs=crs)
        k, unit = self.max_left_out, self.unit
        return curve_frame(
            frame, by, opts, k, unit, checks=False, rows=by is None, xy=xy
        )


def explain(ddf, by=None, *, npartitions: int | None = None, **options):
    """Why each group's hull got its radius, on a dask-geopandas frame (lazy).

    :func:`geoalpha.explain` on each partition of a shuffle by ``by``, as
    :func:`hull` runs :func:`geoalpha.hull` (see :doc:`/dask`); also
    ``ddf.alpha.explain(by=...)``.

    Parameters
    ----------
    ddf, by, npartitions, **options
        As for :func:`hull` (``method="alpha"``).

    Returns
    -------
    dask_geopandas.GeoDataFrame
        Lazy; its ``.compute()`` equals ``geoalpha.explain(ddf.compute(),
        by, ...)`` (with ``sort=True``).

    Raises
    ------
    InvalidInputError
        As :func:`hull`; for ``method`` other than ``"alpha"``.

    .. versionadded:: 0.3.0

    Examples
    --------
    >>> import dask_geopandas
    >>> import geoalpha
    >>> from geoalpha import datasets
    >>> points = datasets.load("uk_clusters")
    >>> ddf = dask_geopandas.from_geopandas(points, npartitions=4)
    >>> why = geoalpha.explain(ddf, by="Cluster", suspicious=False).compute()
    >>> len(why), why["limited_by"].iloc[0]
    (691, 'coverage')
    """
    ddf = _frame(ddf, "explain()")
    opts = _dask_options(why_options(options, "explain()"))
    return _per_group(ddf, by, npartitions, opts, _Explain(opts), "radius", [])


explain.__signature__ = _options.signature(explain)


def curve(
    ddf,
    by=None,
    *,
    max_left_out: int = 5,
    outlier_unit: str = "rows",
    npartitions: int | None = None,
    **options,
):
    """Compute the exact optima with 0 .. ``max_left_out`` out, on dask (lazy).

    :func:`geoalpha.curve` on each partition of a shuffle by ``by``, as
    :func:`hull` runs :func:`geoalpha.hull` (see :doc:`/dask`); also
    ``ddf.alpha.curve(by=...)``.

    Parameters
    ----------
    ddf, by, npartitions
        As for :func:`hull`.
    max_left_out, outlier_unit, **options
        As for :func:`geoalpha.curve`.

    Returns
    -------
    dask.dataframe.DataFrame
        Lazy; its ``.compute()`` equals ``geoalpha.curve(ddf.compute(), by,
        ...)`` (with ``sort=True``).

    Raises
    ------
    InvalidInputError
        As :func:`geoalpha.curve` and :func:`hull`.

    .. versionadded:: 0.3.0

    Examples
    --------
    >>> import dask_geopandas
    >>> import geoalpha
    >>> from geoalpha import datasets
    >>> points = datasets.load("uk_clusters")
    >>> ddf = dask_geopandas.from_geopandas(points, npartitions=4)
    >>> table = geoalpha.curve(ddf, by="Cluster", max_left_out=2, suspicious=False)
    >>> table.compute()["k"].tolist()[:3]
    [0, 1, 2]
    """
    ddf = _frame(ddf, "curve()")
    opts, k, unit = curve_options(options, max_left_out, outlier_unit)
    opts = _dask_options(opts)
    return _per_group(ddf, by, npartitions, opts, _Curve(opts, k, unit), "k", ["k"])


class DaskAlphaAccessor(ColumnHint):
    """``ddf.alpha.hull(...)``, ``.explain(...)``, ``.curve(...)``: lazy, on dask.

    :func:`hull`, :func:`explain` and :func:`curve` on a dask-geopandas frame.
    """

    def __init__(self, obj):
        self._obj = obj

    @functools.wraps(hull)
    def hull(self, by=None, **options):  # noqa: D102 - documented by hull
        return hull(self._obj, by, **options)

    @functools.wraps(explain)
    def explain(self, by=None, **options):  # noqa: D102 - documented by explain
        return explain(self._obj, by, **options)

    @functools.wraps(curve)
    def curve(self, by=None, **options):  # noqa: D102 - documented by curve
        return curve(self._obj, by, **options)


def register(name: str = "alpha") -> None:
    """Register :class:`DaskAlphaAccessor` as ``name`` on dask-geopandas frames."""
    attach(
        [dask_geopandas.GeoDataFrame, dask_geopandas.GeoSeries], name, DaskAlphaAccessor
    )


register()
