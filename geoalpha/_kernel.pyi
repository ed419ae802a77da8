"""Type stub of geoalpha's compiled kernel (the Rust crate at the repository root).

Call it through :func:`geoalpha._core.solve`, which checks the input once,
has the points sorted by group (:func:`sort_groups`, unless they are already)
and builds the polygons from the rings.
"""

from typing import Final, Protocol

import numpy as np
import numpy.typing as npt

__version__: Final[str]
#: Version of the spade crate (exact Delaunay triangulation) the kernel uses.
SPADE_VERSION: Final[str]
#: Points closer than this times their group's extent are one point; a group
#: within it of a line is degenerate.
NEAR_RTOL: Final[float]
#: Floor of that tolerance, in units in the last place of the largest coordinate.
PRECISION_ULPS: Final[float]
#: Circumradii that agree to this relative tolerance are one spectrum value.
TIE_RTOL: Final[float]
#: Relative slack of the solid test ``alpha * r <= 1`` for a given alpha.
ALPHA_RTOL: Final[float]
#: Coordinates beyond this magnitude are refused.
MAX_COORDINATE: Final[float]
#: Groups beyond the number of points a call may have (a larger count is refused).
MAX_EMPTY_GROUPS: Final[int]
#: Branch-and-bound nodes the best union of several pieces may visit.
MAX_UNION_NODES: Final[int]
#: The sphere's radius with ``sphere=True`` (metres): WGS84's authalic radius.
EARTH_RADIUS: Final[float]
#: With ``sphere=True``, a group with a point farther than this (degrees) from
#: its centre (the normalised mean of its unit vectors) is refused (reason 6,
#: ``geoalpha._core.Reason.HEMISPHERE``).
MAX_SPHERE_DEGREES: Final[float]

#: The reason codes by name: ``[("OK", 0), ("FEW", 1), ...]`` (``kernel.Reason``).
REASONS: Final[list[tuple[str, int]]]
#: What limits a radius, by name: ``[("degenerate", 0), ("coverage", 1), ...]``.
LIMITED_BY: Final[list[tuple[str, int]]]

class Request(Protocol):
    """What :func:`alpha_shapes` reads of ``request`` (``geoalpha._core.Compiled``)."""

    holes: bool  #: keep holes (the shape is the solid triangles) or fill them
    components: int  #: largest number of edge-connected pieces (>= 1)
    curve: bool  #: also return every group's validity curve
    threads: int  #: threads to spread the groups over (0 or above the cores: all)
    max_union_nodes: int  #: node budget of the best union (``MAX_UNION_NODES``)
    sphere: bool  #: ``xy`` is lon/lat in degrees, computed on the sphere
    locations: bool  #: ``count``/``fraction`` count locations, not rows
    fraction: float  #: the budget as a fraction in [0, 1) of each group's unit
    count: int  #: the budget as a count (>= 0), the same for every group
    explain: bool  #: the critical triangle, ``limited_by``, the points covered last
    max_left_out: int  #: the outlier optima for k = 1..max_left_out
    left_out_locations: bool  #: those k count locations (else rows)
    suspicious: float  #: flag a radius one location divides by this (0: off)

def alpha_shapes(
    xy: npt.NDArray[np.float64],
    offsets: npt.NDArray[np.int64],
    request: Request,
    *,
    out_xy: npt.NDArray[np.float64] | None = None,
    alpha: npt.NDArray[np.float64] | None = None,
) -> dict[str, np.ndarray]:
    """Optimal (or given-alpha) alpha shapes of every group, in one call.

    Parameters
    ----------
    xy : ndarray of float64, shape (n, 2), C-contiguous
        Points sorted by group, in the computation CRS (metres).
    offsets : ndarray of int64, shape (G + 1,)
        Group ``g`` is ``xy[offsets[g]:offsets[g + 1]]``.
    request : Request
        What to compute, the same for every group (its attributes are read
        once). With ``sphere``, ``xy`` holds longitudes and latitudes in
        degrees and every group is computed on the sphere of radius
        ``EARTH_RADIUS`` (``src/sphere.rs``); groups beyond
        ``MAX_SPHERE_DEGREES`` of their centre get reason 6. The GIL is
        released for the whole computation.
    out_xy : ndarray of float64, shape (n, 2), optional
        The same points in the coordinates the result is returned in; groups
        collinear there are degenerate too (reason 3).
    alpha : ndarray of float64, shape (G,), optional
        A given alpha per group (>= 0; 0 is the convex hull) instead of the
        optimum.

    Returns
    -------
    dict of ndarray
        Per group (G): ``reason`` (uint8, ``geoalpha._core.Reason``: 0 a
        shape, 1 fewer than 3 distinct points, 2 collinear (on a great circle
        with ``sphere``), 3 collinear in ``out_xy``, 4 no rings, 6 a point
        beyond ``MAX_SPHERE_DEGREES`` of the group's centre, 7 the kernel
        failed on this group: a panic inside it, caught, the other groups
        unaffected), ``alpha``, ``n_distinct``, ``n_parts``, ``area``,
        ``n_outliers`` (rows), ``whole``, ``capped``,
        ``limited_by`` (uint8, ``LIMITED_BY``), ``suspicious``; ``critical``
        (3 per group: point indices of the critical triangle, -1 without);
        ``last_vertex``/``last_offsets`` (the points covered last). Per point
        (n): ``rep`` (index of the point that represents it), ``left_out``.
        Rings: ``ring_vertex`` (point indices, closed rings),
        ``ring_offsets``, ``polygon_offsets``, ``group_offsets`` (geoarrow's
        MultiPolygon layout). Curves: ``curve_value``, ``curve_valid``,
        ``curve_offsets``. Alternatives (k = 1..``max_left_out``, and a
        flagged group's one-location optimum), grouped by ``alt_offsets``:
        ``alt_k``, ``alt_radius``, ``alt_area``, ``alt_parts``,
        ``alt_capped``, and the rows each leaves out, ``alt_rows`` by
        ``alt_row_offsets``.

    Raises
    ------
    ValueError
        On offsets, lengths or options out of range, or a coordinate that is
        not finite or beyond ``MAX_COORDINATE`` (a latitude beyond 90
        degrees with ``sphere``).
    RuntimeError
        If the kernel failed unexpectedly outside any group (a bug; no panic
        crosses over; one inside a group is that group's reason 7).
    KeyboardInterrupt
        On Ctrl-C (SIGINT) during the call: the kernel stops within about
        half a second (it checks between groups and inside large ones).
    """

def sort_groups(
    xy: npt.NDArray[np.float64],
    codes: npt.NDArray[np.int64],
    groups: int,
    *,
    out_xy: npt.NDArray[np.float64] | None = None,
    threads: int = 0,
) -> tuple[
    npt.NDArray[np.float64], npt.NDArray[np.float64] | None, npt.NDArray[np.int64]
]:
    """Sort the points stably by group, as :func:`alpha_shapes` takes them.

    Counting sorts (the order beside the points on a second of ``threads``
    threads, 0: every core) with the GIL released: the same order as numpy's
    stable argsort.

    Parameters
    ----------
    xy : ndarray of float64, shape (n, 2), C-contiguous
        The points.
    codes : ndarray of int64, shape (n,), C-contiguous
        Each point's group, ``0 <= code < groups``.
    groups : int
        The number of groups, at most ``n + MAX_EMPTY_GROUPS``.
    out_xy : ndarray of float64, shape (n, 2), optional
        The same points in the output coordinates, sorted alike.
    threads : int
        Threads (0, or more than the cores the process may run on: every core).

    Returns
    -------
    tuple of ndarray
        ``xy`` and ``out_xy`` (or None) sorted, and ``order`` (int64, shape
        (n,)): the input row of each sorted point.

    Raises
    ------
    ValueError
        On arrays of different lengths or shapes, a code out of range, or
        more groups than ``n + MAX_EMPTY_GROUPS``.
    """

def geodesic_areas(
    lon: npt.NDArray[np.float64],
    lat: npt.NDArray[np.float64],
    ring_offsets: npt.NDArray[np.int64],
    polygon_offsets: npt.NDArray[np.int64],
    geometry_offsets: npt.NDArray[np.int64],
    *,
    threads: int = 0,
) -> npt.NDArray[np.float64]:
    """Areas (m²) on the WGS84 ellipsoid of (multi)polygons, in one call.

    The layout of :func:`shapely.to_ragged_array` for (multi)polygons. Each
    ring's edges are geodesics between its vertices; its area (Karney's
    algorithm, GeographicLib's, crate ``geographiclib-rs``) is that of the
    side smaller than half the ellipsoid whichever way it turns, so a ring
    around a pole gives the cap. A polygon's area is its first ring's minus
    the others' (holes); a geometry's, the sum of its polygons'. Rings of
    fewer than three distinct vertices count 0. The geometries run on
    ``threads`` threads (0: every core) with the GIL released.

    Parameters
    ----------
    lon, lat : ndarray of float64, shape (n,), C-contiguous
        The vertices, in degrees (EPSG:4326); a ring's last vertex may repeat
        its first. Longitudes may lie outside [-180, 180].
    ring_offsets : ndarray of int64, shape (R + 1,)
        Ring ``r`` is vertices ``ring_offsets[r]:ring_offsets[r + 1]``.
    polygon_offsets : ndarray of int64, shape (P + 1,)
        Polygon ``p`` is rings ``polygon_offsets[p]:polygon_offsets[p + 1]``,
        its exterior first.
    geometry_offsets : ndarray of int64, shape (G + 1,)
        Geometry ``g`` is polygons ``geometry_offsets[g]:geometry_offsets[g + 1]``.
    threads : int
        Threads (0, or more than the cores: every core).

    Returns
    -------
    ndarray of float64, shape (G,)
        The area of each geometry, in square metres.

    Raises
    ------
    ValueError
        Offsets that do not run from 0 to the length of what they index
        without going down, ``lon`` and ``lat`` of different lengths, or a
        vertex that is not finite or has a latitude beyond +-90.
    """

def split_overlaps(
    xy: npt.NDArray[np.float64],
    ring_offsets: npt.NDArray[np.int64],
    polygon_offsets: npt.NDArray[np.int64],
    geometry_offsets: npt.NDArray[np.int64],
    points: npt.NDArray[np.float64],
    point_offsets: npt.NDArray[np.int64],
    pairs: npt.NDArray[np.int64],
    *,
    threads: int = 0,
) -> dict[str, np.ndarray | list[str]]:
    """``overlap="split"``: each overlap of ``pairs`` to the nearest point's group.

    One constrained triangulation (spade) per component of overlapping groups
    holds their rings and, per pair, the Voronoi edges between a point of
    one group and one of the other; each triangle goes to the group of the
    nearest point among those whose polygons hold it, and each group's
    polygon is traced from its triangles (``src/split.rs``). The points in
    the boxes the pairs share are checked with exact predicates: covered by
    their group's triangles, strictly inside no other's. Components run on
    ``threads`` threads with the GIL released.

    Parameters
    ----------
    xy, ring_offsets, polygon_offsets, geometry_offsets
        The polygons, one (Multi)Polygon a geometry, in the layout of
        :func:`shapely.to_ragged_array` (closed rings).
    points : ndarray of float64, shape (k, 2), C-contiguous
        The points of each geometry's group (those its polygon covers).
    point_offsets : ndarray of int64, shape (G + 1,)
        Geometry ``g``'s points are ``points[point_offsets[g]:point_offsets[g + 1]]``.
    pairs : ndarray of int64, shape (p, 2), C-contiguous
        The pairs of geometries whose interiors overlap.
    threads : int
        Threads (0, or more than the cores: every core).

    Returns
    -------
    dict
        ``status`` (uint8, per geometry: 0 in no pair, 1 split, 2 its
        component failed: a location of two groups, a coordinate spade
        refuses, a constraint spade routed around a crossing, a failed
        check); the split polygons as ``xy``, ``ring_offsets``,
        ``polygon_offsets``, ``geometry_offsets`` (MultiPolygons, empty for
        status 0 and 2); ``failures``, the reason of each failed component.

    Raises
    ------
    ValueError
        Offsets that do not rise from 0 to the length of what they index, or
        a pair naming no geometry.
    """
