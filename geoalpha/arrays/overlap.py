"""``overlap="split"``: the hulls of neighbouring groups made interior-disjoint.

Wherever two groups' polygons overlap (their interiors meet), each part of the
overlap goes to the group of the nearest input point: the Voronoi cells of the
two groups' points there (GEOS), restricted to the overlap. Every point stays
covered by its own group's polygon and is strictly inside no other
(:doc:`/user_guide/neighbours`).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import shapely

from geoalpha.arrays.guarantee import EMPTY_POLYGON, covered, enforce

__all__ = ["Split", "overlapping_pairs", "split_overlaps"]

#: Relative slack on the radius within which points may be nearest to an overlap.
_SLACK = 1e-9
#: Grid of the last resort of :func:`_overlay`, relative to the coordinates.
_GRID_RTOL = 1e-12
#: Parts a split leaves that are smaller than this share of the group's polygon and
#: hold none of its points are float noise of the overlay, not territory.
_CRUMB_RTOL = 1e-12


class Split(NamedTuple):
    """Result of :func:`split_overlaps`, one entry a group (``shared``: locations)."""

    geometry: np.ndarray  #: the polygons, split where they overlapped
    changed: np.ndarray  #: bool: the group ceded or lost area
    neighbours: np.ndarray  #: groups whose polygon shares a boundary line with it
    shared: np.ndarray  #: (m, 2) locations in an overlap holding points of 2 groups
    shared_groups: np.ndarray  #: (m, 2) the two groups of each shared location
    failed: np.ndarray  #: bool: split polygon failed the guarantee, kept unsplit


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
    n_jobs : int or None, default 1
        Threads of the point tests.

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
    [[1.5, 1.5], [1, 1]]
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
    own[at] = covered(geoms, xy[at], codes[at], n_jobs=n_jobs)
    take = np.flatnonzero(own)
    order = take[np.argsort(codes[take], kind="stable")]
    starts = np.searchsorted(codes[order], np.arange(n + 1))
    losses: list[list] = [[] for _ in range(n)]
    shared, shared_groups = [], []
    angles = _angles(geoms, *_shared_locations(xy[take], codes[take]))
    overlaps = _overlay(shapely.intersection, geoms[pairs[:, 0]], geoms[pairs[:, 1]])
    for (g, h), overlap in zip(pairs.tolist(), overlaps, strict=True):
        pg = xy[order[starts[g] : starts[g + 1]]]
        ph = xy[order[starts[h] : starts[h + 1]]]
        lose_g, lose_h, both = _split_pair(overlap, pg, ph, g, h, angles)
        losses[g].append(lose_g)
        losses[h].append(lose_h)
        if len(both):
            shared.append(both)
            shared_groups.append(np.tile([g, h], (len(both), 1)))
    out = geoms.copy()
    changed = np.flatnonzero(involved)
    for g in changed:
        out[g] = _without_crumbs(_cut(geoms[g], losses[g]), geoms[g])
    # The guarantee on the split polygons: valid, covering their own points.
    mask = np.zeros(n, dtype=bool)
    mask[changed] = True
    fixed, failed = enforce(out, xy, codes, mask, exempt=~own, n_jobs=n_jobs)
    out = np.where(failed, geoms, fixed)
    if shared:  # each location once per pair of groups
        both = np.concatenate(
            [np.concatenate(shared), np.concatenate(shared_groups)], axis=1
        )
        both = np.unique(both, axis=0)
        shared, shared_groups = [both[:, :2]], [both[:, 2:].astype(np.int64)]
    return Split(
        out,
        mask & ~failed,
        _neighbours(out, touching, np.where(failed[touching].any(axis=1), False, inner))
        if len(touching)
        else np.zeros(n, dtype=np.int64),
        np.concatenate(shared) if shared else np.zeros((0, 2)),
        np.concatenate(shared_groups) if shared else np.zeros((0, 2), dtype=np.int64),
        failed,
    )


def _split_pair(overlap, pg: np.ndarray, ph: np.ndarray, g: int, h: int, angles):
    """Split one overlap: the parts groups g and h lose, and their shared locations.

    The points that can be nearest to some location of the overlap: those within
    ``d + diagonal`` of the centre of its bounding box, ``d`` the distance from
    there to the nearest point (any farther one is farther than that one from
    every location of the box).
    """
    x0, y0, x1, y1 = shapely.bounds(overlap)
    centre = np.array([(x0 + x1) / 2, (y0 + y1) / 2])
    diagonal = float(np.hypot(x1 - x0, y1 - y0))
    both = np.concatenate([pg, ph])
    if not len(both):
        return EMPTY_POLYGON, EMPTY_POLYGON, np.zeros((0, 2))
    dist = np.hypot(*(both - centre).T)
    reach = (dist.min() + diagonal) * (1 + _SLACK) + _SLACK * np.abs(centre).max()
    near = dist <= reach
    label = np.r_[np.zeros(len(pg), dtype=np.int8), np.ones(len(ph), dtype=np.int8)]
    sites, inverse = np.unique(both[near], axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    has = np.zeros((len(sites), 2), dtype=bool)
    has[inverse, label[near]] = True
    if not has[:, 1].any():
        return EMPTY_POLYGON, overlap, np.zeros((0, 2))
    if not has[:, 0].any():
        return overlap, EMPTY_POLYGON, np.zeros((0, 2))
    pad = max(diagonal, reach, 1e-300)
    frame = shapely.box(x0 - pad, y0 - pad, x1 + pad, y1 + pad)
    cells = _voronoi_cells(sites, frame)
    shapely.prepare(overlap)
    meets = shapely.intersects(overlap, cells)  # only these cells matter
    mixed = has.all(axis=1) & meets
    to_g = [_cells_union(cells[has[:, 0] & ~mixed & meets])]
    to_h = [_cells_union(cells[has[:, 1] & ~mixed & meets])]
    if mixed.any():
        for site, cell in zip(sites[mixed], cells[mixed], strict=True):
            chosen = angles[tuple(site.tolist())]
            half = _half_plane(site, chosen[g], chosen[h], cell)
            to_g.append(_overlay(shapely.intersection, cell, half))
            to_h.append(_overlay(shapely.difference, cell, half))
    region_g, region_h = _union(to_g), _union(to_h)
    lose_g = _overlay(shapely.intersection, overlap, region_h)
    lose_h = _overlay(shapely.intersection, overlap, region_g)
    return lose_g, lose_h, sites[mixed]


def _shared_locations(xy: np.ndarray, codes: np.ndarray):
    """Return the locations holding points of several groups, and their groups."""
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


def _cut(poly, losses: list):
    """Return ``poly`` without the union of ``losses`` (parts of it), checked by area.

    A float overlay can misjudge an edge nearly along another and return the
    polygon whole; the area says so (``losses`` lie in ``poly``): then the parts
    are taken away one by one, and last with snap-rounding (:func:`_overlay`).
    """
    losses = np.array([g for g in losses if not shapely.is_empty(g)], dtype=object)
    if not len(losses):
        return poly
    lost = _union(list(losses))
    whole, part = shapely.area(poly), shapely.area(lost)
    tol = 1e-9 * whole

    def right(cut) -> bool:
        return abs(shapely.area(cut) - (whole - part)) <= tol

    cut = _overlay(shapely.difference, poly, lost)
    if right(cut):
        return cut
    cut = poly
    for loss in losses:
        cut = _overlay(shapely.difference, cut, loss)
    if right(cut):
        return cut
    scale = max(float(np.abs(shapely.bounds(poly)).max()), 1e-300)
    return shapely.difference(poly, lost, grid_size=_GRID_RTOL * scale)


def _union(geoms: list):
    """Return the union of polygons (an overlay only for two or more non-empty)."""
    geoms = [g for g in geoms if not shapely.is_empty(g)]
    if not geoms:
        return EMPTY_POLYGON
    if len(geoms) == 1:
        return geoms[0]
    return _overlay(shapely.union_all, np.array(geoms, dtype=object))


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
        if shapely.is_valid(union) and abs(shapely.area(union) - total) <= 1e-9 * total:
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
        return op(*geoms)
    except shapely.errors.GEOSException:
        pass
    fixed = [shapely.make_valid(shapely.remove_repeated_points(g)) for g in geoms]
    try:
        return op(*fixed)
    except shapely.errors.GEOSException:
        pass
    bounds = np.array([shapely.bounds(g) for g in np.ravel(fixed)]).reshape(-1, 4)
    scale = max(float(np.nanmax(np.abs(bounds))) if bounds.size else 1.0, 1e-300)
    return op(*fixed, grid_size=_GRID_RTOL * scale)


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
