"""The tables of ``explain()`` and ``curve()``: why each group got its radius.

Both read what :func:`~.pipeline.run_all` made (the kernel's
:class:`~geoalpha._core.Why`), one row per group or per group and ``k``
(:doc:`/user_guide/why`). The checks of their options and the runs that
make them are here too, shared by the eager faces (``hulls``) and dask's
partitions (``dask``).
"""

from __future__ import annotations

import itertools
import numbers

import numpy as np
import pandas as pd
import shapely

from geoalpha import _core as kernel
from geoalpha._frame.pipeline import Ran, run_all
from geoalpha._options import META, Options
from geoalpha.errors import (
    InvalidInputError,
    OutlierWarning,
    first_n,
    setting,
    spelled,
    warn_user,
)

__all__ = [
    "CURVE_COLUMNS",
    "EXPLAIN_COLUMNS",
    "curve_frame",
    "curve_options",
    "curve_table",
    "explain_asked",
    "explain_frame",
    "explain_table",
    "why_options",
]

#: Columns of :func:`geoalpha.explain` after the group keys (then ``geometry``).
EXPLAIN_COLUMNS = (
    "radius",
    "alpha",
    "limited_by",
    "critical_rows",
    "radius_without_1",
    "area_m2_without_1",
    "rows_without_1",
    "suspicious",
)
#: Columns of :func:`geoalpha.curve` after the group keys.
CURVE_COLUMNS = ("k", "radius", "alpha", "area_m2", "n_parts", "left_out")


def _kept(ran: Ran) -> np.ndarray:
    """Return the codes of the groups with a row in the hull table, in its order."""
    keep = ran.hulls.keep
    n = ran.groups.n_groups
    return np.arange(n) if keep is None else np.flatnonzero(keep)


def _keys(ran: Ran, kept: np.ndarray, repeat=None) -> dict:
    columns = (np.asarray(c)[kept] for c in ran.groups.columns)
    if repeat is not None:
        columns = (np.repeat(c, repeat) for c in columns)
    return dict(zip(ran.groups.names, columns, strict=True))


def _label_lists(ran: Ran, positions: np.ndarray, offsets: np.ndarray) -> pd.Series:
    """Index labels of the points ``positions[offsets[i]:offsets[i + 1]]``, per i.

    A Series of lists (object dtype), on a range index.
    """
    labels = ran.points.labels[np.asarray(positions, dtype=np.int64)].tolist()
    cuts = np.asarray(offsets, dtype=np.int64).tolist()
    # an object column even with no row (dask's meta is the table of no row)
    return pd.Series([labels[a:b] for a, b in itertools.pairwise(cuts)], dtype=object)


def _first_alternatives(alt, n_groups: int) -> np.ndarray:
    """Each group's k = 1 alternative (an index into ``alt``), -1 without one."""
    first = np.full(n_groups, -1, dtype=np.int64)
    ones = np.flatnonzero(alt.k == 1)
    first[alt.group[ones][::-1]] = ones[::-1]  # the first of each group wins
    return first


def _in_unit(frame, ran: Ran, suffix: str):
    """Say the unit of planar areas not in metres, as the hull table does.

    With ``crs=None`` on input not in metres, :func:`geoalpha.hull` writes
    ``area`` and ``unit`` (:func:`~.schema.with_area_unit`); ``area_m2{suffix}``
    then becomes ``area{suffix}``, followed by the same ``unit``.
    """
    if "unit" not in ran.table.columns:
        return frame
    unit = ran.table["unit"].iloc[0] if len(ran.table) else ""  # (no row)
    name = f"area{suffix}"
    frame = frame.rename(columns={f"area_m2{suffix}": name})
    frame.insert(list(frame.columns).index(name) + 1, "unit", unit)
    return frame


def explain_table(ran: Ran):
    """Build :func:`geoalpha.explain`'s GeoDataFrame from a run with ``explain``."""
    import geopandas as gpd

    hulls, why = ran.hulls, ran.hulls.why
    kept = _kept(ran)
    alt = why.alternatives
    degenerate = np.asarray(hulls.degenerate, dtype=bool)[kept]
    names = np.array([kernel.LIMITED_BY[c] for c in range(len(kernel.LIMITED_BY))])
    limited = np.where(degenerate, "degenerate", names[why.limited_by[kept]])
    # critical_rows: the three corners, then the points covered last
    corners = why.critical[kept]
    has = (corners[:, 0] >= 0) & ~degenerate
    last, last_offsets = why.last
    n_last = np.where(has, np.diff(last_offsets)[kept], 0)
    size = np.where(has, 3 + n_last, 0)
    offsets = np.zeros(len(kept) + 1, dtype=np.int64)
    np.cumsum(size, out=offsets[1:])
    take = np.zeros(offsets[-1], dtype=np.int64)
    starts = offsets[:-1][has]
    for j in range(3):
        take[starts + j] = corners[has, j]
    counts = n_last[has]
    within = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    src = np.repeat(last_offsets[kept][has], counts) + within
    take[np.repeat(starts + 3, counts) + within] = last[src]
    critical = _label_lists(ran, take, offsets)
    geometry = np.full(len(kept), None, dtype=object)
    if has.any():
        ring = ran.points.coords[corners[has]]  # (g, 3, 2)
        geometry[has] = shapely.polygons(ring)
    # the one-location alternative
    first = _first_alternatives(alt, ran.groups.n_groups)[kept]
    first = np.where(degenerate, -1, first)
    ok = first >= 0
    i = first[ok]
    # area_m2 of a hull is geodesic, the kernel's planar: scale the alternative
    # by the group's ratio of the two (the CRS's areal scale where it is).
    with np.errstate(divide="ignore", invalid="ignore"):
        scale = np.where(hulls.planar_area > 0, hulls.area / hulls.planar_area, 1.0)
    radius_1 = np.full(len(kept), np.nan)
    area_1 = np.full(len(kept), np.nan)
    radius_1[ok] = alt.radius[i]
    area_1[ok] = alt.area[i] * scale[kept][ok]
    n_rows = np.zeros(len(kept), dtype=np.int64)
    n_rows[ok] = np.diff(alt.row_offsets)[i]
    row_offsets = np.zeros(len(kept) + 1, dtype=np.int64)
    np.cumsum(n_rows, out=row_offsets[1:])
    src = np.concatenate(
        [np.arange(alt.row_offsets[a], alt.row_offsets[a + 1]) for a in i] or [[]]
    ).astype(np.int64)
    rows_1 = _label_lists(ran, alt.rows[src], row_offsets)
    table = ran.table
    values = {
        "radius": table["radius"].to_numpy(),
        "alpha": table["alpha"].to_numpy(),
        "limited_by": limited,
        "critical_rows": critical,
        "radius_without_1": radius_1,
        "area_m2_without_1": area_1,
        "rows_without_1": rows_1,
        "suspicious": np.asarray(why.suspicious, dtype=bool)[kept] & ~degenerate,
    }
    frame = _in_unit(pd.DataFrame({**_keys(ran, kept), **values}), ran, "_without_1")
    return gpd.GeoDataFrame(frame, geometry=geometry, crs=ran.points.crs)


def curve_table(ran: Ran, max_left_out: int, unit: str):
    """Build :func:`geoalpha.curve`'s DataFrame from a run with ``max_left_out``."""
    hulls, alt = ran.hulls, ran.hulls.why.alternatives
    kept = _kept(ran)
    table = ran.table
    shaped = ~np.asarray(hulls.degenerate, dtype=bool)[kept]
    kept, table = kept[shaped], table[shaped]
    n_groups = ran.groups.n_groups
    # one row per group (k = 0) and per alternative, grouped, k ascending
    count = np.bincount(alt.group, minlength=n_groups)
    sizes = 1 + count[kept]
    where = np.zeros(n_groups, dtype=bool)
    where[kept] = True
    use = np.flatnonzero(where[alt.group])  # the alternatives of kept groups
    owner = np.concatenate([kept, alt.group[use]])
    order = np.lexsort((np.concatenate([np.zeros(len(kept)), alt.k[use]]), owner))
    # k = 0 from the hull table, the others from the kernel
    zero_parts = table["n_parts"].to_numpy().astype(np.int64)
    k = np.concatenate([np.zeros(len(kept), dtype=np.int64), alt.k[use]])[order]
    radius = np.concatenate([table["radius"].to_numpy(), alt.radius[use]])[order]
    area = np.concatenate([hulls.planar_area[kept], alt.area[use]])[order]
    parts = np.concatenate([zero_parts, alt.n_parts[use]])[order]
    n_left = np.concatenate(
        [np.zeros(len(kept), np.int64), np.diff(alt.row_offsets)[use]]
    )
    n_left = n_left[order]
    offsets = np.zeros(len(order) + 1, dtype=np.int64)
    np.cumsum(n_left, out=offsets[1:])
    which = order - len(kept)
    src = [
        np.arange(alt.row_offsets[use[w]], alt.row_offsets[use[w] + 1])
        for w in which
        if w >= 0
    ]
    src = np.concatenate(src or [[]]).astype(np.int64)
    left_out = _label_lists(ran, alt.rows[src], offsets)
    with np.errstate(divide="ignore", invalid="ignore"):
        scale = np.where(hulls.planar_area > 0, hulls.area / hulls.planar_area, 1.0)
    owner = owner[order]
    short = np.flatnonzero(sizes - 1 < max_left_out)
    if len(short):
        columns_of = ran.groups.columns
        shown = first_n(
            f"{', '.join(str(c[kept[j]]) for c in columns_of) or 'all points'} "
            f"({sizes[j] - 1})"
            for j in short
        )
        warn_user(
            f"{spelled('curve()')}: {len(short)} group(s) have fewer {unit} than "
            f"{setting('max_left_out', max_left_out)} leaves a shape for (at least "
            f"3 locations stay); their curves stop earlier (largest k): {shown}",
            OutlierWarning,
        )
    with np.errstate(divide="ignore"):
        alpha = np.concatenate([table["alpha"].to_numpy(), 1.0 / alt.radius[use]])
    alpha = alpha[order]
    columns = {
        "k": k,
        "radius": radius,
        "alpha": alpha,
        "area_m2": area * scale[owner],
        "n_parts": parts.astype(np.int64),
        "left_out": left_out,
    }
    return _in_unit(pd.DataFrame({**_keys(ran, kept, sizes), **columns}), ran, "")


def why_options(options: dict, caller: str) -> Options:
    """Check the options of ``explain()``/``curve()`` (eager and dask): alpha only."""
    opts = Options.from_kwargs(options, caller=caller)
    if opts.method != "alpha":
        raise InvalidInputError(
            f"{caller} explains the optimal alpha shape: use it with "
            f"{setting('method', 'alpha')}; got {setting('method', opts.method)}"
        )
    return opts


def explain_asked(opts: Options) -> dict:
    """Return what ``explain()`` asks of the kernel beyond ``hull()``."""
    asked = dict(explain=True, max_left_out=1, left_out_unit="locations")
    if not opts.outliers and opts.search == "exact" and opts.alpha is None:
        asked["suspicious_factor"] = kernel.SUSPICIOUS_FACTOR
    return asked


def explain_frame(frame, by, opts: Options, **run):
    """Return ``explain()``'s table of a GeoDataFrame (dask: of a partition).

    ``run``: :func:`~geoalpha._frame.pipeline.run_all`'s ``checks``/``rows``.
    """
    return explain_table(run_all(frame, by, opts, **run, **explain_asked(opts)))


def curve_options(options: dict, max_left_out, outlier_unit) -> tuple:
    """Check ``curve()``'s arguments (also dask's): ``(Options, K, unit)``."""
    if (
        isinstance(max_left_out, bool)
        or not isinstance(max_left_out, numbers.Integral)
        or max_left_out < 0
    ):
        raise InvalidInputError(
            f"{spelled('max_left_out')} must be an integer >= 0; got {max_left_out!r}"
        )
    unit = META["outlier_unit"].check("outlier_unit", outlier_unit)
    opts = why_options(options, "curve()")
    if opts.outliers:
        raise InvalidInputError(
            "curve() leaves out k = 0 .. max_left_out itself: use it without "
            f"outliers; got {setting('outliers', opts.outliers)}"
        )
    return opts, int(max_left_out), unit


def curve_frame(frame, by, opts: Options, max_left_out: int, unit: str, **run):
    """Return ``curve()``'s table of a GeoDataFrame (dask: of a partition).

    ``run``: :func:`~geoalpha._frame.pipeline.run_all`'s ``checks``/``rows``.
    """
    asked = dict(max_left_out=max_left_out, left_out_unit=unit)
    return curve_table(run_all(frame, by, opts, **run, **asked), max_left_out, unit)
