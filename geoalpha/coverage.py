"""Outlier-tolerant optimum: the best pieces of the shape cover ``n - k`` points.

Pure numpy/scipy (no pandas, no shapely), batched over groups like
:mod:`geoalpha.core`.

Definition (DESIGN.md, "Outliers"): with ``k`` points allowed to stay out of
a group of ``n`` distinct points, let ``S(R)`` be the usual shape at radius
threshold ``R`` (``holes`` semantics included) and ``P1, P2, ...`` its
edge-connected pieces. A point is *covered* by a piece when it is a vertex of
one of the piece's triangles (a point that Qhull merged with a numerically
coincident vertex is covered with that vertex). The *best coverage* at ``R``
is the largest number of distinct points that the union of at most
``components`` pieces covers: the ``components`` pieces that cover most
points, which is simply their total when they share no point. ``S(R)`` is
valid when its best coverage is at least ``n - k``, and the optimum is the
smallest valid ``R`` (the largest valid alpha).

As ``R`` grows, every piece of ``S(R)`` lies inside one piece of ``S(R')``
for ``R' > R`` (shapes only grow, so pieces only grow and merge), hence the
pieces chosen at ``R`` fit in at most ``components`` pieces at ``R'`` that
cover at least as many points: the best coverage is non-decreasing in ``R``.
So the optimum is the first spectrum value where the coverage is reached, and
it lies between the rank where the whole shape first covers ``n - k`` points
and the optimum without outliers (which is valid for every ``k``). It is
found by a bisection over each group's sorted spectrum, all groups at once:
every round is one labelling of the pieces of all active groups
(:func:`scipy.sparse.csgraph.connected_components`) and one count of the
distinct points per piece, ``O(m)`` (Euler's formula for the pieces of filled
shapes, which are disks; otherwise the smallest and largest piece label
around each vertex, with the few vertices where pieces meet sorted out
explicitly), and ``O(log m)`` rounds. The tests check the monotonicity on
random and real groups rather than assume it, and compare with a brute force
that tries every spectrum value.

Where the ``components`` pieces that cover most points share a vertex, the
best set is found by a branch and bound over the group's pieces (rare: only
pieces that touch at a vertex share points).

A group whose ``k`` is 0 keeps the result without outliers (at most
``components`` pieces and every point covered), bit for bit. (With ``k = 0``
the definition above would also accept a shape with an extra piece all of
whose points lie on the chosen pieces; the result without outliers does not.)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse import csr_array
from scipy.sparse.csgraph import connected_components

from geoalpha.core import Triangulation
from geoalpha.errors import InvalidInputError

__all__ = [
    "Kept",
    "best_coverage",
    "check_outliers",
    "outlier_budget",
    "outlier_optimum",
    "point_weight",
]

#: Rounds of the bisection: more than log2 of any spectrum length.
_MAX_ROUNDS = 64


def check_outliers(outliers) -> None:
    """Raise :class:`InvalidInputError` unless ``outliers`` is a valid budget.

    Parameters
    ----------
    outliers : float or int
        A float in ``[0, 1)`` (a fraction of each group's distinct points) or
        an int ``>= 0`` (a count per group).

    Examples
    --------
    >>> check_outliers(0.02), check_outliers(3)
    (None, None)
    >>> check_outliers(1.5)
    Traceback (most recent call last):
    ...
    geoalpha.errors.InvalidInputError: outliers must be a fraction in [0, 1) or ...
    """
    if isinstance(outliers, bool | np.bool_):
        ok = False
    elif isinstance(outliers, int | np.integer):
        ok = outliers >= 0
    elif isinstance(outliers, float | np.floating):
        ok = 0 <= outliers < 1
    else:
        ok = False
    if not ok:
        raise InvalidInputError(
            "outliers must be a fraction in [0, 1) or a count >= 0 (an int); "
            f"got {outliers!r}"
        )


def outlier_budget(outliers, n_distinct) -> np.ndarray:
    """Return the number ``k`` of distinct points each group may leave out.

    Parameters
    ----------
    outliers : float or int
        A float ``q`` in ``[0, 1)``: ``k = floor(q * n)`` (``q * n`` rounded to
        9 decimals first, so that ``0.29 * 100`` gives 29, not 28); an int: ``k``
        itself for every group.
    n_distinct : array_like of int, shape (G,)
        Distinct points ``n`` of each group.

    Returns
    -------
    ndarray of int, shape (G,)

    Examples
    --------
    >>> outlier_budget(0.02, [13, 50, 586]).tolist()
    [0, 1, 11]
    >>> outlier_budget(0.29, [100]).tolist(), outlier_budget(3, [2, 40]).tolist()
    ([29], [3, 3])
    """
    check_outliers(outliers)
    n = np.asarray(n_distinct, dtype=np.int64)
    if isinstance(outliers, int | np.integer):
        return np.full(n.shape, int(outliers), dtype=np.int64)
    return np.floor(np.round(float(outliers) * n, 9)).astype(np.int64)


@dataclass(frozen=True)
class Kept:
    """The outlier-tolerant optimum of every group.

    Attributes
    ----------
    rank : ndarray of shape (G,)
        Rank (into ``tri.values``) of the optimal radius threshold.
    inside : ndarray of bool, shape (m,)
        Triangles of the kept pieces.
    n_pieces : ndarray of shape (G,)
        Kept pieces per group.
    n_outliers : ndarray of shape (G,)
        Distinct points left out per group.
    outlier : ndarray of bool, shape (p,)
        For every point of ``tri.xy``: left out (not covered by a kept piece).
    """

    rank: np.ndarray
    inside: np.ndarray
    n_pieces: np.ndarray
    n_outliers: np.ndarray
    outlier: np.ndarray


def point_weight(tri: Triangulation) -> np.ndarray:
    """Distinct points each point of ``tri.xy`` stands for as a vertex.

    A vertex counts itself and the points Qhull set aside as lying on one of
    its edges farther than the tolerance from it (``tri.distinct``); exact
    duplicates and near-duplicates merged into it count 0, as in
    ``tri.n_distinct``. Other points count 0. Over a non-degenerate group the
    weights sum to ``tri.n_distinct``.

    Examples
    --------
    >>> from geoalpha import core
    >>> square = [[0, 0], [1, 0], [1, 1], [0, 1], [0, 1], [1, 1 + 1e-13]]
    >>> tri = core.triangulate(square)  # a repeat and a near-duplicate
    >>> point_weight(tri).tolist(), tri.n_distinct.tolist()
    ([1, 1, 1, 1, 0, 0], [4])
    """
    return np.bincount(tri.vertex[tri.distinct], minlength=len(tri.xy))


def _coverage_rank(tri, weight, point_weight_, need) -> np.ndarray:
    """Smallest rank per group at which the whole shape covers ``need`` points."""
    G, K = tri.n_groups, len(tri.values)
    vmin = np.full(len(tri.xy), K, dtype=np.int64)
    np.minimum.at(vmin, tri.triangles.ravel(), np.repeat(weight, 3))
    v = np.flatnonzero((vmin < K) & (point_weight_ > 0))
    group = tri.point_group[v]
    order = np.lexsort((vmin[v], group))
    v, group = v[order], group[order]
    cum = np.cumsum(point_weight_[v])
    size = np.bincount(group, minlength=G)
    start = np.cumsum(size) - size
    before = np.concatenate([[0], cum])[start]
    short = (cum - before[group]) < need[group]
    index = start + np.bincount(group, weights=short, minlength=G).astype(np.int64)
    rank = np.full(G, K, dtype=np.int64)
    ok = (size > 0) & (index < start + size)
    rank[ok] = vmin[v[index[ok]]]
    return rank


@dataclass(frozen=True)
class _Corners:
    """Triangle corners sorted by vertex, for counting the points of pieces."""

    tri: np.ndarray  # triangle of each corner
    vertex: np.ndarray  # its vertex (non-decreasing)
    start: np.ndarray  # first corner of each vertex
    segment: np.ndarray  # vertex number (0 ..) of each corner
    heavy: np.ndarray  # corners of vertices that stand for several points
    filled: bool  # weights are fill radii: every piece is a disk

    @classmethod
    def build(cls, tri: Triangulation, point_weight_, filled: bool) -> _Corners:
        flat = tri.triangles.ravel()
        order = np.argsort(flat, kind="stable")
        vertex = flat[order]
        new = np.r_[True, vertex[1:] != vertex[:-1]] if len(flat) else np.zeros(0, bool)
        return cls(
            tri=order // 3,
            vertex=vertex,
            start=np.flatnonzero(new),
            segment=np.cumsum(new) - 1,
            heavy=np.flatnonzero(point_weight_[vertex] > 1),
            filled=filled,
        )


def _pairs(lab, corners, p, which=None):
    """Distinct (piece, vertex) pairs of the corners ``which`` (default: all)."""
    which = np.flatnonzero(lab >= 0) if which is None else which[lab[which] >= 0]
    key = np.unique(lab[which] * p + corners.vertex[which])
    return key // p, key % p


def _best_cover(tri, weight, rank, active, point_weight_, components, need, corners):
    """Best coverage of the shapes at ``rank`` (one per group) of active groups.

    With ``need`` (per group) the exact search where chosen pieces overlap is
    only made where it decides ``coverage >= need``; with None, everywhere.
    ``corners`` is :class:`_Corners` of ``tri``.

    Returns the coverage per group (0 for inactive groups), and the triangles
    ``sel`` of the shapes with the piece ``label`` of each and ``chosen``, the
    pieces of the best set.
    """
    G, p, m = tri.n_groups, len(tri.xy), len(tri.triangles)
    inside = active[tri.tri_group] & (weight <= rank[tri.tri_group])
    sel = np.flatnonzero(inside)
    a, b = tri.dual_edges()
    both = inside[a] & inside[b]
    position = np.full(m, -1, dtype=np.int64)
    position[sel] = np.arange(len(sel))
    # CSR directly: dual edges are listed by their first triangle.
    head = position[a[both]]
    indptr = np.zeros(len(sel) + 1, dtype=np.int64)
    np.cumsum(np.bincount(head, minlength=len(sel)), out=indptr[1:])
    graph = csr_array(
        (np.ones(len(head)), position[b[both]], indptr), shape=(len(sel), len(sel))
    )
    n_pieces, label = connected_components(graph, directed=False)
    piece_group = np.zeros(n_pieces, dtype=np.int64)
    piece_group[label] = tri.tri_group[sel]

    piece_of = np.full(m, -1, dtype=np.int64)
    piece_of[sel] = label
    if corners.filled and components == 1:
        # Every piece of a filled shape is a disk (a hole or a vertex where
        # a piece touches itself would enclose triangles, which are filled),
        # so by Euler's formula it has 1 + 2 F - E distinct vertices (F
        # triangles, E inner edges); vertices standing for several points
        # add the others.
        count = (
            1
            + 2 * np.bincount(label, minlength=n_pieces)
            - np.bincount(label[head], minlength=n_pieces)
        )
        if len(corners.heavy):
            pair_piece, pair_vertex = _pairs(
                piece_of[corners.tri], corners, p, corners.heavy
            )
            np.add.at(count, pair_piece, point_weight_[pair_vertex] - 1)
    else:
        # Distinct (piece, vertex) pairs: a vertex whose triangles in the
        # shape are all in one piece gives one pair (smallest and largest
        # label agree); the few vertices where pieces meet are sorted out.
        lab = piece_of[corners.tri]
        start = corners.start
        if len(start):
            high = np.maximum.reduceat(lab, start)
            low = np.minimum.reduceat(np.where(lab >= 0, lab, n_pieces), start)
        else:
            high = low = np.zeros(0, dtype=np.int64)
        one = (high >= 0) & (low == high)
        pair_piece, pair_vertex = high[one], corners.vertex[start[one]]
        many = (high >= 0) & (low < high)
        if many.any():
            extra = _pairs(lab, corners, p, np.flatnonzero(many[corners.segment]))
            pair_piece = np.concatenate([pair_piece, extra[0]])
            pair_vertex = np.concatenate([pair_vertex, extra[1]])
        count = np.bincount(
            pair_piece, weights=point_weight_[pair_vertex], minlength=n_pieces
        ).astype(np.int64)

    # The `components` pieces that cover most points (ties: first piece).
    order = np.lexsort((np.arange(n_pieces), -count, piece_group))
    size = np.bincount(piece_group, minlength=G)
    start = np.cumsum(size) - size
    place = np.arange(n_pieces) - start[piece_group[order]]
    chosen = np.zeros(n_pieces, dtype=bool)
    chosen[order[place < components]] = True
    best = np.bincount(piece_group[chosen], weights=count[chosen], minlength=G).astype(
        np.int64
    )
    if components > 1:
        # The chosen pieces may share points (pieces touching at a vertex):
        # count their union, and where that falls short of `need` but the
        # total does not, search the best set exactly (rare, small).
        vertex = np.unique(pair_vertex[chosen[pair_piece]])
        union = np.bincount(
            tri.point_group[vertex], weights=point_weight_[vertex], minlength=G
        ).astype(np.int64)
        short = union < best
        if need is not None:
            short &= (union < need) & (best >= need)
        unsure = np.flatnonzero(short)
        best = union
        for g in unsure.tolist():
            mine = np.flatnonzero(piece_group == g)
            in_pair = np.isin(pair_piece, mine)
            best[g], pick = _max_union(
                pair_piece[in_pair],
                pair_vertex[in_pair],
                point_weight_,
                mine,
                count[mine],
                components,
            )
            chosen[mine] = False
            chosen[pick] = True
    return best, sel, label, chosen


def _max_union(pair_piece, pair_vertex, point_weight_, pieces, count, components):
    """Largest weighted union of at most ``components`` pieces: branch and bound.

    Pieces are tried in decreasing order of their own count; a branch stops
    when its count plus the counts of the next pieces cannot beat the best
    union found. Returns the union's weight and the pieces.
    """
    order = np.argsort(-count, kind="stable")
    pieces, count = pieces[order].tolist(), count[order].tolist()
    members = {q: set() for q in pieces}
    for q, v in zip(pair_piece.tolist(), pair_vertex.tolist(), strict=True):
        members[q].add(v)
    w = {v: int(point_weight_[v]) for v in pair_vertex.tolist()}
    best = [0, ()]

    def grow(start, chosen, covered, value):
        if value > best[0]:
            best[0], best[1] = value, chosen
        left = components - len(chosen)
        if left == 0:
            return
        for i in range(start, len(pieces)):
            if value + sum(count[i : i + left]) <= best[0]:
                return  # counts only decrease from here on
            new = members[pieces[i]] - covered
            grow(
                i + 1,
                (*chosen, pieces[i]),
                covered | new,
                value + sum(w[v] for v in new),
            )

    grow(0, (), frozenset(), 0)
    return best[0], np.array(best[1], dtype=np.int64)


def outlier_optimum(
    tri: Triangulation,
    weight: np.ndarray,
    upper: np.ndarray,
    k: np.ndarray,
    components: int,
    *,
    filled: bool = False,
) -> Kept:
    """Outlier-tolerant optimum of every group whose budget ``k`` is > 0.

    Parameters
    ----------
    tri : Triangulation
    weight : ndarray of int, shape (m,)
        Weight of every triangle as a rank (radius, or fill radius for
        ``holes=False``), as for :meth:`geoalpha.core.Spectrum.build`.
    upper : ndarray of int, shape (G,)
        A valid rank of every group: the optimum without outliers.
    k : ndarray of int, shape (G,)
        Distinct points each group may leave out; groups with 0 (and
        degenerate groups) keep ``upper`` and every triangle up to it.
    components : int
        Largest number of pieces kept.
    filled : bool, default False
        True if ``weight`` are fill radii (``holes=False``), as for
        :meth:`geoalpha.core.Spectrum.build`: pieces are then counted by
        Euler's formula.

    Returns
    -------
    Kept

    Examples
    --------
    >>> from geoalpha import core
    >>> square = [[0, 0], [1, 0], [1, 1], [0, 1], [0.5, 0.5]]
    >>> tri = core.triangulate(square + [[9, 9]])  # one stray point
    >>> w = core.fill_radius(tri)
    >>> upper = core.Spectrum.build(tri, w, filled=True).optimum()
    >>> kept = outlier_optimum(tri, w, upper, np.array([1]), 1, filled=True)
    >>> float(tri.values[kept.rank[0]]), kept.n_outliers.tolist()
    (0.5, [1])
    >>> tri.xy[kept.outlier].tolist()
    [[9.0, 9.0]]
    """
    G = tri.n_groups
    active = (np.asarray(k) > 0) & ~tri.degenerate
    hi = np.asarray(upper, dtype=np.int64).copy()
    if not active.any():
        return Kept(
            rank=hi,
            inside=weight <= hi[tri.tri_group],
            n_pieces=np.zeros(G, dtype=np.int64),
            n_outliers=np.zeros(G, dtype=np.int64),
            outlier=np.zeros(len(tri.xy), dtype=bool),
        )
    point_weight_ = point_weight(tri)
    corners = _Corners.build(tri, point_weight_, filled)
    need = tri.n_distinct - np.asarray(k, dtype=np.int64)
    lo = np.minimum(_coverage_rank(tri, weight, point_weight_, need), hi)
    lo = np.maximum(lo, tri.value_ptr[:-1])
    for _ in range(_MAX_ROUNDS):
        todo = active & (lo < hi)
        if not todo.any():
            break
        mid = (lo + hi) // 2
        best, *_ = _best_cover(
            tri, weight, mid, todo, point_weight_, components, need, corners
        )
        ok = best >= need
        hi = np.where(todo & ok, mid, hi)
        lo = np.where(todo & ~ok, mid + 1, lo)

    inside = weight <= hi[tri.tri_group]
    # At the optimum, the best set itself (not just one that is good enough).
    best, sel, label, chosen = _best_cover(
        tri, weight, hi, active, point_weight_, components, None, corners
    )
    inside[sel] = chosen[label]
    held = np.zeros(len(tri.xy), dtype=bool)
    held[np.compress(inside, tri.triangles, axis=0).ravel()] = True
    return Kept(
        rank=hi,
        inside=inside,
        n_pieces=_count_chosen(tri, sel, label, chosen, G),
        n_outliers=np.where(active, tri.n_distinct - best, 0),
        outlier=active[tri.point_group] & ~held[tri.vertex],
    )


def _count_chosen(tri, sel, label, chosen, G) -> np.ndarray:
    """Chosen pieces per group."""
    first = np.full(len(chosen), -1, dtype=np.int64)
    first[label[::-1]] = sel[::-1]
    return np.bincount(tri.tri_group[first[chosen]], minlength=G)


def best_coverage(
    tri: Triangulation,
    weight: np.ndarray,
    rank: np.ndarray,
    components: int,
    *,
    filled: bool = False,
) -> np.ndarray:
    """Best coverage of every group's shape at ``rank`` (one rank per group).

    The largest number of distinct points the union of at most
    ``components`` pieces covers (searched exactly where pieces share points).
    ``filled``: the weights are fill radii (see :func:`outlier_optimum`).

    Examples
    --------
    >>> from geoalpha import core
    >>> tri = core.triangulate([[0, 0], [1, 0], [1, 1], [0, 1], [9, 9]])
    >>> best_coverage(tri, tri.rank, np.array([tri.rank.min()]), 1).tolist()
    [4]
    """
    active = ~tri.degenerate
    point_weight_ = point_weight(tri)
    return _best_cover(
        tri,
        weight,
        np.asarray(rank),
        active,
        point_weight_,
        components,
        None,
        _Corners.build(tri, point_weight_, filled),
    )[0]
