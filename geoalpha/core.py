"""Exact optimal alpha shapes on Delaunay triangulations, batched over groups.

Pure numpy/scipy: no pandas, no shapely. Everything works on many groups at
once: GEOS triangulates all groups in one call (through
:mod:`geoalpha.delaunay`, the one module here that imports shapely, loaded
when :func:`triangulate` runs), and only the groups it cannot do go one by
one to Qhull (scipy's :class:`~scipy.spatial.Delaunay`).

Notation (see ``DESIGN.md``): a triangle ``t`` of the Delaunay triangulation
has circumradius ``r(t)``; it is *solid* at ``alpha`` when ``alpha * r(t) <= 1``,
i.e. when ``r(t) <= R`` with ``R = 1 / alpha``. We work with the radius
threshold ``R`` throughout and convert to ``alpha`` only at the edges.

With ``holes=False`` every triangle gets a *fill radius* ``f(t)`` (the
max-min radius along dual paths to the outside of the convex hull) and the
filled shape at ``R`` is ``{t : f(t) <= R}``; with ``holes=True`` the weights
are the radii themselves. Both cases then share one machinery:

* coverage holds from ``R_cov = max_v min_{t ni v} w(t)`` on;
* the number of edge-connected pieces at ``R`` is
  ``#{t : w(t) <= R} - #{edges of weight <= R} + #{vertices of weight <= R}``:
  with holes kept, the edges of a minimum spanning forest of the dual graph
  weighted by ``max(w_a, w_b)`` and no vertices; with holes filled, all dual
  edges and the vertices inside the convex hull weighted by their largest
  ``w`` (Euler's formula; see :class:`Spectrum`).

Radii are ranked per group (each group's spectrum in its own range of
ranks), so all these counts at every spectrum value are running sums over
ranks: ``O(m)`` once the radii of each group are sorted, ``O(m log m)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse import csr_array
from scipy.sparse.csgraph import (
    breadth_first_order,
    connected_components,
    minimum_spanning_tree,
)
from scipy.spatial import Delaunay, QhullError

__all__ = [
    "Rings",
    "Spectrum",
    "Triangulation",
    "boundary_rings",
    "fill_radius",
    "merge_ties",
    "piece_labels",
    "radius_of_alpha",
    "triangulate",
]

#: Relative slack of the solid test ``r <= 1 / alpha`` when alpha comes from a
#: user (a float): ``1 / (1 / r)`` may differ from ``r`` by an ulp, and
#: ``alpha_shape(p, optimal_alpha(p))`` must give the optimal shape.
ALPHA_RTOL = 8 * np.finfo(float).eps

#: Circumradii that agree to this relative tolerance are one spectrum value.
TIE_RTOL = 1e-10


@dataclass(frozen=True)
class Triangulation:
    """Delaunay triangulations of many groups, concatenated.

    Attributes
    ----------
    xy : ndarray of shape (p, 2)
        The points sorted by group (duplicates included), in the input
        coordinates.
    local : ndarray of shape (p, 2)
        The same points relative to their group's first point (used for all
        metric computations, so that large offsets such as UTM northings lose
        no precision).
    point_group : ndarray of shape (p,)
        Group code of each point.
    point_ptr : ndarray of shape (G + 1,)
        Points of group ``g`` are ``point_ptr[g]:point_ptr[g + 1]``.
    input_point : ndarray of shape (n,)
        For each input row, its index in ``xy``.
    vertex : ndarray of shape (p,)
        For each point, the triangulation vertex that represents it: itself,
        or for a duplicate or a point that Qhull merged with a numerically
        coincident one (a "coplanar" point), that neighbour.
    n_distinct : ndarray of shape (G,)
        Distinct points of each group.
    triangles : ndarray of shape (m, 3)
        Vertex indices (into ``xy``) of every triangle, counter-clockwise.
    neighbors : ndarray of shape (m, 3)
        ``neighbors[t, j]`` is the triangle across the edge opposite vertex
        ``j`` of ``t``, or -1 on the convex hull.
    tri_group : ndarray of shape (m,)
        Group code of each triangle; triangles are contiguous by group.
    tri_ptr : ndarray of shape (G + 1,)
        Triangles of group ``g`` are ``tri_ptr[g]:tri_ptr[g + 1]``.
    radius : ndarray of shape (m,)
        Circumradius of each triangle (``inf`` for a flat one); radii equal up
        to :data:`TIE_RTOL` are merged (see :func:`merge_ties`).
    values : ndarray of shape (K,)
        The radius spectra of the groups: the distinct radii of each group,
        ascending, group after group.
    value_ptr : ndarray of shape (G + 1,)
        The spectrum of group ``g`` is ``values[value_ptr[g]:value_ptr[g + 1]]``.
    rank : ndarray of shape (m,)
        Rank of each triangle's radius in ``values`` (``radius == values[rank]``).
        The computations run on ranks, which are exact and, within a group,
        sort as radii do (ranks of different groups are never compared).
    area : ndarray of shape (m,)
        Area of each triangle.
    degenerate : ndarray of shape (G,)
        True for groups with fewer than 3 distinct points or all collinear
        (no triangle, hence no alpha).
    """

    xy: np.ndarray
    local: np.ndarray
    point_group: np.ndarray
    point_ptr: np.ndarray
    input_point: np.ndarray
    vertex: np.ndarray
    n_distinct: np.ndarray
    triangles: np.ndarray
    neighbors: np.ndarray
    tri_group: np.ndarray
    tri_ptr: np.ndarray
    radius: np.ndarray
    values: np.ndarray
    value_ptr: np.ndarray
    rank: np.ndarray
    area: np.ndarray
    degenerate: np.ndarray

    @property
    def n_groups(self) -> int:
        """Number of groups."""
        return len(self.point_ptr) - 1

    def dual_edges(self) -> tuple[np.ndarray, np.ndarray]:
        """Return each pair of edge-adjacent triangles once, as ``(a, b)``, a < b.

        Pairs are listed by ``a`` (non-decreasing). Computed once per
        triangulation and cached.
        """
        cached = self.__dict__.get("_dual_edges")
        if cached is None:
            a = np.repeat(np.arange(len(self.triangles)), 3)
            b = self.neighbors.ravel()
            keep = b > a
            cached = (a[keep], b[keep])
            object.__setattr__(self, "_dual_edges", cached)
        return cached

    def rank_of(self, radius, group=None) -> np.ndarray:
        """Rank of the largest value of each group's spectrum that is <= ``radius``.

        Parameters
        ----------
        radius : array_like of float
            Radius thresholds, one per entry of ``group`` (or broadcast).
        group : array_like of int, optional
            Group codes; default: every group, ``0 .. G-1``.

        Returns
        -------
        ndarray of int
            Ranks into ``values``; ``value_ptr[g] - 1`` where no radius of
            group ``g`` is <= the threshold (no triangle is solid).

        Examples
        --------
        >>> tri = triangulate([[0, 0], [2, 0], [0, 2], [2, 2.1]])
        >>> tri.values.round(4).tolist()
        [1.4142, 1.416]
        >>> tri.rank_of([1.415, 1.0, 9.0], group=[0, 0, 0]).tolist()
        [0, -1, 1]
        """
        group = np.arange(self.n_groups) if group is None else group
        group = np.asarray(group, dtype=np.int64)
        radius = np.broadcast_to(np.asarray(radius, dtype=float), group.shape)
        cached = self.__dict__.get("_value_lookup")
        if cached is None:
            # Every value's index among all distinct values, offset by group:
            # sorted, since each group's values are.
            distinct, index = np.unique(self.values, return_inverse=True)
            key = self.value_group() * (len(distinct) + 1) + index.ravel()
            cached = (distinct, key)
            object.__setattr__(self, "_value_lookup", cached)
        distinct, key = cached
        below = np.searchsorted(distinct, radius, side="right") - 1
        query = group * (len(distinct) + 1) + below
        return np.searchsorted(key, query, side="right") - 1

    def value_group(self) -> np.ndarray:
        """Return the group of each spectrum value (shape ``(K,)``), cached."""
        cached = self.__dict__.get("_value_group")
        if cached is None:
            cached = np.repeat(np.arange(self.n_groups), np.diff(self.value_ptr))
            object.__setattr__(self, "_value_group", cached)
        return cached


def _check_points(points) -> np.ndarray:
    xy = np.asarray(points, dtype=float)
    if xy.size == 0:  # no points at all, however they were spelled ([], (0, 2))
        return np.empty((0, 2))
    if xy.ndim != 2 or xy.shape[1] != 2:
        raise ValueError(
            f"points must be an (n, 2) array of x, y; got shape {xy.shape}"
        )
    bad = np.flatnonzero(~np.isfinite(xy).all(axis=1))
    if len(bad):
        shown = ", ".join(map(str, bad[:10])) + (", ..." if len(bad) > 10 else "")
        raise ValueError(
            f"points must have finite coordinates; got NaN or inf in {len(bad)} "
            f"row(s) (positions {shown})"
        )
    return xy


def _group_codes(groups, n: int, n_groups: int | None) -> tuple[np.ndarray, int]:
    if groups is None:
        return np.zeros(n, dtype=np.int64), 1 if n_groups is None else n_groups
    codes = np.asarray(groups)
    if codes.shape != (n,) or not np.issubdtype(codes.dtype, np.integer):
        raise ValueError(
            f"groups must be {n} integer group codes (one per point); got "
            f"{codes.dtype} array of shape {codes.shape}"
        )
    codes = codes.astype(np.int64, copy=False)
    if n and codes.min() < 0:
        raise ValueError("groups must be codes >= 0 (as from pandas.factorize)")
    size = int(codes.max()) + 1 if n else 0
    if n_groups is None:
        n_groups = size
    elif n_groups < size:
        raise ValueError(f"n_groups={n_groups} but groups has code {size - 1}")
    return codes, n_groups


def triangulate(
    points, groups=None, *, n_groups: int | None = None, progress=None
) -> Triangulation:
    """Delaunay-triangulate the distinct points of every group.

    Parameters
    ----------
    points : array_like of shape (n, 2)
        Planar coordinates (a metric CRS for meaningful alphas).
    groups : array_like of shape (n,), optional
        Integer group code ``0 .. G-1`` of each point; all one group if None.
    n_groups : int, optional
        Number of groups ``G`` (default: largest code + 1); codes without a
        point make empty, degenerate groups.
    progress : object with an ``update(n)`` method, optional
        Told how many groups were triangulated, every 256 groups (a
        ``tqdm`` bar fits).

    Returns
    -------
    Triangulation

    Raises
    ------
    ValueError
        If coordinates are NaN/inf (the message names the rows) or the
        shapes do not fit.

    Examples
    --------
    >>> tri = triangulate([[0, 0], [1, 0], [0, 1], [1, 1], [1, 1]])
    >>> tri.n_distinct.tolist(), len(tri.triangles), tri.degenerate.tolist()
    ([4], 2, [False])
    """
    xy_in = _check_points(points)
    n = len(xy_in)
    codes, n_groups = _group_codes(groups, n, n_groups)

    # Points sorted by group (a no-op when they already are). Duplicates stay:
    # GEOS and Qhull keep one of them as the vertex (Qhull reports the others
    # as "coplanar" points), and they map to that vertex below.
    if n > 1 and (codes[1:] < codes[:-1]).any():
        order = np.argsort(codes, kind="stable")
        xy, point_group = xy_in[order], codes[order]
    else:
        order = np.arange(n)
        xy, point_group = xy_in, codes
    input_point = np.empty(n, dtype=np.int64)
    input_point[order] = np.arange(n)

    counts = np.bincount(point_group, minlength=n_groups)
    point_ptr = np.zeros(n_groups + 1, dtype=np.int64)
    np.cumsum(counts, out=point_ptr[1:])
    # Origin of each group: its first distinct point. Differences of nearby
    # floats are exact (Sterbenz), so gridded data stay exactly gridded.
    origin = xy[np.minimum(point_ptr[:-1], max(len(xy) - 1, 0))] if len(xy) else xy
    local = xy - origin[point_group]

    # GEOS triangulates all groups in one call (geoalpha.delaunay); the groups
    # where its output is not a valid triangulation go to Qhull, one by one.
    from geoalpha.delaunay import triangulate_groups

    degenerate = counts < 3
    todo = np.flatnonzero(~degenerate)
    batch = triangulate_groups(local, point_ptr, todo, progress)
    ntri = np.zeros(n_groups, np.int64)
    ntri[todo] = batch.n_triangles
    simplices, neighbors, block_group = [batch.triangles], [batch.neighbors], []
    moved = np.flatnonzero(batch.vertex != np.arange(len(xy)))  # duplicates
    coplanar = [np.column_stack([moved, batch.vertex[moved]])]
    first = len(batch.triangles)  # neighbours index the blocks concatenated
    for g in todo[batch.failed].tolist():
        s, e = point_ptr[g], point_ptr[g + 1]
        try:
            d = Delaunay(local[s:e])
        except QhullError:  # all (numerically) collinear
            degenerate[g] = True
            continue
        simplices.append(d.simplices + s)
        neighbors.append(np.where(d.neighbors >= 0, d.neighbors + first, -1))
        block_group.append(np.full(len(d.simplices), g))
        first += len(d.simplices)
        ntri[g] = len(d.simplices)
        if len(d.coplanar):
            coplanar.append(d.coplanar[:, [0, 2]] + s)

    tri_ptr = np.zeros(n_groups + 1, dtype=np.int64)
    np.cumsum(ntri, out=tri_ptr[1:])
    tri_group = np.repeat(np.arange(n_groups), ntri)
    triangles = np.concatenate(simplices).astype(np.int64)
    nb = np.concatenate(neighbors).astype(np.int64)
    if block_group:  # put Qhull's triangles in their groups' place
        order = np.argsort(
            np.concatenate([np.repeat(todo, batch.n_triangles), *block_group]),
            kind="stable",
        )
        new = np.empty_like(order)
        new[order] = np.arange(len(order))
        triangles = triangles[order]
        nb = np.where(nb >= 0, new[np.maximum(nb, 0)], -1)[order]

    # Orient every triangle counter-clockwise (swap vertices 1, 2 and the
    # neighbours opposite them where Qhull gave them clockwise).
    twice_area, edges2_product = _edges_and_cross(xy, triangles)
    cw = twice_area < 0
    triangles[cw] = triangles[cw][:, [0, 2, 1]]
    nb[cw] = nb[cw][:, [0, 2, 1]]
    cross = np.abs(twice_area)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        circumradius = np.sqrt(edges2_product) / (2.0 * cross)
    circumradius[~(cross > 0)] = np.inf
    radius, rank, values = merge_ties(circumradius, tri_group)
    value_group = np.empty(len(values), dtype=np.int64)
    value_group[rank] = tri_group
    area = np.abs(cross) / 2.0

    # Points Qhull merged with a nearby vertex are represented by it.
    vertex = np.arange(len(xy))
    n_distinct = counts.copy()
    cp = np.concatenate(coplanar)
    if len(cp):
        vertex[cp[:, 0]] = cp[:, 1]
        same = (xy[cp[:, 0]] == xy[cp[:, 1]]).all(axis=1)
        n_distinct -= np.bincount(point_group[cp[same, 0]], minlength=n_groups)
    n_distinct[degenerate] = _distinct_counts(xy, point_group, degenerate, n_groups)[
        degenerate
    ]

    return Triangulation(
        xy=xy,
        local=local,
        point_group=point_group,
        point_ptr=point_ptr,
        input_point=input_point,
        vertex=vertex,
        n_distinct=n_distinct,
        triangles=triangles,
        neighbors=nb,
        tri_group=tri_group,
        tri_ptr=tri_ptr,
        radius=radius,
        values=values,
        value_ptr=_offsets(value_group, n_groups),
        rank=rank,
        area=area,
        degenerate=degenerate,
    )


def _distinct_counts(xy, point_group, which, n_groups) -> np.ndarray:
    """Distinct points per group, counted for the groups in ``which`` only."""
    sel = np.flatnonzero(which[point_group])
    out = np.zeros(n_groups, dtype=np.int64)
    if len(sel):
        p, g = xy[sel], point_group[sel]
        o = np.lexsort((p[:, 1], p[:, 0], g))
        p, g = p[o], g[o]
        new = np.ones(len(sel), dtype=bool)
        new[1:] = (g[1:] != g[:-1]) | (p[1:] != p[:-1]).any(axis=1)
        out += np.bincount(g[new], minlength=n_groups)
    return out


def _edges_and_cross(xy: np.ndarray, triangles: np.ndarray):
    """Twice the signed area and the product of the squared edge lengths.

    Edge vectors are differences of the input coordinates (exact for nearby
    points, Sterbenz), and the cross product is taken at the vertex opposite
    the longest edge, between the two shorter edges: the best conditioned of
    the three choices, so that needle triangles (near-duplicate points) keep
    their circumradius ``|ab| |bc| |ca| / (2 |cross|)`` to a few ulps.
    """
    x, y = np.ascontiguousarray(xy[:, 0]), np.ascontiguousarray(xy[:, 1])
    px = [x[triangles[:, k]] for k in range(3)]
    py = [y[triangles[:, k]] for k in range(3)]
    # Edge k runs from vertex k to vertex k+1 and is opposite vertex k+2.
    dx = [px[(k + 1) % 3] - px[k] for k in range(3)]
    dy = [py[(k + 1) % 3] - py[k] for k in range(3)]
    e2 = [dx[k] * dx[k] + dy[k] * dy[k] for k in range(3)]

    def cross_at(k):  # between edge k (out of vertex k) and edge k-1 reversed
        return dy[k] * dx[k - 1] - dx[k] * dy[k - 1]

    # The longest edge (the first of equals) and the vertex opposite it.
    first = (e2[0] >= e2[1]) & (e2[0] >= e2[2])
    second = ~first & (e2[1] >= e2[2])
    cross = np.where(first, cross_at(2), np.where(second, cross_at(0), cross_at(1)))
    return cross, e2[0] * e2[1] * e2[2]


def merge_ties(
    radius: np.ndarray, group: np.ndarray | None = None, rtol: float = TIE_RTOL
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Give radii that agree to ``rtol`` (relative) the largest of their values.

    Cocircular points (grids, rounded coordinates) have triangles with the same
    circumradius in exact arithmetic, which rounding splits by an ulp or two.
    Merging them keeps such triangles entering the shape together, as the
    definition wants. Runs of values each within ``rtol`` of the previous one
    form one value. With ``group`` given (non-decreasing codes), only radii of
    the same group are merged, so that a group's result never depends on the
    other groups, and the distinct values are listed group by group.

    Returns
    -------
    merged : ndarray
        The merged radii, same shape as ``radius``.
    rank : ndarray of int
        Index of each merged radius in ``values``.
    values : ndarray
        The distinct merged radii (``merged == values[rank]``): ascending, or
        with ``group``, ascending within each group, groups in order (so that
        ranks compare as radii within a group).

    Examples
    --------
    >>> merged, rank, values = merge_ties(np.array([2.0, 1.0, 1.0 + 1e-15]))
    >>> merged.tolist(), rank.tolist(), values.tolist()
    ([2.0, 1.000000000000001, 1.000000000000001], [1, 0, 0], [1.000000000000001, 2.0])
    >>> merge_ties(np.array([2.0, 1.0, 3.0]), np.array([0, 0, 1]))[1].tolist()
    [1, 0, 2]
    """
    if len(radius) == 0:
        return radius, np.zeros(0, dtype=np.int64), radius
    order = np.argsort(radius)
    if group is not None:
        # Then stably by group: a radix sort when the codes fit 16 bits.
        g = group[order]
        span = int(g.max()) - int(g.min())
        if span < 2**16:
            g = (g - g.min()).astype(np.uint16)
        order = order[np.argsort(g, kind="stable")]
    s = radius[order]
    start = np.ones(len(s), dtype=bool)
    start[1:] = s[1:] > s[:-1] * (1.0 + rtol)
    if group is not None:
        g = group[order]
        start[1:] |= g[1:] != g[:-1]
    values = np.maximum.reduceat(s, np.flatnonzero(start))
    rank = np.empty(len(radius), dtype=np.int64)
    rank[order] = np.cumsum(start) - 1
    return values[rank], rank, values


def fill_radius(tri: Triangulation) -> np.ndarray:
    """Fill radius of every triangle, as a rank into ``tri.values``.

    A triangle that is not solid at ``R`` is filled in when every dual path
    from it to the outside of the convex hull passes through a solid
    triangle. So it belongs to the filled shape exactly when
    ``R >= f(t)``, where ``f(t)`` is the widest-path (max-min) value of the
    circumradius along dual paths from ``t`` to the outside. Computed for all
    groups at once with one maximum spanning tree rooted at a shared
    "outside" node, then path minima by pointer jumping, all on radius ranks.

    Parameters
    ----------
    tri : Triangulation

    Returns
    -------
    ndarray of int, shape (m,)
        Rank of ``f(t)`` in ``tri.values``; ``f(t) <= r(t)``.

    Examples
    --------
    >>> tri = triangulate([[0, 0], [2, 0], [2, 2], [0, 2], [1, 1.9]])
    >>> bool((tri.values[fill_radius(tri)] <= tri.radius).all())
    True
    """
    m = len(tri.triangles)
    rank = tri.rank
    if m == 0:
        return rank.copy()
    top = len(tri.values)  # rank of the outside: above every radius
    a, b = tri.dual_edges()
    nb = tri.neighbors
    hull = np.flatnonzero((nb[:, 0] < 0) | (nb[:, 1] < 0) | (nb[:, 2] < 0))
    outside = m
    # The graph in CSR form: row t holds the dual edges (t, b), t < b (listed
    # by t already), and the outside's row the triangles on the convex hull.
    indptr = np.zeros(m + 2, dtype=np.int64)
    np.cumsum(np.bincount(a, minlength=m + 1), out=indptr[1:])
    indptr[-1] += len(hull)
    w = np.concatenate([np.minimum(rank[a], rank[b]), rank[hull]])
    # Maximum spanning tree = minimum spanning tree on reversed ranks (> 0).
    graph = csr_array(
        ((top - w).astype(float), np.concatenate([b, hull]), indptr),
        shape=(m + 1, m + 1),
    )
    tree = minimum_spanning_tree(graph, overwrite=True)
    _, parent = breadth_first_order(
        tree, outside, directed=False, return_predecessors=True
    )
    parent[outside] = outside
    r_ext = np.append(rank, top)
    # Edge weight towards the parent is min(rank[t], rank[parent]); the fill
    # radius is the minimum over the path to the root.
    val = np.minimum(r_ext, r_ext[parent])
    while True:
        grand = parent[parent]
        if np.array_equal(grand, parent):
            break
        val = np.minimum(val, val[parent])
        parent = grand
    return val[:m]


def _offsets(group: np.ndarray, n_groups: int) -> np.ndarray:
    """Offsets ``ptr`` (shape ``(G + 1,)``) of items sorted by ``group``."""
    ptr = np.zeros(n_groups + 1, dtype=np.int64)
    np.cumsum(np.bincount(group, minlength=n_groups), out=ptr[1:])
    return ptr


@dataclass(frozen=True)
class Spectrum:
    """Validity oracle for one weight per triangle (radius or fill radius).

    Weights are ranks into the radius spectra ``tri.values``. For every rank
    ``k`` (a value of some group's spectrum) the oracle holds the number of
    edge-connected pieces of that group's shape ``{t : w(t) <= k}``, and for
    every group the rank from which the shape covers every point: ``O(m)``
    to set up, ``O(1)`` per query.

    The number of pieces is counted as
    ``#triangles - #edges + #vertices`` with weights ``<= k``:

    * ``filled=False`` (any weights): the edges are those of a minimum
      spanning forest of the dual graph (weight of a dual edge: the larger
      weight of its two triangles), no vertices;
    * ``filled=True`` (weights whose shapes have no holes at any ``k``, such
      as fill radii): all dual edges, and the vertices inside the convex hull
      with the weight of their last triangle. This is Euler's formula for the
      plane graph of the shape's dual, whose bounded faces are exactly those
      vertices when no triangle outside the shape is enclosed by it, so no
      spanning forest is needed.

    Attributes
    ----------
    tri : Triangulation
        The triangulation (its ``values``, ``value_ptr`` and ``rank_of``).
    pieces : ndarray of shape (K,)
        Pieces of the shape at each rank (of the rank's group).
    cover : ndarray of shape (G,)
        Smallest rank at which every point of the group is covered (``K``
        for degenerate groups).
    """

    tri: Triangulation
    pieces: np.ndarray
    cover: np.ndarray

    @classmethod
    def build(cls, tri: Triangulation, rank: np.ndarray, *, filled=False) -> Spectrum:
        """Set up the oracle for weights ``rank`` (one per triangle of ``tri``).

        Parameters
        ----------
        tri : Triangulation
        rank : ndarray of int, shape (m,)
            Weight of every triangle, as a rank into ``tri.values``.
        filled : bool, default False
            True if no shape ``{t : rank[t] <= k}`` has a hole, i.e. every
            triangle outside it reaches the outside of the convex hull through
            edges of triangles outside it (true of :func:`fill_radius`);
            the pieces are then counted with Euler's formula instead of a
            spanning forest.

        Examples
        --------
        >>> tri = triangulate([[0, 0], [2, 0], [2, 2], [0, 2], [1, 1]])
        >>> spectrum = Spectrum.build(tri, fill_radius(tri), filled=True)
        >>> spectrum.pieces.tolist(), spectrum.optimum().tolist()
        ([1], [0])
        """
        m, G, K = len(tri.triangles), tri.n_groups, len(tri.values)
        value_group = tri.value_group()

        def at_or_below(weight, group, ptr=None):
            # Items of each rank's group with weight <= the rank. Groups are
            # rank ranges, so a running count over all ranks, minus the items
            # of the groups before, counts them.
            ptr = _offsets(group, G) if ptr is None else ptr
            return np.cumsum(np.bincount(weight, minlength=K)) - ptr[value_group]

        # Coverage: each vertex needs one incident triangle in the shape.
        p = len(tri.xy)
        corner = tri.triangles.ravel()
        corner_rank = np.repeat(rank, 3)
        vmin = np.full(p, K, dtype=np.int64)
        np.minimum.at(vmin, corner, corner_rank)
        is_vertex = vmin < K
        cover = np.full(G, -1, dtype=np.int64)
        np.maximum.at(cover, tri.point_group[is_vertex], vmin[is_vertex])
        cover[tri.degenerate] = K

        pieces = at_or_below(rank, tri.tri_group, tri.tri_ptr)
        a, b = tri.dual_edges()
        if filled:
            pieces -= at_or_below(np.maximum(rank[a], rank[b]), tri.tri_group[a])
            vmax = np.full(p, -1, dtype=np.int64)
            np.maximum.at(vmax, corner, corner_rank)
            t, j = np.nonzero(tri.neighbors < 0)  # hull edges: not inner vertices
            vmax[tri.triangles[t, (j + 1) % 3]] = -1
            vmax[tri.triangles[t, (j + 2) % 3]] = -1
            inner = np.flatnonzero(vmax >= 0)
            pieces += at_or_below(vmax[inner], tri.point_group[inner])
        elif m:
            edge_rank = np.maximum(rank[a], rank[b])
            graph = csr_array(((edge_rank + 1).astype(float), (a, b)), shape=(m, m))
            forest = minimum_spanning_tree(graph, overwrite=True).tocoo()
            f_rank = np.asarray(forest.data, dtype=np.int64) - 1
            f_group = tri.tri_group[np.asarray(forest.row, dtype=np.int64)]
            pieces -= at_or_below(f_rank, f_group)
        return cls(tri, pieces, cover)

    def pieces_at_rank(self, group: np.ndarray, rank: np.ndarray) -> np.ndarray:
        """Count the pieces of each group's shape with weights of rank <= ``rank``."""
        group, rank = np.broadcast_arrays(group, rank)
        ptr = self.tri.value_ptr
        rank = np.minimum(rank, ptr[group + 1] - 1)  # K: every triangle
        some = rank >= ptr[group]  # else no triangle is in
        n = np.zeros(group.shape, dtype=np.int64)
        n[some] = self.pieces[rank[some]]
        return n

    def valid(self, group, radius, components: int = 1) -> np.ndarray:
        """Test coverage and at most ``components`` pieces at ``radius``."""
        group = np.asarray(group, dtype=np.int64)
        rank = self.tri.rank_of(radius, group)
        n = self.pieces_at_rank(group, rank)
        return (rank >= self.cover[group]) & (n >= 1) & (n <= components)

    def optimum(self, components: int = 1) -> np.ndarray:
        """Smallest valid rank of every group (``K`` where there is none).

        Every value of the group's spectrum is a candidate, so the result is
        the true minimum even where validity is not monotone. (The first
        valid rank is a weight: the shape at any rank is the shape at the
        largest weight below it.)
        """
        K, G = len(self.pieces), len(self.cover)
        group = self.tri.value_group()
        n = self.pieces
        ok = np.flatnonzero(
            (np.arange(K) >= self.cover[group]) & (n >= 1) & (n <= components)
        )
        first = np.ones(len(ok), dtype=bool)
        first[1:] = group[ok[1:]] != group[ok[:-1]]
        best = np.full(G, K, dtype=np.int64)
        best[group[ok[first]]] = ok[first]
        return best


def radius_of_alpha(alpha) -> np.ndarray:
    """Radius threshold ``1 / alpha`` (``inf`` for 0) with a few ulps of slack.

    The slack (:data:`ALPHA_RTOL`) makes ``alpha * r <= 1`` hold for the
    triangle ``r = 1 / alpha`` came from despite rounding.

    Examples
    --------
    >>> radius_of_alpha([0.5, 0.0]).round(12).tolist()
    [2.0, inf]
    """
    alpha = np.asarray(alpha, dtype=float)
    with np.errstate(divide="ignore"):
        return np.where(alpha > 0, (1.0 / alpha) * (1.0 + ALPHA_RTOL), np.inf)


def piece_labels(
    tri: Triangulation, inside: np.ndarray, n_pieces: np.ndarray | None = None
) -> np.ndarray:
    """Label the edge-connected pieces of the triangles where ``inside`` is True.

    Parameters
    ----------
    tri : Triangulation
    inside : ndarray of bool, shape (m,)
    n_pieces : ndarray of shape (G,), optional
        Number of pieces of each group if known (from a :class:`Spectrum`):
        where every group has at most one, the pieces are the groups and no
        graph search is needed.

    Returns
    -------
    ndarray of shape (m,)
        Labels ``0 .. P-1`` numbered by group (pieces of group 0 first) and
        -1 for triangles outside the shape.

    Examples
    --------
    >>> tri = triangulate([[0, 0], [2, 0], [2, 2], [0, 2], [1, 1]])
    >>> piece_labels(tri, np.ones(len(tri.triangles), dtype=bool)).tolist()
    [0, 0, 0, 0]
    """
    if n_pieces is not None and (n_pieces <= 1).all():
        label = np.full(len(inside), -1, dtype=np.int64)
        first = np.cumsum(n_pieces) - n_pieces
        label[inside] = first[tri.tri_group[inside]]
        return label
    m = len(tri.triangles)
    a, b = tri.dual_edges()
    keep = inside[a] & inside[b]
    graph = csr_array((np.ones(keep.sum()), (a[keep], b[keep])), shape=(m, m))
    n, raw = connected_components(graph, directed=False)
    used = np.zeros(n, dtype=bool)
    used[raw[inside]] = True
    label = (np.cumsum(used) - 1)[raw]
    label[~inside] = -1
    # scipy numbers components by their smallest node, and triangles are
    # sorted by group, so labels follow groups; make sure of it.
    first = np.full(int(used.sum()), m, dtype=np.int64)
    sel = np.flatnonzero(inside)
    np.minimum.at(first, label[sel], sel)
    if len(first) and not (np.diff(first) > 0).all():  # pragma: no cover
        order = np.argsort(first, kind="stable")
        new = np.empty_like(order)
        new[order] = np.arange(len(order))
        label[sel] = new[label[sel]]
    return label


@dataclass(frozen=True)
class Rings:
    """Boundary rings of the pieces of a shape, ready for polygon assembly.

    Attributes
    ----------
    vertex : ndarray of shape (k,)
        Point index (into ``Triangulation.xy``) of each ring vertex, rings one
        after another, each listed once (not closed).
    ring : ndarray of shape (k,)
        Ring number of each vertex, ``0 .. R-1``, non-decreasing.
    ring_piece : ndarray of shape (R,)
        Piece number of each ring; the shell of a piece comes before its holes.
    piece_group : ndarray of shape (P,)
        Group code of each piece, non-decreasing.
    """

    vertex: np.ndarray
    ring: np.ndarray
    ring_piece: np.ndarray
    piece_group: np.ndarray


def boundary_rings(tri: Triangulation, inside: np.ndarray, piece: np.ndarray) -> Rings:
    """Trace the boundary of every piece of a shape into closed rings.

    Each boundary edge is directed with the shape on its left. At a vertex
    where a piece's boundary touches itself, the ring turns through the
    exterior wedge (the first outgoing edge counter-clockwise from the
    reversed incoming one), so shells and holes that touch at a vertex become
    separate rings, as valid OGC polygons want. Rings are ordered with the
    list-ranking (pointer jumping) technique, with no loop over edges.

    Parameters
    ----------
    tri : Triangulation
    inside : ndarray of bool, shape (m,)
        Triangles in the shape.
    piece : ndarray of shape (m,)
        Piece labels from :func:`piece_labels`.

    Returns
    -------
    Rings

    Examples
    --------
    >>> tri = triangulate([[0, 0], [2, 0], [2, 2], [0, 2], [1, 1]])
    >>> inside = np.ones(len(tri.triangles), dtype=bool)
    >>> rings = boundary_rings(tri, inside, piece_labels(tri, inside))
    >>> len(rings.vertex), rings.ring_piece.tolist(), rings.piece_group.tolist()
    (4, [0], [0])
    """
    t = np.repeat(np.arange(len(tri.triangles)), 3)
    j = np.tile(np.arange(3), len(tri.triangles))
    nb = tri.neighbors.ravel()
    border = inside[t] & ((nb < 0) | ~inside[np.maximum(nb, 0)])
    t, j = t[border], j[border]
    u = tri.triangles[t, (j + 1) % 3]
    v = tri.triangles[t, (j + 2) % 3]
    pc = piece[t]
    n_edges = len(t)
    n_pieces = int(piece.max()) + 1 if len(piece) and piece.max() >= 0 else 0
    piece_group = np.zeros(n_pieces, dtype=np.int64)
    piece_group[pc] = tri.tri_group[t]
    if n_edges == 0:
        empty = np.empty(0, dtype=np.int64)
        return Rings(empty, empty, empty, piece_group)

    # Successor of each edge: an outgoing edge of the same piece at its head.
    stride = len(tri.xy)
    out_key = pc * stride + u
    order = np.argsort(out_key, kind="stable")
    sorted_key = out_key[order]
    in_key = pc * stride + v
    lo = np.searchsorted(sorted_key, in_key, side="left")
    hi = np.searchsorted(sorted_key, in_key, side="right")
    nxt = order[lo]
    pinch = np.flatnonzero(hi - lo > 1)
    if len(pinch):
        nxt[pinch] = _turn_through_exterior(tri.local, u, v, order, lo, hi, pinch)

    # Rings are the cycles of the successor permutation.
    graph = csr_array((np.ones(n_edges), (np.arange(n_edges), nxt)), (n_edges,) * 2)
    n_rings, label = connected_components(graph, directed=True, connection="weak")
    root = np.full(n_rings, n_edges, dtype=np.int64)
    np.minimum.at(root, label, np.arange(n_edges))
    # List ranking: distance of each edge to the last edge before the root.
    succ = np.where(nxt == root[label], np.arange(n_edges), nxt)
    dist = (succ != np.arange(n_edges)).astype(np.int64)
    while True:
        jump = succ[succ]
        if np.array_equal(jump, succ):
            break
        dist = dist + dist[succ]
        succ = jump
    length = np.bincount(label, minlength=n_rings)
    position = length[label] - 1 - dist

    # Shell (counter-clockwise, positive area) first within each piece.
    pu, pv = tri.local[u], tri.local[v]
    area2 = np.bincount(
        label, weights=pu[:, 0] * pv[:, 1] - pv[:, 0] * pu[:, 1], minlength=n_rings
    )
    ring_piece_raw = pc[root]
    ring_order = np.lexsort((np.arange(n_rings), area2 <= 0, ring_piece_raw))
    ring_new = np.empty(n_rings, dtype=np.int64)
    ring_new[ring_order] = np.arange(n_rings)
    ring = ring_new[label]
    edge_order = np.lexsort((position, ring))
    return Rings(
        vertex=u[edge_order],
        ring=ring[edge_order],
        ring_piece=ring_piece_raw[ring_order],
        piece_group=piece_group,
    )


def _turn_through_exterior(local, u, v, order, lo, hi, pinch) -> np.ndarray:
    """Successor at pinch vertices: first outgoing edge CCW from the reverse edge."""
    count = hi[pinch] - lo[pinch]
    edge = np.repeat(pinch, count)
    start = np.repeat(lo[pinch], count)
    offset = np.arange(len(edge)) - np.repeat(np.cumsum(count) - count, count)
    cand = order[start + offset]
    head = local[v[edge]]
    back = local[u[edge]] - head
    ahead = local[v[cand]] - head
    turn = np.mod(
        np.arctan2(ahead[:, 1], ahead[:, 0]) - np.arctan2(back[:, 1], back[:, 0]),
        2 * np.pi,
    )
    best = np.lexsort((turn, edge))
    first = np.ones(len(best), dtype=bool)
    first[1:] = edge[best][1:] != edge[best][:-1]
    return cand[best][first]
