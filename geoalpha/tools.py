"""``hull()``: one tight polygon per group of points in a GeoDataFrame.

The GeoDataFrame layer: grouping (as :meth:`GeoDataFrame.dissolve`), input
checks, the metric CRS round trip, degenerate groups and the output table.
The numbers come from :mod:`geoalpha.optimal` (one batched call for all
groups) and the comparison methods from shapely/GEOS and :mod:`geoalpha.knn`.
"""

from __future__ import annotations

import contextvars
import sys
import warnings
from typing import Any, Literal

import numpy as np
import pandas as pd
import pyproj
import shapely

from geoalpha import crs as gcrs
from geoalpha.coverage import check_outliers
from geoalpha.errors import (
    AntimeridianWarning,
    DegenerateGroupWarning,
    DroppedRowsWarning,
    GeoAlphaWarning,
    InvalidInputError,
    OutlierWarning,
    user_stacklevel,
)
from geoalpha.optimal import alpha_shapes
from geoalpha.shapes import EMPTY_POLYGON, cover_points, polygonal

__all__ = ["DEGENERATE_POLICIES", "METHODS", "RESULT_COLUMNS", "hull", "outlier_rows"]

#: Hull methods of :func:`hull`.
METHODS = ("alpha", "convex", "concave", "knn")
#: What :func:`hull` does with groups that have no alpha shape.
DEGENERATE_POLICIES = ("buffer", "empty", "drop")
#: Columns :func:`hull` adds next to the group keys (then ``geometry``).
RESULT_COLUMNS = (
    "alpha",
    "radius",
    "n_points",
    "n_outliers",
    "n_parts",
    "area_m2",
    "crs_used",
    "method",
)
#: Show a progress bar by default from this many groups on (on a terminal).
PROGRESS_MIN_GROUPS = 2000
_POINT_TYPES = (0, 4)  # shapely type ids of Point and MultiPoint


def _labels(index: pd.Index, mask: np.ndarray, limit: int = 10) -> str:
    labels = [repr(v) if isinstance(v, str) else str(v) for v in index[mask][:limit]]
    more = ", ..." if mask.sum() > limit else ""
    return ", ".join(labels) + more


def _is_dask(data) -> bool:
    """Tell whether ``data`` is a dask-geopandas frame (without importing dask)."""
    dgpd = sys.modules.get("dask_geopandas")
    return dgpd is not None and isinstance(data, dgpd.GeoDataFrame | dgpd.GeoSeries)


def _as_frame(data) -> Any:
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


def _groups(frame, by, dropna: bool, sort: bool) -> tuple[np.ndarray, pd.DataFrame]:
    """Group code per row (-1: dropped NaN key) and the key table (one row a group)."""
    if by is None:  # one group of all rows (none for an empty frame)
        keys = pd.DataFrame(index=range(1 if len(frame) else 0))
        return np.zeros(len(frame), dtype=np.int64), keys
    names = by if isinstance(by, list) else [by]
    for name in names:
        if isinstance(name, str | int | tuple) and not isinstance(name, bool):
            if name not in frame.columns:
                raise InvalidInputError(
                    f"hull(by={by!r}): no column {name!r}; the columns are "
                    f"{', '.join(map(str, frame.columns))}"
                )
    try:
        grouped = frame.groupby(by, dropna=dropna, sort=sort)
        codes = grouped.ngroup().fillna(-1).to_numpy(dtype=np.int64)
        index = grouped.size().index
    except (ValueError, KeyError, TypeError) as err:
        raise InvalidInputError(f"hull(by=...) cannot group the rows: {err}") from err
    keys = index.to_frame(index=False)
    keys.columns = [
        "group" if (c is None or isinstance(c, int)) and len(keys.columns) == 1 else c
        for c in keys.columns
    ]
    clash = [c for c in keys.columns if c in (*RESULT_COLUMNS, "geometry")]
    if clash:
        raise InvalidInputError(
            f"group column(s) {clash} have the name of a result column; rename them "
            f"(result columns: {', '.join(RESULT_COLUMNS)}, geometry)"
        )
    return codes, keys


def _check_choice(name: str, value, choices) -> None:
    if value not in choices:
        raise InvalidInputError(
            f"{name} must be one of {', '.join(map(repr, choices))}; got {value!r}"
        )


def _progress(progress, n_groups: int):
    if progress is False or (
        progress is None and (n_groups < PROGRESS_MIN_GROUPS or not sys.stderr.isatty())
    ):
        return None
    try:
        from tqdm.auto import tqdm
    except ImportError as err:
        if progress is None:
            return None
        raise ImportError(
            "progress=True needs tqdm: pip install geoalpha[progress]"
        ) from err
    return tqdm(total=n_groups, unit="group", desc="geoalpha hull", file=sys.stderr)


class _Projection:
    """Coordinates for the computation (metric) and for the output (input CRS)."""

    def __init__(self, coords, codes, n_groups, src, crs):
        self.out = coords.copy()
        self.crossing = np.zeros(n_groups, dtype=bool)
        self.crs_list: list = []
        self.crs_index = np.zeros(n_groups, dtype=np.int64)
        self.src = src
        self.scale = 1.0
        self.wide = np.zeros(n_groups, dtype=bool)
        #: Unit of the computation coordinates, for messages.
        self.unit = "m" if crs is not None else _unit_name(src)
        if crs is None:  # planar: use the coordinates as they are
            self.xy = coords
            self.names = np.full(n_groups, gcrs.crs_name(src) if src else "planar")
            return
        if src is None:
            raise InvalidInputError(
                "the input has no CRS, so it cannot be projected to metres; set it "
                "with gdf.set_crs(...) or pass crs=None to use the coordinates as "
                "planar values"
            )
        if src.is_geographic:
            lon, lat = coords[:, 0], coords[:, 1]
            self.xy, self.crs_list, self.crs_index = gcrs.metric_crs(
                lon, lat, codes, n_groups, crs=crs, source_crs=src
            )
            self.crossing = gcrs.crosses_antimeridian(lon, codes, n_groups)
            self.out[:, 0] = gcrs.unwrap_lon(lon, codes, self.crossing)
            width = np.full(n_groups, -np.inf)
            np.maximum.at(width, codes, self.out[:, 0])
            low = np.full(n_groups, np.inf)
            np.minimum.at(low, codes, self.out[:, 0])
            self.wide = width - low > 180.0
        elif isinstance(crs, str) and crs.strip().lower() in ("auto", "auto-group"):
            # Used as it is, in metres: a CRS in feet is scaled (alpha stays 1/m).
            self.scale = src.axis_info[0].unit_conversion_factor or 1.0
            self.xy = coords * self.scale if self.scale != 1.0 else coords
            self.crs_list = [src]
        else:
            target = gcrs.parse_crs(crs)
            if target.is_geographic:
                raise InvalidInputError(
                    f"crs= must be a projected (metric) CRS, got "
                    f"{gcrs.crs_name(target)} (geographic)"
                )
            t = pyproj.Transformer.from_crs(src, target, always_xy=True)
            self.xy = np.column_stack(t.transform(coords[:, 0], coords[:, 1]))
            self.crs_list = [target]
        self.names = np.array([gcrs.crs_name(c) for c in self.crs_list], dtype=object)[
            self.crs_index
        ]

    def to_output(self, geoms: np.ndarray, groups: np.ndarray) -> np.ndarray:
        """Transform metric geometries of ``groups`` back to the output coordinates."""
        if not self.crs_list:
            return geoms
        out = geoms.copy()
        if self.scale != 1.0:
            return shapely.transform(geoms, lambda c: c / self.scale)
        for k, target in enumerate(self.crs_list):
            sel = self.crs_index[groups] == k
            if not sel.any() or target == self.src:
                continue
            # cached, and a fast pipeline for the local LAEA CRSs
            back = gcrs._transformer(gcrs._crs_key(target), self.src.srs)

            def move(c, back=back):
                return np.column_stack(back.transform(c[:, 0], c[:, 1]))

            out[sel] = shapely.transform(geoms[sel], move)
        wrap = self.crossing[groups]
        if wrap.any():
            out[wrap] = shapely.transform(
                out[wrap], lambda c: np.column_stack([c[:, 0] % 360.0, c[:, 1]])
            )
        return out


def _unit_name(crs) -> str:
    """Name of the unit of planar coordinates used as they are (crs=None)."""
    if crs is None:
        return "unit"
    return crs.axis_info[0].unit_name if crs.axis_info else "unit"


def _to_input_vertices(geoms, groups, xy, out, codes) -> np.ndarray:
    """Replace metric vertex coordinates (input points) by their output coordinates."""
    coords, which = shapely.get_coordinates(geoms, return_index=True)
    keys = pd.MultiIndex.from_arrays([codes, xy[:, 0], xy[:, 1]])
    first = ~keys.duplicated()
    table = keys[first]
    loc = table.get_indexer(
        pd.MultiIndex.from_arrays([groups[which], coords[:, 0], coords[:, 1]])
    )
    if (loc < 0).any():  # pragma: no cover - GEOS keeps input coordinates
        raise RuntimeError("a hull vertex is not an input point")
    return shapely.set_coordinates(geoms.copy(), out[np.flatnonzero(first)[loc]])


def _comparison_hulls(method, proj, codes, n_groups, *, holes, ratio, k, bar):
    """GEOS concave or KNN hull per group, built in metres, in output coordinates."""
    order = np.argsort(codes, kind="stable")
    xy, sc = proj.xy[order], codes[order]
    ptr = np.searchsorted(sc, np.arange(n_groups + 1))
    geoms = np.full(n_groups, EMPTY_POLYGON, dtype=object)
    labels = np.full(n_groups, method, dtype=object)
    if method == "concave":
        mp = shapely.multipoints(xy, indices=sc)
        present = np.unique(sc)
        geoms[present] = shapely.concave_hull(
            mp[present], ratio=ratio, allow_holes=holes
        )
        labels[:] = f"concave ratio={ratio:g}"
        if bar is not None:
            bar.update(n_groups)
    else:
        from geoalpha.knn import knn_hull

        for g in range(n_groups):
            try:
                geoms[g], used = knn_hull(xy[ptr[g] : ptr[g + 1]], k=k)
                labels[g] = f"knn k={used}"
            except InvalidInputError:
                pass
            if bar is not None:
                bar.update(1)
    degenerate = (shapely.get_type_id(geoms) != 3) | shapely.is_empty(geoms)
    geoms[degenerate] = EMPTY_POLYGON
    area = shapely.area(geoms)
    present = ~degenerate
    out = np.full(n_groups, EMPTY_POLYGON, dtype=object)
    out[present] = _to_input_vertices(
        geoms[present], np.flatnonzero(present), proj.xy, proj.out, codes
    )
    return cover_points(out, proj.out, codes), area, labels, degenerate


def _convex_hulls(proj, codes, n_groups):
    """Convex hulls in the output coordinates, where they are exact."""
    order = np.argsort(codes, kind="stable")
    hulls = np.full(n_groups, EMPTY_POLYGON, dtype=object)
    present = np.unique(codes)
    hulls[present] = shapely.convex_hull(
        shapely.multipoints(proj.out[order], indices=codes[order])
    )[present]
    return hulls


def hull(
    gdf,
    by=None,
    *,
    alpha: float | None = None,
    holes: bool = False,
    components: int = 1,
    crs: Any = "auto",
    method: Literal["alpha", "convex", "concave", "knn"] = "alpha",
    search: Literal["exact", "ladder", "bisect"] = "exact",
    max_iterations: int = 10_000,
    ratio: float = 0.3,
    k: int = 3,
    degenerate: Literal["buffer", "empty", "drop"] = "buffer",
    buffer: float = 1.0,
    vertices: bool = False,
    dropna: bool = True,
    sort: bool = True,
    progress: bool | None = None,
    n_jobs: int = 1,
    outliers: float = 0,
    grow: float = 0.0,
):
    """Tightest single polygon around each group of points.

    For every group, finds the optimal alpha exactly (the largest alpha whose
    alpha shape is one polygon containing every point of the group) and
    returns the polygons in a GeoDataFrame in the input CRS, one row per
    group, ready for ``to_file``. Also available as ``gdf.alpha.hull(...)``.

    Parameters
    ----------
    gdf : GeoDataFrame or GeoSeries
        Point geometries (MultiPoints count as their points). A
        ``dask_geopandas.GeoDataFrame`` gives a lazy result: see
        :func:`geoalpha.dask.hull`.
    by : str, list of str, or array_like, optional
        Group the rows by these columns or values, as in
        :meth:`GeoDataFrame.dissolve`; None gives one hull of all points.
    alpha : float, optional
        Use this alpha (1/metre) for every group instead of the optimum;
        0 is the convex hull.
    holes : bool, default False
        Keep holes in the shapes (True) or fill every hole (False).
    components : int, default 1
        Largest number of separate pieces a group's shape may have (a
        MultiPolygon when > 1).
    crs : "auto", CRS or None, default "auto"
        Metric CRS for the computation. ``"auto"``: geographic input goes to
        one UTM zone when the data fit it, else to a UTM zone or a local
        Lambert azimuthal equal-area CRS per group (see
        :func:`geoalpha.crs.metric_crs`); projected input is used as is.
        A CRS (anything pyproj accepts): use that projected CRS. None: use
        the coordinates as planar values as they are (required for input
        without a CRS; with lon/lat input alphas are then in 1/degree, as in
        the seed paper).
    method : {"alpha", "convex", "concave", "knn"}, default "alpha"
        ``"alpha"``: the optimal alpha shape (exact unless ``search`` says
        otherwise). ``"convex"``: the convex hull. ``"concave"``: GEOS
        :func:`shapely.concave_hull` with ``ratio``. ``"knn"``: the
        Moreira-Santos k-nearest-neighbour concave hull, starting at ``k``.
        All give the same output table.
    search : {"exact", "ladder", "bisect"}, default "exact"
        With ``method="alpha"``: ``"ladder"`` and ``"bisect"`` reproduce the
        seed paper's integer ladder and ``alphashape``'s float bisection.
        Their results depend on units: integer alphas in 1/metre are nearly
        always 0, the convex hull.
    max_iterations : int, default 10000
        Bisection steps before ``search="bisect"`` gives up (``alphashape``'s
        default).
    ratio : float, default 0.3
        ``ratio`` of :func:`shapely.concave_hull` (``method="concave"``).
    k : int, default 3
        Starting number of neighbours for ``method="knn"``.
    degenerate : {"buffer", "empty", "drop"}, default "buffer"
        What a group with fewer than 3 distinct points, or all collinear,
        becomes (it has no alpha shape): ``"buffer"`` a polygon ``buffer``
        metres around its points (so every group keeps a polygonal row and
        the table still exports to a Shapefile), ``"empty"`` an empty
        Polygon, ``"drop"`` no row. A :class:`DegenerateGroupWarning` names
        the groups in every case.
    buffer : float, default 1.0
        Width for ``degenerate="buffer"``, in metres (in the coordinate units
        with ``crs=None``: degrees for lon/lat input).
    vertices : bool, default False
        Accept non-point geometries and use their vertices as points
        (otherwise they are an error).
    dropna : bool, default True
        Drop rows whose group key is missing (counted in a
        :class:`DroppedRowsWarning`), as in ``dissolve``; False makes them a
        group of their own.
    sort : bool, default True
        Sort the groups by key, as in ``dissolve``.
    progress : bool, optional
        Show a progress bar (needs ``tqdm``: ``pip install geoalpha[progress]``).
        Default: only for long runs on a terminal.
    n_jobs : int, default 1
        Worker processes to spread the groups over (-1: one per core), for
        ``method="alpha"`` and ``"convex"``; the result is the same for every
        value. Pays off from about 100,000 points (see
        :mod:`geoalpha.parallel`).
    outliers : float or int, default 0
        Points each group may leave out (``method="alpha"``, exact search,
        no fixed ``alpha``): a float in ``[0, 1)`` is a fraction of the
        group's distinct points (``k = floor(outliers * n)``), an int a count
        ``k``. The optimum is then the largest alpha at which at most
        ``components`` pieces cover at least ``n - k`` distinct points; only
        those pieces are kept. :func:`outlier_rows` tells which input rows
        were left out.
    grow : float, default 0.0
        Grow every hull (not the degenerate buffers) by this distance in
        metres (coordinate units with ``crs=None``), with rounded corners, so
        that every point is strictly inside: predicates such as ``within``,
        ``contains`` or QGIS "Count points in polygon" then count the points
        on the hull's boundary too. ``alpha`` and ``radius`` stay those of the
        optimal shape; ``area_m2`` is the area of the grown polygon; polygon
        vertices are then no longer input points. 0 (the default) keeps the
        exact shape.

    Returns
    -------
    GeoDataFrame
        In the input CRS, one row per group: the group key column(s), then
        ``alpha`` (1/metre in the computation CRS; nan for the methods
        without one and for degenerate groups; 0 for the convex hull),
        ``radius`` (1/alpha, metres), ``n_points`` (input rows of the group),
        ``n_outliers`` (rows of the group left out, 0 unless ``outliers``),
        ``n_parts`` (polygons in the geometry), ``area_m2`` (area in the
        computation CRS), ``crs_used`` (the computation CRS), ``method``
        and the geometry, in a column named as the input's active geometry
        column (``geom`` from ``read_postgis`` stays ``geom``; ``geometry``
        for a GeoSeries) (Polygon; MultiPolygon when ``components > 1``, when a
        group is split at the antimeridian, or, for ``"concave"``/``"knn"``,
        when a hull built in metres touches itself in the input CRS and is
        repaired, with a :class:`GeoAlphaWarning`). Polygon vertices are input
        coordinates (except for degenerate buffers and antimeridian cuts).

    Raises
    ------
    InvalidInputError
        For non-point geometries (unless ``vertices=True``), a ``by`` column
        that does not exist, input without CRS (unless ``crs=None``),
        longitude/latitude out of range, NaN coordinates, bad options. The
        message names the rows or columns.

    Warns
    -----
    DroppedRowsWarning
        Rows with a missing or empty geometry or a missing group key.
    DegenerateGroupWarning
        Groups with fewer than 3 distinct points or all collinear.
    AntimeridianWarning
        Groups across +-180 degrees, returned as split MultiPolygons.
    OutlierWarning
        Groups that left points out (``outliers``), with their counts.

    Notes
    -----
    The accessor is named ``alpha``, so on a result ``hulls["alpha"]`` is
    the column and ``hulls.alpha`` the accessor.

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

        return dask_hull(
            gdf,
            by,
            alpha=alpha,
            holes=holes,
            components=components,
            crs=crs,
            method=method,
            search=search,
            ratio=ratio,
            k=k,
            degenerate=degenerate,
            buffer=buffer,
            vertices=vertices,
            dropna=dropna,
            sort=sort,
            progress=progress,
            n_jobs=n_jobs,
            outliers=outliers,
            **({"grow": grow} if grow else {}),
        )
    frame = _as_frame(gdf)
    _check_choice("method", method, METHODS)
    _check_choice("degenerate", degenerate, DEGENERATE_POLICIES)
    check_outliers(outliers)
    if outliers and method != "alpha":
        raise InvalidInputError(
            f"outliers applies to method='alpha'; got method={method!r}"
        )
    geoms = np.asarray(frame.geometry.array, dtype=object)
    index = frame.index

    # Rows: missing/empty geometries and missing keys are dropped (and told).
    codes, keys = _groups(frame, by, dropna, sort)
    n_groups = len(keys)
    missing = shapely.is_missing(geoms) | shapely.is_empty(geoms)
    types = shapely.get_type_id(geoms)
    other = ~missing & ~np.isin(types, _POINT_TYPES)
    if other.any() and not vertices:
        kinds = pd.Series(np.asarray(frame.geom_type)[other])
        names = ", ".join(f"{n} {t}" for t, n in kinds.value_counts().items())
        raise InvalidInputError(
            f"hull() needs point geometries; got {names} row(s) (index "
            f"{_labels(index, other)}); pass vertices=True (--vertices) to use "
            "their vertices"
        )
    no_key = codes < 0
    dropped = missing | no_key
    if dropped.any():
        parts = []
        if missing.any():
            parts.append(
                f"{missing.sum()} with a missing or empty geometry (index "
                f"{_labels(index, missing)})"
            )
        if (no_key & ~missing).any():
            parts.append(
                f"{(no_key & ~missing).sum()} with a missing group key (index "
                f"{_labels(index, no_key & ~missing)}; dropna=False keeps them)"
            )
        warnings.warn(
            f"hull() dropped {dropped.sum()} of {len(frame)} rows: " + "; ".join(parts),
            DroppedRowsWarning,
            stacklevel=user_stacklevel(),
        )
    kept = np.flatnonzero(~dropped)
    coords, which = shapely.get_coordinates(geoms[kept], return_index=True)
    pcodes = codes[kept][which]
    n_points = np.bincount(codes[kept], minlength=n_groups)
    bad = ~np.isfinite(coords).all(axis=1)
    if bad.any():
        rows = np.zeros(len(index), dtype=bool)
        rows[kept[which[bad]]] = True
        raise InvalidInputError(
            "hull() needs finite coordinates; got NaN or infinite values in "
            f"{rows.sum()} row(s) (index {_labels(index, rows)})"
        )
    try:
        proj = _Projection(coords, pcodes, n_groups, frame.crs, crs)
    except InvalidInputError as err:
        raise InvalidInputError(_rows_to_index(str(err), kept[which], index)) from err

    bar = _progress(progress, n_groups)
    left_out = np.zeros(len(frame), dtype=bool)
    try:
        if method in ("alpha", "convex"):
            res = alpha_shapes(
                proj.xy,
                pcodes,
                alpha=0.0 if method == "convex" else alpha,
                holes=holes,
                components=components,
                search=search,
                max_iterations=max_iterations,
                coords=proj.out,
                n_groups=n_groups,
                progress=bar,
                n_jobs=n_jobs,
                outliers=outliers,
            )
            geometry, area, is_degenerate = res.geometry, res.area, res.degenerate
            left_out[kept[which[res.outlier]]] = True
            alphas = res.alpha
            if method == "convex":
                convex = _convex_hulls(proj, pcodes, n_groups)
                geometry = np.where(is_degenerate, geometry, convex)
            label = method if method == "convex" or search == "exact" else search
            labels = np.full(n_groups, label, dtype=object)
        else:
            geometry, area, labels, is_degenerate = _comparison_hulls(
                method, proj, pcodes, n_groups, holes=holes, ratio=ratio, k=k, bar=bar
            )
            alphas = np.full(n_groups, np.nan)
        if bar is not None:  # groups of 1-2 points are done too: a full bar
            bar.update(max(0, n_groups - bar.n))
    finally:
        if bar is not None:
            bar.close()

    keep_group = np.ones(n_groups, dtype=bool)
    if is_degenerate.any():
        geometry, area, keep_group = _degenerate_groups(
            geometry,
            area,
            is_degenerate,
            keys,
            n_points,
            proj,
            pcodes,
            degenerate,
            buffer,
        )

    if grow:
        geometry, area = _grow(geometry, area, ~is_degenerate, proj, pcodes, grow)
    geometry = _finish(geometry, proj.crossing, proj.wide, keys)
    if method != "alpha":  # repairs may have cut a sliver holding a point
        plain = ~proj.crossing[pcodes]
        geometry = cover_points(geometry, proj.out[plain], pcodes[plain])
    with np.errstate(divide="ignore"):
        radius = 1.0 / alphas
    import geopandas as gpd

    table = keys.copy()
    table["alpha"] = alphas
    table["radius"] = radius
    table["n_points"] = n_points
    table["n_outliers"] = np.bincount(codes[left_out], minlength=n_groups)
    table["n_parts"] = np.where(
        shapely.is_empty(geometry), 0, shapely.get_num_geometries(geometry)
    )
    table["area_m2"] = area
    table["crs_used"] = proj.names
    table["method"] = labels
    out = gpd.GeoDataFrame(table, geometry=list(geometry), crs=frame.crs)
    name = result_geometry_name(frame, keys)
    if name != "geometry":
        out = out.rename_geometry(name)
    if left_out.any():
        _warn_outliers(table["n_outliers"].to_numpy(), keys, outliers)
    rows = _OUTLIER_ROWS.get()
    if rows is not None:
        rows.append(pd.Series(left_out, index=index, name="outlier"))
    return out[keep_group].reset_index(drop=True)


def result_geometry_name(frame, keys) -> str:
    """Name of the result's geometry column: the input's (``geom`` stays ``geom``).

    A GeoSeries, or a name taken by a group key column, gives ``geometry``.
    """
    name = frame.geometry.name if frame.geometry.name is not None else "geometry"
    if not isinstance(name, str) or name in keys.columns or name in RESULT_COLUMNS:
        return "geometry"
    return name


#: Set by :func:`outlier_rows` to receive the left-out rows of :func:`hull`.
_OUTLIER_ROWS: contextvars.ContextVar[list | None] = contextvars.ContextVar(
    "geoalpha_outlier_rows", default=None
)


def _warn_outliers(n_outliers: np.ndarray, keys: pd.DataFrame, outliers) -> None:
    groups = np.flatnonzero(n_outliers)
    rows = keys.iloc[groups[:10]].itertuples(index=False)
    each = "; ".join(
        f"{', '.join(map(repr, key)) or 'all points'} ({n} row{'s' if n != 1 else ''})"
        for key, n in zip(rows, n_outliers[groups[:10]], strict=True)
    )
    more = "; ..." if len(groups) > 10 else ""
    warnings.warn(
        f"hull() left {n_outliers.sum()} row(s) of {len(groups)} group(s) outside "
        f"their hulls (outliers={outliers!r}): {each}{more}; "
        "geoalpha.outlier_rows() marks them",
        OutlierWarning,
        stacklevel=user_stacklevel(),
    )


def outlier_rows(gdf, by=None, **options) -> pd.Series:
    """Mark the input rows that :func:`hull` leaves out with ``outliers=``.

    Parameters
    ----------
    gdf : GeoDataFrame or GeoSeries
        The points, as for :func:`hull`.
    by : str, list of str, or array_like, optional
        The groups, as for :func:`hull`.
    **options
        The options of :func:`hull`, ``outliers`` included.

    Returns
    -------
    pandas.Series of bool
        Aligned with ``gdf`` (same index): True for the rows left out of
        their group's hull (a MultiPoint row: when one of its points is);
        False for the others, dropped rows included.

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
    found: list = []
    token = _OUTLIER_ROWS.set(found)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", OutlierWarning)
            hull(gdf, by, **options)
    finally:
        _OUTLIER_ROWS.reset(token)
    return found[0]


def _rows_to_index(message: str, rows: np.ndarray, index: pd.Index) -> str:
    """Name rows of the input frame (by index label) in a crs error message."""
    import re

    def label(m):
        pos = [int(p) for p in re.findall(r"\d+", m.group(1))]
        shown = ", ".join(str(index[rows[p]]) for p in pos if p < len(rows))
        return f"(index {shown}{', ...' if '...' in m.group(1) else ''})"

    return re.sub(r"\(positions? ([\d, .]+)\)", label, message)


def _degenerate_groups(
    geometry, area, is_degenerate, keys, n_points, proj, pcodes, policy, width
):
    """Apply the degenerate-group policy and warn, naming the groups."""
    groups = np.flatnonzero(is_degenerate & (n_points > 0))
    keep = np.ones(len(geometry), dtype=bool)
    geometry = geometry.copy()
    area = area.copy()
    if policy == "buffer":
        sel = np.flatnonzero(np.isin(pcodes, groups))
        sel = sel[np.argsort(pcodes[sel], kind="stable")]
        mp = shapely.multipoints(
            proj.xy[sel], indices=np.searchsorted(groups, pcodes[sel])
        )
        buffered = shapely.buffer(shapely.convex_hull(mp), width)
        area[groups] = shapely.area(buffered)
        geometry[groups] = proj.to_output(buffered, groups)
        done = f"their rows hold a {width:g} {proj.unit} buffer around their points"
    elif policy == "empty":
        geometry[groups] = EMPTY_POLYGON
        done = "their rows hold an empty polygon"
    else:
        keep[groups] = False
        done = f"they were dropped ({n_points[groups].sum()} rows)"
    names = [
        ", ".join(map(str, row)) if len(row) else "all points"
        for row in keys.iloc[groups[:10]].itertuples(index=False)
    ]
    listed = "; ".join(
        f"{n!r} ({c} row{'s' if c != 1 else ''})"
        for n, c in zip(names, n_points[groups[:10]], strict=True)
    )
    warnings.warn(
        f"{len(groups)} group(s) have fewer than 3 distinct points or all points "
        f"on a line, so no alpha shape: {listed}"
        f"{', ...' if len(groups) > 10 else ''}; {done} (degenerate={policy!r})",
        DegenerateGroupWarning,
        stacklevel=user_stacklevel(),
    )
    return geometry, area, keep


def _finish(
    geometry: np.ndarray, crossing: np.ndarray, wide: np.ndarray, keys
) -> np.ndarray:
    """Repair what the CRS round trip broke, then split antimeridian groups."""
    geometry = geometry.copy()
    invalid = ~shapely.is_valid(geometry)
    if invalid.any():
        geometry[invalid] = polygonal(
            shapely.make_valid(geometry[invalid], method="structure")
        )
        if (invalid & ~wide).any():
            warnings.warn(
                f"{(invalid & ~wide).sum()} hull(s) became invalid in the input CRS "
                "(coordinates too close for it) and were repaired with make_valid: "
                + _names(keys, invalid & ~wide),
                GeoAlphaWarning,
                stacklevel=user_stacklevel(),
            )
    if crossing.any():
        geometry[crossing] = gcrs.split_antimeridian(geometry[crossing])
        warnings.warn(
            f"{crossing.sum()} group(s) cross the antimeridian (+-180 degrees): "
            f"{_names(keys, crossing)}; their hulls are MultiPolygons split at "
            "+-180 degrees (RFC 7946)",
            AntimeridianWarning,
            stacklevel=user_stacklevel(),
        )
    if wide.any():
        warnings.warn(
            f"{wide.sum()} group(s) span more than 180 degrees of longitude: "
            f"{_names(keys, wide)}; no longitude/latitude polygon can represent "
            "their hull faithfully (it may not contain all their points); "
            "'area_m2' and 'alpha' are right, for the geometry use crs= with a "
            "projected output or split the group",
            GeoAlphaWarning,
            stacklevel=user_stacklevel(),
        )
    return geometry


def _names(keys, mask: np.ndarray, limit: int = 10) -> str:
    rows = keys[mask].head(limit).itertuples(index=False)
    names = [", ".join(map(str, r)) or "all points" for r in rows]
    return "; ".join(names) + (", ..." if mask.sum() > limit else "")


def _grow(geometry, area, shaped, proj, pcodes, distance):
    """Buffer the hulls of ``shaped`` groups by ``distance`` in the metric CRS."""
    if not (isinstance(distance, int | float) and np.isfinite(distance)) or (
        distance < 0
    ):
        raise InvalidInputError(
            f"grow must be a distance >= 0 (metres); got {distance!r}"
        )
    sel = np.flatnonzero(shaped & ~shapely.is_empty(geometry))
    if not sel.size:
        return geometry, area
    # Hull vertices are input points: look their metric coordinates up.
    coords, which = shapely.get_coordinates(geometry[sel], return_index=True)
    keys = pd.MultiIndex.from_arrays([pcodes, proj.out[:, 0], proj.out[:, 1]])
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
        warnings.warn(
            f"{(~exact).sum()} hull(s) were not grown: a vertex is not an input "
            "point (repaired geometry)",
            GeoAlphaWarning,
            stacklevel=user_stacklevel(),
        )
    grown = shapely.buffer(metric[exact], distance, quad_segs=4)
    geometry = geometry.copy()
    area = np.asarray(area, dtype=float).copy()
    area[sel[exact]] = shapely.area(grown)
    geometry[sel[exact]] = proj.to_output(grown, sel[exact])
    return geometry, area
