"""Exact optimal alpha shapes on Delaunay triangulations, batched over groups.

Pure numpy/scipy: no pandas, no shapely. Everything works on many groups at
once: a batched triangulation backend handed in by the caller (the array API
passes GEOS, :func:`geoalpha.delaunay.triangulate_groups`, which triangulates
all groups in one call) hands index arrays to :func:`triangulate`, and only
the groups it cannot do go one by one to Qhull (scipy's
:class:`~scipy.spatial.Delaunay`), as does everything without a backend.

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
from scipy.spatial import Delaunay, QhullError, cKDTree

from geoalpha.errors import first_n

__all__ = [
    "NEAR_RTOL",
    "Rings",
    "Spectrum",
    "Triangulation",
    "boundary_rings",
    "collinear_groups",
    "exact_duplicates",
    "fill_radius",
    "hash64",
    "merge_ties",
    "piece_labels",
    "radius_of_alpha",
    "radix_argsort",
    "thin_groups",
    "triangulate",
]

#: Relative slack of the solid test ``r <= 1 / alpha`` when alpha comes from a
#: user (a float): ``1 / (1 / r)`` may differ from ``r`` by an ulp, and
#: ``alpha_shape(p, optimal_alpha(p))`` must give the optimal shape.
ALPHA_RTOL = 8 * np.finfo(float).eps

#: Circumradii that agree to this relative tolerance are one spectrum value.
TIE_RTOL = 1e-10

#: Near-degeneracy tolerance, relative to a group's extent (the larger side
#: of its bounding box): points closer than this are one point, and a group
#: whose points all lie within this distance of a line is degenerate.
NEAR_RTOL = 1e-9
#: Floor of that tolerance, in units in the last place of the group's
#: largest coordinate (the resolution of its float64 coordinates).
PRECISION_ULPS = 64
#: Coordinates beyond this magnitude are refused (their squares overflow).
MAX_COORDINATE = 1e100


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
    distinct : ndarray of bool, shape (p,)
        Whether the point counts as a distinct point of its group: one point
        of each set of exact duplicates or of points merged as
        near-duplicates (its ``vertex``), and points that Qhull set aside
        farther than the tolerance from their vertex. In a non-degenerate
        group they number ``n_distinct``.
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
    distinct: np.ndarray
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
            nb = self.neighbors
            at = np.flatnonzero(nb > np.arange(len(nb))[:, None])
            cached = (at // 3, nb.ravel()[at])
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
    raw = np.asarray(points)
    if raw.size and not (
        np.issubdtype(raw.dtype, np.integer) or np.issubdtype(raw.dtype, np.floating)
    ):
        raise ValueError(
            f"points must be numbers (an (n, 2) array of x, y); got {raw.dtype} values"
        )
    xy = raw.astype(float, copy=False)
    if xy.size == 0:  # no points at all, however they were spelled ([], (0, 2))
        return np.empty((0, 2))
    if xy.ndim != 2 or xy.shape[1] != 2:
        raise ValueError(
            f"points must be an (n, 2) array of x, y; got shape {xy.shape}"
        )
    # One reduction over all values; the rows only when something is wrong
    # (row-wise reductions over two columns cost ten times more).
    largest = np.abs(xy).max()
    if largest <= MAX_COORDINATE:  # False for NaN too
        return xy
    bad = np.flatnonzero(~np.isfinite(xy).all(axis=1))
    if len(bad):
        shown = first_n(bad)
        raise ValueError(
            f"points must have finite coordinates; got NaN or inf in {len(bad)} "
            f"row(s) (positions {shown})"
        )
    huge = np.flatnonzero((np.abs(xy) > MAX_COORDINATE).any(axis=1))
    if len(huge):
        shown = ", ".join(map(str, huge[:10])) + (", ..." if len(huge) > 10 else "")
        raise ValueError(
            f"points must have coordinates within +-{MAX_COORDINATE:g} (their "
            f"squares would overflow); got larger values in {len(huge)} row(s) "
            f"(positions {shown}): rescale them"
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
    points,
    groups=None,
    *,
    n_groups: int | None = None,
    progress=None,
    degenerate=None,
    backend=None,
    out_coords=None,
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
    degenerate : array_like of bool, shape (G,), optional
        Groups to treat as degenerate whatever their points (e.g. groups found
        collinear in the coordinates the result is returned in).
    backend : callable, optional
        Batched Delaunay triangulation ``backend(local, point_ptr, groups,
        progress)`` returning index arrays, such as
        :func:`geoalpha.delaunay.triangulate_groups` (GEOS); the groups it
        fails, and all groups without one, are triangulated by Qhull.
    out_coords : array_like of shape (n, 2), optional
        The same points in the coordinates the result is returned in (e.g.
        longitude/latitude): groups degenerate there by the same tolerances
        (:func:`thin_groups`) are degenerate too.

    Returns
    -------
    Triangulation

    Raises
    ------
    ValueError
        If coordinates are NaN/inf or beyond :data:`MAX_COORDINATE` (the
        message names the rows) or the shapes do not fit.

    Notes
    -----
    Near-degenerate input is decided with tolerances relative to each
    group's extent (the larger side of its bounding box), never below
    :data:`PRECISION_ULPS` units in the last place of its coordinates:

    * points closer than :data:`NEAR_RTOL` times the extent are one
      point (transitively; the first in input order represents them);
    * a group whose points all lie within :data:`NEAR_RTOL` times the
      extent of their principal axis (the least-squares line) is degenerate,
      as are groups with fewer than 3 distinct points;
    * a group whose float triangulation is not a triangulation of its points
      (a check of every group) is degenerate too.

    All metric quantities are computed in coordinates relative to the
    group's first point and scaled by a power of two to an extent of about 1
    (exact), so that neither large offsets nor extreme scales lose precision,
    and orientations use an error-free product, so that the circumradii of
    needle triangles are accurate to a few units in the last place.

    Examples
    --------
    >>> tri = triangulate([[0, 0], [1, 0], [0, 1], [1, 1], [1, 1]])
    >>> tri.n_distinct.tolist(), len(tri.triangles), tri.degenerate.tolist()
    ([4], 2, [False])
    >>> triangulate([[0, 0], [1, 1e-12], [2, 0]]).degenerate.tolist()  # a line
    [True]
    """
    xy_in = _check_points(points)
    n = len(xy_in)
    codes, n_groups = _group_codes(groups, n, n_groups)

    # Points sorted by group (a no-op when they already are).
    if n > 1 and (codes[1:] < codes[:-1]).any():
        order = _group_order(codes, n_groups)
        xy, point_group = np.take(xy_in, order, axis=0), codes[order]
    else:
        order = np.arange(n)
        xy, point_group = xy_in, codes
    input_point = np.empty(n, dtype=np.int64)
    input_point[order] = np.arange(n)

    counts = np.bincount(point_group, minlength=n_groups)
    point_ptr = np.zeros(n_groups + 1, dtype=np.int64)
    np.cumsum(counts, out=point_ptr[1:])
    frame = _Frame.of(xy, point_group, point_ptr)
    local = frame.local

    flagged = np.zeros(n_groups, dtype=bool)
    if degenerate is not None:
        flagged |= np.asarray(degenerate, dtype=bool)
    flagged |= counts < 3
    flagged |= collinear_groups(local, point_group, n_groups, frame.tol)
    if out_coords is not None:  # (thin_groups, on the sort made above)
        out = np.take(_check_points(out_coords), order, axis=0)
        out_frame = _Frame.of(out, point_group, point_ptr)
        flagged |= collinear_groups(
            out_frame.local, point_group, n_groups, out_frame.tol
        )

    # Pass 1: Qhull on every point (it keeps one of each set of duplicates).
    vertex = np.arange(len(xy))
    todo = np.flatnonzero(~flagged)
    simplices, nbrs, coplanar, failed = _delaunay(
        local, point_ptr, todo, progress, backend=backend
    )
    flagged[failed] = True
    # Points Qhull left out without listing them (a near-duplicate of a
    # vertex, sometimes): paired with their nearest vertex, as if listed.
    coplanar = np.concatenate(
        [coplanar, _unlisted(local, point_group, simplices, coplanar)]
    )
    measures = _edges_and_cross(
        xy, simplices, frame.scale[point_group[simplices[:, 0]]]
    )
    # Near-duplicates: Delaunay edges shorter than the tolerance (the
    # Delaunay graph holds every nearest neighbour) and the points Qhull
    # merged. Their groups are triangulated again on one point of each set.
    near = _near_duplicates(
        local, point_group, simplices, measures[2], coplanar, frame.tol
    )
    if len(near):
        redo = np.unique(point_group[near[:, 0]])
        vertex = _representatives(near, len(xy))
        keep = ~np.isin(point_group[simplices[:, 0]], redo)
        keep_cp = ~np.isin(point_group[coplanar[:, 0]], redo)
        simplices, nbrs = _drop_triangles(simplices, nbrs, keep)
        measures = tuple(m[keep] for m in measures)
        coplanar = coplanar[keep_cp]
        use = vertex == np.arange(len(xy))
        s2, n2, c2, failed = _delaunay(local, point_ptr, redo, None, use=use)
        flagged[failed] = True
        m2 = _edges_and_cross(xy, s2, frame.scale[point_group[s2[:, 0]]])
        simplices, nbrs, coplanar, measures = _merge_runs(
            point_group, (simplices, nbrs, coplanar, measures), (s2, n2, c2, m2)
        )
    # Points Qhull set aside as "coplanar" (numerically on an edge, e.g. on
    # a straight stretch of the convex hull) are represented by the vertex
    # it names; they count as distinct points when they are not within the
    # tolerance of it, and the shape is made to cover them (see
    # :func:`geoalpha.shapes.enforce`).
    distinct = vertex == np.arange(len(xy))
    if len(coplanar):
        vertex[coplanar[:, 0]] = vertex[coplanar[:, 1]]
        same = _close(
            local,
            coplanar[:, 0],
            coplanar[:, 1],
            frame.tol[point_group[coplanar[:, 0]]],
        )
        distinct[coplanar[:, 0]] = ~same

    tri_group = point_group[simplices[:, 0]]
    twice_area, e2_product, _ = measures
    # Orient every triangle counter-clockwise (swap vertices 1, 2 and the
    # neighbours opposite them where Qhull gave them clockwise).
    cw = twice_area < 0
    if cw.any():  # (never for GEOS's triangles)
        swap = np.flatnonzero(cw)
        simplices[swap] = np.take(simplices, swap, axis=0)[:, [0, 2, 1]]
        nbrs[swap] = np.take(nbrs, swap, axis=0)[:, [0, 2, 1]]
    cross = np.abs(twice_area)
    # Qhull's vertices: the points it neither set aside nor skipped.
    used = vertex == np.arange(len(xy))
    used[coplanar[:, 0]] = False
    n_vertices = np.bincount(point_group[used], minlength=n_groups)
    flagged |= _not_a_triangulation(nbrs, tri_group, n_vertices, n_groups)

    # Drop the triangles of every degenerate group, then renumber.
    keep = ~flagged[tri_group]
    if not keep.all():
        simplices, nbrs = _drop_triangles(simplices, nbrs, keep)
        tri_group = tri_group[keep]
        cross, e2_product = cross[keep], e2_product[keep]
    vertex[flagged[point_group]] = np.flatnonzero(flagged[point_group])
    ntri = np.bincount(tri_group, minlength=n_groups)
    tri_ptr = np.zeros(n_groups + 1, dtype=np.int64)
    np.cumsum(ntri, out=tri_ptr[1:])

    scale = frame.scale[tri_group]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        circumradius = np.sqrt(e2_product) / (2.0 * cross) / scale
    circumradius[~(cross > 0)] = np.inf
    radius, rank, values = merge_ties(circumradius, tri_group)
    value_group = np.empty(len(values), dtype=np.int64)
    value_group[rank] = tri_group
    area = cross / 2.0 / scale / scale  # (scale * scale overflows below 1e-154)

    n_distinct = np.bincount(point_group[distinct], minlength=n_groups)
    # Degenerate groups: their exactly distinct points.
    n_distinct[flagged] = _distinct_counts(xy, point_group, flagged, n_groups)[flagged]

    return Triangulation(
        xy=xy,
        local=local,
        point_group=point_group,
        point_ptr=point_ptr,
        input_point=input_point,
        vertex=vertex,
        distinct=distinct,
        n_distinct=n_distinct,
        triangles=simplices,
        neighbors=nbrs,
        tri_group=tri_group,
        tri_ptr=tri_ptr,
        radius=radius,
        values=values,
        value_ptr=_offsets(value_group, n_groups),
        rank=rank,
        area=area,
        degenerate=flagged,
    )


@dataclass(frozen=True)
class _Frame:
    """Per-group working coordinates and tolerances (see :func:`triangulate`).

    ``local`` holds each point relative to its group's first point, times
    ``scale`` (a power of two that brings the group's extent into
    ``[0.5, 1)``); ``tol`` is the near-degeneracy tolerance of each group in
    those units.
    """

    local: np.ndarray
    scale: np.ndarray
    tol: np.ndarray

    @classmethod
    def of(cls, xy, point_group, point_ptr) -> _Frame:
        n_groups = len(point_ptr) - 1
        nonempty = np.flatnonzero(np.diff(point_ptr) > 0)
        starts = point_ptr[:-1][nonempty]
        lo = np.zeros((n_groups, 2))
        hi = np.zeros((n_groups, 2))
        if len(nonempty):
            lo[nonempty] = np.minimum.reduceat(xy, starts, axis=0)
            hi[nonempty] = np.maximum.reduceat(xy, starts, axis=0)
        # The largest |coordinate| of a group is at a corner of its box.
        big = np.maximum(np.abs(lo), np.abs(hi)).max(axis=1)
        extent = (hi - lo).max(axis=1)
        _, exponent = np.frexp(extent)  # extent = m * 2**exponent, m in [0.5, 1)
        scale = np.where(extent > 0, np.ldexp(1.0, -exponent), 1.0)
        origin = xy[np.minimum(point_ptr[:-1], max(len(xy) - 1, 0))] if len(xy) else xy
        with np.errstate(over="ignore"):
            # np.take: fancy indexing of (n, 2) arrays costs ~10x in numpy 2
            at = np.take(origin, point_group, axis=0)
            local = (xy - at) * scale[point_group][:, None]
        # The coordinates' own resolution, in the scaled units.
        quantum = np.spacing(big) * scale
        tol = np.maximum(NEAR_RTOL * extent * scale, PRECISION_ULPS * quantum)
        return cls(local, scale, tol)


def _group_order(codes: np.ndarray, n_groups: int) -> np.ndarray:
    """Stable argsort of group codes ``0 .. n_groups - 1``.

    numpy sorts 8- and 16-bit integers stably by radix (``O(n)``); codes
    that fit are sorted as such, which is several times faster than sorting
    them as int64.

    Examples
    --------
    >>> _group_order(np.array([2, 0, 2, 1, 0]), 3).tolist()
    [1, 4, 3, 0, 2]
    """
    if n_groups <= 2**16:
        return np.argsort(codes.astype(np.uint16), kind="stable")
    return radix_argsort(codes, max(int(n_groups) - 1, 1).bit_length())


def thin_groups(points, groups=None, n_groups: int | None = None) -> np.ndarray:
    """Flag the groups that are degenerate by the tolerances of :func:`triangulate`.

    A group is degenerate when it has fewer than 3 points or all its points
    lie within :data:`NEAR_RTOL` times its extent (at least
    :data:`PRECISION_ULPS` units in the last place) of their principal axis.

    Parameters
    ----------
    points : array_like of shape (n, 2)
    groups : array_like of int, shape (n,), optional
    n_groups : int, optional

    Returns
    -------
    ndarray of bool, shape (G,)

    Examples
    --------
    >>> lon = np.full(4, -2.9)  # four points on one meridian
    >>> thin_groups(np.c_[lon, [50.0, 50.001, 50.002, 50.0035]]).tolist()
    [True]
    """
    xy = _check_points(points)
    codes, n_groups = _group_codes(groups, len(xy), n_groups)
    order = _group_order(codes, n_groups)
    xy, codes = np.take(xy, order, axis=0), codes[order]
    ptr = _offsets(codes, n_groups)
    frame = _Frame.of(xy, codes, ptr)
    thin = collinear_groups(frame.local, codes, n_groups, frame.tol)
    return thin | (np.diff(ptr) < 3)


def collinear_groups(local, point_group, n_groups: int, tol) -> np.ndarray:
    """Flag the groups whose points all lie within ``tol`` of their principal axis.

    Parameters
    ----------
    local : ndarray of shape (p, 2)
        Coordinates (of points sorted by group, or in any order).
    point_group : ndarray of shape (p,)
        Group of each point.
    n_groups : int
        Number of groups.
    tol : float or ndarray of shape (G,)
        Largest distance from the line, per group.

    Returns
    -------
    ndarray of bool, shape (G,)
        True for groups within ``tol`` of a line (and for empty groups).

    Examples
    --------
    >>> xy = np.array([[0, 0], [1, 1], [2, 2.0000001], [0, 0], [1, 0], [0, 1]])
    >>> collinear_groups(xy, np.array([0, 0, 0, 1, 1, 1]), 2, 1e-6).tolist()
    [True, False]
    """
    count = np.bincount(point_group, minlength=n_groups).astype(float)
    with np.errstate(invalid="ignore", divide="ignore"):
        cx = np.bincount(point_group, local[:, 0], n_groups) / count
        cy = np.bincount(point_group, local[:, 1], n_groups) / count
    dx = local[:, 0] - cx[point_group]
    dy = local[:, 1] - cy[point_group]
    sxx = np.bincount(point_group, dx * dx, n_groups)
    syy = np.bincount(point_group, dy * dy, n_groups)
    sxy = np.bincount(point_group, dx * dy, n_groups)
    theta = 0.5 * np.arctan2(2.0 * sxy, sxx - syy)  # direction of the axis
    ux, uy = np.cos(theta)[point_group], np.sin(theta)[point_group]
    width = np.zeros(n_groups)
    np.maximum.at(width, point_group, np.abs(dx * uy - dy * ux))
    return width <= np.broadcast_to(tol, (n_groups,))


def _delaunay(local, point_ptr, groups, progress, use=None, backend=None):
    """Triangulate with a batched backend, and with Qhull the groups it cannot do.

    Same contract as :func:`_qhull`. ``backend`` (e.g.
    :func:`geoalpha.delaunay.triangulate_groups`, GEOS, which checks its
    output group by group; None: Qhull only) triangulates the groups; the
    groups it fails go to Qhull one by one, and their triangles are put back
    in group order. Exact duplicates come back as coplanar pairs, as Qhull
    reports them. The second pass on representatives (``use``) is Qhull's: it
    only sees groups with near-duplicates.
    """
    if use is not None or backend is None:
        return _smallest_first(*_qhull(local, point_ptr, groups, progress, use))
    batch = backend(local, point_ptr, groups, progress)
    moved = np.flatnonzero(batch.vertex != np.arange(len(local)))  # duplicates
    cp = np.column_stack([moved, batch.vertex[moved]])
    redo = groups[batch.failed]
    if len(redo) == 0:
        return _smallest_first(
            batch.triangles, batch.neighbors, cp, np.empty(0, dtype=np.int64)
        )
    tri, nb, cp2, failed = _qhull(local, point_ptr, redo, None)
    tri = np.concatenate([batch.triangles, tri])
    nb = np.where(nb >= 0, nb + len(batch.triangles), -1)
    nb = np.concatenate([batch.neighbors, nb])
    order = np.argsort(
        np.searchsorted(point_ptr, tri[:, 0], side="right"), kind="stable"
    )
    new = np.empty_like(order)
    new[order] = np.arange(len(order))
    nb = np.where(nb >= 0, new[np.maximum(nb, 0)], -1)[order]
    tri = np.take(tri, order, axis=0)
    return _smallest_first(tri, nb, np.concatenate([cp, cp2]), failed)


def _smallest_first(tri, nb, cp, failed):
    """Rotate every triangle (and its neighbours) to start at its smallest index.

    The radii are computed from vertex 0 out, so the same triangle from GEOS
    or from Qhull gets the same radius to the last bit.
    """
    t0, t1, t2 = tri[:, 0], tri[:, 1], tri[:, 2]
    # Column ``k`` of the result is column ``(first + k) % 3`` of the input.
    at1 = (t1 < t0) & (t1 < t2)
    at2 = (t2 < t0) & (t2 < t1)
    out = []
    for a in (tri, nb):
        c0, c1, c2 = a[:, 0], a[:, 1], a[:, 2]
        r = np.empty_like(a)
        r[:, 0] = np.where(at1, c1, np.where(at2, c2, c0))
        r[:, 1] = np.where(at1, c2, np.where(at2, c0, c1))
        r[:, 2] = np.where(at1, c0, np.where(at2, c1, c2))
        out.append(r)
    return out[0], out[1], cp, failed


def _qhull(local, point_ptr, groups, progress, use=None):
    """Qhull per listed group: triangles, neighbours and coplanar pairs.

    Returns global point and triangle indices. ``use`` (bool per point)
    restricts each group to some of its points. Groups whose points Qhull
    finds (numerically) collinear are returned in ``failed``. The loop body
    is Qhull alone; the index arithmetic is batched afterwards.
    """
    simplices, neighbors, coplanar, owner, failed, done = [], [], [], [], [], []
    starts, ends = point_ptr[groups].tolist(), point_ptr[groups + 1].tolist()
    for i, (g, s, e) in enumerate(zip(groups.tolist(), starts, ends, strict=True)):
        if progress is not None and i % 256 == 255:
            progress.update(256)
        pts = local[s:e] if use is None else local[s:e][use[s:e]]
        try:
            d = Delaunay(pts)
        except (QhullError, ValueError):  # all (numerically) collinear
            failed.append(g)
            continue
        done.append(g)
        simplices.append(d.simplices)
        neighbors.append(d.neighbors)
        cp = d.coplanar
        if len(cp):
            coplanar.append(cp)
            owner.append(len(done) - 1)
    if progress is not None:
        progress.update(len(groups) % 256)
    empty = np.empty((0, 3), dtype=np.int64)
    failed = np.asarray(failed, dtype=np.int64)
    if not simplices:
        return empty, empty, empty[:, :2], failed
    done = np.asarray(done, dtype=np.int64)
    ntri = np.array([len(x) for x in simplices], dtype=np.int64)
    tri_offset = np.repeat(np.cumsum(ntri) - ntri, ntri)
    # Local point number -> global index: the group's start, or with ``use``
    # the group's used points in order.
    if use is None:
        to_global = None
        start = np.repeat(point_ptr[done], ntri)
    else:
        used = np.flatnonzero(use)
        first_used = np.searchsorted(used, point_ptr[done])
        start = np.repeat(first_used, ntri)
    tri = np.concatenate(simplices).astype(np.int64) + start[:, None]
    nb = np.concatenate(neighbors).astype(np.int64)
    nb = np.where(nb >= 0, nb + tri_offset[:, None], -1)
    if coplanar:
        cp = np.concatenate(coplanar).astype(np.int64)
        cp[:, 1] = np.repeat(owner, [len(x) for x in coplanar])
        cp = cp[:, [0, 2, 1]]  # point, vertex, ordinal of its group in done
    else:
        cp = empty
    if len(cp):
        size = (point_ptr[done + 1] - point_ptr[done])[cp[:, 2]]
        if use is not None:
            size = np.diff(np.searchsorted(used, point_ptr))[done][cp[:, 2]]
        ok = (cp[:, 0] < size) & (cp[:, 1] < size)  # not Qhull's point at infinity
        base = (
            point_ptr[done] if use is None else np.searchsorted(used, point_ptr[done])
        )
        cp = cp[ok, :2] + base[cp[ok, 2]][:, None]
    else:
        cp = empty[:, :2]
    if use is not None:
        to_global = used
        tri = to_global[tri]
        cp = to_global[cp]
    return tri, nb, cp, failed


def _unlisted(local, point_group, simplices, coplanar) -> np.ndarray:
    """Pairs (point, nearest vertex) for points of triangulated groups left out.

    Qhull keeps one of points it finds coincident and lists the others as
    "coplanar", but sometimes drops one without listing it. Such a point is
    paired with the nearest triangle vertex of its group, so that it is
    merged (a near-duplicate) or covered (see :func:`triangulate`) like a
    listed one. Returns an ``(k, 2)`` array, usually empty.
    """
    empty = np.empty((0, 2), dtype=np.int64)
    if len(simplices) == 0:
        return empty
    p = len(local)
    vertex = np.zeros(p, dtype=bool)
    vertex[simplices.ravel()] = True
    seen = vertex.copy()
    seen[coplanar.ravel()] = True
    has_triangles = np.zeros(int(point_group.max()) + 1, dtype=bool)
    has_triangles[point_group[simplices[:, 0]]] = True
    lost = np.flatnonzero(~seen & has_triangles[point_group])
    if not len(lost):
        return empty
    # One tree over the vertices of the groups concerned, each group moved
    # 8 units apart along x (local coordinates lie within [-1, 1]).
    groups = np.unique(point_group[lost])
    near = np.flatnonzero(vertex & np.isin(point_group, groups))
    shift = 8.0 * np.searchsorted(groups, point_group)

    def placed(i):
        return np.column_stack([local[i, 0] + shift[i], local[i, 1]])

    _, nearest = cKDTree(placed(near)).query(placed(lost))
    return np.column_stack([lost, near[nearest]])


def _close(local, a, b, tol) -> np.ndarray:
    d = np.take(local, a, axis=0) - np.take(local, b, axis=0)
    return d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1] < tol * tol


def _near_duplicates(local, point_group, simplices, e2_min, coplanar, tol):
    """Pairs of distinct points closer than their group's tolerance, ``(k, 2)``.

    ``e2_min`` is the shortest squared edge of each triangle (scaled units):
    only triangles with an edge below the tolerance are looked at.
    """
    if len(simplices) == 0:
        return np.empty((0, 2), dtype=np.int64)
    t = tol[point_group[simplices[:, 0]]]
    short = np.compress(e2_min < t * t, simplices, axis=0)
    a = short.ravel()
    b = short[:, [1, 2, 0]].ravel()
    pairs = np.concatenate([np.column_stack([a, b]), coplanar])
    t = tol[point_group[pairs[:, 0]]]
    short = _close(local, pairs[:, 0], pairs[:, 1], t)
    pairs = np.compress(short, pairs, axis=0)  # (10x pairs[short] in numpy 2)
    # Exact duplicates alone need no second pass: Qhull kept one of them.
    first = np.take(local, pairs[:, 0], axis=0)
    second = np.take(local, pairs[:, 1], axis=0)
    differ = (first[:, 0] != second[:, 0]) | (first[:, 1] != second[:, 1])
    redo = np.zeros(len(tol), dtype=bool)
    redo[point_group[pairs[differ, 0]]] = True
    return np.compress(redo[point_group[pairs[:, 0]]], pairs, axis=0)


def _representatives(pairs, p: int) -> np.ndarray:
    """Smallest point index of each connected set of ``pairs`` (identity elsewhere)."""
    graph = csr_array((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(p, p))
    _, label = connected_components(graph, directed=False)
    first = np.full(label.max() + 1, p, dtype=np.int64)
    np.minimum.at(first, label, np.arange(p))
    return first[label]


def _merge_runs(point_group, old, new):
    """Concatenate two sets of per-group triangles, sorted by group again.

    Each set is ``(simplices, neighbors, coplanar, measures)`` with
    ``measures`` a tuple of per-triangle arrays.
    """
    s1, n1, c1, m1 = old
    s2, n2, c2, m2 = new
    n2 = np.where(n2 >= 0, n2 + len(s1), -1)
    s = np.concatenate([s1, s2])
    nb = np.concatenate([n1, n2])
    c = np.concatenate([c1, c2])
    order = np.argsort(point_group[s[:, 0]], kind="stable")
    inverse = np.empty_like(order)
    inverse[order] = np.arange(len(order))
    nb = np.where(nb >= 0, inverse[np.maximum(nb, 0)], -1)[order]
    measures = tuple(np.concatenate([a, b])[order] for a, b in zip(m1, m2, strict=True))
    return s[order], nb, c, measures


def _drop_triangles(simplices, nbrs, keep):
    """Keep whole groups' triangles, renumbering the neighbours."""
    renumber = np.cumsum(keep) - 1
    nbrs = np.compress(keep, nbrs, axis=0)  # (10x nbrs[keep] in numpy 2)
    simplices = np.compress(keep, simplices, axis=0)
    return simplices, np.where(nbrs >= 0, renumber[np.maximum(nbrs, 0)], -1)


def _not_a_triangulation(nbrs, tri_group, n_vertices, n_groups) -> np.ndarray:
    """Flag the groups whose triangles are not a triangulated disk (checks Qhull).

    Euler's formula for a triangulated disk: ``#triangles = 2 #vertices - 2 -
    #hull edges`` (the hull is one cycle: as many edges as vertices).
    """
    bad = np.zeros(n_groups, dtype=bool)
    if len(nbrs) == 0:
        return bad
    hull = np.bincount(tri_group[np.nonzero(nbrs < 0)[0]], minlength=n_groups)
    ntri = np.bincount(tri_group, minlength=n_groups)
    has = ntri > 0
    bad[has] = ntri[has] != 2 * n_vertices[has] - 2 - hull[has]
    return bad


def _distinct_counts(xy, point_group, which, n_groups) -> np.ndarray:
    """Distinct points per group, counted for the groups in ``which`` only."""
    sel = np.flatnonzero(which[point_group])
    out = np.zeros(n_groups, dtype=np.int64)
    if len(sel):
        p, g = np.take(xy, sel, axis=0), point_group[sel]
        o = np.lexsort((p[:, 1], p[:, 0], g))
        p, g = p[o], g[o]
        new = np.ones(len(sel), dtype=bool)
        new[1:] = (g[1:] != g[:-1]) | (p[1:] != p[:-1]).any(axis=1)
        out += np.bincount(g[new], minlength=n_groups)
    return out


#: Dekker's splitter for float64 (2**27 + 1).
_SPLIT = 134217729.0


def _two_product(a, b):
    """Split ``a * b`` into ``p + e`` exactly (Dekker), elementwise."""
    p = a * b
    c = _SPLIT * a
    a_hi = c - (c - a)
    a_lo = a - a_hi
    c = _SPLIT * b
    b_hi = c - (c - b)
    b_lo = b - b_hi
    e = ((a_hi * b_hi - p) + a_hi * b_lo + a_lo * b_hi) + a_lo * b_lo
    return p, e


def _two_diff(a, b):
    """Split ``a - b`` into ``d + e`` exactly (Knuth), elementwise."""
    d = a - b
    bv = a - d
    return d, (a - (d + bv)) + (bv - b)


def _edges_and_cross(xy: np.ndarray, triangles: np.ndarray, scale=1.0):
    """Twice the signed area, the product and the least of the squared edges.

    All in coordinates multiplied by ``scale`` (per triangle; a power of two,
    so exact). Each edge vector is a difference of input coordinates, kept
    with its rounding error (exact as ``d + e``). The cross product is taken
    at the vertex opposite the longest edge (so the result does not depend
    on the order in which the triangle's vertices are listed) and is accurate
    to a few units in the last place even for needle triangles (nearly
    collinear or nearly coincident points): the products are split
    error-free (Dekker) wherever they cancel, and the rounding errors of the
    differences enter to first order.
    """
    x, y = np.ascontiguousarray(xy[:, 0]), np.ascontiguousarray(xy[:, 1])
    px = [x[triangles[:, k]] for k in range(3)]
    py = [y[triangles[:, k]] for k in range(3)]
    with np.errstate(over="ignore", under="ignore", invalid="ignore"):
        # Edge k runs from vertex k to vertex k+1 (exact as d + e), scaled.
        ex, ey, ex_e, ey_e = [], [], [], []
        for k in range(3):
            dx, dx_e = _two_diff(px[(k + 1) % 3], px[k])
            dy, dy_e = _two_diff(py[(k + 1) % 3], py[k])
            ex.append(dx * scale)
            ey.append(dy * scale)
            ex_e.append(dx_e * scale)
            ey_e.append(dy_e * scale)
        e2 = [ex[k] * ex[k] + ey[k] * ey[k] for k in range(3)]
        # Longest edge j (the first of equals); the apex opposite it is
        # vertex j+2, with edges a = edge j+2 out of it and b = -edge j+1.
        first = (e2[0] >= e2[1]) & (e2[0] >= e2[2])
        second = ~first & (e2[1] >= e2[2])

        def pick(values, shift):  # values[(j + shift) % 3] (np.choose: 7x slower)
            return np.where(
                first,
                values[shift % 3],
                np.where(second, values[(1 + shift) % 3], values[(2 + shift) % 3]),
            )

        ax, ay = pick(ex, 2), pick(ey, 2)
        ax_e, ay_e = pick(ex_e, 2), pick(ey_e, 2)
        bx, by = -pick(ex, 1), -pick(ey, 1)
        bx_e, by_e = -pick(ex_e, 1), -pick(ey_e, 1)
        p1 = ax * by
        p2 = ay * bx
        cross = p1 - p2
        # First-order terms of the differences' rounding errors.
        cross_e = (ax * by_e + ax_e * by) - (ay * bx_e + ay_e * bx)
        # Where the two products nearly cancel, recompute them error-free.
        hard = np.abs(cross) < 0.0625 * (np.abs(p1) + np.abs(p2))
        if hard.any():
            q1, e1 = _two_product(ax[hard], by[hard])
            q2, e2h = _two_product(ay[hard], bx[hard])
            cross[hard] = (q1 - q2) + (e1 - e2h)  # q1 - q2 is exact here
        cross = cross + cross_e
    # The product in sorted order, so that it does not depend on the vertex
    # order either (rounding of a * b * c does).
    least = np.minimum(np.minimum(e2[0], e2[1]), e2[2])
    most = np.maximum(np.maximum(e2[0], e2[1]), e2[2])
    middle = np.maximum(
        np.minimum(e2[0], e2[1]), np.minimum(np.maximum(e2[0], e2[1]), e2[2])
    )
    return cross, least * middle * most, least


def merge_ties(
    radius: np.ndarray, group: np.ndarray | None = None, rtol: float = TIE_RTOL
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Give radii that agree to ``rtol`` (relative) the largest of their values.

    Cocircular points (grids, rounded coordinates) have triangles with the same
    circumradius in exact arithmetic, which rounding splits by an ulp or two.
    Merging them keeps such triangles entering the shape together, as the
    definition wants. Greedy runs form one value each: a run starts at the
    smallest value not yet taken and holds every value up to
    ``start * (1 + rtol)`` (runs do not chain, so a merged value spans at
    most ``rtol``). With ``group`` given (non-decreasing codes), only radii of
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
    by_value = np.argsort(radius)
    order = by_value
    if group is not None:
        # Then stably by group: a radix sort when the codes fit 16 bits.
        g = group[by_value]
        span = int(g.max()) - int(g.min())
        if span < 2**16:
            g = (g - g.min()).astype(np.uint16)
        order = by_value[np.argsort(g, kind="stable")]
    s = radius[order]
    g = group[order] if group is not None else np.zeros(len(s), dtype=np.int64)
    # Rank of each value among all values (increasing within each group).
    value_rank = np.empty(len(radius), dtype=np.int64)
    value_rank[by_value] = np.arange(len(radius))
    start = _run_starts(s, g, value_rank[order], radius[by_value], rtol)
    values = np.maximum.reduceat(s, np.flatnonzero(start))
    rank = np.empty(len(radius), dtype=np.int64)
    rank[order] = np.cumsum(start) - 1
    return values[rank], rank, values


def _run_starts(s, g, value_rank, all_sorted, rtol: float) -> np.ndarray:
    """Greedy runs of values sorted by group, then value: each within ``rtol``.

    A run starts at each group's first value and then at the first value
    above ``first * (1 + rtol)``, so that no chain of small steps spans more
    than ``rtol``. Only chains of values each within ``rtol`` of the
    previous one need work (elsewhere every value starts a run); there the
    starts are the path ``first -> next(first) -> ...``, found by pointer
    doubling (each round doubles the known part of the path). ``value_rank``
    is each value's rank among all values (``all_sorted``), which makes the
    search within groups one global search.
    """
    n = len(s)
    close = np.zeros(n, dtype=bool)
    with np.errstate(over="ignore", invalid="ignore"):
        close[1:] = (s[1:] <= s[:-1] * (1.0 + rtol)) & (g[1:] == g[:-1])
    start = ~close
    if not close.any():
        return start
    chained = np.flatnonzero(close | np.append(close[1:], False))
    # Each chain ends before the next start; a step past it leaves the chain.
    bounds = np.append(np.flatnonzero(start), n)
    chain_end = bounds[np.searchsorted(bounds, chained, side="right")]
    gc = g[chained].astype(np.int64)
    with np.errstate(over="ignore"):
        above = np.searchsorted(all_sorted, s[chained] * (1.0 + rtol), side="right")
    # Position (in group-then-value order) of the group's first value of
    # rank >= ``above``: these keys are sorted, as ranks are within groups.
    key = g.astype(np.int64) * (n + 1) + value_rank
    nxt = np.searchsorted(key, gc * (n + 1) + above, side="left")
    nxt = np.clip(nxt, chained + 1, chain_end)
    # Pointer doubling over the chained values; k (their count) is the exit.
    k = len(chained)
    jump = np.searchsorted(chained, nxt)
    jump[nxt >= chain_end] = k
    jump = np.append(jump, k)
    on = np.append(start[chained], False)
    for _ in range(_doublings(k + 1)):
        more = on.copy()
        more[jump[on]] = True
        more[k] = False
        grand = jump[jump]
        if np.array_equal(more, on) and np.array_equal(grand, jump):
            break
        on, jump = more, grand
    start[chained] = on[:k]
    return start


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
    # The triangles relabelled by descending rank (``order[i]`` is the
    # triangle of label i; the outside is label m). Each dual edge sits in
    # the row of its later endpoint, whose rank is the edge's weight
    # ``min(rank[a], rank[b])``, so the weights in CSR order ascend and the
    # sort inside Kruskal's algorithm finds them sorted (no O(E log E) sort).
    order = radix_argsort(top - 1 - rank, top.bit_length())
    # scipy's graph routines work in int32: so do we where it fits.
    itype = np.int32 if m < 2**31 - 2 else np.int64
    label = np.empty(m + 1, dtype=itype)
    label[order] = np.arange(m, dtype=itype)
    label[m] = -1  # the outside, as neighbour -1 (moved to label m below)
    # Neighbours are near in memory, so gather first, then permute once.
    col = np.take(label[tri.neighbors], order, axis=0)
    keep = col < np.arange(m, dtype=itype)[:, None]
    indptr = np.zeros(m + 2, dtype=itype)
    k8 = keep.view(np.uint8)  # columns summed (no row-wise reduction)
    np.cumsum(k8[:, 0] + k8[:, 1] + k8[:, 2], out=indptr[1 : m + 1])
    indptr[m + 1] = indptr[m]
    col = col[keep]
    col[col < 0] = m
    # The ranks in label order, counted out (no gather); the outside last.
    r_ext = np.repeat(
        np.arange(top, -1, -1, dtype=itype), np.bincount(top - rank, minlength=top + 1)
    )
    r_ext = np.append(r_ext, itype(top))
    # Kruskal only compares weights, so each edge's position in this
    # (ascending) order is its weight: ties broken, still a maximum tree.
    graph = csr_array((np.arange(1.0, len(col) + 1), col, indptr), shape=(m + 1, m + 1))
    tree = minimum_spanning_tree(graph, overwrite=True)
    _, parent = breadth_first_order(tree, m, directed=False, return_predecessors=True)
    parent[m] = m
    # Edge weight towards the parent is min(rank[t], rank[parent]); the fill
    # radius is the minimum over the path to the root.
    val = np.minimum(r_ext, r_ext[parent])
    for _ in range(_doublings(m + 1)):
        grand = parent[parent]
        if np.array_equal(grand, parent):
            break
        val = np.minimum(val, val[parent])
        parent = grand
    else:  # pragma: no cover - a BFS tree has depth <= m
        raise RuntimeError("fill_radius: the spanning tree has a cycle")
    out = np.empty(m, dtype=np.int64)
    out[order] = val[:m]
    return out


def radix_argsort(key: np.ndarray, bits: int) -> np.ndarray:
    """Stable argsort of non-negative integers below ``2**bits``, 16 bits a pass.

    numpy's stable sort of ``uint16`` is a radix sort (``O(n)``); a least
    significant digit first sort of 16-bit digits is several times faster
    than ``np.argsort`` of int64 keys.

    Examples
    --------
    >>> radix_argsort(np.array([70000, 3, 70000, 1]), 17).tolist()
    [3, 1, 0, 2]
    """
    order = np.argsort((key & 0xFFFF).astype(np.uint16), kind="stable")
    for shift in range(16, min(bits, 64), 16):  # at most 3 more passes
        digit = ((key[order] >> shift) & 0xFFFF).astype(np.uint16)
        order = order[np.argsort(digit, kind="stable")]
    return order


def hash64(*words: np.ndarray) -> np.ndarray:
    """Mix unsigned 64-bit words elementwise into one hash (splitmix64 steps).

    Examples
    --------
    >>> a = np.array([1, 2], dtype=np.uint64)
    >>> h = hash64(a, a[::-1])
    >>> h.dtype, bool(h[0] != h[1])
    (dtype('uint64'), True)
    """
    h = np.zeros(len(words[0]), dtype=np.uint64)
    with np.errstate(over="ignore"):
        for w in words:
            h = (h ^ w) + np.uint64(0x9E3779B97F4A7C15)
            h = (h ^ (h >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
            h = (h ^ (h >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
            h ^= h >> np.uint64(31)
    return h


def exact_duplicates(
    xy: np.ndarray, codes: np.ndarray, other=None
) -> np.ndarray | None:
    """Rows that repeat an earlier row exactly: same group, same coordinates.

    Parameters
    ----------
    xy : ndarray of shape (n, 2)
        Coordinates (checked: finite floats).
    codes : ndarray of int, shape (n,)
        Group code of each row.
    other : ndarray of shape (n, 2), optional
        Further coordinates of the rows that must be equal too (the
        coordinates the result is returned in).

    Returns
    -------
    ndarray of int, shape (n,), or None
        For each row the first row (in input order) with its group and
        coordinates (itself for the first ones); None when no row repeats
        another.

    Notes
    -----
    Rows are sorted by a 48-bit hash of their group and coordinates (those of
    ``other`` too) with a stable radix sort, and neighbours in that order are
    compared exactly. Equal rows have
    equal hashes, so they are found unless a colliding row sorts between two
    of them; a hash collision can therefore only leave a duplicate in place
    (which the triangulation handles as before), never join two different
    points.

    Examples
    --------
    >>> xy = np.array([[0.0, 0], [1, 1], [0, 0], [-0.0, 0], [0, 0]])
    >>> exact_duplicates(xy, np.array([0, 0, 0, 0, 1])).tolist()
    [0, 1, 0, 0, 4]
    >>> exact_duplicates(xy[:2], np.zeros(2, dtype=int)) is None
    True
    """
    n = len(xy)
    if n < 2:
        return None
    x = xy[:, 0] + 0.0  # -0.0 -> 0.0: equal values, equal bits
    y = xy[:, 1] + 0.0
    words = [x.view(np.uint64), y.view(np.uint64), codes.astype(np.uint64)]
    if other is not None:
        words += [(other[:, j] + 0.0).view(np.uint64) for j in (0, 1)]
    key = hash64(*words)
    order = radix_argsort(key >> np.uint64(16), 48)
    sk = key[order]
    same = sk[1:] == sk[:-1]
    if not same.any():
        return None
    a, b = order[:-1][same], order[1:][same]
    equal = (codes[a] == codes[b]) & (x[a] == x[b]) & (y[a] == y[b])
    if other is not None:
        equal &= (other[a, 0] == other[b, 0]) & (other[a, 1] == other[b, 1])
    if not equal.any():
        return None
    # Runs of equal rows in the (stable) order start at their first row.
    link = np.zeros(n, dtype=bool)  # position i + 1 equals position i
    link[1:][np.flatnonzero(same)[equal]] = True
    start = np.where(link, 0, np.arange(n))
    np.maximum.accumulate(start, out=start)
    rep = np.empty(n, dtype=np.int64)
    rep[order] = order[start]
    return rep


def _doublings(n: int) -> int:
    """Pointer-jumping rounds that settle any path of ``n`` items (a bound)."""
    return max(int(n).bit_length(), 1) + 1


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
            # Dual edges are listed by ``a``, so by group: offsets by search.
            pieces -= at_or_below(
                np.maximum(rank[a], rank[b]), None, np.searchsorted(a, tri.tri_ptr)
            )
            vmax = np.full(p, -1, dtype=np.int64)
            np.maximum.at(vmax, corner, corner_rank)
            # Vertices of hull edges (those of the other two corners of a
            # missing neighbour) are not inner vertices.
            out = tri.neighbors < 0
            on_hull = np.empty_like(out)
            on_hull[:, 0] = out[:, 1] | out[:, 2]
            on_hull[:, 1] = out[:, 2] | out[:, 0]
            on_hull[:, 2] = out[:, 0] | out[:, 1]
            vmax[tri.triangles[on_hull]] = -1
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
    failed : ndarray of shape (G,), optional
        Groups whose boundary edges do not close into rings (a triangle set
        that float rounding made inconsistent); their rings are left out.
    """

    vertex: np.ndarray
    ring: np.ndarray
    ring_piece: np.ndarray
    piece_group: np.ndarray
    failed: np.ndarray | None = None


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
    # Edge j of triangle t (opposite corner j) is flat entry 3 t + j; a
    # missing neighbour (-1) reads the appended False.
    in_ext = np.append(inside, False)
    at = np.flatnonzero(inside[:, None] & ~in_ext[tri.neighbors])
    j = at % 3
    t = at // 3
    corner = tri.triangles.ravel()
    u = corner[np.where(j == 2, at - 2, at + 1)]
    v = corner[np.where(j == 0, at + 2, at - 1)]
    pc = piece[t]
    n_pieces = int(piece.max()) + 1 if len(piece) and piece.max() >= 0 else 0
    piece_group = np.zeros(n_pieces, dtype=np.int64)
    piece_group[pc] = tri.tri_group[t]
    failed = np.zeros(tri.n_groups, dtype=bool)
    # Every edge must be the successor of exactly one edge, and the cycles
    # must be rings of 3 or more edges; a group where float rounding broke
    # that (an inconsistent triangle set) is reported in ``failed`` and its
    # edges are left out, at most once per call (groups are independent).
    for _ in range(2):
        nxt = _successors(tri, u, v, pc)
        n_edges = len(t)
        bad = nxt < 0
        bad |= np.bincount(nxt[~bad], minlength=n_edges)[nxt.clip(0)] != 1
        if not bad.any():
            # One successor per edge: the CSR rows are the edges themselves.
            graph = csr_array(
                (np.ones(n_edges), nxt, np.arange(n_edges + 1)), (n_edges,) * 2
            )
            n_rings, label = connected_components(
                graph, directed=True, connection="weak"
            )
            length = np.bincount(label, minlength=n_rings)
            bad = length[label] < 3
        if not bad.any():
            break
        failed[tri.tri_group[t[bad]]] = True
        ok = ~failed[tri.tri_group[t]]
        t, u, v, pc = t[ok], u[ok], v[ok], pc[ok]
    if n_edges == 0:
        empty = np.empty(0, dtype=np.int64)
        return Rings(empty, empty, empty, piece_group, failed)

    # Rings are the cycles of the successor permutation.
    root = np.full(n_rings, n_edges, dtype=np.int64)
    np.minimum.at(root, label, np.arange(n_edges))
    # List ranking: distance of each edge to the last edge before the root.
    succ = np.where(nxt == root[label], np.arange(n_edges), nxt)
    dist = (succ != np.arange(n_edges)).astype(np.int64)
    for _ in range(_doublings(n_edges)):
        jump = succ[succ]
        if np.array_equal(jump, succ):
            break
        dist = dist + dist[succ]
        succ = jump
    else:  # pragma: no cover - nxt is a permutation (checked above)
        raise RuntimeError("boundary_rings: the successors do not form cycles")
    position = length[label] - 1 - dist

    # Shell (counter-clockwise, positive area) first within each piece.
    x, y = tri.local[:, 0], tri.local[:, 1]
    area2 = np.bincount(label, weights=x[u] * y[v] - x[v] * y[u], minlength=n_rings)
    ring_piece_raw = pc[root]
    ring_order = np.lexsort((np.arange(n_rings), area2 <= 0, ring_piece_raw))
    ring_new = np.empty(n_rings, dtype=np.int64)
    ring_new[ring_order] = np.arange(n_rings)
    # Rings in their new order, each edge at its position within its ring.
    new_length = length[ring_order]
    start = np.cumsum(new_length) - new_length
    vertex = np.empty(n_edges, dtype=u.dtype)
    vertex[start[ring_new[label]] + position] = u
    return Rings(
        vertex=vertex,
        ring=np.repeat(np.arange(n_rings), new_length),
        ring_piece=ring_piece_raw[ring_order],
        piece_group=piece_group,
        failed=failed,
    )


def _successors(tri, u, v, pc) -> np.ndarray:
    """Successor of each boundary edge: an outgoing edge of its piece at its head.

    -1 where the head has no outgoing edge (an inconsistent triangle set).
    """
    n = len(u)
    if n == 0:
        return np.empty(0, dtype=np.int64)
    stride = len(tri.xy)
    # Most heads have one outgoing edge: a lookup, if it is of the same piece.
    out_degree = np.bincount(u, minlength=stride)
    n_out = out_degree[v]
    some_out = np.zeros(stride, dtype=np.int64)
    some_out[u] = np.arange(n)
    nxt = some_out[v]
    nxt = np.where((n_out == 1) & (pc[nxt] == pc), nxt, -1)
    several = np.flatnonzero(n_out > 1)
    if len(several) == 0:
        return nxt
    # Elsewhere search the edges leaving those heads by (piece, tail).
    leaving = np.flatnonzero(out_degree[u] > 1)
    out_key = pc[leaving] * stride + u[leaving]
    sort = np.argsort(out_key, kind="stable")
    order = leaving[sort]
    sorted_key = out_key[sort]
    in_key = pc[several] * stride + v[several]
    lo = np.zeros(n, dtype=np.int64)
    hi = np.zeros(n, dtype=np.int64)
    lo[several] = np.searchsorted(sorted_key, in_key, side="left")
    hi[several] = np.searchsorted(sorted_key, in_key, side="right")
    found = hi[several] > lo[several]
    nxt[several] = np.where(found, order[np.minimum(lo[several], len(order) - 1)], -1)
    pinch = several[hi[several] - lo[several] > 1]
    if len(pinch):
        nxt[pinch] = _turn_through_exterior(tri.local, u, v, order, lo, hi, pinch)
    return nxt


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


# The input checks of triangulate(), for the callers that cut the input into
# runs first (geoalpha.parallel): points as an (n, 2) float array (ValueError
# naming NaN/inf rows), group codes with their count, and their stable order.
check_points = _check_points
group_codes = _group_codes
group_order = _group_order
