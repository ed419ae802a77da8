"""``hull()`` on one in-memory GeoDataFrame, as a pipeline of named stages.

:func:`run` calls one function per stage, each handing its result to the next
by return value (the stages, in order: docs/architecture.md).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable
from functools import partial
from typing import Any, NamedTuple

import numpy as np
import pandas as pd
import shapely

from geoalpha import _core as kernel
from geoalpha._arrays.comparison import comparison_hulls
from geoalpha._arrays.guarantee import (
    EMPTY_POLYGON,
    convex_hulls,
    covered,
    enforce,
    left_outside,
    repair_invalid,
)
from geoalpha._arrays.optimal import solve_checked, warn_searches
from geoalpha._arrays.overlap import split_overlaps
from geoalpha._arrays.sphere import MAX_SPHERE_DEGREES
from geoalpha._core import AlphaShapes, Reason
from geoalpha._crs_parsing import is_sphere, parse_crs
from geoalpha._frame import crs as gcrs
from geoalpha._frame import progress
from geoalpha._frame.checks import check_distortion, check_grouping
from geoalpha._frame.schema import (
    planar_unit,
    result_columns,
    result_frame,
    result_geometry_name,
    with_area_unit,
)
from geoalpha._frame.sphere import SphereProjection
from geoalpha._options import Options, Request
from geoalpha.errors import (
    AntimeridianWarning,
    DegenerateGroupWarning,
    DroppedRowsWarning,
    GeoAlphaWarning,
    InvalidInputError,
    OutlierWarning,
    SharedLocationWarning,
    SuspiciousHullWarning,
    did_you_mean,
    first_n,
    setting,
    spelled,
    warn_user,
)

__all__ = [
    "Groups",
    "Points",
    "RowReport",
    "area_ceded",
    "as_frame",
    "compute",
    "degenerate_policy",
    "group",
    "guarantee",
    "merge_reports",
    "project",
    "read_points",
    "report_rows",
    "row_report",
    "run",
    "run_all",
    "scan_rows",
    "scan_xy",
    "split_at_antimeridian",
    "split_overlaps_stage",
    "suspicious_groups",
    "table",
    "warn_output_crs",
    "warn_split",
    "warn_suspicious",
]


class Groups(NamedTuple):
    """Output of :func:`group`: a code per row and the key columns, as arrays."""

    codes: np.ndarray  #: group code per row, -1 for a dropped missing key
    names: tuple  #: names of the key columns
    columns: tuple  #: one array per key column, a row a group
    n_groups: int  #: number of groups

    @property
    def keys(self) -> pd.DataFrame:
        """One row per group: the key column(s), built when asked (dask's ``meta``)."""
        keys = pd.DataFrame(dict(enumerate(self.columns)), range(self.n_groups))
        keys.columns = list(self.names)
        return keys


class Points(NamedTuple):
    """Output of :func:`read_points`: the points that take part."""

    coords: np.ndarray  #: (n, 2) coordinates in the input CRS
    codes: np.ndarray  #: group code per point
    n_points: np.ndarray  #: input rows per group
    labels: Any  #: index label per point (for messages), indexable by positions
    rows: np.ndarray  #: row position (in the frame) of each point
    crs: Any  #: the CRS of ``coords`` (the frame's; None when it has none)


class Ran(NamedTuple):
    """Everything :func:`run_all` made: the table and what explain/curve read."""

    table: Any  #: the result GeoDataFrame
    left_out: np.ndarray  #: the row mask of :func:`geoalpha.outlier_rows`
    groups: Groups
    points: Points
    proj: Any  #: the :class:`~.crs.Projection`
    #: the result record as the last stage left it (``area``: ``area_m2``;
    #: ``planar_area``: in the computation CRS, as the alternatives')
    hulls: AlphaShapes


def run(
    frame,
    by,
    options: Options,
    *,
    checks: bool = True,
    rows: bool = True,
    xy: np.ndarray | None = None,
):
    """``hull(frame, by, **options)`` on an in-memory GeoDataFrame: every stage.

    Returns the result table and the row mask of :func:`geoalpha.outlier_rows`.
    ``checks=False`` leaves out the set-up warnings (:mod:`~.checks`),
    ``rows=False`` the dropped rows' (:func:`geoalpha.dask.hull` makes them once);
    ``xy``: the rows' coordinates, when every row is a 2D point read already
    (:func:`read_points`).
    """
    ran = run_all(frame, by, options, checks=checks, rows=rows, xy=xy)
    return ran.table, ran.left_out


def run_all(
    frame,
    by,
    options: Options,
    *,
    checks: bool = True,
    rows: bool = True,
    xy: np.ndarray | None = None,
    **asked,
) -> Ran:
    """Run :func:`run`, returning every stage's result (:class:`Ran`).

    ``xy`` as for :func:`run`; ``asked``: more of the kernel
    (:class:`~geoalpha._options.Request`: ``explain``, ``max_left_out``,
    ``left_out_unit``).
    """
    outer = progress.current()
    if outer is not None and options.progress is not False:
        return _stages(frame, by, options, outer, checks, rows, xy, asked)
    with progress.phases(progress.HULL_PHASES, options.progress) as bar:
        return _stages(frame, by, options, bar, checks, rows, xy, asked)


def _stages(frame, by, options, bar: progress.Phases, checks, rows, xy, asked) -> Ran:
    bar.estimate(progress.hull_costs(len(frame), 0, per_group_crs=False))  # 0: unknown
    bar.start("group")
    groups = group(frame, by, options)
    n_groups = groups.n_groups
    if checks:
        check_grouping(n_groups, len(frame), by)
    points = read_points(frame, groups, options, warn=rows, xy=xy)
    crs = points.crs  # (frame.crs builds a GeoSeries each time)
    # Guess whether groups get a metric CRS each: wide lon/lat, crs="auto".
    src = parse_crs(crs) if gcrs.auto_mode(options.crs) is not None else None
    lon = points.coords[:, 0] if src is not None and src.is_geographic else []
    many = len(lon) > 0 and bool(np.ptp(lon) > 2 * gcrs.UTM_HALF_WIDTH)
    bar.sized(len(points.codes), n_groups, per_group_crs=many)
    bar.start("project")
    if checks:
        check_distortion(points.coords, crs, options.crs)
    proj = project(points, crs, options)
    bar.start("compute", units=n_groups)
    names = partial(_names, groups, counts=points.n_points)
    hulls = compute(points, proj, n_groups, options, names=names, **asked)
    if not asked.get("max_left_out") or asked.get("left_out_unit") == "locations":
        # (a curve in rows has no one-location alternative to name)
        warn_suspicious(hulls, groups, points, options)
    bar.start("check")
    hulls = grow(hulls, points, proj, options)
    grown = hulls.geometry
    hulls = split_at_antimeridian(hulls, points, proj)
    hulls = guarantee(hulls, groups, points, proj, options)
    hulls = degenerate_policy(hulls, groups, points, proj, options)
    hulls = split_overlaps_stage(hulls, groups, points, proj, options)
    warn_output_crs(hulls, groups, points, proj)
    hulls = hulls._replace(
        area=area_m2(hulls, grown, proj, options), planar_area=hulls.area
    )
    hulls = area_ceded(hulls, proj, options)
    name = result_geometry_name(frame, groups.names)
    out = table(groups, points, proj, hulls, crs, name)
    # Planar areas in another unit than metres: ``area`` and ``unit``, as the CLI.
    out = with_area_unit(out, planar_unit(crs, options.crs))
    left_out = report_outliers(hulls, groups, points, len(frame), options)
    return Ran(out, left_out, groups, points, proj, hulls)


def _quoted(value) -> str:
    """Return a key as Python spells it: ``'HI'``, ``67`` (not ``np.int64(67)``)."""
    return repr(value.item() if isinstance(value, np.generic) else value)


def _names(
    groups: Groups, which: np.ndarray, counts=None, value=None, distinct=None
) -> str:
    """Name groups by key (quoted whole, or each value by ``value``) for messages."""
    shown = which[:11]  # first_n shows 10, and "..." when there is an 11th

    def key(value) -> str:
        missing = pd.api.types.is_scalar(value) and pd.isna(value)
        return "nan" if missing else str(value)

    names = [
        ", ".join(map(value or key, (column[i] for column in groups.columns)))
        or "all points"
        for i in np.asarray(shown).tolist()
    ]
    if counts is not None:
        names = [
            f"{n if value else repr(n)} ({c} row{'s' if c != 1 else ''}"
            for n, c in zip(names, counts[shown], strict=True)
        ]
        if distinct is not None:
            names = [
                f"{n}, {d} distinct point{'s' if d != 1 else ''}"
                for n, d in zip(names, distinct[shown], strict=True)
            ]
        names = [f"{n})" for n in names]
    return first_n(names, limit=10, sep="; ")


def _distinct_points(points: Points, which: np.ndarray) -> np.ndarray:
    """Distinct coordinate pairs of each group (counted for the groups ``which``)."""
    out = np.zeros(len(points.n_points), dtype=np.int64)
    sel = np.isin(points.codes, which)
    if sel.any():
        keyed = np.column_stack([points.codes[sel], points.coords[sel]])
        codes = np.unique(keyed, axis=0)[:, 0].astype(np.intp)
        out += np.bincount(codes, minlength=len(out))
    return out


def as_frame(data):
    """Return the input as a GeoDataFrame with an active geometry column."""
    import geopandas as gpd

    if isinstance(data, gpd.GeoSeries):
        return data.to_frame("geometry").set_geometry("geometry")
    if isinstance(data, gpd.GeoDataFrame):
        if data._geometry_column_name not in data.columns:
            raise InvalidInputError(
                "hull() needs a GeoDataFrame with an active geometry column; "
                "call set_geometry() first"
            )
        return data
    raise InvalidInputError(
        f"hull() needs a GeoDataFrame or GeoSeries; got {type(data).__name__}"
    )


def group(frame, by, options: Options) -> Groups:
    """Group code per row (-1: dropped missing key) and the key table.

    ``by`` as for :meth:`GeoDataFrame.dissolve`; None: one group of all rows.
    """
    if by is None:
        return Groups(np.zeros(len(frame), dtype=np.int64), (), (), min(len(frame), 1))
    names = by if isinstance(by, list) else [by]
    levels = [n for n in frame.index.names if n is not None]
    for name in names:
        label = isinstance(name, str | int | tuple) and not isinstance(name, bool)
        if label and name not in frame.columns and name not in levels:
            geometry = frame._geometry_column_name
            choices = [c for c in frame.columns if c != geometry] + levels
            also = f" and the index levels {', '.join(map(str, levels))}"
            raise InvalidInputError(
                f"hull(by={by!r}): no column {name!r}"
                f"{did_you_mean(name, choices)}; the columns "
                f"are {', '.join(map(str, frame.columns))}{also if levels else ''}"
            )
    try:
        groups = _factorize_column(frame, by, options)
        if groups is None:
            grouped = frame.groupby(by, dropna=options.dropna, sort=options.sort)
            codes = grouped.ngroup().fillna(-1).to_numpy(dtype=np.int64)
            keys = grouped.size().index.to_frame(index=False)
            columns = [keys.iloc[:, j].array for j in range(keys.shape[1])]
            groups = Groups(codes, tuple(keys.columns), tuple(columns), len(keys))
    except (ValueError, KeyError, TypeError) as err:
        raise InvalidInputError(f"hull(by=...) cannot group the rows: {err}") from err
    if len(groups.names) == 1 and isinstance(groups.names[0], int | None):
        groups = groups._replace(names=("group",))
    columns = result_columns(options.overlap)
    clash = [c for c in groups.names if c in (*columns, "geometry")]
    if clash:
        raise InvalidInputError(
            f"group column(s) {clash} have the name of a result column; rename them "
            f"(result columns: {', '.join(columns)}, geometry)"
        )
    return groups


def _factorize_column(frame, by, options: Options) -> Groups | None:
    """Group one plain column as ``groupby`` does, without its cost; else None."""
    name = by[0] if isinstance(by, list) and len(by) == 1 else by
    plain = isinstance(name, str) and name not in frame.index.names
    if not plain or name not in frame.columns or not frame.columns.is_unique:
        return None
    column = frame[name]
    if isinstance(column.dtype, pd.CategoricalDtype):
        return None
    counted = _counted(column) if options.sort and column.dtype == np.int64 else None
    codes, uniques = counted or pd.factorize(
        column, sort=options.sort, use_na_sentinel=options.dropna
    )
    codes = codes.astype(np.int64, copy=False)
    return Groups(codes, (name,), (pd.Index(uniques).array,), len(uniques))


def _counted(column: pd.Series) -> tuple | None:
    """``pd.factorize(column, sort=True)`` of int64 keys 0 .. 4n, by counting."""
    values = column.to_numpy()
    if not len(values) or values.min() < 0 or values.max() > 4 * len(values):
        return None
    present = np.bincount(values) > 0
    return (np.cumsum(present) - 1)[values], np.flatnonzero(present)


class _RowLabels:
    """Index labels of points, looked up only when a message names them."""

    def __init__(self, index: pd.Index, rows: np.ndarray):
        self._index = index
        self._rows = rows

    def __getitem__(self, where):
        return np.asarray(self._index[self._rows[where]], dtype=object)


#: Index labels kept of each kind of bad row (first_n shows 10, "..." for an 11th).
_SHOWN = 11


class RowReport(NamedTuple):
    """What :func:`scan_rows` found: bad rows by kind; :func:`merge_reports` sums."""

    n_rows: int  #: rows scanned
    #: per kind ("non_point", "missing", "no_key", "infinite"): number of rows
    counts: dict[str, int]
    #: per kind: the first :data:`_SHOWN` index labels, in row order
    labels: dict[str, list]
    #: geometry type -> rows, of the non-point rows (first appearance order)
    types: dict[str, int]


_ROW_KINDS = ("non_point", "missing", "no_key", "infinite")


def scan_rows(frame, codes: np.ndarray, vertices: bool):
    """Sort the rows of ``frame`` into usable and bad ones.

    Dropped: a missing or empty geometry, a NaN coordinate (an empty WKB point), a
    missing key (``codes`` -1). Errors (:func:`report_rows`): the others.

    Returns
    -------
    (RowReport, numpy.ndarray, numpy.ndarray)
        The report, the (n, 2) coordinates of the rows kept, and the row
        position of each coordinate.
    """
    geoms = np.asarray(frame[frame._geometry_column_name].array, dtype=object)
    coords = np.empty((len(geoms), 2))
    try:  # NaN for a missing or non-point geometry; an empty point raises
        shapely.get_x(geoms, out=coords[:, 0])
        shapely.get_y(geoms, out=coords[:, 1])
        clean = np.isfinite(coords).all() and not (codes < 0).any()
    except shapely.errors.GEOSException:
        clean = False
    if clean:  # the usual case, in two passes: finite points, each with a key
        which = np.arange(len(geoms))
        masks = dict.fromkeys(_ROW_KINDS, np.zeros(len(geoms), dtype=bool))
    else:
        coords, which, masks = _bad_rows(geoms, codes, vertices)
    bad = masks["non_point"]  # (geom_type names every row: only when needed)
    types = Counter(np.asarray(frame.geom_type)[bad].tolist()) if bad.any() else {}
    return _report(len(geoms), masks, frame.index, types), coords, which


def scan_xy(index: pd.Index, xy: np.ndarray, codes: np.ndarray):
    """:func:`scan_rows` of rows that are all 2D points, from their coordinates.

    The rows of a frame whose every geometry is a non-empty 2D point, given
    as their ``(n, 2)`` coordinates ``xy`` (as :func:`shapely.get_coordinates`
    reads them) and the frame's ``index``: the same report, coordinates and
    rows as :func:`scan_rows` of the frame, without reading a geometry.
    Dropped: a NaN coordinate, a missing key (``codes`` -1); refused
    (:func:`report_rows`): an infinite coordinate.

    Returns
    -------
    (RowReport, numpy.ndarray, numpy.ndarray)
        As :func:`scan_rows`.

    Examples
    --------
    >>> import pandas as pd
    >>> xy = np.array([[0.0, 1.0], [np.nan, 2.0], [3.0, 4.0]])
    >>> report, coords, which = scan_xy(pd.RangeIndex(3), xy, np.zeros(3, int))
    >>> report.counts["missing"], report.labels["missing"], which.tolist()
    (1, [1], [0, 2])
    """
    n = len(xy)
    finite = np.isfinite(xy).all(axis=1)
    if finite.all() and not (codes < 0).any():  # the usual case: every row kept
        masks = dict.fromkeys(_ROW_KINDS, np.zeros(n, dtype=bool))
        return _report(n, masks, index, {}), xy, np.arange(n)
    missing = np.isnan(xy).any(axis=1)  # (as scan_rows: NaN before a missing key)
    no_key = (codes < 0) & ~missing
    infinite = ~finite & ~missing & ~no_key
    which = np.flatnonzero(~(missing | no_key))
    kinds = (np.zeros(n, dtype=bool), missing, no_key, infinite)
    masks = dict(zip(_ROW_KINDS, kinds, strict=True))
    return _report(n, masks, index, {}), xy[which], which


def _report(n_rows: int, masks: dict, index: pd.Index, types: dict) -> RowReport:
    """Return the :class:`RowReport` of the bad-row ``masks`` (by kind) of a frame."""
    return RowReport(
        n_rows=n_rows,
        counts={k: int(m.sum()) for k, m in masks.items()},
        labels={  # (taking an Index at no row costs more than the test)
            k: index[np.flatnonzero(m)[:_SHOWN]].tolist() if m.any() else []
            for k, m in masks.items()
        },
        types=dict(types),
    )


def row_report(frame, by, *, dropna: bool, vertices: bool) -> RowReport:
    """Return the :class:`RowReport` of ``frame`` before grouping (:func:`scan_rows`).

    Parameters
    ----------
    frame, by
        A GeoDataFrame and its key columns (a list or None): with ``dropna``, a
        row missing one has a missing key (as ``groupby(dropna=True)`` says).
    dropna, vertices : bool
        As for :func:`geoalpha.hull`.

    Returns
    -------
    RowReport

    Examples
    --------
    >>> import geopandas as gpd
    >>> points = gpd.points_from_xy([0, 1], [0, 1])
    >>> frame = gpd.GeoDataFrame({"k": [1, None]}, geometry=points)
    >>> row_report(frame, ["k"], dropna=True, vertices=False).counts["no_key"]
    1
    """
    codes = np.zeros(len(frame), dtype=np.int64)
    if by and dropna:
        codes[frame[by].isna().any(axis=1).to_numpy()] = -1
    return scan_rows(frame, codes, vertices)[0]


def _bad_rows(geoms: np.ndarray, codes: np.ndarray, vertices: bool):
    """:func:`scan_rows` of rows not all usable points: coordinates, rows, masks."""
    kind = shapely.get_type_id(geoms)
    missing = (kind < 0) | shapely.is_empty(geoms)
    point = np.isin(kind, (0, 4))  # shapely type ids of Point and MultiPoint
    non_point = ~missing & ~point
    usable = np.flatnonzero(~missing & (point | vertices))
    coords, at = shapely.get_coordinates(geoms[usable], return_index=True)
    which = usable[at]
    missing[which[np.isnan(coords).any(axis=1)]] = True
    no_key = (codes < 0) & ~missing
    keep = ~(missing | no_key)[which]
    coords, which = coords[keep], which[keep]
    infinite = np.zeros(len(geoms), dtype=bool)
    infinite[which[~np.isfinite(coords).all(axis=1)]] = True
    kinds = (non_point & (not vertices), missing, no_key, infinite)
    return coords, which, dict(zip(_ROW_KINDS, kinds, strict=True))


def merge_reports(reports) -> RowReport:
    """Add up the :class:`RowReport` of consecutive parts of a frame (in order)."""
    reports = list(reports)
    return RowReport(
        n_rows=sum(r.n_rows for r in reports),
        counts={k: sum(r.counts[k] for r in reports) for k in _ROW_KINDS},
        labels={
            k: [label for r in reports for label in r.labels[k]][:_SHOWN]
            for k in _ROW_KINDS
        },
        types=dict(sum((Counter(r.types) for r in reports), Counter())),
    )


def _shown_labels(labels: list) -> str:
    return first_n(repr(v) if isinstance(v, str) else str(v) for v in labels)


def report_rows(report: RowReport, *, warn: bool = True) -> None:
    """Raise the error, or make the warning, that bad rows call for.

    Parameters
    ----------
    report : RowReport
        From :func:`scan_rows` (or :func:`merge_reports`).
    warn : bool, default True
        Warn (:class:`DroppedRowsWarning`) about the rows dropped for a missing
        geometry, coordinate or key (False: the errors only).

    Raises
    ------
    InvalidInputError
        Non-point geometries (without ``vertices=True``), then infinite
        coordinates, naming the rows by index label.
    """
    counts, labels = report.counts, report.labels
    if counts["non_point"]:
        order = sorted(report.types.items(), key=lambda item: -item[1])
        names = ", ".join(f"{n} {t}" for t, n in order)
        raise InvalidInputError(
            f"{spelled('hull()')} needs point geometries; got {names} row(s) (index "
            f"{_shown_labels(labels['non_point'])}); pass "
            f"{setting('vertices', True)} to use their vertices"
        )
    dropped = counts["missing"] + counts["no_key"]
    if dropped and warn:
        parts = []
        if counts["missing"]:
            parts.append(
                f"{counts['missing']} with a missing or empty geometry or NaN "
                f"coordinates (index {_shown_labels(labels['missing'])})"
            )
        if counts["no_key"]:
            parts.append(
                f"{counts['no_key']} with a missing group key (index "
                f"{_shown_labels(labels['no_key'])}; {setting('dropna', False)} "
                "keeps them)"
            )
        warn_user(
            f"{spelled('hull()')} dropped {dropped} of {report.n_rows} rows: "
            + "; ".join(parts),
            DroppedRowsWarning,
        )
    if counts["infinite"]:
        raise InvalidInputError(
            f"{spelled('hull()')} needs finite coordinates; got infinite values in "
            f"{counts['infinite']} row(s) (index {_shown_labels(labels['infinite'])})"
        )


def read_points(
    frame,
    groups: Groups,
    options: Options,
    *,
    warn: bool = True,
    xy: np.ndarray | None = None,
) -> Points:
    """Read the points that take part and their group codes; refuse or drop bad rows.

    ``xy``: the rows' coordinates when every row is a 2D point, read already
    (:func:`scan_xy`; the geometry column is then not read, only its CRS).
    """
    if xy is not None:
        report, coords, which = scan_xy(frame.index, xy, groups.codes)
    else:
        report, coords, which = scan_rows(frame, groups.codes, options.vertices)
    report_rows(report, warn=warn)
    first = np.ones(len(which), dtype=bool)  # a row's first point (which is sorted)
    first[1:] = which[1:] != which[:-1]
    every = len(which) == len(groups.codes) and first.all()  # which: 0 .. n - 1
    codes = groups.codes if every else groups.codes[which]
    n_points = np.bincount(codes if every else codes[first], minlength=groups.n_groups)
    return Points(
        coords=coords,
        codes=codes,
        n_points=n_points,
        labels=_RowLabels(frame.index, which),
        rows=which,
        crs=frame[frame._geometry_column_name].array.crs,
    )


def project(points: Points, source, options: Options) -> gcrs.Projection:
    """Project the points to metres, with the way back (:class:`~.crs.Projection`).

    ``crs="sphere"``: :class:`~.sphere.SphereProjection`.
    """
    args = (points.coords, points.codes, len(points.n_points), source)
    if is_sphere(options.crs):
        return SphereProjection(*args, labels=points.labels)
    return gcrs.Projection(*args, options.crs, labels=points.labels)


def compute(
    points: Points,
    proj: gcrs.Projection,
    n_groups: int,
    options: Options,
    names: Callable[[np.ndarray], str] | None = None,
    **asked,
) -> AlphaShapes:
    """Compute the shape of every group, by ``method``, in the output coordinates.

    ``"alpha"``, ``"convex"``: one kernel call, the others :mod:`~.arrays.comparison`
    (a shown bar counts groups done); ``names`` names groups (by code) in warnings;
    ``asked``: more of the kernel (:meth:`~geoalpha._options.Options.request`). The
    suspicious check runs at the exact optimum without outliers.
    """
    method = options.method
    bar = progress.current()
    if bar is not None and not bar.shown:
        bar = None  # nobody to tell: one batch, not one per PROGRESS_GROUPS groups
    try:
        if method not in ("alpha", "convex"):
            return _comparison(points, proj, n_groups, options, names, bar)
        sphere = getattr(proj, "sphere", False)
        alpha = 0.0 if method == "convex" else options.alpha
        optimum = alpha is None and options.search == "exact"
        if options.suspicious and optimum and not options.outliers:
            asked.setdefault("suspicious_factor", kernel.SUSPICIOUS_FACTOR)
        request = options.request(
            sphere=sphere, alpha=None if alpha is None else float(alpha), **asked
        )
        res = solve_checked(
            proj.lonlat if sphere else proj.xy,
            points.codes,
            n_groups,
            request,
            # None: the output coordinates are the computation's (projected input)
            out=proj.out if sphere or proj.out is not proj.xy else None,
            progress=bar,
            polar=getattr(proj, "polar", None),
        )  # too wide for the sphere: degenerate (HEMISPHERE), worded below
        warn_searches(res, request, names)
        geometry = res.geometry
        if method == "convex" and not sphere:  # (the sphere's is the kernel's)
            convex = convex_hulls(proj.out, points.codes, n_groups)
            geometry = np.where(res.degenerate, geometry, convex)
        # "ladder"/"bisect" name the search that gave the alpha
        exact = method == "convex" or options.search == "exact"
        return res._replace(
            geometry=geometry,  # area_m2 (on the ellipsoid) comes at the end
            labels=np.full(n_groups, method if exact else options.search, dtype=object),
            made=res.geometry,
        )
    finally:
        if bar is not None:  # groups of 1-2 points are done too: the phase ends full
            bar.update(n_groups)


def _comparison(
    points, proj, n_groups: int, options: Options, names, bar
) -> AlphaShapes:
    """:func:`compute` for ``"concave"`` and ``"knn"``: no alpha, no kernel sweep."""
    kw = {"holes": options.holes, "ratio": options.ratio, "k": options.k, "bar": bar}
    made = comparison_hulls(
        options.method, proj.xy, proj.out, points.codes, n_groups, **kw
    )
    if made.without_holes.any():
        which = np.flatnonzero(made.without_holes)
        named = names(which) if names is not None else first_n(map(str, which))
        warn_user(
            f"GEOS's concave hull with holes failed for {len(which)} "
            f"group(s): {named}; they got the concave hull without holes "
            "(the 'method' column says so)",
            GeoAlphaWarning,
        )
    return AlphaShapes(
        alpha=np.full(n_groups, np.nan),
        geometry=made.geometry,
        n_points=points.n_points,
        n_distinct=None,  # (not counted by the comparison methods)
        n_parts=None,  # (the table counts the final polygon's)
        area=made.area,
        degenerate=made.degenerate,
        outlier=np.zeros(len(points.codes), dtype=bool),
        reason=_reasons(made.degenerate, points, proj),
        certain=np.zeros(len(points.codes), dtype=bool),
        labels=made.labels,
        made=made.geometry,
    )


def degenerate_policy(
    hulls: AlphaShapes,
    groups: Groups,
    points: Points,
    proj: gcrs.Projection,
    options: Options,
) -> AlphaShapes:
    """Apply ``degenerate=`` to groups without a shape (or point); warn about them."""
    n_points = points.n_points
    degenerate = hulls.degenerate | (n_points == 0)
    which = np.flatnonzero(degenerate)
    if not len(which):
        return hulls
    geometry = hulls.geometry.copy()
    area = np.array(hulls.area, dtype=np.float64)
    policy = options.degenerate
    if policy == "buffer":
        codes = points.codes
        sel = np.flatnonzero(np.isin(codes, which))
        sel = sel[np.argsort(codes[sel], kind="stable")]
        if getattr(proj, "sphere", False):  # metres for these groups only
            xy, to_output = proj.metric_of(sel, which)
        else:
            xy, to_output = proj.xy[sel], partial(proj.to_output, groups=which)
        hull = convex_hulls(xy, np.searchsorted(which, codes[sel]), len(which))
        buffered = shapely.buffer(hull, options.buffer)
        buffered[shapely.is_empty(hull)] = EMPTY_POLYGON  # no point left
        area[which] = shapely.area(buffered)
        geometry[which] = to_output(buffered)
        done = (
            f"their rows hold a {options.buffer:g} {proj.unit} buffer around their "
            "points"
        )
        redone = _buffer_in_output(geometry, sel, points.codes, proj)
        cross = which[proj.crossing[which]]
        if len(cross):
            geometry[cross] = _split(geometry[cross], cross, points)
        if len(redone):
            done += (
                f", except {_names(groups, redone)}: that buffer is no valid polygon "
                "holding their points in the output CRS (around a pole, or across "
                "more than 180 degrees of longitude), so theirs is the convex hull of "
                "their points there, widened by "
                f"{kernel.OUTPUT_BUFFER_RTOL:g} of their extent"
            )
    elif policy == "empty":
        geometry[which] = EMPTY_POLYGON
        area[which] = 0.0
        done = "their rows hold an empty polygon"
    else:
        done = f"they were dropped ({n_points[which].sum()} rows)"
    distinct = _distinct_points(points, which)
    why = _why_degenerate(hulls.reason, which, groups, n_points, proj.wide, distinct)
    far = which[hulls.reason[which] == Reason.HEMISPHERE]
    if len(far):
        why = _too_wide_for_the_sphere(far, groups, points, proj) + (
            f"; {why}" if why else ""
        )
    warn_user(
        why + f"; {done} ({setting('degenerate', policy)})",
        DegenerateGroupWarning,
    )
    keep = ~degenerate if policy == "drop" else hulls.keep
    labels = hulls.labels
    if policy == "buffer":  # the row holds a buffer, not the method's hull
        labels = np.array(labels, dtype=object)
        labels[which] = "buffer"
    return hulls._replace(
        geometry=geometry, area=area, degenerate=degenerate, keep=keep, labels=labels
    )


def _why_degenerate(
    reason, which, groups: Groups, n_points, wide, distinct=None
) -> str:
    """Word why the groups ``which`` have no shape, from their reason codes."""
    which = which[reason[which] != Reason.HEMISPHERE]  # (_too_wide_for_the_sphere)
    thin = np.isin(reason[which], kernel.THIN) | (n_points[which] == 0)
    failed = ~thin & (reason[which] == Reason.FAILED)
    reasons = []
    if failed.any():
        reasons.append(
            f"the kernel failed on {failed.sum()} group(s) (a bug: please report it "
            f"with their points; the other groups are unaffected): "
            f"{_names(groups, which[failed], n_points)}"
        )
    if thin.any():
        named = _names(groups, which[thin], n_points, distinct=distinct)
        reasons.append(
            f"{thin.sum()} group(s) have fewer than 3 distinct points or all points "
            f"on a line, so no alpha shape: {named}"
        )
    spread = ~thin & ~failed & wide[which]
    other = ~thin & ~failed & ~spread
    if spread.any():
        reasons.append(
            f"{spread.sum()} group(s) span more than 180 degrees of longitude, so "
            "their hull has no valid longitude/latitude polygon holding all their "
            f"points and they have no alpha: {_names(groups, which[spread], n_points)} "
            "(split the group, e.g. by continent, or give the points in a projected "
            "CRS that holds them)"
        )
    if other.any():
        reasons.append(
            f"{other.sum()} group(s) got no valid polygon holding all their "
            "points in the output CRS (their shapes fold there, near a pole or across "
            "a continent, or its coordinates are too coarse for them): "
            f"{_names(groups, which[other], n_points)}"
        )
    return "; ".join(reasons)


def _too_wide_for_the_sphere(far, groups: Groups, points: Points, proj) -> str:
    """Word the groups ``crs="sphere"`` refused, naming each one's farthest rows.

    Angles from the group's centre, the normalised mean of its unit vectors (as
    the kernel's): the rows beyond :data:`MAX_SPHERE_DEGREES`, farthest first.
    """
    lon, lat = np.radians(proj.lonlat).T
    unit = np.column_stack([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon)])
    unit = np.column_stack([unit, np.sin(lat)])
    named = []
    for g in far[:11]:
        rows = np.flatnonzero(points.codes == g)
        centre = unit[rows].sum(axis=0)
        centre /= np.linalg.norm(centre) or 1.0
        angle = np.degrees(np.arccos(np.clip(unit[rows] @ centre, -1.0, 1.0)))
        order = np.argsort(-angle, kind="stable")
        beyond = order[angle[order] > MAX_SPHERE_DEGREES]
        shown = (beyond if len(beyond) else order[:1])[:5]
        labels = points.labels[rows[shown]].tolist()
        where = ", ".join(
            f"{label!r} ({a:.0f} degrees)"
            for label, a in zip(labels, angle[shown], strict=True)
        )
        more = f" and {len(beyond) - 5} more" if len(beyond) > 5 else ""
        group = _names(groups, np.array([g]), points.n_points)
        named.append(f"{group}, the farthest at index {where}{more}")
    return (
        f"{len(far)} group(s) have points farther than {MAX_SPHERE_DEGREES:g} "
        f"degrees from their centre, beyond what {setting('crs', 'sphere')} "
        f"handles, so no shape on the sphere: {first_n(named, limit=10, sep='; ')} "
        f"(split them with a finer {setting('by')} key, or compute them with "
        f"{setting('crs', 'auto')})"
    )


def _reasons(degenerate, points: Points, proj: gcrs.Projection) -> np.ndarray:
    """Reasons (:data:`~geoalpha._core.THIN`, else ``GUARANTEE``) of bare groups.

    The groups a comparison method left without a shape.
    """
    which = np.flatnonzero(degenerate)
    reason = np.zeros(len(degenerate), dtype=np.int64)
    if not len(which):
        return reason
    sel = np.flatnonzero(np.isin(points.codes, which))
    code = np.searchsorted(which, points.codes[sel])
    sphere = getattr(proj, "sphere", False)
    res = kernel.solve(
        (proj.lonlat if sphere else proj.xy)[sel],
        code,
        len(which),
        Request(sphere=sphere, alpha=0.0),
        out=proj.out[sel],
    )
    reason[which] = np.where(
        np.isin(res.reason, kernel.THIN), res.reason, Reason.GUARANTEE
    )
    return reason


def _buffer_in_output(geometry, sel, codes, proj: gcrs.Projection) -> np.ndarray:
    """Redo in place the degenerate buffers that fail in the output CRS; return them."""
    mine = codes[sel]
    groups = np.unique(mine)
    own = geometry[groups]
    bad = np.zeros(len(geometry), dtype=bool)
    bad[groups] = ~shapely.is_valid(own) | shapely.is_empty(own)
    ok = ~bad[mine]
    inside = covered(own, proj.out[sel[ok]], np.searchsorted(groups, mine[ok]))
    bad[mine[ok][~inside]] = True
    redo = np.flatnonzero(bad)
    if not len(redo):
        return redo
    take = sel[bad[mine]]
    out, starts = proj.out[take], np.searchsorted(codes[take], redo)
    hull = convex_hulls(out, codes[take], len(geometry))[redo]
    lo, hi = np.minimum.reduceat(out, starts), np.maximum.reduceat(out, starts)
    extent = (hi - lo).max(axis=1)
    scale = np.abs(np.r_[lo, hi]).reshape(2, -1, 2).max(axis=(0, 2))
    rtol = kernel.OUTPUT_BUFFER_RTOL
    width = np.maximum(rtol * extent, kernel.REPAIR_RTOL * np.maximum(scale, 1.0))
    buffered = shapely.buffer(hull, width)
    if proj.source is not None and proj.source.is_geographic:
        buffered = shapely.intersection(buffered, shapely.box(-540, -90, 540, 90))
    geometry[redo] = buffered
    return redo


def split_at_antimeridian(
    hulls: AlphaShapes, points: Points, proj: gcrs.Projection
) -> AlphaShapes:
    """Split the hulls across +-180 degrees there (RFC 7946), input longitudes back."""
    which = np.flatnonzero(proj.crossing & ~hulls.degenerate)
    if not len(which):
        return hulls
    geometry = hulls.geometry.copy()
    geometry[which] = _split(geometry[which], which, points)
    return hulls._replace(geometry=geometry)


def _split(geoms: np.ndarray, which: np.ndarray, points: Points) -> np.ndarray:
    """Split ``geoms`` (groups ``which``) at +-180 degrees, input longitudes back."""
    parts = gcrs.split_antimeridian(_valid(geoms))
    lon, lat = points.coords[:, 0], points.coords[:, 1]
    return _valid(gcrs.restore_longitudes(parts, which, lon, lat, points.codes))


def _valid(geoms: np.ndarray) -> np.ndarray:
    """Repair invalid polygons (GEOS cuts only valid ones)."""
    invalid = ~shapely.is_valid(geoms)
    if invalid.any():
        geoms = geoms.copy()
        geoms[invalid] = repair_invalid(geoms[invalid])
    return geoms


def guarantee(
    hulls: AlphaShapes,
    groups: Groups,
    points: Points,
    proj: gcrs.Projection,
    options: Options,
) -> AlphaShapes:
    """Check every group's polygon once, in the output CRS: repaired, or degenerate.

    See :func:`geoalpha._arrays.guarantee.enforce`. Not checked: rows left out,
    coverage at a given ``alpha``, groups wider than 180 degrees of longitude, and
    a point at -180 degrees held at +180 (or the reverse; :func:`warn_output_crs`).
    """
    xy, codes, geometry = points.coords, points.codes, hulls.geometry
    check = ~hulls.degenerate
    beyond = _beyond_the_line(geometry, points, proj.crossing & check)
    exempt = hulls.outlier | beyond
    # Per point: certain to be covered, its group's polygon being the one made.
    certain = hulls.certain
    if geometry is not hulls.made and certain.any():
        same = np.array([a is b for a, b in zip(geometry, hulls.made, strict=True)])
        certain = certain & same[codes]
    fixed = options.method == "alpha" and options.alpha is not None
    limit, unfaithful = None, np.zeros_like(check)
    if options.method == "alpha" and not fixed:  # a split adds parts
        polar = getattr(proj, "polar", None)
        split = proj.crossing | proj.wide if polar is None else proj.crossing | polar
        limit = np.where(split, np.inf, options.components)
        # No lon/lat polygon is the alpha shape of a group wider than 180 degrees.
        unfaithful = check & proj.wide
    geometry, failed = enforce(
        geometry,
        xy,
        codes,
        check & ~unfaithful,
        # At a given alpha only alpha 0 (the convex hull) holds every point.
        cover=(np.asarray(hulls.alpha) == 0) if fixed else True,
        components=limit,
        test=~certain,
        exempt=exempt if exempt.any() else None,
        n_jobs=options.n_jobs,
    )
    # A repair may have grown a hull over a row left out on purpose.
    outlier = left_outside(hulls.outlier, geometry, xy, codes)
    if failed.any():
        which = np.flatnonzero(failed)
        warn_user(
            f"{len(which)} group(s) got no valid polygon covering all their points "
            f"in the output CRS (float geometry is too coarse for them there): "
            f"{_names(groups, which, points.n_points)}; they are treated as "
            "degenerate",
            DegenerateGroupWarning,
        )
    failed |= unfaithful  # (degenerate_policy says why)
    geometry[failed] = EMPTY_POLYGON
    return hulls._replace(
        geometry=geometry,
        alpha=np.where(failed, np.nan, hulls.alpha),
        degenerate=hulls.degenerate | failed,
        reason=np.where(
            failed & (hulls.reason == Reason.OK), Reason.GUARANTEE, hulls.reason
        ),
        outlier=outlier,
    )


def _beyond_the_line(geometry, points: Points, crossing) -> np.ndarray:
    """Points at exactly +-180 degrees that their group's hull holds only at -+180."""
    xy, codes = points.coords, points.codes
    beyond = np.zeros(len(codes), dtype=bool)
    if crossing.any():
        at = np.flatnonzero(crossing[codes] & (np.abs(xy[:, 0]) == 180.0))
        mirror = xy[at] * np.array([-1.0, 1.0])
        beyond[at] = ~covered(geometry, xy[at], codes[at]) & covered(
            geometry, mirror, codes[at]
        )
    return beyond


def warn_output_crs(hulls: AlphaShapes, groups: Groups, points: Points, proj) -> None:
    """Warn about the groups split at +-180 degrees and those wider than 180."""
    if proj.crossing.any():
        split = proj.crossing & ~hulls.degenerate
        beyond = _beyond_the_line(hulls.geometry, points, split)
        crossing = np.flatnonzero(proj.crossing)
        message = (
            f"{len(crossing)} group(s) cross the antimeridian (+-180 degrees): "
            f"{_names(groups, crossing)}; their hulls are MultiPolygons split at "
            "+-180 degrees (RFC 7946)"
        )
        if beyond.any():
            missed = points.codes[beyond]
            counts = np.bincount(missed, minlength=len(proj.crossing))
            message += (
                f"; {beyond.sum()} of their point(s) lie outside the split hull, on "
                "the other side of the +-180 line from it (a longitude of -180 for a "
                "hull that reaches the line at +180, or the reverse): "
                + _names(groups, np.unique(missed), counts)
            )
        warn_user(message, AntimeridianWarning)
    wide = proj.wide & ~hulls.degenerate
    if wide.any():
        warn_user(
            f"{wide.sum()} group(s) span more than 180 degrees of longitude: "
            f"{_names(groups, np.flatnonzero(wide))}; no longitude/latitude "
            "polygon can represent their hull faithfully (it may not contain all "
            "their points); their 'alpha' is right (in 'crs_used'), and 'area_m2' "
            "is that of their hull's vertices joined by geodesics; "
            "for the geometry, give the points in a projected CRS that holds them, "
            "or split the group",
            GeoAlphaWarning,
        )


def area_m2(
    hulls: AlphaShapes,
    before_split: np.ndarray,
    proj: gcrs.Projection,
    options: Options,
) -> np.ndarray:
    """Return ``area_m2``: geodesic, on the WGS84 ellipsoid, whatever ``crs=``.

    That of each geometry (:func:`~.crs.geodesic_areas`), or of the hull
    ``before_split`` for groups wider than 180 degrees of longitude (whose output
    polygon cannot be faithful). ``crs=None``: planar, in the input's units.
    """
    if options.crs is None:
        return hulls.area
    wide = proj.wide & ~hulls.degenerate
    geometry = np.where(wide, before_split, hulls.geometry)
    return gcrs.geodesic_areas(geometry, proj.source, n_jobs=options.n_jobs)


def table(
    groups: Groups,
    points: Points,
    proj: gcrs.Projection,
    hulls: AlphaShapes,
    crs,
    geometry_name: str = "geometry",
):
    """Build the result: one row per kept group (:func:`~.schema.result_frame`)."""
    geometry = hulls.geometry
    with np.errstate(divide="ignore"):
        radius = 1.0 / hulls.alpha
    values = {
        "alpha": hulls.alpha,
        "radius": radius,
        "n_points": points.n_points,
        "n_outliers": np.bincount(
            points.codes[hulls.outlier], minlength=len(points.n_points)
        ),
        "n_parts": np.where(
            shapely.is_empty(geometry), 0, shapely.get_num_geometries(geometry)
        ),
        "area_m2": hulls.area,
        "crs_used": proj.names,
        "method": hulls.labels,
    }
    if hulls.neighbours is not None:  # overlap="split"
        values.update(area_ceded_m2=hulls.ceded, neighbours=hulls.neighbours)
    columns, keep = groups.columns, hulls.keep
    if keep is not None:
        values = {name: np.asarray(v)[keep] for name, v in values.items()}
        geometry, columns = geometry[keep], [c[keep] for c in columns]
    keys = dict(zip(groups.names, columns, strict=True))
    return result_frame(keys, values, geometry, crs, geometry_name)


def split_overlaps_stage(
    hulls: AlphaShapes,
    groups: Groups,
    points: Points,
    proj: gcrs.Projection,
    options: Options,
) -> AlphaShapes:
    """``overlap="split"``: split the overlaps of groups' polygons by nearest point.

    In the output coordinates, on the final polygons (degenerate buffers too),
    with :func:`geoalpha._arrays.overlap.split_overlaps`, which checks the split
    polygons with the guarantee (:func:`~geoalpha._arrays.guarantee.enforce`).
    Groups wider than 180 degrees of longitude (no faithful polygon) and dropped
    groups take no part. Warns about locations holding rows of two groups
    (:class:`~geoalpha.errors.SharedLocationWarning`).
    """
    if options.overlap != "split":
        return hulls
    check = ~proj.wide if hulls.keep is None else ~proj.wide & hulls.keep
    # Covered, as :func:`guarantee` checked: the rows not left out of groups it
    # checked (not degenerate, not across the antimeridian, not at a given
    # alpha, where only alpha 0 holds every point). The others are tested.
    checked = ~hulls.degenerate & ~proj.crossing
    fixed = options.method == "alpha" and options.alpha is not None
    known = None if fixed else ~hulls.outlier & checked[points.codes]
    split = split_overlaps(
        hulls.geometry,
        points.coords,
        points.codes,
        check=check,
        known=known,
        n_jobs=options.n_jobs,
    )
    warn_split(split, groups)
    area = hulls.area
    if options.crs is None and split.changed.any():  # planar, in the input units
        area = np.array(area, dtype=np.float64)
        area[split.changed] = shapely.area(split.geometry[split.changed])
    return hulls._replace(
        geometry=split.geometry,
        area=area,
        unsplit=hulls.geometry,
        neighbours=split.neighbours,
    )


def warn_split(split, groups: Groups) -> None:
    """Warn about what ``overlap="split"`` could not do plainly.

    The locations holding rows of two groups whose hulls overlap
    (:class:`~geoalpha.errors.SharedLocationWarning`), the groups whose split
    polygon failed the guarantee (they keep their hull), and the pairs that
    still overlap after the split.

    Parameters
    ----------
    split : geoalpha._arrays.overlap.Split
    groups : Groups
        Names the groups (its ``codes`` are not used).
    """
    if split.failed.any():
        which = np.flatnonzero(split.failed)
        warn_user(
            f"{len(which)} group(s) kept their hull where it overlaps a neighbour's "
            "(its split failed the guarantee in the output coordinates): "
            f"{_names(groups, which)} ({setting('overlap', 'split')})",
            GeoAlphaWarning,
        )
    if len(split.still):
        pairs = [
            f"{_names(groups, pair[:1], value=repr)} and "
            f"{_names(groups, pair[1:], value=repr)}"
            for pair in split.still[:11]
        ]
        warn_user(
            f"{len(split.still)} pair(s) of groups still overlap after "
            f"{setting('overlap', 'split')} (GEOS's overlay could not cut them "
            "exactly): " + first_n(pairs, limit=10, sep="; "),
            GeoAlphaWarning,
        )
    if not len(split.shared):
        return
    shown = [
        f"({x!r}, {y!r}) of {_names(groups, pair[:1], value=repr)} and "
        f"{_names(groups, pair[1:], value=repr)}"
        for (x, y), pair in zip(
            split.shared[:11].tolist(), split.shared_groups[:11], strict=True
        )
    ]
    warn_user(
        f"{len(split.shared)} location(s) hold rows of two groups whose hulls "
        f"overlap ({setting('overlap', 'split')}); each is a boundary vertex of both "
        "groups' polygons, strictly inside neither: "
        + first_n(shown, limit=10, sep="; "),
        SharedLocationWarning,
    )


def area_ceded(
    hulls: AlphaShapes, proj: gcrs.Projection, options: Options
) -> AlphaShapes:
    """``area_ceded_m2`` of ``overlap="split"``: the area given to neighbours.

    The area of the polygon before the split minus that after (as ``area_m2``:
    on the WGS84 ellipsoid; planar in the input's units with ``crs=None``).
    """
    if hulls.unsplit is None:
        return hulls
    ceded = np.zeros(len(hulls.geometry))
    changed = np.flatnonzero(
        np.array(
            [a is not b for a, b in zip(hulls.geometry, hulls.unsplit, strict=True)]
        )
    )
    if len(changed):
        before = hulls.unsplit[changed]
        if options.crs is None:
            full = shapely.area(before)
        else:
            full = gcrs.geodesic_areas(before, proj.source, n_jobs=options.n_jobs)
        ceded[changed] = np.maximum(full - np.asarray(hulls.area)[changed], 0.0)
    return hulls._replace(ceded=ceded)


def grow(
    hulls: AlphaShapes, points: Points, proj: gcrs.Projection, options: Options
) -> AlphaShapes:
    """Buffer the hulls (not degenerate buffers) by ``grow`` metres, in metres."""
    distance = options.grow
    if not distance:
        return hulls
    geometry = hulls.geometry
    sel = np.flatnonzero(~hulls.degenerate & ~shapely.is_empty(geometry))
    if not sel.size:
        return hulls
    coords, which = shapely.get_coordinates(geometry[sel], return_index=True)
    keys = pd.MultiIndex.from_arrays([points.codes, proj.out[:, 0], proj.out[:, 1]])
    first = ~keys.duplicated()
    loc = keys[first].get_indexer(
        pd.MultiIndex.from_arrays([sel[which], coords[:, 0], coords[:, 1]])
    )
    exact = np.ones(sel.size, dtype=bool)
    exact[which[loc < 0]] = False  # a repaired vertex: not an input point
    metric = shapely.set_coordinates(
        geometry[sel].copy(), proj.xy[np.flatnonzero(first)[np.maximum(loc, 0)]]
    )
    if not exact.all():  # pragma: no cover - hull vertices are input points
        warn_user(
            f"{(~exact).sum()} hull(s) were not grown: a vertex is not an input "
            "point (repaired geometry)",
            GeoAlphaWarning,
        )
    grown = shapely.buffer(metric[exact], distance, quad_segs=4)
    geometry = geometry.copy()
    area = np.asarray(hulls.area, dtype=float).copy()
    area[sel[exact]] = shapely.area(grown)
    geometry[sel[exact]] = proj.to_output(grown, sel[exact])
    return hulls._replace(geometry=geometry, area=area)


def suspicious_groups(hulls: AlphaShapes, points: Points) -> list[dict]:
    """Return the flagged groups (:class:`SuspiciousHullWarning`), one dict each.

    Keys: ``group`` (code), ``rows`` (positions of the location's rows among
    the points), ``radius``, ``area`` (with it, computation CRS), ``radius_without``,
    ``area_without``.
    """
    why = hulls.why
    if why is None or not why.suspicious.any():
        return []
    alt = why.alternatives
    flagged = []
    for g in np.flatnonzero(why.suspicious & ~hulls.degenerate):
        i = np.flatnonzero((alt.group == g) & (alt.k == 1))
        if not len(i):  # pragma: no cover - the kernel gives a flagged group one
            continue
        i = int(i[0])
        flagged.append(
            {
                "group": int(g),
                "rows": alt.left_out(i),
                "radius": 1.0 / hulls.alpha[g],
                "area": float(hulls.area[g]),
                "radius_without": float(alt.radius[i]),
                "area_without": float(alt.area[i]),
            }
        )
    return flagged


def _amount(value: float) -> str:
    """Show a radius or area: whole numbers with commas from 100 on."""
    return f"{value:,.0f}" if abs(value) >= 100 else f"{value:.4g}"


def warn_suspicious(
    hulls: AlphaShapes, groups: Groups, points: Points, options
) -> None:
    """Warn about the groups one location forces far beyond their other points."""
    flagged = suspicious_groups(hulls, points) if options.suspicious else []
    if not flagged:
        return
    units = "m" if options.crs is not None else "units"
    lines = []
    for f in flagged[:10]:
        rows = f["rows"]
        x, y = points.coords[rows[0]]
        labels = list(points.labels[rows[:5]])
        more = ", ..." if len(rows) > 5 else ""
        name = _names(groups, np.array([f["group"]]), value=_quoted)
        lines.append(
            f"group {name}: the location "
            f"({x:.6g}, {y:.6g}) with {len(rows)} row(s) (index "
            f"{', '.join(map(repr, labels))}{more}) makes its radius "
            f"{_amount(f['radius'])} {units} and area {_amount(f['area'])} {units}²; "
            f"without it {_amount(f['radius_without'])} {units} and "
            f"{_amount(f['area_without'])} {units}²"
        )
    if len(flagged) > 10:
        lines.append(f"... and {len(flagged) - 10} more group(s)")
    warn_user(
        f"{spelled('hull()')}: in {len(flagged)} group(s) one location forces the "
        f"shape far beyond the other points (leaving it out divides the radius "
        f"by {kernel.SUSPICIOUS_FACTOR:g} or more): " + "; ".join(lines) + ". If "
        f"it is wrong, leave it out with {setting('outliers', 1)}, "
        f"{setting('outlier_unit', 'locations')} (geoalpha.explain() shows why); "
        f"{setting('suspicious', False)} turns this check off",
        SuspiciousHullWarning,
    )


def report_outliers(
    hulls: AlphaShapes, groups: Groups, points: Points, n_rows: int, options: Options
) -> np.ndarray:
    """Warn about the rows left out (``outliers=``) and return them as a row mask."""
    left_out = np.zeros(n_rows, dtype=bool)
    left_out[points.rows[hulls.outlier]] = True
    if left_out.any():
        n_outliers = np.bincount(
            points.codes[hulls.outlier], minlength=len(points.n_points)
        )
        which = np.flatnonzero(n_outliers)
        each = _names(groups, which, n_outliers, value=_quoted)
        warn_user(
            f"{spelled('hull()')} left {n_outliers.sum()} row(s) of {len(which)} "
            f"group(s) outside their hulls ({setting('outliers', options.outliers)}): "
            f"{each}; geoalpha.outlier_rows() marks them",
            OutlierWarning,
        )
    return left_out
