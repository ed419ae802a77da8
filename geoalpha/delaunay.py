"""Delaunay triangulations of many groups in one GEOS call, as index arrays.

:func:`triangulate_groups` hands every group to
:func:`shapely.delaunay_triangles` at once (GEOS loops over the groups in C)
and turns its polygons back into what :func:`geoalpha.core.triangulate`
works on: for every triangle its three point indices (counter-clockwise) and
the triangle across each edge, with no Python loop per triangle or per group.

How the indices come back without a join on coordinates: each group goes to
GEOS as one LineString of its points whose *z* is the point's index. GEOS
keeps the *z* of the coordinates it triangulates, so the corners of its
triangles carry their point indices. Exact duplicates are triangulated once
(GEOS keeps one of them); the points GEOS leaves out are matched to a vertex
with the same coordinates.

GEOS works in floating point with robust predicates, and on some
near-degenerate input its output is not a triangulation of the group's
distinct points. Every group is checked (all points present, positive
areas, each edge in at most two triangles and in opposite directions,
Euler's formula ``T = 2V - 2 - H`` for ``V`` vertices and ``H`` hull edges,
a convex boundary), and a group that fails is reported in ``failed``, for
the caller to triangulate in another way (``core`` uses Qhull). What GEOS
does on the inputs where that matters (measured with GEOS 3.14 on thousands
of generated groups, compared with Qhull):

* exact duplicates: triangulated once, never an error;
* collinear points: an empty result (a failed group);
* nearly collinear points: thin sliver triangles, also where Qhull calls the
  points collinear (three points 1e-12 of the extent off a line). Groups
  flatter than :data:`FLAT_RTOL` fail, so Qhull decides them as before;
* near-duplicates: kept as separate vertices down to the last bit, with
  needle triangles. Below ~1e-14 of the extent the float64 steps after the
  triangulation (rings, polygons) break on them, and Qhull merges such
  points anyway: groups with vertices closer than :data:`NEEDLE_RTOL` fail;
* cocircular points (grids, lattice points on a circle): one of the equally
  valid diagonals, the same radii as Qhull's;
* a ``GEOSException`` fails only its group: a batch that raises is split in
  halves until the failing groups are alone (never seen in these tests).

On every group of the bundled real datasets GEOS passes the checks and its
triangles have Qhull's circumradii.

This module may import shapely; :mod:`geoalpha.core` does not (it imports
this module when it triangulates).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import shapely

from geoalpha.core import hash64, radix_argsort

__all__ = ["GroupTriangles", "each_or_none", "triangulate_groups"]

#: Groups per GEOS call when progress is reported.
PROGRESS_GROUPS = 256

#: A group whose triangles' total area is at most this times the squared
#: diagonal of its bounding box is nearly collinear (a strip narrower than
#: about 2e-9 of its length): it goes to Qhull, which either triangulates it
#: or calls it collinear.
FLAT_RTOL = 1e-9

#: A group with two vertices closer than this times its bounding box's
#: diagonal goes to Qhull, which merges points about that close (GEOS keeps
#: them, and the needle triangles between them are below what the float64
#: steps after the triangulation resolve).
NEEDLE_RTOL = 1e-12

#: Relative tolerance of the convex-boundary check: a turn to the right by
#: less than this times the product of the two edge lengths passes (float
#: rounding of nearly collinear hull points).
TURN_RTOL = 1e-12


class GroupTriangles(NamedTuple):
    """Triangles of many groups, as :func:`triangulate_groups` returns them.

    Attributes
    ----------
    triangles : ndarray of shape (m, 3)
        Point indices of every triangle, counter-clockwise; the triangles of
        each group are contiguous, groups in the order given.
    neighbors : ndarray of shape (m, 3)
        ``neighbors[t, j]``: the triangle across the edge opposite vertex
        ``j`` of ``t`` (an index into ``triangles``), -1 on the convex hull.
    n_triangles : ndarray of shape (k,)
        Triangles of each group given (0 where it failed).
    vertex : ndarray of shape (p,)
        The point that represents each point in the triangulation: itself,
        or a point with the same coordinates (a duplicate).
    failed : ndarray of bool, shape (k,)
        Groups whose GEOS output is not a triangulation of their distinct
        points (for example collinear ones); they have no triangles here.
    """

    triangles: np.ndarray
    neighbors: np.ndarray
    n_triangles: np.ndarray
    vertex: np.ndarray
    failed: np.ndarray


def triangulate_groups(local, point_ptr, groups, progress=None) -> GroupTriangles:
    """Delaunay-triangulate the given groups with GEOS, all in one call.

    Parameters
    ----------
    local : ndarray of shape (p, 2)
        Points sorted by group, in coordinates relative to a point of their
        group (small numbers: GEOS then works at full precision).
    point_ptr : ndarray of shape (G + 1,)
        Points of group ``g`` are ``local[point_ptr[g]:point_ptr[g + 1]]``.
    groups : ndarray of int, shape (k,)
        Groups to triangulate, increasing, each with at least 3 points.
    progress : object with an ``update(n)`` method, optional
        Told how many groups were triangulated, every
        :data:`PROGRESS_GROUPS` groups.

    Returns
    -------
    GroupTriangles

    Examples
    --------
    >>> local = np.array([[0.0, 0], [1, 0], [0, 1], [1, 1], [1, 1],
    ...                   [0, 0], [1, 0], [2, 0]])
    >>> out = triangulate_groups(local, np.array([0, 5, 8]), np.array([0, 1]))
    >>> out.n_triangles.tolist(), out.failed.tolist()
    ([2, 0], [False, True])
    >>> out.vertex[4] in (3, 4), len(out.triangles)
    (True, 2)
    """
    local = np.asarray(local, dtype=float)
    groups = np.asarray(groups, dtype=np.int64)
    p, k = len(local), len(groups)
    vertex = np.arange(p)
    empty = np.empty((0, 3), dtype=np.int64)
    if k == 0:
        return GroupTriangles(
            empty, empty, np.zeros(0, np.int64), vertex, np.zeros(0, bool)
        )

    # One LineString per group, z = point index.
    start, stop = point_ptr[groups], point_ptr[groups + 1]
    size = stop - start
    offsets = np.zeros(k + 1, dtype=np.int64)
    np.cumsum(size, out=offsets[1:])
    if offsets[-1] == p and start[0] == 0:  # the groups are all the points
        rows = np.arange(p)
    else:
        rows = np.repeat(start - offsets[:-1], size) + np.arange(offsets[-1])
    xyz = np.empty((len(rows), 3))
    xyz[:, :2] = np.take(local, rows, axis=0)  # ~10x faster than local[rows]
    xyz[:, 2] = rows
    lines = shapely.from_ragged_array(shapely.GeometryType.LINESTRING, xyz, (offsets,))
    if progress is None:
        collections = each_or_none(shapely.delaunay_triangles, lines)
    else:
        collections = np.empty(k, dtype=object)
        for s in range(0, k, PROGRESS_GROUPS):
            collections[s : s + PROGRESS_GROUPS] = each_or_none(
                shapely.delaunay_triangles, lines[s : s + PROGRESS_GROUPS]
            )
            progress.update(min(PROGRESS_GROUPS, k - s))

    failed = shapely.is_missing(collections)  # GEOS raised
    n_tri = shapely.get_num_geometries(collections).astype(np.int64)
    corners = shapely.get_coordinates(collections, include_z=True)
    # Each triangle is a closed ring of 4 corners, z the point index.
    z = np.ascontiguousarray(corners[:, 2]).reshape(-1, 4)[:, :3]
    tri_gi = np.repeat(np.arange(k), n_tri)  # triangle -> position in groups
    point_gi = np.repeat(np.arange(k), size)  # row -> position in groups
    if len(z) and not (z.min() >= 0 and z.max() < p):  # z lost: all to Qhull
        failed[:] = True
        return GroupTriangles(empty, empty, np.zeros(k, np.int64), vertex, failed)
    tri = z.astype(np.int64)

    # Positive areas (GEOS emits counter-clockwise triangles); corners that
    # are the points their z names (GEOS copies coordinates); no needles
    # (two vertices closer than NEEDLE_RTOL of the extent) and not nearly
    # flat as a whole: such groups are Qhull's to triangulate or to call
    # collinear, as before.
    area2, shortest2, same = _check_corners(local, tri, corners)
    lo = np.minimum.reduceat(xyz[:, :2], offsets[:-1], axis=0)
    hi = np.maximum.reduceat(xyz[:, :2], offsets[:-1], axis=0)
    diagonal2 = np.square(hi - lo).sum(axis=1)
    bad = ~(area2 > 0) | ~same | (shortest2 < NEEDLE_RTOL**2 * diagonal2[tri_gi])
    failed[tri_gi[bad]] = True
    failed |= np.bincount(tri_gi, weights=area2, minlength=k) <= FLAT_RTOL * diagonal2

    # Points GEOS left out: exact duplicates of a vertex, or a failure.
    used = np.zeros(p, dtype=bool)
    used[tri.ravel()] = True
    used_row = used[rows]
    if not used_row.all():
        twin = _twins(local, rows, point_gi, used_row)
        lost = ~used_row
        lost[lost] = twin < 0
        failed[point_gi[lost]] = True
        missing = rows[~used_row]
        vertex[missing] = np.where(twin >= 0, twin, missing)

    neighbors, hull_edges = _neighbors(tri, p, int(size.max()), tri_gi, failed)

    # Euler's formula for a triangulated disk: T = 2V - 2 - H.
    n_vertex = np.bincount(point_gi, weights=used_row, minlength=k).astype(np.int64)
    n_hull = np.bincount(tri_gi[hull_edges[:, 0]], minlength=k)
    failed |= n_tri != 2 * n_vertex - 2 - n_hull
    failed |= _bad_boundary(local, tri, hull_edges, tri_gi, k)

    if failed.any():
        keep = ~failed[tri_gi]
        new = np.cumsum(keep) - 1
        tri = np.compress(keep, tri, axis=0)
        nb = np.compress(keep, neighbors, axis=0)
        neighbors = np.where(nb >= 0, new[np.maximum(nb, 0)], -1)
        n_tri[failed] = 0
        vertex[rows[failed[point_gi]]] = rows[failed[point_gi]]
    return GroupTriangles(tri, neighbors, n_tri, vertex, failed)


def each_or_none(func, geoms: np.ndarray, **kwargs) -> np.ndarray:
    """Apply a vectorised shapely ``func``; None where GEOS raises.

    A batch that raises is split in halves until the failing geometries are
    alone (``O(f log k)`` calls for ``f`` failures among ``k``), so one bad
    geometry does not lose the batch.

    Examples
    --------
    >>> def fussy(g):  # raises for any batch that holds an empty geometry
    ...     if shapely.is_empty(g).any():
    ...         raise shapely.errors.GEOSException("empty")
    ...     return shapely.area(g)
    >>> each_or_none(fussy, np.array([shapely.box(0, 0, 1, 1), shapely.Polygon()]))
    array([1.0, None], dtype=object)
    """
    try:
        return func(geoms, **kwargs)
    except shapely.errors.GEOSException:
        if len(geoms) == 1:
            return np.array([None], dtype=object)
    half = len(geoms) // 2
    out = np.empty(len(geoms), dtype=object)
    out[:half] = each_or_none(func, geoms[:half], **kwargs)
    out[half:] = each_or_none(func, geoms[half:], **kwargs)
    return out


def _check_corners(xy, tri, corners):
    """Twice the signed area, the shortest squared edge and the corner check.

    The area is the cross product at the vertex opposite the longest edge,
    the best conditioned of the three (as in :mod:`geoalpha.core`). The
    check: whether the triangle's corners in GEOS's output (``corners``,
    4 per triangle) are the points of ``xy`` its indices name.
    """
    x, y = xy[:, 0], xy[:, 1]
    cx = corners[:, 0].reshape(-1, 4)
    cy = corners[:, 1].reshape(-1, 4)
    px = [x[tri[:, j]] for j in range(3)]
    py = [y[tri[:, j]] for j in range(3)]
    same = (px[0] == cx[:, 0]) & (px[1] == cx[:, 1]) & (px[2] == cx[:, 2])
    same &= py[0] == cy[:, 0]
    dx = [px[(j + 1) % 3] - px[j] for j in range(3)]
    dy = [py[(j + 1) % 3] - py[j] for j in range(3)]
    e2 = [dx[j] * dx[j] + dy[j] * dy[j] for j in range(3)]

    def cross_at(j):  # between edge j (out of vertex j) and edge j-1 reversed
        return dy[j] * dx[j - 1] - dx[j] * dy[j - 1]

    first = (e2[0] >= e2[1]) & (e2[0] >= e2[2])
    second = ~first & (e2[1] >= e2[2])
    cross = np.where(first, cross_at(2), np.where(second, cross_at(0), cross_at(1)))
    return cross, np.minimum(np.minimum(e2[0], e2[1]), e2[2]), same


def _twins(local, rows, point_gi, used_row) -> np.ndarray:
    """For each point GEOS left out, a vertex of its group at the same place.

    Returns one point index per row with ``used_row`` False, -1 where there
    is none. Only the groups with such points are sorted, by a 47-bit hash
    of (group, x, y) with the left-out points after the vertices of equal
    hash (one radix sort instead of a four-key lexsort): equal points are
    then next to each other. Each pair found is compared exactly, so a hash
    collision can only leave a point without a twin (its group then fails,
    and is triangulated again by Qhull), never pair different points.
    """
    mine = ~used_row
    has_missing = np.zeros(point_gi[-1] + 1, dtype=bool)
    has_missing[point_gi[mine]] = True
    take = np.flatnonzero(has_missing[point_gi])
    pts, gi, is_missing = rows[take], point_gi[take], mine[take]
    x = np.take(local[:, 0], pts) + 0.0  # -0.0 -> 0.0: equal values, equal bits
    y = np.take(local[:, 1], pts) + 0.0
    key = hash64(x.view(np.uint64), y.view(np.uint64), gi.astype(np.uint64))
    # 47 bits of hash and the left-out bit: three 16-bit radix passes.
    key = (key >> np.uint64(17) << np.uint64(1)) | is_missing.astype(np.uint64)
    order = radix_argsort(key, 48)
    last_used = np.where(is_missing[order], -1, np.arange(len(order)))
    np.maximum.accumulate(last_used, out=last_used)
    where = np.flatnonzero(is_missing[order])
    before = order[np.maximum(last_used[where], 0)]
    me = order[where]
    ok = (last_used[where] >= 0) & (gi[before] == gi[me])
    ok &= (x[before] == x[me]) & (y[before] == y[me])
    twin = np.full(len(take), -1, dtype=np.int64)
    twin[me] = np.where(ok, pts[before], -1)
    return twin[is_missing]


def _neighbors(tri, p, max_size, tri_gi, failed):
    """Triangle across each edge, by sorting the edges.

    Every edge is keyed by its two point indices (smaller first); sorted,
    the two triangles of an inner edge are neighbours in the order, and an
    edge alone is on the hull. An edge in three or more triangles, or in two
    in the same direction (overlapping triangles), marks its group in
    ``failed``. Returns the neighbour array and the hull edges as
    ``(triangle, j)`` pairs, ``j`` the vertex opposite the edge.
    """
    m = len(tri)
    neighbors = np.full(3 * m, -1, dtype=np.int64)
    if m == 0:
        return neighbors.reshape(0, 3), np.empty((0, 2), dtype=np.int64)
    # Slot c = 3 t + j of neighbors is the edge opposite vertex j: from
    # vertex j + 1 to vertex j + 2.
    a = np.empty_like(tri)
    b = np.empty_like(tri)
    a[:, 0], a[:, 1], a[:, 2] = tri[:, 1], tri[:, 2], tri[:, 0]
    b[:, 0], b[:, 1], b[:, 2] = tri[:, 2], tri[:, 0], tri[:, 1]
    a, b = a.ravel(), b.ravel()
    lo = np.minimum(a, b)
    # Both ends are in one group, so (lo, hi - lo) is unique per edge and
    # small: a radix sort orders it. The last bit is the direction.
    key = (lo * max_size + (np.maximum(a, b) - lo)) * 2 + (a > b)
    order = radix_argsort(key, (2 * p * max_size).bit_length())
    sk = key[order]
    pair = np.flatnonzero((sk[1:] >> 1) == (sk[:-1] >> 1))
    c1, c2 = order[pair], order[pair + 1]
    # Three or more in a row, or two in the same direction: not a
    # triangulation.
    wrong = np.zeros(len(pair), dtype=bool)
    wrong[1:] = pair[1:] == pair[:-1] + 1
    wrong[:-1] |= wrong[1:]
    wrong |= (sk[pair] & 1) == (sk[pair + 1] & 1)
    failed[tri_gi[c1[wrong] // 3]] = True
    neighbors[c1] = c2 // 3
    neighbors[c2] = c1 // 3
    alone = np.ones(len(order), dtype=bool)
    alone[pair] = False
    alone[pair + 1] = False
    hull = order[alone]
    return neighbors.reshape(m, 3), np.column_stack([hull // 3, hull % 3])


def _bad_boundary(local, tri, hull_edges, tri_gi, k) -> np.ndarray:
    """Flag the groups whose hull edges are not convex counter-clockwise cycles."""
    bad = np.zeros(k, dtype=bool)
    if len(hull_edges) == 0:
        return bad
    t, j = hull_edges[:, 0], hull_edges[:, 1]
    flat = tri.ravel()
    u = flat[3 * t + (j + 1) % 3]
    v = flat[3 * t + (j + 2) % 3]
    gi = tri_gi[t]
    # Each hull vertex starts exactly one hull edge and ends one.
    p = len(local)
    out_deg = np.bincount(u, minlength=p)
    in_deg = np.bincount(v, minlength=p)
    simple = (out_deg[u] == 1) & (in_deg[u] == 1) & (out_deg[v] == 1)
    bad[gi[~simple]] = True
    nxt = np.full(p, -1, dtype=np.int64)
    nxt[u] = v
    w = nxt[v]
    ok = w >= 0
    lv = np.take(local, v, axis=0)
    d1 = lv - np.take(local, u, axis=0)
    d2 = np.take(local, np.maximum(w, 0), axis=0) - lv
    turn = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    scale = np.hypot(d1[:, 0], d1[:, 1]) * np.hypot(d2[:, 0], d2[:, 1])
    ok &= turn >= -TURN_RTOL * scale
    bad[gi[~ok]] = True
    return bad
