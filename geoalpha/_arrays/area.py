"""Areas of polygons on the WGS84 ellipsoid (``area_m2``), in one compiled call.

Flat vertex arrays with offsets to ``src/geodesic.rs`` (Karney's algorithm).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import shapely

from geoalpha import _core as kernel
from geoalpha import _kernel

__all__ = ["geodesic_areas", "layout"]

_POLYGONAL = (shapely.GeometryType.POLYGON, shapely.GeometryType.MULTIPOLYGON)


def geodesic_areas(
    geometry,
    *,
    to_lonlat: Callable[[np.ndarray, np.ndarray], tuple] | None = None,
    n_jobs: int | None = None,
) -> np.ndarray:
    """Return the area (m²) of each geometry on the WGS84 ellipsoid.

    Edges are geodesics; a ring's area is that of its side smaller than half
    the ellipsoid, whichever way it turns. Holes count negative, the parts of
    multipolygons and the polygons of collections add up; other geometries 0.

    Parameters
    ----------
    geometry : array_like of shapely geometries
        Polygons in longitude/latitude (degrees; longitudes may run past
        +-180), or in the coordinates ``to_lonlat`` takes.
    to_lonlat : callable, optional
        Vectorised ``to_lonlat(x, y) -> (lon, lat)``; None: they are lon/lat.
    n_jobs : int, optional
        Threads (None or -1: every core).

    Returns
    -------
    numpy.ndarray of float64

    Raises
    ------
    ValueError
        A vertex that is not finite, or a latitude beyond +-90.

    Examples
    --------
    >>> cell = shapely.box(0, 0, 1, 1)  # one degree at the equator
    >>> geodesic_areas([cell, shapely.MultiPolygon([cell, cell]), None]).round(3)
    array([1.23087784e+10, 2.46175567e+10, 0.00000000e+00])
    """
    geometry = np.asarray(geometry, dtype=object)
    kind = shapely.get_type_id(geometry)
    direct = np.flatnonzero(np.isin(kind, _POLYGONAL))
    geoms, owner = geometry[direct], direct
    collections = np.flatnonzero(kind == shapely.GeometryType.GEOMETRYCOLLECTION)
    if len(collections):
        parts, index = shapely.get_parts(geometry[collections], return_index=True)
        keep = np.isin(shapely.get_type_id(parts), _POLYGONAL)
        geoms = np.concatenate([geoms, parts[keep]])
        owner = np.concatenate([owner, collections[index[keep]]])
    out = np.zeros(len(geometry))
    if not len(geoms):
        return out
    coords, (rings, polygons, geometries) = layout(geoms)
    lon, lat = coords[:, 0], coords[:, 1]
    if to_lonlat is not None and len(coords):
        # a closed ring's last vertex repeats its first: move each vertex once
        closed = np.flatnonzero(np.diff(rings) > 1)
        last = rings[closed + 1] - 1
        moved = np.ones(len(coords), dtype=bool)
        moved[last] = False
        lon, lat = np.empty(len(coords)), np.empty(len(coords))
        lon[moved], lat[moved] = to_lonlat(coords[moved, 0], coords[moved, 1])
        lon[last], lat[last] = lon[rings[closed]], lat[rings[closed]]
    areas = _kernel.geodesic_areas(
        np.ascontiguousarray(lon, dtype=np.float64),
        np.ascontiguousarray(lat, dtype=np.float64),
        rings,
        polygons,
        geometries,
        threads=kernel.threads(n_jobs),
    )
    return np.bincount(owner, weights=areas, minlength=len(geometry))


def layout(geoms: np.ndarray) -> tuple[np.ndarray, tuple[np.ndarray, ...]]:
    """Vertices and the ring, polygon and geometry offsets the kernel takes."""
    # Polygons without holes (most hulls): offsets from vertex counts (faster).
    one_ring = shapely.get_type_id(geoms) == shapely.GeometryType.POLYGON
    if one_ring.all() and not shapely.get_num_interior_rings(geoms).any():
        counts = shapely.get_num_coordinates(geoms)
        rings = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        each = np.arange(len(geoms) + 1, dtype=np.int64)
        return shapely.get_coordinates(geoms), (rings, each, each)
    _, coords, offsets = shapely.to_ragged_array(geoms)
    if len(offsets) == 2:  # only polygons: one polygon a geometry
        offsets = (*offsets, np.arange(len(geoms) + 1))
    return coords, tuple(np.asarray(o, dtype=np.int64) for o in offsets)
