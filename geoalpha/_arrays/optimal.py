"""The array-level public API: optimal alpha shapes of one or many groups of points."""

from __future__ import annotations

import dataclasses
from typing import Literal

import numpy as np
import shapely

from geoalpha import _core as kernel
from geoalpha._arrays import guarantee
from geoalpha._arrays.lonlat import restore_longitudes
from geoalpha._arrays.search import bisect_alpha, ladder_alpha
from geoalpha._arrays.sphere import (
    close_around_poles,
    follow_arcs,
    refused_message,
    sphere_output,
)
from geoalpha._core import AlphaShapes, Reason
from geoalpha._options import Request
from geoalpha._options import check as check_options
from geoalpha.errors import (
    DegenerateGroupWarning,
    InvalidInputError,
    OutlierWarning,
    SearchWarning,
    first_n,
    setting,
    warn_user,
)

__all__ = ["AlphaShapes", "alpha_shape", "alpha_shapes", "optimal_alpha"]

#: The values of ``search=`` (:data:`geoalpha._options.SEARCHES`), as a type.
Search = Literal["exact", "ladder", "bisect"]

#: The fields of the record after the documented ones (after ``reason``): they
#: serve the stages of ``hull()`` and are None in what :func:`alpha_shapes` returns.
_FOR_THE_STAGES = AlphaShapes._fields[AlphaShapes._fields.index("reason") + 1 :]


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
    n_jobs: int | None = None,
    outliers: float = 0,
    outlier_unit: str = "rows",
    name_groups=None,
    sphere: bool = False,
    polar=None,
) -> AlphaShapes:
    """Optimal alpha shapes of many groups of points in one call.

    Parameters
    ----------
    points : array_like of shape (n, 2)
        Coordinates in a metric (projected) CRS; alpha is in 1/unit of them.
    groups : array_like of int, shape (n,), optional
        Group code ``0 .. G-1`` of each point (:func:`pandas.factorize`), or one group.
    alpha : float or array_like of shape (G,), optional
        Use this alpha instead of the optimum (0 is the convex hull).
    holes, components, search, max_iterations, n_jobs, outliers, outlier_unit
        As for :func:`geoalpha.hull`; the rows left out are reported in
        ``n_outliers`` and ``outlier`` (:doc:`/user_guide/outliers`).
    coords : array_like of shape (n, 2), optional
        Coordinates of the output geometries, one row per point (``points``).
    n_groups : int, optional
        Number of groups (default: largest code + 1).
    progress : object with an ``update(n)`` method, optional
        Progress in groups (e.g. a ``tqdm`` bar).
    name_groups : callable, optional
        Names an array of group codes in warnings, as text (default: by code).
    sphere : bool, default False
        ``points`` are longitudes and latitudes, computed on the sphere: alpha
        in 1/metre, areas in square metres (:doc:`/user_guide/sphere`).
    polar : array_like of bool, shape (n_groups,), optional
        With ``sphere``: the groups around a pole (default: without ``coords``,
        as :func:`~geoalpha._arrays.sphere.sphere_output` finds them).

    Returns
    -------
    AlphaShapes
        Degenerate groups are flagged in ``degenerate``, without a warning
        (but a group the kernel failed on, reason ``FAILED``, warns with its
        rows); the fields after ``reason`` (for :func:`geoalpha.hull`) are None.

    Raises
    ------
    InvalidInputError
        On NaN/inf coordinates, bad shapes or options, groups too wide for
        ``sphere`` (naming the rows or groups).

    Examples
    --------
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
    checked = check_options(
        holes=holes,
        components=components,
        search=search,
        max_iterations=max_iterations,
        outliers=outliers,
        outlier_unit=outlier_unit,
        n_jobs=n_jobs,
    )
    if outliers and (alpha is not None or search != "exact"):  # (as Options)
        raise InvalidInputError(
            "outliers applies to the exact optimum: use it without alpha and "
            f"with {setting('search', 'exact')}; got "
            f"{setting('alpha', alpha)}, {setting('search', search)}"
        )
    if name_groups is not None and not callable(name_groups):
        raise InvalidInputError(
            "name_groups must be a function of an array of group codes that "
            f"returns their names as text; got {type(name_groups).__name__}"
        )
    try:
        xy = kernel.check_points(points)  # (errors name rows of the input)
        codes, n_groups = kernel.group_codes(groups, len(xy), n_groups)
        if coords is not None:  # degeneracy is decided in them too
            coords = np.asarray(coords, dtype=float)
            if coords.shape != xy.shape:
                raise ValueError(
                    f"coords must have the shape of points {xy.shape}; got "
                    f"{coords.shape}"
                )
    except ValueError as err:
        raise InvalidInputError(str(err)) from err
    if sphere and coords is None:
        coords, _, _, polar = sphere_output(xy, codes, n_groups)
    given = None if alpha is None else _given_alpha(alpha, n_groups)
    request = Request(sphere=bool(sphere), alpha=given, **checked)
    res = solve_checked(
        xy, codes, n_groups, request, out=coords, progress=progress, polar=polar
    )
    refused = np.flatnonzero(res.reason == Reason.HEMISPHERE)
    if len(refused):
        raise InvalidInputError(
            refused_message(_named(refused, name_groups), len(refused))
        )
    warn_searches(res, request, name_groups)
    # Around a pole a valid polygon may have any number of parts.
    limit = np.where(polar, np.inf, components) if np.any(polar) else components
    out_xy = xy if coords is None else coords
    _warn_failed(res.reason, codes, name_groups)
    res = _verified(res, out_xy, codes, limit if alpha is None else None)
    return res._replace(**dict.fromkeys(_FOR_THE_STAGES, None))


def _warn_failed(reason, codes, name_groups) -> None:
    """Warn about the groups the kernel failed on (``FAILED``), naming their rows."""
    failed = np.flatnonzero(reason == Reason.FAILED)
    if len(failed):
        rows = np.flatnonzero(np.isin(codes, failed))
        warn_user(
            f"the kernel failed on {len(failed)} group(s) "
            f"({_named(failed, name_groups)}; rows at positions {first_n(rows)}): "
            f"they have no shape (reason {int(Reason.FAILED)}, degenerate), "
            "the other groups are unaffected; this is a bug, please report it "
            "with these points",
            DegenerateGroupWarning,
        )


def _named(which: np.ndarray, name_groups) -> str:
    """Name the groups ``which`` for a message (by code without ``name_groups``)."""
    return f"codes {first_n(which)}" if name_groups is None else name_groups(which)


def warn_searches(res: AlphaShapes, request: Request, name_groups) -> None:
    """Warn about the groups the bisection gave up on or the outlier search capped.

    ``res``: from :func:`solve_checked` with ``request``; ``name_groups``: as
    for :func:`alpha_shapes`.
    """
    max_iterations, components = request.max_iterations, request.components
    if res.gave_up.any():
        warn_user(
            f"{setting('search', 'bisect')} did not converge within "
            f"{setting('max_iterations', max_iterations)} for {res.gave_up.sum()} "
            f"group(s) ({_named(np.flatnonzero(res.gave_up), name_groups)}) and gave "
            f"them alpha 0, the convex hull, as alphashape does; use "
            f"{setting('search', 'exact')}",
            SearchWarning,
        )
    if res.capped.any():
        which = np.flatnonzero(res.capped)
        warn_user(
            f"{setting('outliers')}: the search for the {components} pieces that "
            f"hold the most rows stopped after {kernel.MAX_UNION_NODES:,} steps "
            f"for {len(which)} group(s) ({_named(which, name_groups)}); their "
            "hulls keep the best pieces found, which may leave out more rows than "
            "the optimum",
            OutlierWarning,
        )


def _given_alpha(alpha, n_groups: int) -> np.ndarray:
    try:
        a = np.broadcast_to(np.asarray(alpha, dtype=float), (n_groups,)).copy()
    except (TypeError, ValueError) as err:
        raise InvalidInputError(
            f"alpha must be a number >= 0 (or one per group, {n_groups}); got {alpha!r}"
        ) from err
    if not np.isfinite(a).all() or (a < 0).any():
        raise InvalidInputError(f"alpha must be finite and >= 0; got {alpha!r}")
    return a


def _searched_alpha(curve, n_groups: int, search: str, max_iterations: int):
    """Return the alpha ``search="ladder"``/``"bisect"`` finds on validity curves."""
    # per group: its distinct weights, ascending, and whether the shape at each is valid
    values, valid_at, offsets = curve

    def valid(groups, alphas):
        r = kernel.radius_of_alpha(alphas)
        ok = np.zeros(len(groups), dtype=bool)
        for i, (g, radius) in enumerate(zip(groups, r, strict=True)):
            a, b = offsets[g], offsets[g + 1]
            k = np.searchsorted(values[a:b], radius, side="right") - 1
            ok[i] = k >= 0 and bool(valid_at[a + k])
        return ok

    if search == "ladder":
        return ladder_alpha(valid, n_groups)[0], np.zeros(n_groups, dtype=bool)
    return bisect_alpha(valid, n_groups, max_iterations=max_iterations)[:2]


def solve_checked(
    xy: np.ndarray,
    codes: np.ndarray,
    n_groups: int,
    request: Request,
    *,
    out: np.ndarray | None = None,
    progress=None,
    polar=None,
) -> AlphaShapes:
    """:func:`alpha_shapes` on checked inputs, without the guarantee: one kernel call.

    Trusts its inputs (checked as :func:`alpha_shapes` does; ``request``:
    :meth:`geoalpha._options.Options.request`, with ``alpha`` and ``search``);
    the caller enforces the guarantee
    (:func:`geoalpha._arrays.guarantee.enforce`), words the groups the sphere
    refused (``Reason.HEMISPHERE``: degenerate) and warns about the searches
    that gave up (:func:`warn_searches`). With ``request.sphere``, ``out`` is
    given (the output longitudes and latitudes) and ``polar`` (per group:
    around a pole) may be.
    """
    gave_up = np.zeros(n_groups, dtype=bool)
    try:
        if request.alpha is None and request.search != "exact":
            asked = dataclasses.replace(request, curve=True, outliers=0)
            curve = kernel.solve(xy, codes, n_groups, asked, out=out).curve
            alpha, gave_up = _searched_alpha(
                curve, n_groups, request.search, request.max_iterations
            )
            request = dataclasses.replace(request, alpha=alpha)
        res = kernel.solve(xy, codes, n_groups, request, out=out, progress=progress)
    except ValueError as err:  # what the kernel refuses (e.g. |coordinate| > 1e100)
        raise InvalidInputError(str(err)) from err
    out_xy = xy if out is None else out
    if request.sphere:
        res = _on_the_sphere(res, out_xy, codes, polar)
    return _finished(res, out_xy, codes, gave_up)


def _on_the_sphere(res: AlphaShapes, out_xy, codes, polar) -> AlphaShapes:
    """Unfold the groups' polygons in lon/lat and close the polar ones."""
    polar = np.zeros(len(res.reason), bool) if polar is None else np.asarray(polar)
    geometry = res.geometry.copy()
    # Long edges of a shape concave on the sphere can fold in lon/lat.
    ok = res.reason == Reason.OK
    folded = np.flatnonzero(ok & ~shapely.is_valid(geometry) & ~polar)
    geometry[folded] = follow_arcs(geometry[folded])
    if polar.any():
        which = np.flatnonzero(polar)
        geometry[which] = restore_longitudes(
            close_around_poles(geometry[which]), which, *out_xy.T, codes
        )
    # Their vertices moved (cut at +-180, shifted): test every point.
    return res._replace(geometry=geometry, certain=res.certain & ~polar[codes])


def _finished(res: AlphaShapes, out_xy, codes, gave_up) -> AlphaShapes:
    """Clear what degenerate groups have; a ``whole`` group without rings: its hull."""
    geometry = res.geometry.copy()
    reason, n_parts = res.reason, res.n_parts
    # A group without rings (RINGS) whose shape is every triangle: its convex hull.
    whole = np.flatnonzero((reason == Reason.RINGS) & res.whole)
    if len(whole):
        take = np.isin(codes, whole)
        hulls = guarantee.convex_hulls(out_xy[take], codes[take], len(reason))
        geometry[whole] = hulls[whole]
        reason, n_parts = reason.copy(), n_parts.copy()
        reason[whole] = Reason.OK
        n_parts[whole] = 1
    degenerate = reason != Reason.OK
    geometry[degenerate] = guarantee.EMPTY_POLYGON
    return res._replace(
        alpha=np.where(degenerate, np.nan, res.alpha),  # (the given one, if any)
        geometry=geometry,
        n_parts=np.where(degenerate, 0, n_parts),
        area=np.where(degenerate, 0.0, res.area),
        degenerate=degenerate,
        gave_up=gave_up & ~degenerate,
        capped=res.capped & ~degenerate,
        reason=reason,
    )


def _verified(res: AlphaShapes, out_xy, codes, components) -> AlphaShapes:
    """Enforce the guarantee (``components``: None at a given alpha) on ``res``."""
    # At a given alpha only alpha 0 (the convex hull) holds every point; and a
    # near-duplicate merged into a point the shape covers is covered, as at
    # the optimum (so an optimal alpha fed back gives the optimal shape).
    cover = True if components is not None else res.alpha == 0
    exempt = res.outlier if res.outlier.any() else None
    if components is None and res.rep is not None:
        merged = res.rep != np.arange(len(res.rep))
        held = np.zeros(len(merged), dtype=bool)
        held[merged] = guarantee.covered(
            res.geometry, out_xy[res.rep[merged]], codes[merged]
        )
        if held.any():  # their groups' shapes are not empty
            free = ~cover[codes] & ~held  # not merged into a covered point
            exempt = free if exempt is None else exempt | free
            cover = cover.copy()
            cover[codes[held]] = True
    geometry, failed = guarantee.enforce(
        res.geometry,
        out_xy,
        codes,
        ~res.degenerate,
        cover=cover,
        components=components,
        test=~res.certain,
        exempt=exempt,
    )
    # A repair that took in a just-missed point may have covered one left out.
    outlier = guarantee.left_outside(res.outlier, geometry, out_xy, codes)
    return res._replace(
        geometry=geometry,
        alpha=np.where(failed, np.nan, res.alpha),
        n_parts=np.where(failed, 0, res.n_parts),
        area=np.where(failed, 0.0, res.area),
        degenerate=res.degenerate | failed,
        outlier=outlier,
        n_outliers=np.bincount(codes[outlier], minlength=len(failed)),
        gave_up=res.gave_up & ~failed,
        capped=res.capped & ~failed,
        reason=np.where(failed, Reason.GUARANTEE, res.reason),
    )


def _as_xy(points):
    """Coordinates of shapely points (a MultiPoint, Points, a GeoSeries), else as is."""
    if isinstance(points, shapely.Geometry):
        points = [points]
    values = getattr(points, "values", points)  # a GeoSeries / Series
    if not isinstance(values, list | tuple):
        values = np.asarray(values)  # e.g. a GeometryArray: its geometries
        if values.dtype != object:
            return points
    elif not (values and isinstance(values[0], shapely.Geometry)):
        return points
    geoms = np.asarray(values, dtype=object)
    wrong = ~np.isin(shapely.get_type_id(geoms), (0, 4))
    if wrong.any():
        raise InvalidInputError(
            "points must be x, y coordinates or shapely points (Point, MultiPoint, "
            "a GeoSeries of points); got "
            + ", ".join(sorted({g.geom_type for g in geoms[wrong]}))
        )
    return shapely.get_coordinates(geoms)


def _one_group(points, **kwargs) -> AlphaShapes:
    """:func:`alpha_shapes` of one group, warning when it has no shape."""
    res = alpha_shapes(_as_xy(points), None, n_groups=1, **kwargs)
    if res.degenerate[0] and res.reason[0] != Reason.FAILED:  # (that one warned)
        why = (
            "are fewer than 3 or all collinear (within "
            f"{np.format_float_scientific(kernel.NEAR_RTOL, trim='-', exp_digits=1)}"
            " of their extent of a line; points closer than that are one)"
            if res.reason[0] in kernel.THIN
            else "got no valid polygon holding all of them (float64 could not "
            "build one: near-duplicates or slivers where pieces touch)"
        )
        warn_user(
            f"no alpha shape: the {res.n_distinct[0]} distinct point(s) {why}; "
            "alpha is nan and the shape empty",
            DegenerateGroupWarning,
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
    outlier_unit: str = "rows",
) -> float:
    """Largest alpha whose shape is one piece containing every point.

    Parameters
    ----------
    points : array_like of shape (n, 2)
        Coordinates in a metric CRS (alpha comes in 1/unit of them).
    holes, components, search, max_iterations, outliers, outlier_unit
        As for :func:`alpha_shapes`.

    Returns
    -------
    float
        ``1 / r(t)`` for one Delaunay triangle ``t`` (or 0, the convex hull);
        ``nan`` with a :class:`DegenerateGroupWarning` if there is no shape.

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
    options = dict(holes=holes, components=components, search=search, outliers=outliers)
    res = _one_group(
        points, max_iterations=max_iterations, outlier_unit=outlier_unit, **options
    )
    return float(res.alpha[0])


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
    holes, components, search, outliers
        As for :func:`alpha_shapes` (``components`` and ``outliers`` apply to
        the optimum).

    Returns
    -------
    shapely.Polygon or shapely.MultiPolygon
        At the optimum, a valid (Multi)Polygon of at most ``components`` parts
        covering every input point; at a given alpha, a MultiPolygon where
        pieces separate, empty when nothing is solid (a near-duplicate merged
        into a point it covers is covered too, so the optimal alpha fed back
        gives the optimal shape).

    Examples
    --------
    >>> shape = alpha_shape([[0, 0], [4, 0], [4, 4], [0, 4], [2, 3.5]])
    >>> shape.geom_type, shape.area
    ('Polygon', 15.0)
    >>> alpha_shape([[0, 0], [4, 0], [4, 4], [0, 4], [2, 3.5]], alpha=0).area
    16.0
    """
    options = dict(holes=holes, components=components, search=search, outliers=outliers)
    return _one_group(points, alpha=alpha, **options).geometry[0]
