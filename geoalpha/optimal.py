"""Optimal alpha shapes of point arrays: the array-level public API.

:func:`alpha_shapes` is the batched entry point (many groups in one call, as
the GeoPandas layer uses it); :func:`optimal_alpha` and :func:`alpha_shape`
are the one-group conveniences.
"""

from __future__ import annotations

import warnings
from typing import Literal, NamedTuple

import numpy as np
import shapely

from geoalpha import core, coverage, delaunay, parallel, search, shapes
from geoalpha.errors import (
    DegenerateGroupWarning,
    InvalidInputError,
    SearchWarning,
    first_n,
    user_stacklevel,
)
from geoalpha.options import check

__all__ = ["AlphaShapes", "alpha_shape", "alpha_shapes", "optimal_alpha"]

#: The values of ``search=`` (:data:`geoalpha.options.SEARCHES`), as a type.
Search = Literal["exact", "ladder", "bisect"]


class AlphaShapes(NamedTuple):
    """Result of :func:`alpha_shapes`, one entry per group.

    Attributes
    ----------
    alpha : ndarray of float
        The alpha used (the optimum unless one was given), in 1/unit of the
        coordinates; ``nan`` for degenerate groups, 0 means the convex hull.
    geometry : ndarray of object
        Polygon, MultiPolygon (several pieces) or empty Polygon (degenerate
        group, or nothing solid at the given alpha).
    n_points : ndarray of int
        Input points of the group (duplicates included).
    n_distinct : ndarray of int
        Distinct points of the group.
    n_parts : ndarray of int
        Edge-connected pieces of the shape.
    area : ndarray of float
        Area of the shape in the units of ``points`` squared (square metres for
        metric coordinates), whatever ``coords`` the geometry was built from.
    degenerate : ndarray of bool
        Fewer than 3 distinct points, or all collinear: no triangle, no alpha.
        Both are decided with a tolerance relative to the group's extent
        (:data:`geoalpha.core.NEAR_RTOL`), in ``points`` and in ``coords``; a
        group whose shape float geometry cannot make valid and covering is
        degenerate too (never a polygon that misses a point).
    n_outliers : ndarray of int
        Distinct points of the group left out of the shape (``outliers=``);
        0 without outliers.
    outlier : ndarray of bool, shape (n,)
        One entry per input point (not per group): True where the point was
        left out (duplicates of a left-out point too).
    gave_up : ndarray of bool
        ``search="bisect"`` stopped at ``max_iterations`` and returned alpha
        0, the convex hull (:func:`alpha_shapes` names these groups in a
        :class:`SearchWarning`); False for the other searches.
    """

    alpha: np.ndarray
    geometry: np.ndarray
    n_points: np.ndarray
    n_distinct: np.ndarray
    n_parts: np.ndarray
    area: np.ndarray
    degenerate: np.ndarray
    n_outliers: np.ndarray | None = None
    outlier: np.ndarray | None = None
    gave_up: np.ndarray | None = None


def _check_options(
    holes, components, search_: str, max_iterations, outliers=0, alpha=None
) -> dict:
    """Check the options as ``hull()`` does (:func:`geoalpha.options.check`)."""
    checked = check(
        holes=holes,
        components=components,
        search=search_,
        max_iterations=max_iterations,
        outliers=outliers,
    )
    if outliers and (alpha is not None or search_ != "exact"):
        raise InvalidInputError(
            "outliers applies to the exact optimum: use it without alpha and "
            f"with search='exact'; got alpha={alpha!r}, search={search_!r}"
        )
    return checked


def _rank_threshold(
    tri: core.Triangulation,
    weight: np.ndarray,
    alpha,
    components: int,
    search_: str,
    max_iterations: int,
    *,
    filled: bool,
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, np.ndarray]:
    """Per group: the alpha, the largest solid rank, the number of pieces.

    And whether ``search="bisect"`` gave up. The alpha is nan for degenerate
    groups; the pieces are None if not counted (for a given alpha).
    ``filled``: the weights are fill radii (see :meth:`core.Spectrum.build`).
    """
    G = tri.n_groups
    gave_up = np.zeros(G, dtype=bool)
    if alpha is not None:
        try:
            a = np.broadcast_to(np.asarray(alpha, dtype=float), (G,)).copy()
        except (TypeError, ValueError) as err:
            raise InvalidInputError(
                f"alpha must be a number >= 0 (or one per group, {G}); got {alpha!r}"
            ) from err
        if not np.isfinite(a).all() or (a < 0).any():
            raise InvalidInputError(f"alpha must be finite and >= 0; got {alpha!r}")
        a[tri.degenerate] = np.nan
        return a, tri.rank_of(core.radius_of_alpha(a)), None, gave_up

    spectrum = core.Spectrum.build(tri, weight, filled=filled)
    if search_ == "exact":
        rank = spectrum.optimum(components)
        radius = np.append(tri.values, np.inf)[rank]
        with np.errstate(divide="ignore"):
            a = 1.0 / radius
        a[tri.degenerate] = np.nan
        return a, rank, spectrum.pieces_at_rank(np.arange(G), rank), gave_up

    def valid(groups, alphas):
        return spectrum.valid(groups, core.radius_of_alpha(alphas), components)

    if search_ == "ladder":
        a, _ = search.ladder_alpha(valid, G)
    else:
        a, gave_up, _ = search.bisect_alpha(valid, G, max_iterations=max_iterations)
        gave_up &= ~tri.degenerate
    a[tri.degenerate] = np.nan
    rank = tri.rank_of(core.radius_of_alpha(a))
    return a, rank, spectrum.pieces_at_rank(np.arange(G), rank), gave_up


def _warn_gave_up(gave_up: np.ndarray, max_iterations: int, names: str) -> None:
    """Warn (:class:`SearchWarning`) about the groups the bisection gave up on.

    ``names`` names them (group codes for :func:`alpha_shapes`, keys for
    :func:`geoalpha.hull`).
    """
    warnings.warn(
        f"search='bisect' did not converge within max_iterations={max_iterations} "
        f"for {gave_up.sum()} group(s) ({names}) and gave them alpha 0, the convex "
        "hull, as alphashape does; use search='exact'",
        SearchWarning,
        stacklevel=user_stacklevel(),
    )


def alpha_shapes(
    points,
    groups=None,
    *,
    alpha=None,
    holes: bool = False,
    components: int = 1,
    search: Search = "exact",
    max_iterations: int = 10_000,
    coords=None,
    n_groups: int | None = None,
    progress=None,
    n_jobs: int = 1,
    outliers: float = 0,
    name_groups=None,
) -> AlphaShapes:
    """Optimal alpha shapes of many groups of points in one call.

    Parameters
    ----------
    points : array_like of shape (n, 2)
        Coordinates in a metric (projected) CRS; alpha is in 1/unit of them.
    groups : array_like of int, shape (n,), optional
        Group code ``0 .. G-1`` of each point (e.g. from
        :func:`pandas.factorize`); all points form one group if None.
    alpha : float or array_like of shape (G,), optional
        Use this alpha instead of the optimum (0 is the convex hull).
    holes : bool, default False
        Keep holes (True) or fill every hole not connected to the outside
        (False, the seed paper's "no empty space in the middle").
    components : int, default 1
        Largest number of edge-connected pieces a valid shape may have.
    search : {"exact", "ladder", "bisect"}, default "exact"
        How the optimum is searched: ``"exact"`` finds the true maximum over
        the Delaunay circumradius spectrum; ``"ladder"`` is the seed paper's
        integer ladder (5000, 3000, ..., 5, 0, then integer bisection) and
        ``"bisect"`` ``alphashape``'s float bisection from 0 to the largest
        float. Both use the same validity test as ``"exact"``, but their
        answers depend on the units: integer alphas in 1/metre are nearly
        always 0, the convex hull; the bisection cannot converge when the
        optimum is >= 4 and then returns 0 with a :class:`SearchWarning`.
    max_iterations : int, default 10000
        Bisection steps before ``search="bisect"`` gives up.
    coords : array_like of shape (n, 2), optional
        Coordinates to build the output geometries from, one row per input
        point (default: ``points``). The GeoPandas layer passes the input
        longitude/latitude here, so that every polygon vertex is exactly an
        input point although the computation ran in metres.
    n_groups : int, optional
        Number of groups (default: largest code + 1).
    progress : object with an ``update(n)`` method, optional
        Progress of the triangulation, in groups (e.g. a ``tqdm`` bar).
    n_jobs : int, default 1
        Worker processes to spread the groups over (-1: one per core); see
        :mod:`geoalpha.parallel`. The result is the same for every value.
    outliers : float or int, default 0
        Points each group may leave out: a float in ``[0, 1)`` is a fraction
        of the group's distinct points (``k = floor(outliers * n)``), an int a
        count ``k``. The optimum is then the largest alpha at which at most
        ``components`` pieces of the shape cover at least ``n - k`` distinct
        points; only those pieces are kept, and the points they miss are
        reported (``n_outliers``, ``outlier``). Groups with ``k = 0`` get the
        result without outliers. See :mod:`geoalpha.coverage`.
    name_groups : callable, optional
        Turns an array of group codes into the text that names those groups
        in a warning (:func:`geoalpha.hull` names them by key); default: the
        codes.

    Returns
    -------
    AlphaShapes
        Per group: ``alpha``, ``geometry``, ``n_points``, ``n_distinct``,
        ``n_parts``, ``area``, ``degenerate``, ``n_outliers``; per input
        point: ``outlier``.

    Raises
    ------
    InvalidInputError
        On NaN/inf coordinates (naming the rows), bad shapes or options.

    Notes
    -----
    A triangle is solid when ``alpha * r <= 1`` (evaluated with a few ulps
    of slack, so that feeding an optimal alpha back gives the optimal
    shape). Groups with fewer than 3 distinct points, or all collinear, are
    *degenerate*: ``alpha`` is nan and the geometry an empty Polygon; no
    warning is raised here (check ``degenerate``).

    Examples
    --------
    >>> import numpy as np
    >>> pts = np.array([[0, 0], [4, 0], [4, 4], [0, 4], [2, 3.5],
    ...                 [10, 0], [12, 0], [11, 2]])
    >>> res = alpha_shapes(pts, [0, 0, 0, 0, 0, 1, 1, 1])
    >>> res.alpha.round(4).tolist(), res.n_points.tolist()
    ([0.4308, 0.8], [5, 3])
    >>> [g.geom_type for g in res.geometry]
    ['Polygon', 'Polygon']

    One stray point may stay out:

    >>> stray = np.array([[0, 0], [4, 0], [4, 4], [0, 4], [2, 3.5], [30, 30]])
    >>> res = alpha_shapes(stray, outliers=1)
    >>> res.alpha.round(4).tolist(), res.n_outliers.tolist(), res.outlier.tolist()
    ([0.4308], [1], [False, False, False, False, False, True])
    """
    checked = _check_options(holes, components, search, max_iterations, outliers, alpha)
    if name_groups is not None and not callable(name_groups):
        raise InvalidInputError(
            "name_groups must be a function of an array of group codes that "
            f"returns their names as text; got {type(name_groups).__name__}"
        )
    outliers = checked.pop("outliers")
    options = {"alpha": alpha, **checked}
    options.update(coords=coords, n_groups=n_groups, progress=progress)
    if outliers:  # passed on only when used, so that 0 takes today's path
        options["outliers"] = outliers
    if type(n_jobs) is not int or n_jobs != 1 or _batched(points, groups):
        res = parallel.alpha_shapes_parallel(
            points, groups, batch=_alpha_shapes_batch, n_jobs=n_jobs, **options
        )
    else:
        res = _alpha_shapes_batch(points, groups, **options)
    if res.gave_up.any():
        which = np.flatnonzero(res.gave_up)
        names = f"codes {first_n(which)}" if name_groups is None else name_groups(which)
        _warn_gave_up(res.gave_up, checked["max_iterations"], names)
    return res


def _batched(points, groups) -> bool:
    """Whether to cut the groups into runs (large inputs fit caches better)."""
    return groups is not None and len(points) > 2 * parallel.BATCH_POINTS


def _alpha_shapes_batch(
    points,
    groups,
    *,
    alpha,
    holes,
    components,
    search,
    max_iterations,
    coords,
    n_groups,
    progress,
    outliers=0,
) -> AlphaShapes:
    """:func:`alpha_shapes` of all groups in one pass (no runs, no workers).

    Rows that repeat an earlier row of their group exactly (in ``points`` and
    in ``coords``) are set aside first: the shapes are those of the other
    rows, and the per-row results are copied to the repeats.
    """
    try:
        xy = core.check_points(points)  # (errors name rows of the input)
        codes, n_groups = core.group_codes(groups, len(xy), n_groups)
        out_xy = _output_coordinates(xy, coords)
    except ValueError as err:
        raise InvalidInputError(str(err)) from err
    rep = core.exact_duplicates(xy, codes, out_xy)
    options = dict(alpha=alpha, holes=holes, components=components, search=search)
    options.update(max_iterations=max_iterations, progress=progress)
    if rep is None:
        return _distinct_shapes(xy, codes, out_xy, n_groups, outliers, **options)
    first = rep == np.arange(len(rep))
    rows = np.flatnonzero(first)
    res = _distinct_shapes(
        np.take(xy, rows, axis=0),
        codes[rows],
        None if out_xy is None else np.take(out_xy, rows, axis=0),
        n_groups,
        outliers,
        **options,
    )
    position = np.cumsum(first) - 1  # of each first row among them
    return res._replace(
        n_points=np.bincount(codes, minlength=n_groups),
        outlier=res.outlier[position[rep]],
    )


def _distinct_shapes(
    xy,
    codes,
    out_xy,
    n_groups,
    outliers,
    *,
    alpha,
    holes,
    components,
    search,
    max_iterations,
    progress,
) -> AlphaShapes:
    """:func:`_alpha_shapes_batch` of rows without exact repeats."""
    try:
        tri = core.triangulate(
            xy,
            codes,
            n_groups=n_groups,
            progress=progress,
            backend=delaunay.triangulate_groups,
            out_coords=out_xy,
        )
    except ValueError as err:
        raise InvalidInputError(str(err)) from err
    elsewhere = out_xy is not None  # returned in other coordinates (lon/lat)
    if out_xy is None:
        out_xy = tri.xy
    else:
        order = np.empty(len(out_xy), dtype=np.int64)  # triangulation order
        order[tri.input_point] = np.arange(len(out_xy))
        out_xy = np.take(out_xy, order, axis=0)  # (10x out_xy[order])
    weight = tri.rank if holes else core.fill_radius(tri)
    a, top, n_pieces, gave_up = _rank_threshold(
        tri, weight, alpha, components, search, max_iterations, filled=not holes
    )

    inside = weight <= top[tri.tri_group]
    kept = None
    if outliers:
        k = coverage.outlier_budget(outliers, tri.n_distinct)
        kept = coverage.outlier_optimum(
            tri, weight, top, k, components, filled=not holes
        )
        used = (k > 0) & ~tri.degenerate
        inside, n_pieces = kept.inside, np.where(used, kept.n_pieces, n_pieces)
        with np.errstate(divide="ignore"):
            a = np.where(used, 1.0 / np.append(tri.values, np.inf)[kept.rank], a)
    piece = core.piece_labels(tri, inside, n_pieces)
    rings = core.boundary_rings(tri, inside, piece)
    geometry = shapes.assemble(out_xy, rings, tri.n_groups)
    ring_failed, convex = _convex_where_rings_fail(geometry, tri, inside, rings, out_xy)
    # The guarantee: every group a valid (Multi)Polygon that covers each of
    # its points, in the coordinates it is returned in (at the optimum), or
    # declared degenerate. Points merged as near-duplicates are taken in here.
    check = ~tri.degenerate & ~ring_failed
    # Coverage needs a geometric test only where it is not certain. Every
    # point at exactly the place of a ring vertex is a vertex of the
    # (validity-checked) polygon, so it is covered, in any coordinates. In
    # the coordinates of the triangulation, the other representative points
    # are vertices of triangles in the shape, so they are covered too; in
    # other coordinates (lon/lat) they are tested, as are points merged into
    # another one. (shapes.enforce tests every point of a polygon it had to
    # repair.)
    x, y, v = out_xy[:, 0], out_xy[:, 1], tri.vertex
    test = (x != x[v]) | (y != y[v])
    if elsewhere:
        on_ring = np.zeros(len(out_xy), dtype=bool)
        on_ring[rings.vertex] = True
        test |= ~on_ring[v]
    geometry, failed = shapes.enforce(
        geometry,
        out_xy,
        tri.point_group,
        check,
        # At a given alpha only alpha 0 (the convex hull) holds every point.
        cover=True if alpha is None else np.asarray(a) == 0,
        components=components if alpha is None else None,
        test=test,
        exempt=None if kept is None else kept.outlier,  # left out on purpose
    )
    failed |= ring_failed & ~tri.degenerate
    degenerate = tri.degenerate | failed
    a = np.where(degenerate, np.nan, a)
    geometry[failed] = shapes.EMPTY_POLYGON
    n_parts = np.bincount(rings.piece_group, minlength=tri.n_groups)
    n_parts[convex] = 1
    n_parts[degenerate] = 0
    area = np.bincount(
        tri.tri_group[inside], weights=tri.area[inside], minlength=tri.n_groups
    )
    area[degenerate] = 0.0
    if kept is None:
        n_outliers, outlier = (
            np.zeros(tri.n_groups, np.int64),
            np.zeros(len(codes), bool),
        )
    else:
        n_outliers, outlier = _still_left_out(tri, kept, geometry, out_xy)
        outlier = outlier[tri.input_point]
    return AlphaShapes(
        alpha=a,
        geometry=geometry,
        n_points=np.bincount(codes, minlength=tri.n_groups),
        n_distinct=tri.n_distinct.copy(),
        n_parts=n_parts,
        area=area,
        degenerate=degenerate,
        n_outliers=n_outliers,
        outlier=outlier,
        gave_up=gave_up & ~degenerate,
    )


def _convex_where_rings_fail(geometry, tri, inside, rings, out_xy):
    """Give the convex hull to groups whose whole triangulation is the shape.

    With every triangle of a group in the shape (alpha 0, or an alpha below
    the largest radius), the shape is the convex hull. Flat slivers along a
    straight stretch of the hull (radii ~1e16) can keep
    :func:`geoalpha.core.boundary_rings` from closing its rings; such a
    group gets the convex hull of its points in the output coordinates
    (valid, holding every point) instead of being declared degenerate.
    Changes ``geometry`` in place; returns the groups whose rings still
    failed, and those that got the convex hull.
    """
    failed = rings.failed.copy()
    if not failed.any():
        return failed, np.zeros(0, dtype=np.int64)
    n_tri = np.diff(tri.tri_ptr)
    n_in = np.bincount(tri.tri_group[inside], minlength=tri.n_groups)
    whole = np.flatnonzero(failed & ~tri.degenerate & (n_tri > 0) & (n_in == n_tri))
    if len(whole):
        take = np.flatnonzero(np.isin(tri.point_group, whole))
        geometry[whole] = shapes.convex_hulls(
            np.take(out_xy, take, axis=0), tri.point_group[take], tri.n_groups
        )[whole]
        failed[whole] = False
    return failed, whole


def _still_left_out(tri, kept, geometry, out_xy):
    """Return the points left out (``outliers=``) that the final polygons miss.

    Taking in a point that the kept pieces just miss (a near-duplicate of
    one of their vertices) can move an edge over a point left out; such a
    point is then inside its shape, and no longer reported as left out.
    Returns the distinct points left out per group (points merged as
    near-duplicates count once) and the flag of each point.
    """
    outlier = shapes.left_outside(kept.outlier, geometry, out_xy, tri.point_group)
    if outlier.sum() == kept.outlier.sum():
        return kept.n_outliers, outlier
    own = np.where(tri.distinct, np.arange(len(outlier)), tri.vertex)
    left = np.unique(own[outlier])
    return np.bincount(tri.point_group[left], minlength=tri.n_groups), outlier


def _output_coordinates(points, coords):
    """Return the output coordinates (None: the points), checked.

    Degeneracy is decided in the coordinates the result is returned in, too
    (:func:`geoalpha.core.triangulate`'s ``out_coords``): points on one
    meridian are collinear in longitude/latitude even where their image in
    metres is a hair away from a line.
    """
    if coords is None:
        return None
    c = np.asarray(coords, dtype=float)
    n = len(np.asarray(points))
    if c.shape != (n, 2):
        raise InvalidInputError(
            f"coords must have the shape of points {(n, 2)}; got {c.shape}"
        )
    return c


def _as_xy(points):
    """Coordinates of shapely points (a MultiPoint, Points, a GeoSeries), else as is.

    Any other geometry is an :class:`InvalidInputError` that says what to pass.
    """
    if isinstance(points, shapely.Geometry):
        points = [points]
    values = getattr(points, "values", points)  # a GeoSeries / Series
    if not isinstance(values, np.ndarray | list | tuple):
        values = np.asarray(values)  # e.g. a GeometryArray: its geometries
    if isinstance(values, np.ndarray) and values.dtype != object:
        return points
    if not isinstance(values, np.ndarray):
        if not (isinstance(values, list | tuple) and values):
            return points
        if not isinstance(values[0], shapely.Geometry):
            return points
    geoms = np.asarray(values, dtype=object)
    kinds = shapely.get_type_id(geoms)
    if not np.isin(kinds, (0, 4)).all():
        raise InvalidInputError(
            "points must be x, y coordinates or shapely points (Point, MultiPoint, "
            "a GeoSeries of points); got "
            + ", ".join(sorted({g.geom_type for g in geoms[~np.isin(kinds, (0, 4))]}))
        )
    return shapely.get_coordinates(geoms)


def _one_group(points, **kwargs) -> AlphaShapes:
    xy = _as_xy(points)
    res = alpha_shapes(xy, None, n_groups=1, **kwargs)
    if res.degenerate[0]:
        if len(xy) < 3 or core.thin_groups(xy)[0]:
            why = (
                "are fewer than 3 or all collinear (within 1e-9 of their extent "
                "of a line; points closer than that are one)"
            )
        else:  # the checks of the shape failed
            why = (
                "got no valid polygon holding all of them (float64 could not "
                "build one: near-duplicates or slivers where pieces touch)"
            )
        warnings.warn(
            f"no alpha shape: the {res.n_distinct[0]} distinct point(s) {why}; "
            "alpha is nan and the shape empty",
            DegenerateGroupWarning,
            stacklevel=user_stacklevel(),
        )
    return res


def optimal_alpha(
    points,
    *,
    holes: bool = False,
    components: int = 1,
    search: Search = "exact",
    max_iterations: int = 10_000,
    outliers: float = 0,
) -> float:
    """Largest alpha whose shape is one piece containing every point.

    Parameters
    ----------
    points : array_like of shape (n, 2)
        Coordinates in a metric CRS (alpha comes in 1/unit of them).
    holes : bool, default False
        Keep holes (True) or fill them (False).
    components : int, default 1
        Largest number of edge-connected pieces allowed.
    search : {"exact", "ladder", "bisect"}, default "exact"
        See :func:`alpha_shapes`.
    max_iterations : int, default 10000
        For ``search="bisect"``.
    outliers : float or int, default 0
        Points that may stay out: a fraction in ``[0, 1)`` of the distinct
        points or a count; see :func:`alpha_shapes`.

    Returns
    -------
    float
        ``max{alpha >= 0 : S(alpha) valid}``, exactly ``1 / r(t)`` for one
        Delaunay triangle ``t`` (or 0 for the convex hull); ``nan`` with a
        :class:`DegenerateGroupWarning` for fewer than 3 distinct points or
        collinear points.

    Raises
    ------
    InvalidInputError
        If a coordinate is NaN or inf (the message names the rows).

    Examples
    --------
    >>> round(optimal_alpha([[0, 0], [4, 0], [4, 4], [0, 4], [2, 3.5]]), 6)
    0.430769
    >>> stray = [[0, 0], [4, 0], [4, 4], [0, 4], [2, 3.5], [30, 30]]
    >>> round(optimal_alpha(stray), 6), round(optimal_alpha(stray, outliers=1), 6)
    (0.035624, 0.430769)
    """
    return float(
        _one_group(
            points,
            holes=holes,
            components=components,
            search=search,
            max_iterations=max_iterations,
            outliers=outliers,
        ).alpha[0]
    )


def alpha_shape(
    points,
    alpha: float | None = None,
    *,
    holes: bool = False,
    components: int = 1,
    search: Search = "exact",
    outliers: float = 0,
):
    """Alpha shape of a point set, at the optimal alpha by default.

    Parameters
    ----------
    points : array_like of shape (n, 2)
        Coordinates in a metric CRS.
    alpha : float, optional
        None for the optimum, 0 for the convex hull, else the union of the
        Delaunay triangles with ``alpha * circumradius <= 1``.
    holes : bool, default False
        Keep holes (True) or fill them (False).
    components : int, default 1
        For the optimum: largest number of pieces allowed.
    search : {"exact", "ladder", "bisect"}, default "exact"
        See :func:`alpha_shapes`.
    outliers : float or int, default 0
        For the optimum: points that may stay out (a fraction in ``[0, 1)`` or
        a count); the shape then holds only the pieces that cover the others.
        See :func:`alpha_shapes`.

    Returns
    -------
    shapely.Polygon or shapely.MultiPolygon
        At the optimum, one valid Polygon (a MultiPolygon of at most
        ``components`` parts) covering every input point, whose vertices are
        input points. At a given alpha, a MultiPolygon where pieces separate
        and an empty Polygon when nothing is solid.

    Examples
    --------
    >>> shape = alpha_shape([[0, 0], [4, 0], [4, 4], [0, 4], [2, 3.5]])
    >>> shape.geom_type, shape.area
    ('Polygon', 15.0)
    >>> alpha_shape([[0, 0], [4, 0], [4, 4], [0, 4], [2, 3.5]], alpha=0).area
    16.0
    """
    return _one_group(
        points,
        alpha=alpha,
        holes=holes,
        components=components,
        search=search,
        outliers=outliers,
    ).geometry[0]
