"""Shapely assembly: boundary rings of triangle sets -> valid (Multi)Polygons.

No union of triangles: the rings traced by :func:`geoalpha.core.boundary_rings`
become LinearRings, Polygons and MultiPolygons in three vectorised shapely
calls for all groups at once.
"""

from __future__ import annotations

import numpy as np
import shapely

from geoalpha.core import Rings

__all__ = ["EMPTY_POLYGON", "assemble"]

#: The geometry of a group with no shape (empty Polygon, so that a column of
#: hulls keeps a single geometry type).
EMPTY_POLYGON = shapely.Polygon()


def assemble(coords: np.ndarray, rings: Rings, n_groups: int) -> np.ndarray:
    """Build one geometry per group from traced rings.

    Parameters
    ----------
    coords : ndarray of shape (p, 2)
        Output coordinates of the distinct points the ring vertices index
        (the input coordinates, so that every polygon vertex is an input
        point).
    rings : geoalpha.core.Rings
        Rings with their pieces and groups.
    n_groups : int
        Number of groups.

    Returns
    -------
    ndarray of shape (n_groups,), dtype object
        A Polygon for a group of one piece, a MultiPolygon for several, an
        empty Polygon for none.

    Examples
    --------
    >>> from geoalpha import core
    >>> tri = core.triangulate([[0, 0], [2, 0], [0, 2], [2, 2]])
    >>> inside = np.ones(len(tri.triangles), dtype=bool)
    >>> rings = core.boundary_rings(tri, inside, core.piece_labels(tri, inside))
    >>> assemble(tri.xy, rings, 1)[0].area
    4.0
    """
    out = np.full(n_groups, EMPTY_POLYGON, dtype=object)
    if len(rings.vertex) == 0:
        return out
    linear = shapely.linearrings(coords[rings.vertex], indices=rings.ring)
    polys = shapely.polygons(linear, indices=rings.ring_piece)
    n_pieces = np.bincount(rings.piece_group, minlength=n_groups)
    first_piece = np.cumsum(n_pieces) - n_pieces
    single = np.flatnonzero(n_pieces == 1)
    out[single] = polys[first_piece[single]]
    multi = n_pieces[rings.piece_group] > 1
    if multi.any():
        shapely.multipolygons(polys[multi], indices=rings.piece_group[multi], out=out)
    return out
