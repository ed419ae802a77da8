"""``overlap="split"``: the hulls of neighbouring groups made interior-disjoint.

Wherever two groups' polygons overlap (their interiors meet), each part of the
overlap goes to the group of the nearest input point: the Voronoi cells of the
two groups' points there (GEOS), restricted to the overlap. Every point stays
covered by its own group's polygon and is strictly inside no other
(:doc:`/user_guide/neighbours`).
"""

from __future__ import annotations

import itertools
import warnings
from concurrent.futures import ThreadPoolExecutor
from typing import NamedTuple

import numpy as np
import shapely
from scipy.spatial import cKDTree

from geoalpha import _core as kernel
from geoalpha import _kernel
from geoalpha._arrays.area import layout
from geoalpha._arrays.guarantee import EMPTY_POLYGON, covered, enforce

__all__ = ["Split", "overlapping_pairs", "split_overlaps"]

#: Split in the kernel (``src/split.rs``) first; False: every pair by GEOS
#: (the tests run both).
COMPILED = True
#: Relative slack on the radius within which points may be nearest to an overlap.
_SLACK = 1e-9
#: Largest radius (of the polygon's extent) of a disc :func:`_carve` cuts out.
_CARVE_RTOL = 1e-9
#: Items (pairs, groups) from which :func:`_map` spreads them over threads.
_THREAD_ITEMS = 8
#: Cells per side of the grid that bounds the distance to the nearest point.
_GRID = 16
#: Grid of the last resort of :func:`_overlay`, relative to the coordinates.
_GRID_RTOL = 1e-12
#: Parts a split leaves that are smaller than this share of the group's polygon
#: are float noise of the overlay, not territory (a point of the group left
#: outside by dropping one is taken back in by the guarantee's check).
_CRUMB_RTOL = 1e-12


class Split(NamedTuple):
    """Result of :func:`split_overlaps`, one entry a group (``shared``: locations)."""

    geometry: np.ndarray  #: the polygons, split where they overlapped
    changed: np.ndarray  #: bool: the group ceded or lost area
    neighbours: np.ndarray  #: groups whose polygon shares a boundary line with it
    shared: np.ndarray  #: (m, 2) locations in an overlap holding points of 2 groups
    shared_groups: np.ndarray  #: (m, 2) the two groups of each shared location
    failed: np.ndarray  #: bool: split polygon failed the guarantee, kept unsplit
    #: (p, 2) pairs of groups whose split polygons still overlap (beyond float
    #: noise: 1e-9 of the larger's area), found by checking every split pair
    still: np.ndarray = np.zeros((0, 2), dtype=np.int64)


def overlapping_pairs(geoms: np.ndarray) -> np.ndarray:
    """Return the pairs ``(i, j)``, ``i < j``, of geometries whose interiors meet.

    One STRtree query finds the candidates; ``relate`` keeps those whose interiors
    intersect (an overlap with area), not those that only touch.

    Parameters
    ----------
    geoms : ndarray of shapely geometries, shape (G,)

    Returns
    -------
    ndarray of int, shape (p, 2)

    Examples
    --------
    >>> a, b = shapely.box(0, 0, 2, 2), shapely.box(1, 1, 3, 3)
    >>> overlapping_pairs(np.array([a, b, shapely.box(3, 0, 4, 1)])).tolist()
    [[0, 1]]
    """
    touching = _intersecting(np.asarray(geoms, dtype=object))
    return touching[_inner(geoms, touching)]


def _intersecting(geoms: np.ndarray) -> np.ndarray:
    """Return the pairs ``(i, j)``, ``i < j``, of non-empty geometries that meet."""
    usable = ~(shapely.is_missing(geoms) | shapely.is_empty(geoms))
    index = np.flatnonzero(usable)
    if len(index) < 2:
        return np.zeros((0, 2), dtype=np.int64)
    tree = shapely.STRtree(geoms[index])
    left, right = tree.query(geoms[index], predicate="intersects")
    upper = left < right
    return np.stack([index[left[upper]], index[right[upper]]], axis=1).astype(np.int64)


def _inner(geoms: np.ndarray, pairs: np.ndarray) -> np.ndarray:
    """Whether the interiors of each pair's geometries intersect."""
    if not len(pairs):
        return np.zeros(0, dtype=bool)
    return shapely.relate_pattern(geoms[pairs[:, 0]], geoms[pairs[:, 1]], "T********")


def split_overlaps(
    geoms: np.ndarray,
    xy: np.ndarray,
    codes: np.ndarray,
    *,
    check: np.ndarray | None = None,
    known: np.ndarray | None = None,
    n_jobs: int | None = 1,
) -> Split:
    """Give each part of every overlap to the group of the nearest input point.

    Parameters
    ----------
    geoms : ndarray of shapely (Multi)Polygons, shape (G,)
        One polygon per group (empty for none), in the coordinates of ``xy``.
    xy, codes : ndarray of shape (k, 2) and (k,)
        The input points and the group of each. Only the points their own
        group's polygon covers take part (rows left out by ``outliers=`` do not).
    check : ndarray of bool, shape (G,), optional
        The groups that take part (default: every non-empty polygon).
    known : ndarray of bool, shape (k,), optional
        Points already known to be covered by their group's polygon (the
        pipeline's guarantee has checked them); only the others are tested
        (default: every point of a group that overlaps another is tested).
    n_jobs : int or None, default 1
        Threads of the point tests, and of the pairs' splits and the groups'
        cuts from 16 of them (None or -1: every core); the result is the same.

    Returns
    -------
    Split
        A group whose hull overlapped none is returned as the very same object.
        A location holding points of both groups of an overlap becomes a
        boundary vertex of both: its Voronoi cell is halved by a line through
        it, each half going to the group on its side (``shared`` lists them).

    Examples
    --------
    >>> xy = np.array([[0, 0], [2, 0], [2, 2], [0, 2], [1, 0], [3, 0], [3, 2], [1, 2]])
    >>> codes = np.array([0, 0, 0, 0, 1, 1, 1, 1])
    >>> hulls = np.array([shapely.box(0, 0, 2, 2), shapely.box(1, 0, 3, 2)])
    >>> out = split_overlaps(hulls, xy.astype(float), codes)
    >>> [round(g.area, 6) for g in out.geometry], out.neighbours.tolist()
    ([3.0, 3.0], [1, 1])
    """
    geoms = np.asarray(geoms, dtype=object)
    n = len(geoms)
    usable = ~(shapely.is_missing(geoms) | shapely.is_empty(geoms))
    if check is not None:
        usable &= check
    touching = _intersecting(np.where(usable, geoms, None))  # one STRtree query
    inner = _inner(geoms, touching)
    pairs = touching[inner]
    none = np.zeros(n, dtype=bool)
    if not len(pairs):
        return Split(
            geoms,
            none,
            _neighbours(geoms, touching),
            np.zeros((0, 2)),
            np.zeros((0, 2), dtype=np.int64),
            none,
        )
    involved = np.zeros(n, dtype=bool)
    involved[pairs.ravel()] = True
    at = np.flatnonzero(involved[codes])  # the points of groups that overlap
    own = np.zeros(len(codes), dtype=bool)
    if known is not None:
        own[at] = known[at]
        at = at[~own[at]]  # only those not known yet are tested
    own[at] = covered(geoms, xy[at], codes[at], n_jobs=n_jobs)
    take = np.flatnonzero(own)
    order = take[np.argsort(codes[take], kind="stable")]
    starts = np.searchsorted(codes[order], np.arange(n + 1))
    out = geoms.copy()
    done = np.zeros(n, dtype=bool)
    if COMPILED:
        out, done = _split_compiled(geoms, xy, order, starts, pairs, n_jobs)
    rest = pairs[~done[pairs[:, 0]]]  # (a component is done whole or not at all)
    failed = np.zeros(n, dtype=bool)
    still = np.zeros((0, 2), dtype=np.int64)
    shared = np.zeros((0, 2))
    shared_groups = np.zeros((0, 2), dtype=np.int64)
    if len(rest):
        geos = _split_geos(geoms, xy, codes, own, order, starts, rest, n_jobs)
        out = np.where(done, out, geos.geometry)
        failed, still = geos.failed, geos.still
        shared, shared_groups = geos.shared, geos.shared_groups
    return Split(
        out,
        involved & ~failed,
        _neighbours(out, touching, np.where(failed[touching].any(axis=1), False, inner))
        if len(touching)
        else np.zeros(n, dtype=np.int64),
        shared,
        shared_groups,
        failed,
        still,
    )


def _split_compiled(geoms, xy, order, starts, pairs, n_jobs):
    """Split the overlaps of ``pairs`` in the kernel; return the polygons, done.

    One constrained triangulation per component of overlapping groups
    (``src/split.rs``): every triangle goes to the group of the nearest point
    among those whose polygons hold it, and each group's polygon is traced
    from its triangles, so the split polygons are interior-disjoint by
    construction, with the same vertices where they meet. The kernel checks
    the points where polygons changed (in the boxes the pairs share), with
    exact predicates on the triangles: each covered by its group's and
    strictly inside no other's; here each polygon is checked valid (GEOS).
    ``done[g]`` is False for the groups of a component the kernel could not
    split (a location of two groups, a coordinate it refuses, a check that
    failed): :func:`_split_geos` splits those.
    """
    n = len(geoms)
    inv = np.unique(pairs)
    local = np.full(n, -1, dtype=np.int64)
    local[inv] = np.arange(len(inv))
    coords, (rings, polygons, index) = layout(geoms[inv])
    counts = starts[inv + 1] - starts[inv]
    first = np.concatenate([[0], np.cumsum(counts)])
    # (each group's slice of ``order``, one after the other, in one gather)
    sites = order[np.repeat(starts[inv] - first[:-1], counts) + np.arange(first[-1])]
    got = _kernel.split_overlaps(
        np.ascontiguousarray(coords, dtype=np.float64),
        rings,
        polygons,
        index,
        np.ascontiguousarray(xy[sites], dtype=np.float64),
        first.astype(np.int64),
        np.ascontiguousarray(local[pairs], dtype=np.int64),
        threads=kernel.threads(n_jobs),
    )
    out = geoms.copy()
    done = np.zeros(n, dtype=bool)
    ok = got["status"] == 1
    if not ok.any():
        return out, done
    split = shapely.from_ragged_array(
        shapely.GeometryType.MULTIPOLYGON,
        got["xy"],
        (got["ring_offsets"], got["polygon_offsets"], got["geometry_offsets"]),
    )
    one = shapely.get_num_geometries(split) == 1  # as GEOS's overlays return it
    split[one] = shapely.get_geometry(split[one], 0)
    which = inv[ok]
    out[which] = split[ok]
    done[which] = True
    bad = np.zeros(n, dtype=bool)
    # On threads. shapely.is_valid silences GEOS with warnings.catch_warnings,
    # which swaps the process's warning filters: here, inside this thread's own
    # catch_warnings, they only swap its "ignore" (the caller's filters and
    # record of warnings are restored when all have ended).
    chunks = np.array_split(np.flatnonzero(ok), max(1, kernel.threads(n_jobs)))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        valid = _map(lambda at: shapely.is_valid(split[at]), chunks, n_jobs, 1)
    bad[inv[np.concatenate(chunks)]] = ~np.concatenate(valid)
    # (rounded crossings can leave a ring doubling back within a few units in
    # the last place: rare, and GEOS's split checks and mends what it makes)
    if bad.any():  # their components are split by GEOS instead
        component = _components(n, pairs)
        done &= ~np.isin(component, component[bad])
    return np.where(done, out, geoms), done


def _components(n: int, pairs: np.ndarray) -> np.ndarray:
    """Return the component of every group in the graph of ``pairs`` (a label each)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    return connected_components(graph, directed=False)[1]


def _split_geos(geoms, xy, codes, own, order, starts, pairs, n_jobs) -> Split:
    """Split the overlaps of ``pairs`` with GEOS's overlays (the general way).

    Per pair, the Voronoi cells (GEOS) of the points that can be nearest to
    the overlap, restricted to it (:func:`_split_pair`); each group's polygon
    less what it lost (:func:`_cut`), checked. A location holding points of
    both groups is split here (a half-plane through it, :func:`_half_plane`).
    Returns a :class:`Split` whose ``neighbours`` is not filled.
    """
    n = len(geoms)
    involved = np.zeros(n, dtype=bool)
    involved[pairs.ravel()] = True
    take = np.flatnonzero(own)
    losses: list[list] = [[] for _ in range(n)]
    broken = np.zeros(n, dtype=bool)
    shared, shared_groups = [], []
    angles = _angles(geoms, *_shared_locations(xy[take], codes[take]))
    overlaps = _overlay(shapely.intersection, geoms[pairs[:, 0]], geoms[pairs[:, 1]])

    def split_one(k: int):
        g, h = pairs[k].tolist()
        pg, ph = (
            xy[order[starts[g] : starts[g + 1]]],
            xy[order[starts[h] : starts[h + 1]]],
        )
        try:
            return _split_pair(overlaps[k], pg, ph, g, h, angles)
        except (shapely.errors.GEOSException, ValueError):  # pragma: no cover
            return None

    splits = _map(split_one, range(len(pairs)), n_jobs)
    for (g, h), one in zip(pairs.tolist(), splits, strict=True):
        if one is None:  # pragma: no cover
            broken[[g, h]] = True  # they keep their hulls (a warning says so)
            continue
        lose_g, lose_h, both = one
        losses[g].append(lose_g)
        losses[h].append(lose_h)
        if len(both):
            shared.append(both)
            shared_groups.append(np.tile([g, h], (len(both), 1)))
    changed = np.flatnonzero(involved)
    mine = {g: xy[order[starts[g] : starts[g + 1]]] for g in changed}
    near = _in_boxes(geoms, xy, codes, order, changed)

    def settle(which: np.ndarray, careful: bool):
        """Cut, carve and check the groups ``which``: their polygons, failed."""
        out, bad = geoms.copy(), broken.copy()

        def cut_one(g: int):
            try:
                cut = _cut(geoms[g], losses[g], mine[g], careful=careful)
                return _without_crumbs(cut, geoms[g])
            except (shapely.errors.GEOSException, ValueError):  # pragma: no cover
                return None

        for g, cut in zip(which, _map(cut_one, which, n_jobs), strict=True):
            if cut is None:  # pragma: no cover
                bad[g] = True
            else:
                out[g] = cut
        out = _carve(out, xy, {g: near[g] for g in which}, mine)
        # The guarantee on the split polygons: valid, covering their own points.
        mask = np.zeros(n, dtype=bool)
        mask[which] = True
        fixed, failed = enforce(out, xy, codes, mask, exempt=~own, n_jobs=n_jobs)
        return fixed, (failed | bad) & mask

    # Fast: each cut checked by area; every split pair checked at the end. The
    # groups that failed and those of a pair that still overlaps are cut again
    # with the careful checks and fallbacks of :func:`_cut`.
    fixed, failed = settle(changed, careful=False)
    out = np.where(failed, geoms, fixed)
    left = _still_overlap(out[pairs[:, 0]], out[pairs[:, 1]], n_jobs)
    redo = np.flatnonzero(failed & ~broken)
    redo = np.union1d(redo, pairs[left].ravel())
    if len(redo):
        fixed, again = settle(redo, careful=True)
        out[redo] = np.where(again[redo], geoms[redo], fixed[redo])
        failed[redo] = again[redo]
        left = _still_overlap(out[pairs[:, 0]], out[pairs[:, 1]], n_jobs)
    still = pairs[left]
    mask = involved
    if shared:  # each location once per pair of groups
        both = np.concatenate(
            [np.concatenate(shared), np.concatenate(shared_groups)], axis=1
        )
        both = np.unique(both, axis=0)
        shared, shared_groups = [both[:, :2]], [both[:, 2:].astype(np.int64)]
    return Split(
        out,
        mask & ~failed,
        np.zeros(n, dtype=np.int64),
        np.concatenate(shared) if shared else np.zeros((0, 2)),
        np.concatenate(shared_groups) if shared else np.zeros((0, 2), dtype=np.int64),
        failed,
        still,
    )


def _still_overlap(a: np.ndarray, b: np.ndarray, n_jobs: int | None = 1) -> np.ndarray:
    """Whether the polygons of each pair overlap by more than 1e-9 of the larger.

    The float overlay first (fast, on ``n_jobs`` threads); the pairs it finds
    overlapping (it can report an overlap that is not, around edges nearly
    along each other) or cannot compute are measured again by snap-rounded
    overlay (robust).
    """
    limit = 1e-9 * np.maximum(shapely.area(a), shapely.area(b))

    def float_area(k: int):
        try:
            return shapely.area(shapely.intersection(a[k], b[k]))
        except shapely.errors.GEOSException:
            return np.inf

    suspect = np.array(_map(float_area, range(len(a)), n_jobs), dtype=float) > limit
    if not suspect.any():
        return suspect
    a, b = a[suspect], b[suspect]
    grid = _GRID_RTOL * max(float(np.abs(shapely.total_bounds(a)).max()), 1e-300)
    try:
        left = shapely.area(shapely.intersection(a, b, grid_size=grid))
    except shapely.errors.GEOSException:  # pragma: no cover
        left = shapely.area(_overlay(shapely.intersection, a, b))
    suspect[suspect] = left > limit[suspect]
    return suspect


def _split_pair(overlap, pg: np.ndarray, ph: np.ndarray, g: int, h: int, angles):
    """Split one overlap: the parts groups g and h lose, and their shared locations.

    The points that can be nearest to some location of the overlap
    (:func:`_candidates`) make the Voronoi cells.
    """
    x0, y0, x1, y1 = shapely.bounds(overlap)
    both = np.concatenate([pg, ph])
    if not len(both) or shapely.is_empty(overlap):
        return EMPTY_POLYGON, EMPTY_POLYGON, np.zeros((0, 2))
    near, reach = _candidates(both, overlap)
    label = np.r_[np.zeros(len(pg), dtype=np.int8), np.ones(len(ph), dtype=np.int8)]
    sites, inverse = _distinct(both[near])
    has = np.zeros((len(sites), 2), dtype=bool)
    has[inverse, label[near]] = True
    if not has[:, 1].any():
        return EMPTY_POLYGON, overlap, np.zeros((0, 2))
    if not has[:, 0].any():
        return overlap, EMPTY_POLYGON, np.zeros((0, 2))
    pad = max(float(np.hypot(x1 - x0, y1 - y0)), reach, 1e-300)
    frame = shapely.box(x0 - pad, y0 - pad, x1 + pad, y1 + pad)
    cells = _voronoi_cells(sites, frame)
    shapely.prepare(overlap)
    meets = shapely.intersects(overlap, cells)  # only these cells matter
    mixed = has.all(axis=1) & meets
    # One side's cells are joined (the side with fewer); the other side loses
    # the rest of the overlap, so that the two share one cut exactly.
    of_g, of_h = has[:, 0] & ~mixed & meets, has[:, 1] & ~mixed & meets
    side = 0 if of_g.sum() <= of_h.sum() else 1
    parts = [_cells_union(cells[of_g if side == 0 else of_h])]
    if mixed.any():
        for site, cell in zip(sites[mixed], cells[mixed], strict=True):
            chosen = angles[tuple(site.tolist())]
            half = _half_plane(site, chosen[g], chosen[h], cell)  # g's side
            op = shapely.intersection if side == 0 else shapely.difference
            parts.append(_overlay(op, cell, half))
    won = _overlay(shapely.intersection, overlap, _union(parts))
    rest = _overlay(shapely.difference, overlap, won)
    lose_g, lose_h = (rest, won) if side == 0 else (won, rest)
    return lose_g, lose_h, sites[mixed]


def _carve(geoms, xy, foreign: dict, mine: dict) -> np.ndarray:
    """Cut a point out of a neighbour's polygon that holds it strictly inside.

    Not expected (each point's Voronoi cell goes to its group), but float
    rounding next to near-duplicate points of two groups can leave a point
    just inside the other's cut: a disc around it, narrower than half the
    distance to that group's nearest own point, is taken out of the other's
    polygon, so that the point is strictly inside no polygon but its own. At a
    location of both groups the disc leaves the other group's own point out too:
    the guarantee's check then takes it back in as a vertex, on the boundary.

    ``foreign[g]``: the indices (into ``xy``) of the other groups' points that
    may be strictly inside g's polygon (:func:`_in_boxes`); ``mine[g]``: g's
    own points.
    """
    geoms = geoms.copy()
    for g, near in foreign.items():
        poly = geoms[g]
        if not len(near) or shapely.is_empty(poly):
            continue
        shapely.prepare(poly)
        # (for a point, contains is contains_properly: in the interior)
        pts = xy[near[shapely.contains_xy(poly, xy[near, 0], xy[near, 1])]]
        if not len(pts):
            continue
        own = np.unique(mine[g], axis=0)
        gap = np.full(len(pts), np.inf)
        if len(own) > 1:  # a location of g's own too (shared): the next one
            dist, _ = cKDTree(own).query(pts, k=2)
            gap = np.where(dist[:, 0] > 0, dist[:, 0], dist[:, 1])
        elif len(own):
            gap = np.hypot(*(pts - own[0]).T)
            gap[gap == 0] = np.inf
        x0, y0, x1, y1 = shapely.bounds(poly)
        extent = max(x1 - x0, y1 - y0, 1e-300)
        radius = np.minimum(gap / 2, _CARVE_RTOL * extent)
        keep = radius > 0
        if keep.any():
            discs = shapely.buffer(shapely.points(pts[keep]), radius[keep], quad_segs=2)
            geoms[g] = _overlay(shapely.difference, poly, shapely.union_all(discs))
    return geoms


def _map(func, items, n_jobs: int | None, at_least: int = _THREAD_ITEMS) -> list:
    """Return ``[func(item) for item in items]``, on threads from many items.

    GEOS releases the GIL, so the pairs (or groups) are split in parallel; each
    item is independent and the results come in order: the same for any
    ``n_jobs``. Threads from ``at_least`` items each. A ``func`` that uses
    ``warnings.catch_warnings`` (process-wide), as ``shapely.is_valid`` and
    ``shapely.total_bounds`` do, must run inside the caller's own
    ``catch_warnings``, or it swaps the caller's filters meanwhile.
    """
    items = list(items)
    workers = min(kernel.threads(n_jobs), len(items) // at_least)
    if workers <= 1:
        return [func(item) for item in items]
    with ThreadPoolExecutor(workers) as pool:
        return list(pool.map(func, items))


def _in_boxes(geoms, xy, codes, points: np.ndarray, which: np.ndarray) -> dict:
    """Return, per group of ``which``, the ``points`` of other groups in its box.

    The box of its polygon, widened by float noise (:data:`_SLACK` of the
    coordinates): the points that may end up strictly inside its split polygon
    (those of a neighbour's overlap, or on its boundary, where rounding of the
    cut can move it). One sort by x, then a slice per group.
    """
    byx = points[np.argsort(xy[points, 0], kind="stable")]
    sx = xy[byx, 0]
    pad = _SLACK * max(float(np.abs(xy).max()) if len(xy) else 0.0, 1e-300)
    out = {}
    bounds = shapely.bounds(geoms[which])
    for g, (x0, y0, x1, y1) in zip(which.tolist(), bounds, strict=True):
        lo = np.searchsorted(sx, x0 - pad, side="left")
        hi = np.searchsorted(sx, x1 + pad, side="right")
        at = byx[lo:hi]
        y = xy[at, 1]
        out[g] = at[(y >= y0 - pad) & (y <= y1 + pad) & (codes[at] != g)]
    return out


def _candidates(xy: np.ndarray, overlap) -> tuple[np.ndarray, float]:
    """Mark the points that can be nearest to some location of ``overlap``.

    A grid of up to :data:`_GRID` x :data:`_GRID` cells over its box, of which those
    that meet the overlap count: from a location in a cell, the nearest point is
    at most the cell's centre's distance to its nearest point plus half the
    cell's diagonal away, so a point farther than that plus another half
    diagonal from the centre is nearer to none of the cell's locations than that
    one. Returns the mask and the largest such distance. Fewer points, fewer
    cells: about 4 points a cell, at least 4 x 4.
    """
    grid = int(np.clip(np.sqrt(len(xy) / 4), 4, _GRID))
    x0, y0, x1, y1 = shapely.bounds(overlap)
    xs, ys = np.linspace(x0, x1, grid + 1), np.linspace(y0, y1, grid + 1)
    ix, iy = np.meshgrid(np.arange(grid), np.arange(grid))
    ix, iy = ix.ravel(), iy.ravel()
    shapely.prepare(overlap)
    cells = shapely.box(xs[ix], ys[iy], xs[ix + 1], ys[iy + 1])
    meet = shapely.intersects(overlap, cells)
    if not meet.any():  # (float noise: a sliver between the grid lines)
        meet[:] = True
    ix, iy = ix[meet], iy[meet]
    centres = np.stack([xs[ix] + xs[ix + 1], ys[iy] + ys[iy + 1]], axis=1) / 2
    half = np.hypot(xs[ix + 1] - xs[ix], ys[iy + 1] - ys[iy]) / 2
    tree = cKDTree(xy)
    nearest, _ = tree.query(centres)
    scale = max(float(np.abs(xy).max()), 1e-300)
    radius = (nearest + 2 * half) * (1 + _SLACK) + _SLACK * scale
    found = tree.query_ball_point(centres, radius, return_sorted=False)
    near = np.zeros(len(xy), dtype=bool)
    near[np.fromiter(itertools.chain.from_iterable(found), dtype=np.int64)] = True
    return near, float(radius.max())


def _distinct(xy: np.ndarray):
    """Return the distinct rows of ``xy`` and the index of each row among them."""
    order = np.lexsort((xy[:, 1], xy[:, 0]))
    sx = xy[order]
    new = np.r_[True, (sx[1:] != sx[:-1]).any(axis=1)]
    inverse = np.empty(len(xy), dtype=np.int64)
    inverse[order] = np.cumsum(new) - 1
    return sx[new], inverse


def _shared_locations(xy: np.ndarray, codes: np.ndarray):
    """Return the locations holding points of several groups, and their groups."""
    # Only an x held by two rows can be such a location (one sort, not three).
    sx = np.sort(xy[:, 0])
    twice = sx[1:][sx[1:] == sx[:-1]]
    at = np.isin(xy[:, 0], twice)
    xy, codes = xy[at], codes[at]
    if not len(xy):
        return np.zeros((0, 2)), []
    order = np.lexsort((codes, xy[:, 1], xy[:, 0]))
    sx, sc = xy[order], codes[order]
    new = np.r_[True, (sx[1:] != sx[:-1]).any(axis=1)]  # a location starts
    other = np.r_[False, ~new[1:] & (sc[1:] != sc[:-1])]  # another group there
    if not other.any():
        return np.zeros((0, 2)), []
    starts = np.flatnonzero(new)
    where = np.searchsorted(starts, np.flatnonzero(other), side="right") - 1
    shared = np.unique(where)
    ends = np.r_[starts[1:], len(sx)]
    groups = [np.unique(sc[starts[k] : ends[k]]).tolist() for k in shared]
    return sx[starts[shared]], groups


def _cut(poly, losses: list, points: np.ndarray, careful: bool = True):
    """Return ``poly`` without the union of ``losses`` (parts of it), checked.

    A float overlay can misjudge an edge nearly along another (a loss whose
    ring nearly touches itself): return the polygon whole, drop a piece of a
    loss, or take away more. Each result is checked: none of the group's
    ``points`` taken, no more than the losses' areas taken, and no loss left in
    it (by snap-rounded overlay, which is robust). Tried in turn: the union of
    the losses taken away, the losses one by one, both snap-rounded to a grid
    of :data:`_GRID_RTOL` of the coordinates; else ValueError (the group keeps
    its hull, with a warning).

    Not ``careful``, the first attempt's third check is made by area instead
    (what is left must have the area of ``poly`` less the union's, within 1e-9
    of it), which does not see an error of the union itself: the caller checks
    the split pairs (:func:`_still_overlap`) and cuts the groups of a pair that
    still overlaps again, carefully.
    """
    losses = np.array([g for g in losses if not shapely.is_empty(g)], dtype=object)
    if not len(losses):
        return poly
    tol = 1e-9 * shapely.area(poly)
    most = float(shapely.area(losses).sum())  # (the losses may overlap)
    grid = _GRID_RTOL * max(float(np.abs(shapely.bounds(poly)).max()), 1e-300)
    x0, y0, x1, y1 = shapely.bounds(poly)
    reach = max(_CARVE_RTOL * max(x1 - x0, y1 - y0), 4 * grid)

    def right(cut, lost=None) -> bool:
        if shapely.area(cut) < shapely.area(poly) - most - tol:
            return False
        if len(points):  # (one rounded just outside is taken back in later)
            out = points[~shapely.intersects_xy(cut, *points.T)]
            if len(out) and shapely.distance(cut, shapely.points(out)).max() > reach:
                return False
        if lost is not None:  # parts of poly: what is left has the rest's area
            wanted = shapely.area(poly) - shapely.area(lost)
            return bool(abs(shapely.area(cut) - wanted) <= tol)
        try:
            left = shapely.area(shapely.intersection(cut, losses, grid_size=grid))
        except shapely.errors.GEOSException:
            return False
        return bool(left.sum() <= tol)

    try:  # the losses' union taken away
        lost = _union(list(losses), by_subsets=not careful)
        cut = _overlay(shapely.difference, poly, lost)
        if right(cut, None if careful else lost):
            return cut
    except shapely.errors.GEOSException:
        pass

    def one_by_one() -> object:
        cut = poly
        for loss in losses:
            cut = _overlay(shapely.difference, cut, loss)
        return cut

    def snapped() -> object:
        lost = shapely.union_all(losses, grid_size=grid)
        return _areal(shapely.difference(poly, lost, grid_size=grid))

    def snapped_one_by_one() -> object:
        cut = poly
        for loss in losses:
            cut = _areal(shapely.difference(cut, loss, grid_size=grid))
        return cut

    for attempt in (one_by_one, snapped, snapped_one_by_one):
        try:
            cut = attempt()
        except shapely.errors.GEOSException:
            continue
        if right(cut):
            return cut
    raise ValueError("the overlay of the split does not hold")  # (kept unsplit)


def _union(geoms: list, by_subsets: bool = False):
    """Return the union of polygons (an overlay only for two or more non-empty).

    ``by_subsets``: by disjoint subsets where shapely has it (>= 2.1), faster
    but in random grid draws less often right than the plain union (checked by
    the caller).
    """
    geoms = [g for g in geoms if not shapely.is_empty(g)]
    if not geoms:
        return EMPTY_POLYGON
    if len(geoms) == 1:
        return geoms[0]
    subsets = by_subsets and hasattr(shapely, "disjoint_subset_union_all")
    op = _union_by_subsets if subsets else shapely.union_all
    return _overlay(op, np.array(geoms, dtype=object))


def _union_by_subsets(geoms: np.ndarray, grid_size=None):
    """``shapely.disjoint_subset_union_all`` (snap-rounded: ``union_all``)."""
    if grid_size is None:
        return shapely.disjoint_subset_union_all(geoms)
    return shapely.union_all(geoms, grid_size=grid_size)


def _cells_union(cells: np.ndarray):
    """Return the union of Voronoi cells (a coverage: edges shared exactly).

    ``coverage_union_all`` only drops the shared edges, far faster than an
    overlay; checked by area (a coverage's union has the sum of its areas),
    else the overlay.
    """
    if not len(cells):
        return EMPTY_POLYGON
    if len(cells) == 1:
        return cells[0]
    try:
        union = shapely.coverage_union_all(cells)
        total = float(shapely.area(cells).sum())
        if abs(shapely.area(union) - total) <= 1e-9 * total:
            return union
    except shapely.errors.GEOSException:
        pass
    return _overlay(shapely.union_all, cells)


def _voronoi_cells(sites: np.ndarray, frame) -> np.ndarray:
    """Return the Voronoi cell of each site (distinct), clipped to ``frame``."""
    if len(sites) == 1:
        return np.array([frame], dtype=object)
    points = shapely.multipoints(sites)
    try:
        diagram = shapely.voronoi_polygons(points, extend_to=frame, ordered=True)
        return np.asarray(shapely.get_parts(diagram), dtype=object)
    except (shapely.errors.UnsupportedGEOSVersionError, TypeError):  # GEOS < 3.12
        diagram = shapely.voronoi_polygons(points, extend_to=frame)
    cells = np.asarray(shapely.get_parts(diagram), dtype=object)
    site, cell = shapely.STRtree(cells).query(shapely.points(sites), predicate="within")
    out = np.empty(len(sites), dtype=object)
    out[site] = cells[cell]
    return out


def _corner(poly, site: np.ndarray) -> tuple[float, float]:
    """Return the directions from ``site`` into ``poly``: ``(start, sweep)`` angles.

    The corner at a vertex (the rings oriented with the interior on their left),
    a half-turn on an edge, the full turn inside.
    """
    best = (np.inf, 0.0, 2 * np.pi)
    parts = shapely.get_parts(poly)
    for part in parts[shapely.get_type_id(parts) == 3]:
        part = shapely.geometry.polygon.orient(part, 1.0)
        for ring in (part.exterior, *part.interiors):
            xy = shapely.get_coordinates(ring)
            at = np.flatnonzero((xy[:-1] == site).all(axis=1))
            if len(at):
                i = at[0]
                after, before = xy[i + 1] - site, xy[i - 1 if i else -2] - site
                a1 = float(np.arctan2(after[1], after[0]))
                a2 = float(np.arctan2(before[1], before[0]))
                return a1, (a2 - a1) % (2 * np.pi) or 2 * np.pi
            a, edge = xy[:-1], xy[1:] - xy[:-1]
            length2 = np.maximum((edge**2).sum(axis=1), 1e-300)
            t = np.clip(((site - a) * edge).sum(axis=1) / length2, 0.0, 1.0)
            dist = np.hypot(*(a + t[:, None] * edge - site).T)
            k = int(np.argmin(dist))
            if dist[k] < best[0]:
                normal = float(np.arctan2(edge[k, 0], -edge[k, 1]))  # left of the edge
                best = (dist[k], normal - np.pi / 2, np.pi)
    scale = max(float(np.abs(site).max()), 1.0)
    return best[1:] if best[0] <= 1e-12 * scale else (0.0, 2 * np.pi)


def _angles(geoms, sites: np.ndarray, groups: list) -> dict:
    """Choose, per location of several groups, a distinct direction for each group.

    Each direction points into the group's polygon at the location; the pair of
    groups then halves the location's Voronoi cell along the bisector of their
    two directions, so every group keeps a corner there (the location is a
    boundary vertex of each), whatever the number of groups.
    """
    out = {}
    for site, members in zip(sites, groups, strict=True):
        corners = sorted(
            ((_corner(geoms[g], site), g) for g in members), key=lambda c: c[0][1]
        )
        chosen: dict[int, float] = {}
        for (start, sweep), g in corners:
            candidates = start + sweep * np.array(
                [0.5, 0.25, 0.75, 0.125, 0.375, 0.625, 0.875]
            )
            taken = np.array(list(chosen.values()))
            if len(taken):
                gap = np.abs(
                    (candidates[:, None] - taken[None, :] + np.pi) % (2 * np.pi) - np.pi
                )
                candidates = candidates[np.argsort(-gap.min(axis=1), kind="stable")]
            chosen[g] = float(candidates[0])
        out[tuple(site.tolist())] = chosen
    return out


def _half_plane(site: np.ndarray, alpha_g: float, alpha_h: float, cell):
    """Return the half-plane over ``cell`` of group g at a location of g and h.

    Bounded by the line through ``site`` that bisects the directions chosen for
    the two groups (:func:`_angles`), on the side of g's; ``site`` is one of its
    vertices, exactly.
    """
    ug = np.array([np.cos(alpha_g), np.sin(alpha_g)])
    uh = np.array([np.cos(alpha_h), np.sin(alpha_h)])
    along = ug + uh
    if np.hypot(*along) < 1e-9:  # opposite directions
        along = np.array([-ug[1], ug[0]])
    v = along / np.hypot(*along)
    n = np.array([-v[1], v[0]])
    if float(np.dot(n, ug)) < 0:
        n = -n
    x0, y0, x1, y1 = shapely.bounds(cell)
    r = 4 * max(float(np.hypot(x1 - x0, y1 - y0)), 1e-300)
    ring = [
        site,
        site + r * v,
        site + r * v + r * n,
        site - r * v + r * n,
        site - r * v,
    ]
    return shapely.Polygon(ring)


def _overlay(op, *geoms):
    """Run a GEOS overlay; on a robustness failure, again on repaired inputs.

    Last, with snap-rounding to a grid of :data:`_GRID_RTOL` of the extent
    (vertices may move by that much; the guarantee is checked afterwards).
    """
    try:
        return _areal(op(*geoms))
    except shapely.errors.GEOSException:
        pass
    fixed = [
        _areal(shapely.make_valid(shapely.remove_repeated_points(g))) for g in geoms
    ]
    try:
        return _areal(op(*fixed))
    except shapely.errors.GEOSException:
        pass
    bounds = np.array([shapely.bounds(g) for g in np.ravel(fixed)]).reshape(-1, 4)
    scale = max(float(np.nanmax(np.abs(bounds))) if bounds.size else 1.0, 1e-300)
    return _areal(op(*fixed, grid_size=_GRID_RTOL * scale))


def _areal(geom):
    """Keep the polygons of an overlay's result (not the lines where they touch)."""
    if isinstance(geom, np.ndarray):
        return np.array([_areal(g) for g in geom], dtype=object).reshape(geom.shape)
    if geom is None or shapely.get_type_id(geom) in (3, 6):
        return geom
    parts = shapely.get_parts(geom)
    parts = parts[(shapely.get_type_id(parts) == 3) & (shapely.area(parts) > 0)]
    if not len(parts):
        return EMPTY_POLYGON
    return parts[0] if len(parts) == 1 else shapely.multipolygons(parts)


def _without_crumbs(split, before):
    """Drop parts of ``split`` that are float noise (tiny, next to nothing)."""
    parts = shapely.get_parts(split)
    if len(parts) <= 1:
        return split if not shapely.is_empty(split) else EMPTY_POLYGON
    area = shapely.area(parts)
    keep = area > _CRUMB_RTOL * shapely.area(before)
    if keep.all():
        return split
    parts = parts[keep]
    return parts[0] if len(parts) == 1 else shapely.multipolygons(parts)


def _neighbours(geoms: np.ndarray, touching: np.ndarray, inner=None) -> np.ndarray:
    """Count, per group, the groups whose polygon shares a boundary line with it.

    ``touching``: the pairs that intersected before the split (the split only
    takes area away, so no other pair can share a boundary after it), and
    ``inner``: those that overlapped, which the split leaves sharing the line
    that divides their overlap (counted without a test).
    """
    count = np.zeros(len(geoms), dtype=np.int64)
    if not len(touching):
        return count
    inner = np.zeros(len(touching), dtype=bool) if inner is None else inner
    a, b = geoms[touching[~inner, 0]], geoms[touching[~inner, 1]]
    meet = inner.copy()
    meet[~inner] = shapely.relate_pattern(a, b, "****1****")
    np.add.at(count, touching[meet, 0], 1)
    np.add.at(count, touching[meet, 1], 1)
    return count
