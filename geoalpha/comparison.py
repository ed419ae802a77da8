"""The comparison methods of :func:`geoalpha.hull`: convex, concave and KNN hulls.

``method="convex"`` takes its alpha from :func:`geoalpha.alpha_shapes` (0) and
its polygons from :func:`convex_hulls`, built in the output coordinates where
they are exact. ``method="concave"`` (GEOS ``concave_hull``) and
``method="knn"`` (:func:`geoalpha.knn.knn_hull`) are built in metres by
:func:`comparison_hulls` and then given the input coordinates as vertices.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import shapely

from geoalpha.crs import Projection
from geoalpha.errors import InvalidInputError
from geoalpha.knn import knn_hull
from geoalpha.shapes import EMPTY_POLYGON, cover_points, covered

__all__ = ["ComparisonHulls", "comparison_hulls", "convex_hulls"]


class ComparisonHulls:
    """Per group: ``geometry`` (output CRS), ``area``, ``labels``, ``degenerate``."""

    def __init__(self, geometry, area, labels, degenerate):
        self.geometry = geometry
        self.area = area
        self.labels = labels
        self.degenerate = degenerate


def convex_hulls(out_xy: np.ndarray, codes: np.ndarray, n_groups: int) -> np.ndarray:
    """Convex hull of each group, built in the output coordinates ``out_xy``.

    Examples
    --------
    >>> import numpy as np
    >>> xy = np.array([[0, 0], [2, 0], [0, 2], [1, 0.5], [5, 5]])
    >>> [g.area for g in convex_hulls(xy, np.array([0, 0, 0, 0, 1]), 2)]
    [2.0, 0.0]
    """
    order = np.argsort(codes, kind="stable")
    hulls = np.full(n_groups, EMPTY_POLYGON, dtype=object)
    present = np.unique(codes)
    hulls[present] = shapely.convex_hull(
        shapely.multipoints(out_xy[order], indices=codes[order])
    )[present]
    return hulls


def _to_input_vertices(geoms, groups, xy, out, codes) -> np.ndarray:
    """Replace metric vertex coordinates (input points) by their output coordinates."""
    coords, which = shapely.get_coordinates(geoms, return_index=True)
    keys = pd.MultiIndex.from_arrays([codes, xy[:, 0], xy[:, 1]])
    first = ~keys.duplicated()
    table = keys[first]
    loc = table.get_indexer(
        pd.MultiIndex.from_arrays([groups[which], coords[:, 0], coords[:, 1]])
    )
    if (loc < 0).any():  # pragma: no cover - GEOS keeps input coordinates
        raise RuntimeError("a hull vertex is not an input point")
    return shapely.set_coordinates(geoms.copy(), out[np.flatnonzero(first)[loc]])


def _concave(mp: np.ndarray, ratio: float, holes: bool) -> np.ndarray:
    """GEOS concave hull of each MultiPoint; None where GEOS raises.

    A batch that raises is split in halves until the failing groups are
    alone (as :func:`geoalpha.delaunay.triangulate_groups` does).
    """
    try:
        return shapely.concave_hull(mp, ratio=ratio, allow_holes=holes)
    except shapely.errors.GEOSException:
        if len(mp) == 1:
            return np.array([None], dtype=object)
    half = len(mp) // 2
    out = np.empty(len(mp), dtype=object)
    out[:half] = _concave(mp[:half], ratio, holes)
    out[half:] = _concave(mp[half:], ratio, holes)
    return out


def comparison_hulls(
    method: str,
    proj: Projection,
    codes: np.ndarray,
    n_groups: int,
    *,
    holes: bool,
    ratio: float,
    k: int,
    bar=None,
) -> ComparisonHulls:
    """GEOS concave (``method="concave"``) or KNN hull per group, built in metres.

    The polygons come back in the output coordinates with the input points as
    vertices, every point covered (:func:`geoalpha.shapes.cover_points`).
    """
    order = np.argsort(codes, kind="stable")
    xy, sc = proj.xy[order], codes[order]
    ptr = np.searchsorted(sc, np.arange(n_groups + 1))
    geoms = np.full(n_groups, EMPTY_POLYGON, dtype=object)
    labels = np.full(n_groups, method, dtype=object)
    if method == "concave":
        mp = shapely.multipoints(xy, indices=sc)
        present = np.unique(sc)
        labels[:] = f"concave ratio={ratio:g}"
        hulls = _concave(mp[present], ratio, holes)
        if holes:  # GEOS fails some nearly collinear groups with holes only
            failed = shapely.is_missing(hulls)
            hulls[failed] = _concave(mp[present][failed], ratio, False)
            labels[present[failed]] = f"concave ratio={ratio:g} (no holes)"
        geoms[present] = hulls
        if bar is not None:
            bar.update(n_groups)
    else:
        for g in range(n_groups):
            try:
                geoms[g], used = knn_hull(xy[ptr[g] : ptr[g + 1]], k=k)
                labels[g] = f"knn k={used}"
            except InvalidInputError:
                pass
            if bar is not None:
                bar.update(1)
    degenerate = (shapely.get_type_id(geoms) != 3) | shapely.is_empty(geoms)
    geoms[degenerate] = EMPTY_POLYGON
    area = shapely.area(geoms)
    present = ~degenerate
    out = np.full(n_groups, EMPTY_POLYGON, dtype=object)
    out[present] = _to_input_vertices(
        geoms[present], np.flatnonzero(present), proj.xy, proj.out, codes
    )
    out = cover_points(out, proj.out, codes)
    # A hull that GEOS could not grow over its points in the output
    # coordinates (around a pole, across the globe) is no hull there.
    missed = ~covered(out, proj.out, codes) & present[codes]
    if missed.any():
        lost = np.unique(codes[missed])
        out[lost], degenerate[lost], area[lost] = EMPTY_POLYGON, True, 0.0
    invalid = present & ~degenerate & ~shapely.is_valid(out)
    if invalid.any():
        out[invalid], degenerate[invalid], area[invalid] = EMPTY_POLYGON, True, 0.0
    return ComparisonHulls(out, area, labels, degenerate)
