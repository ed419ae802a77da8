"""The guarantee in the output coordinates: valid polygons covering their points.

Checked with ``shapely.covers`` (distance 0), repaired, or reported.
"""

from __future__ import annotations

import inspect
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import shapely

from geoalpha import _core as kernel

__all__ = [
    "EMPTY_POLYGON",
    "convex_hulls",
    "covered",
    "enforce",
    "left_outside",
    "repair_invalid",
]

#: The geometry of a group with no shape (a column of hulls keeps one type).
EMPTY_POLYGON = kernel.EMPTY_POLYGON
#: Whether ``shapely.make_valid`` takes ``method=`` (shapely >= 2.1; 2.0 is what
#: the QGIS plugin installs to match QGIS's GEOS 3.11).
_MAKE_VALID_METHOD = "method" in inspect.signature(shapely.make_valid).parameters
#: Points from which :func:`covered` spreads its tests over threads.
THREAD_POINTS = 100_000
#: Points outside a group's polygon taken in one at a time as vertices; the
#: rest of the group's are joined to it at once (:func:`_cover_points`).
TAKE_IN_POINTS = 64


def convex_hulls(out_xy: np.ndarray, codes: np.ndarray, n_groups: int) -> np.ndarray:
    """Convex hull of each group in ``out_xy``; an empty Polygon for one without points.

    Examples
    --------
    >>> xy = np.array([[0, 0], [2, 0], [0, 2], [1, 0.5], [5, 5]])
    >>> [g.area for g in convex_hulls(xy, np.array([0, 0, 0, 0, 1]), 2)]
    [2.0, 0.0]
    >>> [g.area for g in convex_hulls(xy[:4], np.array([2, 2, 2, 2]), 3)]
    [0.0, 0.0, 2.0]
    """
    hulls = np.full(n_groups, EMPTY_POLYGON, dtype=object)
    if len(codes) == 0:
        return hulls
    # Any subset of groups: multipoints wants indices 0 .. k-1, all present.
    present, index = np.unique(codes, return_inverse=True)
    order = np.argsort(index, kind="stable")
    hulls[present] = shapely.convex_hull(
        shapely.multipoints(out_xy[order], indices=index[order])
    )
    return hulls


def left_outside(flag, geoms, xy, codes) -> np.ndarray:
    """Of the points ``flag`` marks (left out, ``outliers=``), those still outside.

    Examples
    --------
    >>> square = np.array([shapely.box(0, 0, 1, 1)])
    >>> xy = np.array([[0.5, 0.5], [2.0, 2.0]])
    >>> left_outside(np.array([True, True]), square, xy, np.zeros(2, int)).tolist()
    [False, True]
    """
    if not flag.any():
        return flag
    out = flag.copy()
    out[flag] = ~covered(geoms, xy[flag], codes[flag])
    return out


def enforce(
    geoms,
    out_xy,
    codes,
    check,
    *,
    cover=True,
    components=None,
    test=None,
    exempt=None,
    n_jobs=1,
):
    """Verify the guarantee per group (:doc:`/user_guide/guarantee`); repair or report.

    Invalid geometries are repaired (:func:`repair_invalid`), points outside
    made vertices.

    Parameters
    ----------
    geoms, check : ndarray of shape (G,)
        Geometry of each group, and the groups to verify (bool).
    out_xy, codes : ndarray of shape (k, 2) and (k,)
        Points, in the geometries' coordinates, and the group of each.
    cover : bool or ndarray of bool, shape (G,), default True
        Whether every point must be covered, for all groups or per group
        (False: validity only, e.g. for a shape at a given alpha > 0).
    components : int or ndarray of float, shape (G,), optional
        Largest number of parts allowed.
    test : ndarray of bool, shape (k,), optional
        The points to test (default: all; always all of a repaired geometry).
    exempt : ndarray of bool, shape (k,), optional
        Points left out on purpose (``outliers=``): never tested or taken in.
    n_jobs : int or None, default 1
        Threads that test the points (:func:`covered`).

    Returns
    -------
    geoms, failed : ndarray of shape (G,)
        The geometries, repaired where needed; the groups of ``check`` that
        could not hold the guarantee (the caller declares them degenerate).

    Examples
    --------
    >>> bow = shapely.Polygon([(0, 0), (2, 2), (2, 0), (0, 2)])  # self-crossing
    >>> pts = np.array([[0, 0], [2, 2], [2, 0], [0, 2]])
    >>> codes, check = np.zeros(4, dtype=int), np.array([True])
    >>> fixed, failed = enforce(np.array([bow]), pts, codes, check)
    >>> bool(fixed[0].is_valid), failed.tolist()
    (True, [False])
    """
    geoms = geoms.copy()
    failed = np.zeros(len(geoms), dtype=bool)
    if not check.any():
        return geoms, failed
    sel = np.flatnonzero(check)
    repaired = np.zeros(len(geoms), dtype=bool)
    repaired[sel] = ~shapely.is_valid(geoms[sel])
    if repaired.any():
        try:
            geoms[repaired] = repair_invalid(geoms[repaired])
        except shapely.errors.GEOSException:  # pragma: no cover - defensive
            failed |= repaired
    covering = np.broadcast_to(np.asarray(cover, dtype=bool), (len(geoms),))
    needed = covering[codes] if exempt is None else covering[codes] & ~exempt
    mine = (check & ~failed)[codes] & needed
    if test is not None:
        mine &= (test | repaired[codes]) if repaired.any() else test
    outside = ~covered(
        geoms, np.compress(mine, out_xy, axis=0), codes[mine], n_jobs=n_jobs
    )
    repair = np.unique(codes[mine][outside])
    if len(repair):
        take = np.isin(codes, repair) & needed
        try:
            geoms = _cover_points(geoms, out_xy[take], codes[take])
        except shapely.errors.GEOSException:
            failed[repair] = True
        repaired[repair] = True
    # Whatever was repaired is verified again, from scratch.
    again = repaired & ~failed
    if again.any():
        g = geoms[again]
        bad = ~shapely.is_valid(g) | shapely.is_empty(g)
        bad |= ~np.isin(shapely.get_type_id(g), (3, 6))
        if components is not None:
            limit = components if np.ndim(components) == 0 else components[again]
            bad |= shapely.get_num_geometries(g) > limit
        failed[np.flatnonzero(again)[bad]] = True
        take = again[codes] & ~failed[codes] & needed
        miss = ~covered(geoms, np.compress(take, out_xy, axis=0), codes[take])
        failed[codes[take][miss]] = True
    # An empty optimum covers nothing.
    failed[sel[covering[sel] & shapely.is_empty(geoms[sel])]] = True
    geoms[failed] = EMPTY_POLYGON
    return geoms, failed


def _cover_points(geoms, out_xy, codes) -> np.ndarray:
    """Grow each group's geometry to take in its points outside.

    At most :data:`TAKE_IN_POINTS` points of a group one at a time as vertices
    (:func:`_take_in`: each rebuilds the part's rings); the rest of a group
    at once (:func:`_take_in_all`), so the time is linear in the points
    outside, never their number times the ring's size (issue #37).
    """
    geoms = geoms.copy()
    outside = ~covered(geoms, out_xy, codes) & ~shapely.is_empty(geoms[codes])
    order = np.argsort(codes[outside], kind="stable")
    xy, which = out_xy[outside][order], codes[outside][order]
    groups, starts = np.unique(which, return_index=True)
    ends = np.append(starts[1:], len(which))[: len(groups)]
    for g, a, b in zip(groups, starts, ends, strict=True):
        poly = geoms[g]
        try:
            for p in shapely.points(xy[a : min(b, a + TAKE_IN_POINTS)]):
                if not poly.covers(p):
                    poly = _take_in(poly, p)
            if b - a > TAKE_IN_POINTS:
                poly = _take_in_all(poly, xy[a + TAKE_IN_POINTS : b])
        except (shapely.errors.GEOSException, ValueError):
            continue  # left as it was: the caller's coverage check fails it
        geoms[g] = poly
    return geoms


def _take_in_all(poly, xy):
    """Join the points of ``xy`` outside ``poly`` to it by thin strips, in one union.

    Each point's shortest line to the polygon, widened by
    :data:`~geoalpha._core.REPAIR_RTOL` of the extent: O(k log k) for k points.
    """
    points = shapely.points(xy)
    points = points[~shapely.covers(poly, points)]
    if len(points) == 0:
        return poly
    lines = shapely.shortest_line(poly, points)
    coords = np.r_[shapely.get_coordinates(poly), xy]
    extent = max(np.ptp(coords, axis=0).max(), np.abs(coords).max(), 1.0)
    strips = shapely.buffer(lines, kernel.REPAIR_RTOL * extent)
    grown = shapely.union_all(np.r_[[poly], strips])
    return _polygonal(np.array([grown], dtype=object))[0]


def covered(
    geoms: np.ndarray, xy: np.ndarray, codes: np.ndarray, n_jobs: int | None = 1
) -> np.ndarray:
    """Whether each point is covered by its group's geometry (distance 0).

    ``shapely.covers`` as :func:`shapely.intersects_xy` (the same predicate for a
    point) on geometries prepared here, in place, without building Points.

    Parameters
    ----------
    geoms, xy, codes : ndarray of shape (G,), (k, 2), (k,)
        Geometry of each group; points in its coordinates; group of each.
    n_jobs : int or None, default 1
        Threads (None or -1: every core), from :data:`THREAD_POINTS` points on.

    Returns
    -------
    ndarray of bool, shape (k,)

    Examples
    --------
    >>> square = np.array([shapely.box(0, 0, 1, 1)])
    >>> covered(square, np.array([[1.0, 0.5], [0.5, 0.5], [2, 2]]), np.zeros(3, int))
    array([ True,  True, False])
    """
    if len(xy) == 0:
        return np.ones(0, dtype=bool)
    shapely.prepare(geoms)
    if len(xy) < THREAD_POINTS:
        return shapely.intersects_xy(geoms[codes], xy[:, 0], xy[:, 1])
    # Many points: tested group by group (each prepared polygon stays in
    # cache), on threads that each take their own groups.
    keys = codes.astype(np.uint16) if len(geoms) <= 1 << 16 else codes
    order = np.argsort(keys, kind="stable")  # (radix sort for 16-bit keys)
    sc, sxy = codes[order], np.take(xy, order, axis=0)
    workers = max(1, min(kernel.threads(n_jobs), len(xy) // THREAD_POINTS))
    cuts = np.searchsorted(sc, np.arange(workers + 1) * len(geoms) // workers)
    out = np.empty(len(xy), dtype=bool)

    def test(k: int) -> None:
        a, b = cuts[k], cuts[k + 1]
        out[order[a:b]] = shapely.intersects_xy(
            geoms[sc[a:b]], sxy[a:b, 0], sxy[a:b, 1]
        )

    with ThreadPoolExecutor(workers) as pool:
        list(pool.map(test, range(workers)))
    return out


def _take_in(poly, p):
    """Make ``p`` a vertex of a nearest ring edge of ``poly``, else add its ear."""
    parts = list(shapely.get_parts(poly))
    i = int(np.argmin(shapely.distance(parts, p)))
    part = parts[i]
    rings = [shapely.get_coordinates(r) for r in (part.exterior, *part.interiors)]
    which = np.concatenate([np.full(len(r) - 1, k) for k, r in enumerate(rings)])
    at = np.concatenate([np.arange(len(r) - 1) for r in rings])
    starts = np.concatenate([r[:-1] for r in rings])
    ends = np.concatenate([r[1:] for r in rings])
    segments = shapely.linestrings(np.stack([starts, ends], axis=1))
    nearest = np.argsort(shapely.distance(segments, p), kind="stable")
    for e in nearest[:8]:
        changed = list(rings)
        changed[which[e]] = np.insert(rings[which[e]], at[e] + 1, [p.x, p.y], axis=0)
        grown = shapely.Polygon(changed[0], changed[1:])
        if grown.is_valid and grown.covers(p):
            break
    else:  # fall back to adding the ear's outline, slightly widened
        e = nearest[0]
        ear = shapely.linestrings([starts[e], (p.x, p.y), ends[e]])
        extent = max(np.ptp(rings[0], axis=0).max(), abs(p.x), abs(p.y), 1.0)
        width = kernel.REPAIR_RTOL * extent
        grown = shapely.union(part, shapely.buffer(ear, width))
        grown = _polygonal(np.array([grown], dtype=object))[0]
    parts[i] = grown
    if len(parts) == 1:
        return parts[0]
    return shapely.multipolygons(shapely.get_parts(np.array(parts, dtype=object)))


def repair_invalid(geoms: np.ndarray) -> np.ndarray:
    """Make invalid geometries valid and keep their polygonal parts.

    ``make_valid(method="structure")`` on shapely 2.1+, "linework" on 2.0
    (parts may differ where a ring overlaps itself; callers check again).

    Examples
    --------
    >>> bow = shapely.Polygon([(0, 0), (2, 2), (2, 0), (0, 2)])  # self-crossing
    >>> fixed = repair_invalid(np.array([bow]))[0]
    >>> bool(fixed.is_valid), fixed.geom_type, float(fixed.area)
    (True, 'MultiPolygon', 2.0)
    """
    method = {"method": "structure"} if _MAKE_VALID_METHOD else {}
    return _polygonal(shapely.make_valid(geoms, **method))


def _polygonal(geoms: np.ndarray) -> np.ndarray:
    """Keep the polygonal parts (area > 0) of geometries, not collapsed lines."""
    parts, which = shapely.get_parts(geoms, return_index=True)
    keep = (shapely.get_type_id(parts) == 3) & (shapely.area(parts) > 0)
    out = geoms.copy()
    for g in np.unique(which):
        mine = parts[(which == g) & keep]
        if len(mine) == 1:
            out[g] = mine[0]
        elif len(mine) > 1:
            out[g] = shapely.multipolygons(mine)
        else:
            out[g] = EMPTY_POLYGON
    return out
