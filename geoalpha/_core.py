"""The compiled kernel (:mod:`geoalpha._kernel`) and the polygons it returns.

:func:`solve` hands every group to the Rust kernel in one call; rings come back as
indices of input points, so every vertex is an input point, bit for bit.
"""

from __future__ import annotations

import enum
import itertools
import numbers
import os
from typing import NamedTuple

import numpy as np
import shapely

from geoalpha import _kernel
from geoalpha._options import Request
from geoalpha.errors import first_n

__all__ = [
    "ALPHA_RTOL",
    "ANTIMERIDIAN_SNAP",
    "LIMITED_BY",
    "MAX_COORDINATE",
    "MAX_EMPTY_GROUPS",
    "MAX_UNION_NODES",
    "NEAR_RTOL",
    "OUTPUT_BUFFER_RTOL",
    "PRECISION_ULPS",
    "REASONS",
    "REPAIR_RTOL",
    "SUSPICIOUS_FACTOR",
    "THIN",
    "TIE_RTOL",
    "AlphaShapes",
    "Alternatives",
    "Compiled",
    "Reason",
    "Why",
    "check_points",
    "cores",
    "group_codes",
    "radius_of_alpha",
    "solve",
    "threads",
]

#: Points closer than this times their group's extent are one point, and a
#: group within it of a line is degenerate.
NEAR_RTOL: float = _kernel.NEAR_RTOL
#: Floor of that tolerance in units in the last place of the group's largest
#: coordinate.
PRECISION_ULPS: float = _kernel.PRECISION_ULPS
#: Circumradii that agree to this relative tolerance are one spectrum value.
TIE_RTOL: float = _kernel.TIE_RTOL
#: Slack of the solid test ``alpha * r <= 1`` for a given alpha.
ALPHA_RTOL: float = _kernel.ALPHA_RTOL
#: Coordinates beyond this magnitude are refused (their squares overflow).
MAX_COORDINATE: float = _kernel.MAX_COORDINATE
#: Groups beyond the number of points a call may have (empty ones): a larger
#: count is refused (:func:`group_codes`), as each group costs memory.
MAX_EMPTY_GROUPS: int = _kernel.MAX_EMPTY_GROUPS

# The tolerances of the Python side, here with the kernel's so that every
# tolerance of geoalpha is in this module (docs/user_guide/guarantee.md).

#: Width of the widened ear (or strip) that takes in a point no other repair
#: could, in the output coordinates, relative to the polygon's extent (at least 1).
REPAIR_RTOL = 1e-9
#: Width of the ``degenerate="buffer"`` polygon made in the output coordinates
#: (where the metric one is not valid there), relative to the extent there.
OUTPUT_BUFFER_RTOL = 1e-6
#: Longitudes this close (degrees) to the antimeridian are put on it when a
#: hull is split there.
ANTIMERIDIAN_SNAP = 1e-9


class Reason(enum.IntEnum):
    """Why a group has no shape (``OK``: it has one), the one definition of the codes.

    The compiled kernel exports the names of its codes (``_kernel.REASONS``),
    which a test compares with these; ``GUARANTEE`` is Python's own (the
    guarantee stage found no valid polygon holding the group's points in the
    output coordinates); ``HEMISPHERE`` is ``crs="sphere"``'s refusal (a point
    beyond ``MAX_SPHERE_DEGREES`` of its group's centre).

    Examples
    --------
    >>> import warnings
    >>> import geoalpha
    >>> from geoalpha import Reason
    >>> xy = [[0, 0], [1, 1], [2, 2], [5, 5], [0, 3], [1, 3], [0, 4]]
    >>> with warnings.catch_warnings():  # a DegenerateGroupWarning names them
    ...     warnings.simplefilter("ignore")
    ...     res = geoalpha.alpha_shapes(xy, [0, 0, 0, 1, 2, 2, 2])
    >>> [Reason(r).name for r in res.reason]
    ['COLLINEAR', 'FEW', 'OK']
    """

    OK = 0
    FEW = 1  #: fewer than 3 distinct points
    COLLINEAR = 2  #: all points on a line
    COLLINEAR_OUT = 3  #: all points on a line in the output coordinates
    RINGS = 4  #: no rings could be traced
    GUARANTEE = 5  #: no valid polygon holding its points in the output coordinates
    HEMISPHERE = 6  #: too wide for the sphere's kernel
    FAILED = 7  #: the kernel failed on this group; the other groups are unaffected


#: The reasons of a group too thin for any shape: fewer than 3 distinct points,
#: or all on a line (in the computation or the output coordinates).
THIN = (Reason.FEW, Reason.COLLINEAR, Reason.COLLINEAR_OUT)


#: What limits a group's radius, by the kernel's code (``_kernel.LIMITED_BY``):
#: ``"coverage"``, ``"connection"``, ``"outliers"``, ``"alpha given"``,
#: ``"degenerate"`` (:doc:`/user_guide/why`).
LIMITED_BY: dict[int, str] = {code: name for name, code in _kernel.LIMITED_BY}

#: A group is suspicious when leaving out one location divides its optimal
#: radius by at least this factor (:doc:`/user_guide/why` justifies it).
SUSPICIOUS_FACTOR = 4.0

#: Why a group has no shape, worded, by the kernel's :class:`Reason` (OK: it has one).
REASONS: dict[Reason, str] = {
    Reason.FEW: "fewer than 3 distinct points",
    Reason.COLLINEAR: "all points on a line",
    Reason.COLLINEAR_OUT: "all points on a line in the output coordinates",
    Reason.RINGS: "no rings could be traced",
    Reason.FAILED: "the kernel failed on this group (a bug: please report it with "
    "its points)",
}

#: The geometry of a group with no shape.
EMPTY_POLYGON = shapely.Polygon()

#: Node budget of the exact best union of several pieces (``outliers=`` with
#: ``components > 1``); a group that reaches it gets the best union found.
MAX_UNION_NODES: int = _kernel.MAX_UNION_NODES

#: Runs of groups, one kernel call each, when a progress bar is shown (else one).
PROGRESS_CHUNKS = 20


def cores() -> int:
    """Return the number of cores this process may run on.

    Examples
    --------
    >>> cores() >= 1
    True
    """
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1


def threads(n_jobs: int | None) -> int:
    """Return the kernel's thread count for ``n_jobs``: at most :func:`cores`.

    None or -1 is every core; more than the cores is capped to them (more
    threads than cores only cost time: the result is the same).

    Examples
    --------
    >>> threads(1), threads(10**6) == cores()
    (1, True)
    >>> threads(None) == threads(-1) == cores()
    True
    """
    if n_jobs is None or n_jobs == -1:
        return cores()
    return min(int(n_jobs), cores())


def check_points(points) -> np.ndarray:
    """Return ``points`` as an (n, 2) float array; raise ValueError naming bad rows.

    Examples
    --------
    >>> check_points([[0, 1], [float("nan"), 3]])
    Traceback (most recent call last):
    ...
    ValueError: points must have finite coordinates; got NaN or inf in 1 row(s) ...
    """
    raw = np.asarray(points)
    if raw.size and raw.dtype.kind not in "iuf":  # integers or floats
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
    if np.abs(xy).max() <= MAX_COORDINATE:  # False for NaN too
        return xy
    bad = np.flatnonzero(~np.isfinite(xy).all(axis=1))
    if len(bad):
        raise ValueError(
            f"points must have finite coordinates; got NaN or inf in {len(bad)} "
            f"row(s) (positions {first_n(bad)})"
        )
    huge = np.flatnonzero((np.abs(xy) > MAX_COORDINATE).any(axis=1))
    raise ValueError(
        f"points must have coordinates within +-{MAX_COORDINATE:g} (their "
        f"squares would overflow); got larger values in {len(huge)} row(s) "
        f"(positions {first_n(huge)}): rescale them"
    )


def group_codes(groups, n: int, n_groups: int | None) -> tuple[np.ndarray, int]:
    """Return the group codes (int64) and the number of groups; ValueError if bad.

    Codes of any integer type and size are checked before they are converted:
    at most ``n + MAX_EMPTY_GROUPS`` groups (each costs memory, even empty).

    Examples
    --------
    >>> codes, n = group_codes([1, 0, 1], 3, None)
    >>> codes.tolist(), n
    ([1, 0, 1], 2)
    >>> group_codes([0, 2**40, 1], 3, None)
    Traceback (most recent call last):
    ...
    ValueError: groups must be codes 0 .. G - 1 (as from pandas.factorize) ...
    """
    limit = n + MAX_EMPTY_GROUPS
    if n_groups is not None and (
        isinstance(n_groups, bool)
        or not isinstance(n_groups, numbers.Integral)
        or not 0 <= n_groups <= limit
    ):
        raise ValueError(
            f"n_groups must be an integer from 0 to the number of points + "
            f"{MAX_EMPTY_GROUPS} ({limit}); got {n_groups!r}"
        )
    if groups is None:
        return np.zeros(n, dtype=np.int64), 1 if n_groups is None else int(n_groups)
    codes = np.asarray(groups)
    if codes.shape != (n,) or not np.issubdtype(codes.dtype, np.integer):
        raise ValueError(
            f"groups must be {n} integer group codes (one per point); got "
            f"{codes.dtype} array of shape {codes.shape}"
        )
    # As Python integers: exact for every integer type (uint64 too).
    low, top = (int(codes.min()), int(codes.max())) if n else (0, -1)
    if low < 0:
        raise ValueError("groups must be codes >= 0 (as from pandas.factorize)")
    if top >= limit:
        raise ValueError(
            "groups must be codes 0 .. G - 1 (as from pandas.factorize) with G at "
            f"most the number of points + {MAX_EMPTY_GROUPS} ({limit}); got code "
            f"{top}: factorize the keys first"
        )
    codes = codes.astype(np.int64, copy=False)
    size = top + 1
    if n_groups is None:
        n_groups = size
    elif n_groups < size:
        raise ValueError(f"n_groups={n_groups} but groups has code {size - 1}")
    return codes, n_groups


def radius_of_alpha(alpha) -> np.ndarray:
    """Radius threshold ``1 / alpha`` (``inf`` for 0) with the kernel's slack.

    Examples
    --------
    >>> radius_of_alpha([0.5, 0.0]).round(12).tolist()
    [2.0, inf]
    """
    alpha = np.asarray(alpha, dtype=float)
    with np.errstate(divide="ignore"):
        return np.where(alpha > 0, (1.0 / alpha) * (1.0 + ALPHA_RTOL), np.inf)


class AlphaShapes(NamedTuple):
    """One entry per group (:doc:`/user_guide/arrays`): the one result record.

    :func:`solve` makes it; :func:`geoalpha.alpha_shapes` returns it (as
    ``geoalpha.AlphaShapes``), and every stage of :func:`geoalpha.hull`
    hands it on updated (``_replace``) down to the table.

    Attributes
    ----------
    alpha : ndarray of float
        The alpha used (the optimum unless given), in 1/unit of the coordinates;
        ``nan`` for degenerate groups, 0 means the convex hull.
    geometry : ndarray of object
        Polygon, MultiPolygon (several pieces) or empty Polygon.
    n_points, n_distinct : ndarray of int
        Input points of the group (duplicates included), and distinct points.
    n_parts : ndarray of int
        Edge-connected pieces of the shape.
    area : ndarray of float
        In the units of ``points`` squared, whatever ``coords`` the geometry has.
    degenerate : ndarray of bool
        The group has no shape (``reason`` is not ``OK``), never one that misses
        a point.
    n_outliers : ndarray of int
        Rows of the group left out of the shape (``outliers=``), else 0.
    outlier : ndarray of bool, shape (n,)
        Per input point: left out (duplicates of a left-out point too).
    gave_up, capped : ndarray of bool
        ``search="bisect"`` stopped at ``max_iterations`` with alpha 0; the piece
        search of ``outliers=`` stopped at :data:`geoalpha._core.MAX_UNION_NODES`.
    reason : ndarray of int
        Why a group is degenerate (a :class:`~geoalpha.Reason`), 0 if not.

    Notes
    -----
    The other fields are for the stages of :func:`geoalpha.hull` (None where
    not made, and in what :func:`geoalpha.alpha_shapes` returns): ``certain``
    (per point: a vertex of its group's polygon in the output coordinates, or
    covered by construction there while that polygon is the one made; not
    tested again), ``rep`` (per point: the row of its
    representative, itself unless merged as a near-duplicate; None when none
    was merged), ``whole`` (the shape is every triangle), ``curve`` (the
    validity curves ``(values, valid, offsets)``, when asked), ``why``
    (:class:`Why`, what :attr:`~geoalpha._options.Request.explain` asked);
    and, added by the frame's stages, ``labels`` (the ``method`` column),
    ``made`` (the polygons :func:`~geoalpha._frame.pipeline.compute` made),
    ``keep`` (the groups that get a row), ``unsplit``, ``neighbours`` and
    ``ceded`` (``overlap="split"``) and ``planar_area`` (``area`` in the
    computation CRS, kept when ``area`` becomes ``area_m2``).

    Examples
    --------
    >>> import geoalpha
    >>> square = [[0, 0], [4, 0], [4, 4], [0, 4], [2, 2]]
    >>> triangle = [[9, 9], [12, 9], [9, 12]]
    >>> res = geoalpha.alpha_shapes(square + triangle, [0] * 5 + [1] * 3)
    >>> res.n_points.tolist(), res.area.tolist(), res.degenerate.tolist()
    ([5, 3], [16.0, 4.5], [False, False])
    """

    alpha: np.ndarray
    geometry: np.ndarray
    n_points: np.ndarray
    n_distinct: np.ndarray
    n_parts: np.ndarray
    area: np.ndarray
    degenerate: np.ndarray
    n_outliers: np.ndarray | None = None
    outlier: np.ndarray | None = None
    gave_up: np.ndarray | None = None
    capped: np.ndarray | None = None
    reason: np.ndarray | None = None
    certain: np.ndarray | None = None
    rep: np.ndarray | None = None
    whole: np.ndarray | None = None
    curve: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
    why: Why | None = None
    labels: np.ndarray | None = None
    made: np.ndarray | None = None
    keep: np.ndarray | None = None
    unsplit: np.ndarray | None = None
    neighbours: np.ndarray | None = None
    ceded: np.ndarray | None = None
    planar_area: np.ndarray | None = None


class Alternatives(NamedTuple):
    """The outlier optima for ``k`` from 1 to ``max_left_out``, flat: one entry each.

    ``group``, ``k``, ``radius``, ``area`` (computation CRS), ``n_parts``,
    ``capped``; the rows each leaves out are ``rows[row_offsets[i]:
    row_offsets[i + 1]]`` (input positions, ascending).
    """

    group: np.ndarray
    k: np.ndarray
    radius: np.ndarray
    area: np.ndarray
    n_parts: np.ndarray
    capped: np.ndarray
    rows: np.ndarray
    row_offsets: np.ndarray

    def left_out(self, i: int) -> np.ndarray:
        """Return the input positions of the rows alternative ``i`` leaves out."""
        return self.rows[self.row_offsets[i] : self.row_offsets[i + 1]]


class Why(NamedTuple):
    """Why each group got its radius (:attr:`Request.explain`), and its alternatives.

    Per group: ``limited_by`` (a key of :data:`LIMITED_BY`), ``critical``
    (shape (G, 3): input positions of the critical triangle's corners, -1
    without one), ``last`` (the points covered last: input positions
    ``last[0][last[1][g]:last[1][g + 1]]``), ``suspicious``. ``alternatives``:
    :class:`Alternatives`.
    """

    limited_by: np.ndarray
    critical: np.ndarray
    last: tuple[np.ndarray, np.ndarray]
    suspicious: np.ndarray
    alternatives: Alternatives


#: Results that are point indices (shifted when groups run in chunks).
_INDICES = ("rep", "ring_vertex", "last_vertex", "alt_rows")


def _run(xy, out, offsets, alpha, progress, request) -> dict:
    """Run the kernel on all groups: one call, or about 20 runs of groups with a bar."""
    n_groups = len(offsets) - 1
    cuts = [0, n_groups]
    if progress is not None and n_groups >= 2 * PROGRESS_CHUNKS:
        cuts = np.linspace(0, n_groups, PROGRESS_CHUNKS + 1).astype(int)
    parts = []
    for g0, g1 in itertools.pairwise(cuts):
        a, b = offsets[g0], offsets[g1]
        res = _kernel.alpha_shapes(
            xy[a:b],
            offsets[g0 : g1 + 1] - a,
            request,
            out_xy=None if out is None else out[a:b],
            alpha=None if alpha is None else alpha[g0:g1],
        )
        parts.append((a, res))
        if progress is not None:
            progress.update(g1 - g0)
    if len(parts) == 1:
        return parts[0][1]
    joined = {}  # the chunks' results as one: indices and offsets shifted
    for key in parts[0][1]:
        arrays, last = [], 0
        for k, (base, res) in enumerate(parts):
            a = res[key]
            if key in _INDICES:
                a = a + base
            elif key == "critical":
                a = np.where(a >= 0, a + base, a)
            elif key.endswith("_offsets"):
                a = (a if k == 0 else a[1:]) + last
                last = int(a[-1]) if len(a) else last
            arrays.append(a)
        joined[key] = np.concatenate(arrays)
    return joined


def _geometries(coords, res, n_groups: int) -> np.ndarray:
    """One Polygon (a part as built), MultiPolygon or empty Polygon per group."""
    out = np.full(n_groups, EMPTY_POLYGON, dtype=object)
    n_parts = res["n_parts"]
    if not n_parts.any():
        return out
    parts = shapely.from_ragged_array(
        shapely.GeometryType.POLYGON,
        np.take(coords, res["ring_vertex"], axis=0),
        (res["ring_offsets"], res["polygon_offsets"]),
    )
    one = n_parts == 1
    out[one] = parts[res["group_offsets"][:-1][one]]
    many = n_parts > 1
    if many.any():  # a group's parts are consecutive, groups in order
        owner = np.repeat(np.arange(many.sum()), n_parts[many])
        out[many] = shapely.multipolygons(
            parts[np.repeat(many, n_parts)], indices=owner
        )
    return out


#: What :func:`solve` computes unless told: the optimum, holes filled, one piece.
DEFAULT_REQUEST = Request()


def solve(
    xy: np.ndarray,
    codes: np.ndarray,
    n_groups: int,
    request: Request = DEFAULT_REQUEST,
    *,
    out: np.ndarray | None = None,
    progress=None,
) -> AlphaShapes:
    """Run the kernel on every group and build the polygons.

    Parameters
    ----------
    xy, codes, n_groups
        Checked points (:func:`check_points`) in the computation CRS, their
        group codes ``0 .. n_groups - 1`` (:func:`group_codes`), and how many.
    request : Request
        What to compute (:meth:`geoalpha._options.Options.request`): holes,
        components, outliers, a given alpha (one, or one per group, >= 0)
        instead of the optimum, the sphere, the curves, why, the alternatives.
    out : ndarray of shape (n, 2), optional
        The points in the output coordinates (polygons, collinearity).
    progress : object with ``update(n)``, optional
        Advanced in about 20 steps.

    Returns
    -------
    AlphaShapes
        As the kernel made it: ``reason`` as it says (a group of reason
        ``RINGS`` may be ``whole``), ``alpha``, ``area`` and the polygons of
        degenerate groups not yet cleared, ``gave_up`` all False; per point
        (input order): ``outlier``, ``certain``, ``rep``.

    Examples
    --------
    >>> xy = np.array([[0, 0], [4, 0], [4, 4], [0, 4], [2, 3.5]])
    >>> res = solve(xy, np.zeros(5, dtype=np.int64), 1, Request(n_jobs=1))
    >>> res.reason.tolist(), res.n_distinct.tolist(), res.geometry[0].geom_type
    ([0], [5], 'Polygon')
    """
    n, sizes = len(xy), np.bincount(codes, minlength=n_groups)
    offsets = np.zeros(n_groups + 1, dtype=np.int64)
    np.cumsum(sizes, out=offsets[1:])
    sxy, order = np.ascontiguousarray(xy, dtype=float), np.arange(n)
    sout = None if out is None else np.ascontiguousarray(out)
    n_threads = threads(request.n_jobs)
    if n > 1 and (codes[1:] < codes[:-1]).any():  # (sorted input is not copied)
        codes = np.ascontiguousarray(codes, dtype=np.int64)
        sxy, sout, order = _kernel.sort_groups(
            sxy, codes, n_groups, out_xy=sout, threads=n_threads
        )
    alpha = request.alpha
    if alpha is not None:  # one per group
        alpha = np.broadcast_to(np.asarray(alpha, dtype=float), (n_groups,))
        alpha = np.ascontiguousarray(alpha)
    res = _run(sxy, sout, offsets, alpha, progress, Compiled(request, n_threads))
    coords = sxy if sout is None else sout
    # A point is on a ring when its coordinates are a ring vertex's: it is
    # one (a merged near-duplicate taken in), or it has its representative's.
    # In the computation coordinates a point with its representative's
    # coordinates is covered too: the kernel's rings hold every distinct point.
    certain = np.zeros(n, dtype=bool)
    certain[res["ring_vertex"]] = True
    rep = res["rep"]
    point = np.ascontiguousarray(coords, float).reshape(n, 2).view(complex)[:, 0]
    same = point == point[rep]
    certain |= same if out is None else certain[rep] & same
    return AlphaShapes(
        alpha=res["alpha"],
        geometry=_geometries(coords, res, n_groups),
        n_points=sizes,
        n_distinct=res["n_distinct"].astype(np.int64),
        n_parts=res["n_parts"].astype(np.int64),
        area=res["area"],
        degenerate=res["reason"] != Reason.OK,
        n_outliers=res["n_outliers"].astype(np.int64),
        outlier=_in_input_order(res["left_out"], order, False),
        gave_up=np.zeros(n_groups, dtype=bool),
        capped=res["capped"],
        reason=res["reason"].astype(np.int64),
        certain=_in_input_order(certain, order, True),
        rep=_rows_of_representatives(rep, order),
        whole=res["whole"],
        curve=(res["curve_value"], res["curve_valid"], res["curve_offsets"])
        if request.curve
        else None,
        why=_why(res, order, n_groups),
    )


def _in_input_order(flags: np.ndarray, order: np.ndarray, usual: bool) -> np.ndarray:
    """Per-point flags of the sorted points, in input order (all ``usual``: no work)."""
    out = np.full(len(flags), usual, dtype=bool)
    if (flags != usual).any():
        out[order] = flags
    return out


def _rows_of_representatives(rep: np.ndarray, order: np.ndarray) -> np.ndarray | None:
    """Per input row, the row of its representative; None when no point was merged."""
    if not (rep != np.arange(len(rep))).any():
        return None
    rows = np.empty(len(rep), dtype=np.int64)
    rows[order] = order[rep]
    return rows


class Compiled:
    """A :class:`~geoalpha._options.Request` as the compiled kernel reads it.

    Its attributes are those of ``Request`` in ``src/lib.rs`` (``threads`` from
    ``n_jobs``; ``fraction`` or ``count``, the outlier budget, only for the
    optimum, not at a given alpha).

    Examples
    --------
    >>> Compiled(Request(outliers=0.1), 1).fraction
    0.1
    """

    def __init__(self, request: Request, n_threads: int):
        optimum = request.alpha is None
        self.holes = bool(request.holes)
        self.components = int(request.components)
        self.curve = bool(request.curve)
        self.threads = n_threads
        self.max_union_nodes = MAX_UNION_NODES
        self.sphere = bool(request.sphere)
        self.locations = request.locations
        self.fraction = request.fraction if optimum else 0.0
        count = optimum and request.budget_kind == "count"
        self.count = int(request.outliers) if count else 0
        self.explain = bool(request.explain)
        self.max_left_out = int(request.max_left_out)
        self.left_out_locations = request.left_out_locations
        self.suspicious = float(request.suspicious_factor)


def _why(res: dict, order: np.ndarray, n_groups: int) -> Why:
    """Return the kernel's explanation with point indices as input positions."""
    critical = res["critical"].reshape(n_groups, 3)
    if len(order):  # (no points: no triangle either)
        critical = np.where(critical >= 0, order[np.maximum(critical, 0)], -1)
    alt_offsets = res["alt_offsets"]
    return Why(
        limited_by=res["limited_by"],
        critical=critical,
        last=(order[res["last_vertex"]], res["last_offsets"]),
        suspicious=res["suspicious"],
        alternatives=Alternatives(
            group=np.repeat(np.arange(n_groups), np.diff(alt_offsets)),
            k=res["alt_k"].astype(np.int64),
            radius=res["alt_radius"],
            area=res["alt_area"],
            n_parts=res["alt_parts"].astype(np.int64),
            capped=res["alt_capped"],
            rows=order[res["alt_rows"]],
            row_offsets=res["alt_row_offsets"],
        ),
    )
