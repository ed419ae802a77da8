"""Brute-force references for the exact optimum, straight from DESIGN.md.

They share nothing with geoalpha's kernel but scipy's Delaunay: every spectrum
value is tried in increasing order of radius and the shape is checked by its
definition.

* :func:`shapely_optimum` builds the shape as ``shapely.union_all`` of
  triangles, counts its pieces as the parts of that union (GEOS splits
  pieces that touch only at a vertex) and tests coverage with
  ``shapely.covers``. Slow; for small sets.
* :func:`graph_optimum` adds the triangles in increasing order of radius to
  a union-find of edge-connected pieces, counting pieces and covered points
  as it goes, and stops at the first spectrum value whose shape is valid.
  O(m log m); for the real datasets' groups. With holes filled, each
  triangle enters at its *fill radius*, the largest radius at which it is
  still joined to the outside of the convex hull by triangles that are not
  solid, found by a second union-find, adding the triangles in decreasing
  order of radius.
* :func:`graph_optimum_per_value` builds every candidate shape anew and counts
  its pieces with scipy's ``connected_components``. O(m^2); it cross-checks
  :func:`graph_optimum` on small sets (tests/test_reference.py).

Holes are filled (``holes=False``) in the shapes of :func:`shape_mask` by a
plain breadth-first search from the outside of the convex hull through
non-solid triangles.
"""

from __future__ import annotations

import itertools
import math
from collections import deque
from decimal import Decimal, localcontext
from fractions import Fraction

import numpy as np
import shapely
from scipy.sparse import csr_array
from scipy.sparse.csgraph import connected_components
from scipy.spatial import Delaunay


def exact_circumradius(a, b, c) -> float:
    """Circumradius of the triangle of float points a, b, c, correctly rounded.

    R^2 = |ab|^2 |bc|^2 |ca|^2 / (2 cross)^2 is evaluated in rational
    arithmetic on the input floats themselves, so no rounding of coordinates
    (centring, differences) or cancellation in the cross product can creep
    in; ``inf`` for a flat triangle.
    """
    (ax, ay), (bx, by), (cx, cy) = (
        tuple(map(Fraction, map(float, v))) for v in (a, b, c)
    )
    cross = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    if cross == 0:
        return math.inf
    ab2 = (bx - ax) ** 2 + (by - ay) ** 2
    bc2 = (cx - bx) ** 2 + (cy - by) ** 2
    ca2 = (ax - cx) ** 2 + (ay - cy) ** 2
    r2 = ab2 * bc2 * ca2 / (4 * cross * cross)
    # float(Fraction) is correctly rounded; the square root adds < 1 ulp.
    return math.sqrt(float(r2))


def exact_delaunay(points):
    """Delaunay triangles and neighbours of a few points, in rational arithmetic.

    Brute force over every triple (O(n^4) exact ``incircle`` tests: for a
    dozen points): a triangle is Delaunay when no point is strictly inside
    its circumcircle. Returns ``(simplices, neighbors)`` as scipy's Delaunay
    does (counter-clockwise; neighbour ``k`` opposite vertex ``k``, -1 on the
    hull), or None when four points are cocircular (not unique) or all are
    collinear.
    """
    p = [(Fraction(float(x)), Fraction(float(y))) for x, y in points]

    def orient(a, b, c):
        return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])

    def incircle(a, b, c, d):  # > 0: d inside the circle of ccw a, b, c
        rows = [(q[0] - d[0], q[1] - d[1]) for q in (a, b, c)]
        m = [(x, y, x * x + y * y) for x, y in rows]
        return (
            m[0][0] * (m[1][1] * m[2][2] - m[2][1] * m[1][2])
            - m[0][1] * (m[1][0] * m[2][2] - m[2][0] * m[1][2])
            + m[0][2] * (m[1][0] * m[2][1] - m[2][0] * m[1][1])
        )

    tris = []
    for i, j, k in itertools.combinations(range(len(p)), 3):
        o = orient(p[i], p[j], p[k])
        if o == 0:
            continue
        t = (i, j, k) if o > 0 else (i, k, j)
        side = [incircle(*(p[v] for v in t), p[m]) for m in range(len(p)) if m not in t]
        if any(s > 0 for s in side):
            continue
        if any(s == 0 for s in side):
            return None
        tris.append(t)
    if not tris:
        return None
    simplices = np.array(tris, dtype=np.int64)
    edge = {}
    for t, s in enumerate(tris):
        for k in range(3):
            edge[(s[(k + 1) % 3], s[(k + 2) % 3])] = (t, k)
    neighbors = np.full((len(tris), 3), -1, dtype=np.int64)
    for (a, b), (t, k) in edge.items():
        if (b, a) in edge:
            neighbors[t, k] = edge[(b, a)][0]
    return simplices, neighbors


#: The documented near-degeneracy rule (README "Near-degenerate input"),
#: restated here rather than imported: relative to the set's extent, never
#: below 64 units in the last place of its largest coordinate.
NEAR_RTOL = 1e-9
PRECISION_ULPS = 64


def tolerance(points) -> float:
    p = np.asarray(points, dtype=float)
    extent = float(np.ptp(p, axis=0).max())
    return max(NEAR_RTOL * extent, PRECISION_ULPS * float(np.spacing(np.abs(p).max())))


def near_labels(points) -> np.ndarray:
    """Label of each point's set of points closer than the tolerance (transitively).

    Brute force (all pairs, breadth-first search); sets are numbered in the
    input order of their first point.
    """
    p = np.asarray(points, dtype=float)
    tol = tolerance(p)
    close = ((p[:, None, :] - p[None, :, :]) ** 2).sum(axis=-1) < tol * tol
    label = np.full(len(p), -1, dtype=np.int64)
    n_sets = 0
    for i in range(len(p)):
        if label[i] >= 0:
            continue
        label[i] = n_sets
        queue = deque([i])
        while queue:
            j = queue.popleft()
            for k in np.flatnonzero(close[j] & (label < 0)):
                label[k] = n_sets
                queue.append(k)
        n_sets += 1
    return label


def merge_near(points) -> np.ndarray:
    """One point per set of points closer than the tolerance (transitively).

    Each set is represented by its first point in input order.
    """
    p = np.asarray(points, dtype=float)
    _, first = np.unique(near_labels(p), return_index=True)
    return p[first]


def is_collinear(points) -> bool:
    """Whether every point lies within the tolerance of the principal axis."""
    p = np.asarray(points, dtype=float)
    if len(np.unique(p, axis=0)) < 3:
        return True
    centred = p - p.mean(axis=0)
    _, _, vt = np.linalg.svd(centred, full_matrices=False)
    normal = vt[1]
    return float(np.abs(centred @ normal).max()) <= tolerance(p)


def triangulation(points):
    """Distinct points, Delaunay simplices and neighbours, exact circumradii.

    Points closer than the tolerance are merged first; a collinear set (by
    the same tolerance) raises ValueError, as having no triangle.
    """
    if is_collinear(points):
        raise ValueError("collinear within the tolerance")
    pts = np.unique(merge_near(points), axis=0)
    d = Delaunay(pts - pts.mean(axis=0))
    r = np.array([exact_circumradius(*pts[s]) for s in d.simplices], dtype=float)
    return pts, d.simplices, d.neighbors, r


#: Radii this close (relative) are the same value: cocircular points give equal
#: radii in exact arithmetic that rounding splits (DESIGN: ties are attained).
TIE = 1e-10


def merged(r):
    """Each radius replaced by the largest of its tie run (the kernel's ``merge_ties``).

    Runs are greedy and do not chain: a run starts at the smallest radius
    not yet taken and holds every radius up to ``start * (1 + TIE)``, so a
    merged value spans at most TIE (a chain of small steps starts new runs).
    Brute force: one pass over the sorted distinct radii.
    """
    r = np.asarray(r, dtype=float)
    u = np.unique(r)
    value = np.empty(len(u))
    i = 0
    while i < len(u):
        j = i
        while j + 1 < len(u) and u[j + 1] <= u[i] * (1 + TIE):
            j += 1
        value[i : j + 1] = u[j]
        i = j + 1
    return value[np.searchsorted(u, r)]


def shape_mask(neighbors, r, R, holes):
    """Triangles in S(R): solid ones, plus enclosed ones when holes=False."""
    solid = merged(r) <= R
    if holes:
        return solid
    reach = np.zeros(len(r), dtype=bool)
    queue = deque()
    for t in range(len(r)):
        if not solid[t] and (neighbors[t] < 0).any():
            reach[t] = True
            queue.append(t)
    while queue:
        t = queue.popleft()
        for s in neighbors[t]:
            if s >= 0 and not solid[s] and not reach[s]:
                reach[s] = True
                queue.append(s)
    return ~reach


def spectrum(r):
    """Distinct merged radii (:func:`merged`), ascending."""
    return np.unique(merged(r))


def shapely_shape(pts, simplices, mask):
    tris = shapely.polygons(pts[simplices[mask]])
    return shapely.union_all(tris)


def shapely_valid(pts, shape, components):
    if shape.is_empty:
        return False, 0
    parts = len(shape.geoms) if shape.geom_type == "MultiPolygon" else 1
    covered = bool(shapely.covers(shape, shapely.points(pts)).all())
    return covered and parts <= components, parts


def shapely_optimum(points, holes=False, components=1):
    """(alpha, shape) by trying every spectrum value with shapely."""
    pts, simplices, neighbors, r = triangulation(points)
    for R in spectrum(r):
        mask = shape_mask(neighbors, r, R, holes)
        shape = shapely_shape(pts, simplices, mask)
        ok, _ = shapely_valid(pts, shape, components)
        if ok:
            return (1.0 / R if np.isfinite(R) else 0.0), shape
    raise AssertionError("the convex hull is always valid")


def graph_optimum_per_value(points, holes=False, components=1):
    """Optimal alpha by trying every spectrum value with connected_components."""
    pts, simplices, neighbors, r = triangulation(points)
    m = len(r)
    a = np.repeat(np.arange(m), 3)
    b = neighbors.ravel()
    keep = b >= 0
    a, b = a[keep], b[keep]
    for R in spectrum(r):
        mask = shape_mask(neighbors, r, R, holes)
        covered = np.zeros(len(pts), dtype=bool)
        covered[simplices[mask].ravel()] = True
        if not covered.all():
            continue
        e = mask[a] & mask[b]
        g = csr_array((np.ones(e.sum()), (a[e], b[e])), shape=(m, m))
        _, label = connected_components(g, directed=False)
        if len(np.unique(label[mask])) <= components:
            return 1.0 / R if np.isfinite(R) else 0.0
    raise AssertionError("the convex hull is always valid")


class UnionFind:
    """Disjoint sets of 0..n-1 with path halving and union by size."""

    def __init__(self, n):
        self.parent = list(range(n))
        self.size = [1] * n

    def find(self, i):
        parent = self.parent
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    def union(self, i, j):
        """Join the sets of i and j; True when they were two sets."""
        i, j = self.find(i), self.find(j)
        if i == j:
            return False
        if self.size[i] < self.size[j]:
            i, j = j, i
        self.parent[j] = i
        self.size[i] += self.size[j]
        return True


def runs(key):
    """``(value, triangles)`` for each distinct value of ``key``, ascending."""
    order = np.argsort(key, kind="stable")
    cuts = np.flatnonzero(np.diff(key[order])) + 1
    return [(key[group[0]], group) for group in np.split(order, cuts)]


def fill_radii(neighbors, r):
    """Per triangle, the least R at which it is in the filled shape S(R).

    A triangle is outside the filled S(R) when it and a path of triangles
    to the outside of the convex hull all have merged radius > R. Adding the
    triangles in decreasing order of merged radius to a union-find that has
    one more node for the outside, a triangle is first joined to the outside
    once the triangles of radius >= v are in, v its fill radius: it is left
    out for every R < v and in for every R >= v.
    """
    m = len(r)
    outside = m
    sets = UnionFind(m + 1)
    members = {t: [t] for t in range(m)}  # by root, for the sets not outside
    fill = np.full(m, np.nan)
    added = np.zeros(m, dtype=bool)
    for value, tris in reversed(runs(r)):
        added[tris] = True
        for t in tris.tolist():
            for s in neighbors[t].tolist():
                if s >= 0 and not added[s]:
                    continue
                a, b = sets.find(t), sets.find(outside if s < 0 else s)
                if a == b:
                    continue
                out = sets.find(outside)
                if out in (a, b):
                    for u in members.pop(b if a == out else a):
                        fill[u] = value
                    sets.union(a, b)
                    continue
                big, small = (a, b) if len(members[a]) >= len(members[b]) else (b, a)
                members[big].extend(members.pop(small))
                sets.union(a, b)
                members[sets.find(a)] = members.pop(big)
    assert not np.isnan(fill).any(), "every triangle reaches the outside"
    return fill


def graph_optimum(points, holes=False, components=1):
    """Optimal alpha by one union-find sweep over the spectrum.

    Triangles enter in increasing order of merged radius (of fill radius
    with holes filled); after each spectrum value the shape is valid when
    every point is a vertex of an added triangle and the added triangles
    form at most ``components`` edge-connected pieces. The first valid value
    is the answer: no monotonicity is assumed.
    """
    pts, simplices, neighbors, r = triangulation(points)
    return mesh_optimum(len(pts), simplices, neighbors, r, holes, components)


def mesh_optimum(n_points, simplices, neighbors, r, holes=False, components=1):
    """:func:`graph_optimum` on a given triangulation (``n_points`` vertices;
    ``neighbors`` -1 on the boundary): the sphere's reference uses it."""
    radius = merged(r)
    key = radius if holes else fill_radii(neighbors, radius)
    m = len(r)
    sets = UnionFind(m)
    added = np.zeros(m, dtype=bool)
    covered = np.zeros(n_points, dtype=bool)
    n_covered = pieces = 0
    entering = dict(runs(key))
    for R in spectrum(r):
        for t in entering.get(R, np.empty(0, dtype=int)).tolist():
            added[t] = True
            pieces += 1
            for s in neighbors[t].tolist():
                if s >= 0 and added[s] and sets.union(t, s):
                    pieces -= 1
            for v in simplices[t].tolist():
                if not covered[v]:
                    covered[v] = True
                    n_covered += 1
        if n_covered == n_points and pieces <= components:
            return 1.0 / R if np.isfinite(R) else 0.0
    raise AssertionError("the convex hull is always valid")


# --------------------------------------------------------------------------
# Outliers (issues #14, #24): the best pieces cover rows - k rows
# --------------------------------------------------------------------------


def filled_mask(neighbors, r, R):
    """``shape_mask(..., holes=False)`` with scipy instead of a Python BFS.

    Non-solid triangles joined by their edges, plus one node for the outside
    of the convex hull joined to the non-solid triangles on the hull; the
    filled shape is everything not in the outside's component.
    """
    m = len(r)
    solid = merged(r) <= R
    a = np.repeat(np.arange(m), 3)
    b = neighbors.ravel()
    b = np.where(b < 0, m, b)  # m: the outside
    open_ = ~np.append(solid, False)
    keep = open_[a] & open_[b]
    g = csr_array((np.ones(keep.sum()), (a[keep], b[keep])), shape=(m + 1, m + 1))
    _, label = connected_components(g, directed=False)
    return label[:m] != label[m]


def piece_sets(simplices, neighbors, mask):
    """Vertex sets (frozensets of point indices) of the edge-connected pieces."""
    m = len(mask)
    a = np.repeat(np.arange(m), 3)
    b = neighbors.ravel()
    e = (b >= 0) & mask[a] & mask[np.maximum(b, 0)]
    g = csr_array((np.ones(e.sum()), (a[e], b[e])), shape=(m, m))
    _, label = connected_components(g, directed=False)
    inside = np.flatnonzero(mask)
    if len(inside) == 0:
        return []
    order = np.argsort(label[inside], kind="stable")
    tris, labs = inside[order], label[inside][order]
    cuts = np.flatnonzero(np.diff(labs)) + 1
    return [frozenset(simplices[t].ravel().tolist()) for t in np.split(tris, cuts)]


def row_weights(points, pts) -> np.ndarray:
    """Rows of ``points`` at each distinct point ``pts`` of :func:`triangulation`.

    A row counts at the point that represents its set of near-duplicates
    (:func:`merge_near`: the first point of the set in input order).
    """
    p = np.asarray(points, dtype=float)
    label = near_labels(p)
    _, first = np.unique(label, return_index=True)
    where = {tuple(pts[i].tolist()): i for i in range(len(pts))}
    weight = np.zeros(len(pts), dtype=np.int64)
    for row in range(len(p)):
        weight[where[tuple(p[first[label[row]]].tolist())]] += 1
    return weight


def best_union(sets, components, weight):
    """Most rows a union of at most ``components`` of ``sets`` holds, by enumeration.

    ``weight[v]``: rows at point ``v``. Only sets that can beat the union
    ``L`` of the ``components`` heaviest are enumerated: a set ``X`` in a
    better choice weighs more than ``L - S``, ``S`` the total of the
    ``components - 1`` heaviest (the others add at most S).
    """
    if not sets:
        return 0

    def rows(union):
        return int(sum(weight[v] for v in union))

    heavy = sorted(sets, key=rows, reverse=True)
    sizes = [rows(s) for s in heavy]
    best = rows(frozenset().union(*heavy[:components]))
    floor = best - sum(sizes[: components - 1])
    candidates = [s for s in sets if rows(s) > floor]
    for size in range(1, components + 1):
        for choice in itertools.combinations(candidates, size):
            best = max(best, rows(frozenset().union(*choice)))
    return best


def coverage_curve(points, holes=False, components=(1, 2, 3), unit="rows"):
    """Best coverage, in rows, at every spectrum value, for several ``components``.

    Returns ``(n, radii, cover)``: the number of rows, the spectrum
    (ascending) and ``cover[c]``, the most rows ``c`` pieces hold at each
    radius. Stops once one piece covers every point (nothing changes after
    that for outliers). ``unit="locations"``: every distinct point weighs 1.
    """
    pts, simplices, neighbors, r = triangulation(points)
    weight = row_weights(points, pts)
    if unit == "locations":
        weight = np.ones(len(pts), dtype=np.int64)
    n = int(weight.sum())
    radii, cover = [], {c: [] for c in components}
    for R in spectrum(r):
        mask = (merged(r) <= R) if holes else filled_mask(neighbors, r, R)
        sets = piece_sets(simplices, neighbors, mask)
        radii.append(R)
        for c in components:
            cover[c].append(best_union(sets, c, weight))
        if max(map(len, sets), default=0) == len(pts):
            break
    return n, np.array(radii), {c: np.array(v) for c, v in cover.items()}


def budget(outliers, n):
    """k for a fraction of n rows (floor of q * n, to 9 decimals first) or a count."""
    if isinstance(outliers, int):
        return outliers
    return math.floor(round(outliers * n, 9))


def outlier_optimum_from_curve(curve, components, k):
    """Largest alpha whose best coverage is >= n - k rows: the first such radius.

    The first valid radius of the whole scan, so no monotonicity is assumed.
    Returns ``(alpha, rows left out)``.
    """
    n, radii, cover = curve
    ok = np.flatnonzero(cover[components] >= n - k)
    R = radii[ok[0]]
    return (1.0 / R if np.isfinite(R) else 0.0), int(n - cover[components][ok[0]])


def outlier_optimum(points, holes=False, components=1, outliers=0):
    """``(alpha, rows left out)`` of the outlier-tolerant optimum.

    A group whose budget k (in rows) is 0 has the optimum without outliers.
    """
    k = budget(outliers, len(points))
    if k == 0:
        return graph_optimum(points, holes=holes, components=components), 0
    curve = coverage_curve(points, holes=holes, components=(components,))
    return outlier_optimum_from_curve(curve, components, k)


#: How closely ``area_m2`` must match :func:`ellipsoid_areas`: 1e-9 of the
#: area, or 1e-4 m² (both Karney's implementations, GeographicLib's C in PROJ
#: and the Rust crate, sum per-edge terms as large as the area between the
#: edge and the equator, so a 10 m² polygon carries ~1e-5 m² of rounding,
#: which they round differently when a polygon crosses the prime meridian).
AREA_RTOL, AREA_ATOL = 1e-9, 1e-4


def ellipsoid_areas(hulls) -> np.ndarray:
    """Areas (m²) on the WGS84 ellipsoid of a result's geometries, by pyproj.

    Independent of geoalpha: the polygons moved to EPSG:4326 by geopandas,
    oriented (shell anticlockwise, holes clockwise) and measured with
    ``pyproj.Geod(ellps="WGS84").geometry_area_perimeter``.
    """
    import pyproj

    geod = pyproj.Geod(ellps="WGS84")
    lonlat = hulls.geometry.to_crs(4326).array
    return np.array(
        [
            0.0
            if g is None or g.is_empty
            else abs(geod.geometry_area_perimeter(shapely.orient_polygons(g))[0])
            for g in lonlat
        ]
    )


# --------------------------------------------------------------------------
# The sphere in 60 significant digits (issue #37): no float unit vectors
# --------------------------------------------------------------------------

_PI = Decimal("3.14159265358979323846264338327950288419716939937510582097494459")


def _dsin(x: Decimal) -> Decimal:
    """sin in decimal arithmetic (Taylor series after reduction to [-pi, pi])."""
    with localcontext() as ctx:
        ctx.prec = 60
        x = x % (2 * _PI)
        if x > _PI:
            x -= 2 * _PI
        term, total, k = x, x, 1
        while abs(term) > Decimal(10) ** -70:
            term *= -x * x / ((2 * k) * (2 * k + 1))
            total += term
            k += 1
        return +total


def decimal_unit(lon: float, lat: float) -> tuple:
    """The unit vector of a longitude and latitude in degrees, 60 digits."""
    with localcontext() as ctx:
        ctx.prec = 60
        lo = Decimal(float(lon)) * _PI / 180
        la = Decimal(float(lat)) * _PI / 180
        cos_la = _dsin(la + _PI / 2)
        return (cos_la * _dsin(lo + _PI / 2), cos_la * _dsin(lo), _dsin(la))


def _sub(a, b):
    return tuple(x - y for x, y in zip(a, b, strict=True))


def _dot(a, b):
    return sum(x * y for x, y in zip(a, b, strict=True))


def _cross(a, b):
    return (
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    )


def decimal_cap_radius(u, v, w) -> float:
    """Angular radius of the circle through three decimal unit vectors.

    The circumradius of their chord triangle, ``|ab| |bc| |ca| / (2 |ab x ac|)``,
    is the sine of the smaller cap's angular radius (a formula the kernel does
    not use), evaluated in 60 digits.
    """
    with localcontext() as ctx:
        ctx.prec = 60
        ab, bc, ca = (_dot(d, d).sqrt() for d in (_sub(v, u), _sub(w, v), _sub(u, w)))
        n = _cross(_sub(v, u), _sub(w, u))
        return math.asin(float(ab * bc * ca / (2 * _dot(n, n).sqrt())))


def decimal_sphere_optimum(lonlat, radius, holes=False, components=1) -> float:
    """Optimal alpha on the sphere of ``radius``, the unit vectors in 60 digits.

    The stereographic image from minus the points' mean direction (circles to
    circles) is computed in decimal arithmetic and rounded to floats relative
    to the first point, so it keeps offsets far below an ulp of the sphere;
    Qhull triangulates it (every point must be a vertex), and each triangle's
    radius is :func:`decimal_cap_radius`. Then :func:`mesh_optimum`.
    """
    u = [decimal_unit(*p) for p in lonlat]
    with localcontext() as ctx:
        ctx.prec = 60
        m = tuple(sum(v[k] for v in u) for k in range(3))
        c = tuple(x / _dot(m, m).sqrt() for x in m)
        e1 = _cross((Decimal(0), Decimal(0), Decimal(1)), c)
        e1 = tuple(x / _dot(e1, e1).sqrt() for x in e1)
        e2 = _cross(c, e1)
        img = [
            (2 * _dot(v, e1) / (1 + _dot(v, c)), 2 * _dot(v, e2) / (1 + _dot(v, c)))
            for v in u
        ]
        x0, y0 = img[0]
        plane = np.array([(float(x - x0), float(y - y0)) for x, y in img])
    d = Delaunay(plane)
    hull = len(np.unique(d.convex_hull))
    assert len(d.simplices) == 2 * len(plane) - hull - 2, "Qhull dropped a point"
    r = np.array([radius * decimal_cap_radius(*(u[i] for i in s)) for s in d.simplices])
    return mesh_optimum(len(plane), d.simplices, d.neighbors, r, holes, components)
