"""Alpha shapes on the sphere: the array side of ``crs="sphere"``.

The kernel does the geometry (``src/sphere.rs``); this module words the groups
it refuses and turns its rings into valid longitude/latitude polygons.
"""

from __future__ import annotations

import functools

import numpy as np
import shapely

from geoalpha import _kernel
from geoalpha._arrays.lonlat import output_lonlat, snap_meridian
from geoalpha.errors import setting

__all__ = [
    "EARTH_RADIUS",
    "MAX_SPHERE_DEGREES",
    "close_around_poles",
    "follow_arcs",
    "polar_groups",
    "refused_message",
    "sphere_output",
]

#: Radius of the sphere (metres): WGS84's authalic radius (the ellipsoid's area).
EARTH_RADIUS: float = _kernel.EARTH_RADIUS
#: Largest angle (degrees) from a group's centre to one of its points.
MAX_SPHERE_DEGREES: float = _kernel.MAX_SPHERE_DEGREES


def refused_message(names: str, count: int) -> str:
    """Word the error of groups too wide for the sphere's kernel, naming them.

    Examples
    --------
    >>> refused_message("'Chile'", 1)  # doctest: +ELLIPSIS
    "crs='sphere' handles groups ... 1 group(s) do not: 'Chile'. ..."
    """
    return (
        f"{setting('crs', 'sphere')} handles groups whose points all lie within "
        f"{MAX_SPHERE_DEGREES:g} degrees of their centre (well inside a "
        f"hemisphere); {count} group(s) do not: {names}. Split them "
        f"({setting('by')} with a finer key) or compute them with "
        f"{setting('crs', 'auto')}"
    )


def polar_groups(
    lonlat: np.ndarray, codes: np.ndarray, which: np.ndarray
) -> np.ndarray:
    """Of the groups ``which``, those whose spherical convex hull holds a pole.

    Tested in the gnomonic projection from the group's centre (great circles
    map to lines).

    Examples
    --------
    >>> lonlat = np.array([[0, 80], [120, 80], [240, 80],  # around the pole
    ...                    [10, 10], [12, 10], [11, 12.0]])
    >>> codes = np.array([0, 0, 0, 1, 1, 1])
    >>> polar_groups(lonlat, codes, np.array([0, 1])).tolist()
    [True, False]
    """
    unit = _unit(lonlat)
    out = np.zeros(len(which), dtype=bool)
    for k, g in enumerate(which):
        u = unit[codes == g]
        c = u.sum(axis=0)
        if not np.linalg.norm(c) > 0:
            continue
        c /= np.linalg.norm(c)
        axis = np.array([0.0, 0.0, 1.0]) if abs(c[2]) < 0.9 else np.array([1.0, 0, 0])
        e1 = np.cross(axis, c)
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(c, e1)
        z = u @ c
        if (z <= 0).any() or c[2] == 0:
            continue
        hull = shapely.MultiPoint(np.column_stack([u @ e1 / z, u @ e2 / z]))
        pole = shapely.Point(e1[2] / c[2], e2[2] / c[2])  # the one on c's side
        out[k] = shapely.covers(hull.convex_hull, pole)
    return out


def sphere_output(lonlat: np.ndarray, codes: np.ndarray, n_groups: int):
    """Output longitudes and latitudes of ``crs="sphere"``, and the polar groups.

    Returns ``(out, crossing, wide, polar)``: as
    :func:`~geoalpha._arrays.lonlat.output_lonlat`, but the groups around a pole
    (:func:`polar_groups`) keep their input longitudes and neither cross nor are wide.

    Examples
    --------
    >>> lonlat = np.array([[179.0, 0.0], [-179.0, 1.0], [179.0, 2.0]])
    >>> out, crossing, wide, polar = sphere_output(lonlat, np.zeros(3, int), 1)
    >>> out[:, 0].tolist(), crossing.tolist(), polar.tolist()
    ([179.0, 181.0, 179.0], [True], [False])
    """
    out, crossing, wide = output_lonlat(lonlat, codes, n_groups)
    maybe = np.flatnonzero(crossing | wide)
    polar = np.zeros(n_groups, dtype=bool)
    if len(maybe):
        polar[maybe] = polar_groups(lonlat, codes, maybe)
    if polar.any() and out is not lonlat:  # (a copy output_lonlat made)
        mine = polar[codes]
        out[mine] = lonlat[mine]
    return out, crossing & ~polar, wide & ~polar, polar


def close_around_poles(geometry: np.ndarray) -> np.ndarray:
    """Longitude/latitude polygons of the shapes of groups around a pole.

    Rings follow their great-circle arcs, unwrapped; a shell once around in
    longitude is closed along the pole (+-90), cut at +-180 degrees and made
    valid (:doc:`/user_guide/sphere`).

    Examples
    --------
    >>> cap = shapely.Polygon([(0, 80), (120, 80), (240, 80)])  # around the pole
    >>> closed = close_around_poles(np.array([cap]))[0]
    >>> closed.is_valid, closed.bounds
    (True, (-180.0, 80.0, 180.0, 90.0))
    """
    return _rebuilt(geometry, _close_one)


def follow_arcs(geometry: np.ndarray) -> np.ndarray:
    """Polygons whose edges follow the sphere's great-circle arcs.

    For longitude/latitude polygons that fold over themselves (long edges far
    from their arcs); longitudes stay unwrapped across +-180 where they were.

    Examples
    --------
    >>> big = shapely.Polygon([(0, 0), (40, 60), (80, 0)])
    >>> arcs = follow_arcs(np.array([big]))[0]
    >>> arcs.is_valid, len(arcs.exterior.coords) > 4
    (True, True)
    """
    return _rebuilt(
        geometry,
        lambda p: shapely.Polygon(
            _densify(np.asarray(p.exterior.coords), keep=True),
            [_densify(np.asarray(h.coords), keep=True) for h in p.interiors],
        ),
    )


def _rebuilt(geometry: np.ndarray, rebuild) -> np.ndarray:
    """Rebuild every part of every geometry; the union of each made valid."""
    out = geometry.copy()
    for g, geom in enumerate(geometry):
        if geom is not None and not geom.is_empty:
            merged = shapely.union_all([rebuild(p) for p in shapely.get_parts(geom)])
            out[g] = merged if merged.is_valid else shapely.make_valid(merged)
    return out


def _unit(lonlat: np.ndarray) -> np.ndarray:
    """Return the unit vectors of longitudes and latitudes in degrees."""
    lon, lat = np.radians(lonlat[:, 0]), np.radians(lonlat[:, 1])
    return np.column_stack(
        [np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)]
    )


def _densify(ring: np.ndarray, step: float = 0.25, keep: bool = False) -> np.ndarray:
    """Points every ``step`` degrees (of arc and of longitude) along a ring's arcs."""
    u = _unit(ring)
    out = [ring[:1]]
    for k in range(len(ring) - 1):
        a, b = u[k], u[k + 1]
        arc = np.degrees(np.arctan2(np.linalg.norm(np.cross(a, b)), a @ b))
        dlon = abs((ring[k + 1, 0] - ring[k, 0] + 180.0) % 360.0 - 180.0)
        pieces = int(np.ceil(max(arc, dlon) / step))
        if pieces > 1:
            t = np.linspace(0.0, 1.0, pieces + 1)[1:-1, None]
            w = (1 - t) * a + t * b  # on the chord, then onto the sphere
            w /= np.linalg.norm(w, axis=1)[:, None]
            lon = np.degrees(np.arctan2(w[:, 1], w[:, 0]))
            if keep:  # the edge's longitudes (beyond 180 where it is)
                lon = ring[k, 0] + (lon - ring[k, 0] + 180.0) % 360.0 - 180.0
            out.append(np.column_stack([lon, np.degrees(np.arcsin(w[:, 2]))]))
        out.append(ring[k + 1 : k + 2])
    return np.vstack(out)


def _unwrap(ring: np.ndarray) -> tuple[np.ndarray, float]:
    """Return a ring unwrapped by whole turns of longitude, and its net turn."""
    dlon = np.diff(ring[:, 0])
    dlon = (dlon + 180.0) % 360.0 - 180.0
    steps = ring[0, 0] + np.concatenate([[0.0], np.cumsum(dlon)])
    turns = np.round((steps - ring[:, 0]) / 360.0)
    return np.column_stack([ring[:, 0] + 360.0 * turns, ring[:, 1]]), float(dlon.sum())


def _close_one(polygon):
    shell, total = _unwrap(_densify(np.asarray(polygon.exterior.coords)))
    if abs(total) >= 180.0:
        pole = 90.0 if total > 0 else -90.0
        shell = np.vstack([shell, [[shell[-1, 0], pole], [shell[0, 0], pole]]])
    west = shell[:, 0].min()
    holes = []
    for hole in polygon.interiors:
        h, _ = _unwrap(_densify(np.asarray(hole.coords)))
        h[:, 0] -= 360.0 * np.floor((h[0, 0] - west) / 360.0)
        holes.append(h)
    whole = shapely.Polygon(shell, holes)
    if not whole.is_valid:
        whole = shapely.make_valid(whole)
    seam = shell[0, 0]
    pieces = []
    for k in range(-2, 3):
        box = shapely.box(-180.0 + 360.0 * k, -90.0, 180.0 + 360.0 * k, 90.0)
        piece = shapely.intersection(whole, box)
        if not piece.is_empty:
            shift = functools.partial(snap_meridian, x=seam, west=360.0 * k)
            pieces.append(shapely.transform(piece, shift))
    return shapely.union_all(pieces)
