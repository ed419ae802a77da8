"""The k-nearest-neighbours concave hull of Moreira & Santos (2007), for comparison."""

from __future__ import annotations

import math
from numbers import Integral

import numpy as np
import shapely
from numpy.typing import ArrayLike
from scipy.spatial import cKDTree
from shapely.geometry.polygon import orient

from geoalpha.errors import InvalidInputError, first_n

__all__ = ["knn_hull"]


def knn_hull(
    points: ArrayLike, k: int = 3, *, max_k: int | None = None
) -> tuple[shapely.Polygon, int]:
    """Concave hull of points by the k-nearest-neighbours walk.

    From the lowest point, walk counter-clockwise, each step to the one of the
    ``k`` nearest unused points with the largest right-hand turn whose new edge
    touches no earlier edge; raise ``k`` until the ring is a valid polygon
    covering every point (the paper checks neither validity nor every point).

    Parameters
    ----------
    points : array_like of shape (n, 2)
        x, y coordinates in a metric (projected) CRS. Duplicates are ignored.
    k : int, default 3
        Number of nearest neighbours to start with: at least 3 (as in the
        paper), at most ``n - 1`` for ``n`` distinct points.
    max_k : int, optional
        Largest ``k`` to try, at least ``max(k, 3)``; default ``n - 1``.

    Returns
    -------
    polygon, k : shapely.Polygon, int
        Valid, counter-clockwise, covering every point, with input vertices; the
        ``k`` that gave it, ``n`` if every ``k`` failed (the convex hull).

    Raises
    ------
    InvalidInputError
        On a bad ``points``, ``k`` or ``max_k``, or < 3 distinct or collinear points.

    References
    ----------
    .. [1] A. Moreira and M. Y. Santos, "Concave hull: a k-nearest neighbours
       approach for the computation of the region occupied by a set of
       points", GRAPP 2007, pp. 61-68.

    Examples
    --------
    An L-shaped grid of points gets an L-shaped hull, not the convex hull:

    >>> xy = np.array([(x, y) for x in range(5) for y in range(5)
    ...                if x <= 1 or y <= 1], dtype=float)
    >>> poly, k = knn_hull(xy)
    >>> poly.area, poly.convex_hull.area, k
    (8.0, 11.5, 3)
    >>> knn_hull([(0, 0), (1, 1), (2, 2)])
    Traceback (most recent call last):
    ...
    geoalpha.errors.InvalidInputError: knn_hull() needs points that are not all collinear; got 3 distinct collinear points
    """  # noqa: E501
    pts = _as_points(points)
    k_start = _first_k(k, max_k)
    n = len(pts)
    if n < 3:
        raise InvalidInputError(f"knn_hull() needs at least 3 distinct points; got {n}")
    convex = shapely.convex_hull(shapely.multipoints(pts))
    if not isinstance(convex, shapely.Polygon):
        raise InvalidInputError(
            "knn_hull() needs points that are not all collinear; "
            f"got {n} distinct collinear points"
        )
    start = int(np.lexsort((pts[:, 0], pts[:, 1]))[0])
    local = pts - pts[start]  # small numbers: better-conditioned orientations
    tree = cKDTree(local)
    geoms = shapely.points(pts)
    k_stop = n - 1 if max_k is None else min(max_k, n - 1)
    for kk in range(min(k_start, n - 1), k_stop + 1):
        ring = _walk(local, tree, start, kk)
        polygon = None if ring is None else shapely.Polygon(pts[ring])
        if polygon is not None and polygon.is_valid:
            shapely.prepare(polygon)
            if shapely.covers(polygon, geoms).all():
                return polygon, kk
    return orient(convex, sign=1.0), n


def _as_points(points: ArrayLike) -> np.ndarray:
    """Distinct finite points as a float (n, 2) array, or raise."""
    try:
        arr = np.asarray(points, dtype=float)
    except (TypeError, ValueError) as err:
        raise InvalidInputError(
            f"knn_hull() needs an (n, 2) array of x, y coordinates; got {err}"
        ) from err
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise InvalidInputError(
            "knn_hull() needs an (n, 2) array of x, y coordinates; "
            f"got an array of shape {arr.shape}"
        )
    bad = np.flatnonzero(~np.isfinite(arr).all(axis=1))
    if len(bad):
        raise InvalidInputError(
            "knn_hull() needs finite coordinates; got "
            f"{len(bad)} rows with NaN or infinity (index {first_n(bad, limit=5)})"
        )
    # + 0.0 turns -0.0 into 0.0 so that np.unique sees them as one point
    return np.unique(arr + 0.0, axis=0)


def _first_k(k: int, max_k: int | None) -> int:
    """Check ``k`` and ``max_k``; return the first k to try, max(k, 3)."""
    named = {"k": k} if max_k is None else {"k": k, "max_k": max_k}
    for name, value in named.items():
        if not isinstance(value, Integral) or isinstance(value, bool) or value < 1:
            raise InvalidInputError(
                f"knn_hull() needs {name} to be a positive integer; got {value!r}"
            )
    k_start = max(int(k), 3)
    if max_k is not None and max_k < k_start:
        raise InvalidInputError(
            f"knn_hull() needs max_k >= max(k, 3) = {k_start}; got max_k={max_k}"
        )
    return k_start


def _walk(local: np.ndarray, tree: cKDTree, start: int, k: int) -> np.ndarray | None:
    """Walk with ``k`` neighbours; return the ring's indices, or None if stuck."""
    n = len(local)
    used = np.zeros(n, dtype=bool)
    used[start] = True
    ring = np.empty(n, dtype=np.intp)
    ring[0] = start
    m = 1  # points on the ring, all used but the start once it may close it
    start_back = False
    ax, ay = local[start].tolist()
    dx, dy = 1.0, 0.0  # the direction of the last edge; the paper's angle 0
    while True:
        if not start_back and m in (4, n):
            used[start] = False
            start_back = True
        # one query: the nearest k unused points are among the k + (used)
        # nearest (at least 3 are asked for: arrays come back)
        _, near = tree.query((ax, ay), k=min(n, k + m - start_back))
        near = near[~used[near]][:k]
        ux = local[near, 0] - ax
        uy = local[near, 1] - ay
        # Straight back along the last edge would overlap it.
        keep = (dx * uy - dy * ux != 0) | (dx * ux + dy * uy > 0)
        near, ux, uy = near[keep], ux[keep], uy[keep]
        # Counter-clockwise angle from the way back, ascending: the largest
        # right-hand turn first; ties keep the nearer point first.
        angle = (np.arctan2(uy, ux) - math.atan2(-dy, -dx)) % (2.0 * np.pi)
        order = np.argsort(angle, kind="stable")
        near, ux, uy = near[order], ux[order], uy[order]
        free = _free(ax, ay, ux, uy, near == start, local[ring[:m]])
        if len(free) == 0:
            return None
        i = free[0]
        nxt = int(near[i])
        if nxt == start:
            return ring[:m]
        ring[m] = nxt
        m += 1
        used[nxt] = True
        dx, dy = float(ux[i]), float(uy[i])
        ax, ay = local[nxt].tolist()


def _free(
    ax: float,
    ay: float,
    ux: np.ndarray,
    uy: np.ndarray,
    closes: np.ndarray,
    ring: np.ndarray,
) -> np.ndarray:
    """Positions of the candidates whose new edge ``a -> a + u`` is free, in order.

    Free: touching no edge of ``ring`` (the hull so far, ending at ``a``) but
    the last, nor the first for the edge that ``closes`` the ring.
    """
    if len(ring) < 3:  # no edge but the last
        return np.arange(len(ux))
    p = ring[:-2]  # edges p -> p + e, all but the last
    ex = ring[1:-1, 0] - p[:, 0]
    ey = ring[1:-1, 1] - p[:, 1]
    px = p[:, 0] - ax
    py = p[:, 1] - ay
    # orientations of p, q against a -> b (d1, d2) and of a, b against p -> q
    # (d3, d4), with q = p + e and b = a + u; candidates (c, 1) x edges (e,)
    ux, uy = ux[:, None], uy[:, None]
    cross = ux * ey - uy * ex
    d1 = ux * py - uy * px
    d2 = d1 + cross
    d3 = ey * px - ex * py
    d4 = d3 - cross
    hit = (d1 * d2 <= 0) & (d3 * d4 <= 0)
    collinear = (d1 == 0) & (d2 == 0)
    if collinear.any():  # on one line: hit only if the segments overlap
        qx, qy = px + ex, py + ey
        apart = (
            (np.maximum(px, qx) < np.minimum(0.0, ux))
            | (np.minimum(px, qx) > np.maximum(0.0, ux))
            | (np.maximum(py, qy) < np.minimum(0.0, uy))
            | (np.minimum(py, qy) > np.maximum(0.0, uy))
        )
        hit &= ~(collinear & apart)
    shut = np.flatnonzero(closes)
    if len(shut):
        # The closing edge ends where the first edge starts: only an overlap,
        # the first edge's end on the closing edge's line on a's side, counts.
        i = shut[0]
        hit[i, 0] = cross[i, 0] == 0 and ex[0] * ux[i, 0] + ey[0] * uy[i, 0] < 0
    return np.flatnonzero(~hit.any(axis=1))
