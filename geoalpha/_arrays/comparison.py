"""The comparison methods of :func:`geoalpha.hull`: concave and KNN hulls."""

from __future__ import annotations

import contextlib
from typing import NamedTuple

import numpy as np
import pandas as pd
import shapely

from geoalpha._arrays.guarantee import EMPTY_POLYGON
from geoalpha._arrays.knn import knn_hull
from geoalpha.errors import InvalidInputError

__all__ = ["ComparisonHulls", "comparison_hulls"]


class ComparisonHulls(NamedTuple):
    """Per group: ``geometry`` (output CRS), ``area``, ``labels``, ``degenerate``.

    ``without_holes``: GEOS failed the concave hull with holes; got the one without.
    """

    geometry: np.ndarray
    area: np.ndarray
    labels: np.ndarray
    degenerate: np.ndarray
    without_holes: np.ndarray


def _each_or_none(func, geoms: np.ndarray, **kwargs) -> np.ndarray:
    """Apply a vectorised shapely ``func``; None where GEOS raises (halving batches)."""
    try:
        return func(geoms, **kwargs)
    except shapely.errors.GEOSException:
        if len(geoms) == 1:
            return np.array([None], dtype=object)
    half = len(geoms) // 2
    out = np.empty(len(geoms), dtype=object)
    out[:half] = _each_or_none(func, geoms[:half], **kwargs)
    out[half:] = _each_or_none(func, geoms[half:], **kwargs)
    return out


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


def comparison_hulls(
    method: str,
    xy: np.ndarray,
    out: np.ndarray,
    codes: np.ndarray,
    n_groups: int,
    *,
    holes: bool,
    ratio: float,
    k: int,
    bar=None,
) -> ComparisonHulls:
    """GEOS concave (``method="concave"``) or KNN hull per group, built in metres.

    ``xy`` holds the points in metres, ``out`` in the output coordinates, one row
    per point of ``codes``; the polygons come back in ``out``'s, not yet checked
    (:func:`geoalpha._arrays.guarantee.enforce`).
    """
    order = np.argsort(codes, kind="stable")
    sorted_xy, sc = xy[order], codes[order]
    ptr = np.searchsorted(sc, np.arange(n_groups + 1))
    geoms = np.full(n_groups, EMPTY_POLYGON, dtype=object)
    labels = np.full(n_groups, method, dtype=object)
    without_holes = np.zeros(n_groups, dtype=bool)
    if method == "concave":
        mp = shapely.multipoints(sorted_xy, indices=sc)
        present = np.unique(sc)
        labels[:] = f"concave ratio={ratio:g}"
        hulls = _each_or_none(
            shapely.concave_hull, mp[present], ratio=ratio, allow_holes=holes
        )
        if holes:  # GEOS fails some nearly collinear groups with holes only
            failed = shapely.is_missing(hulls)
            hulls[failed] = _each_or_none(
                shapely.concave_hull, mp[present][failed], ratio=ratio
            )
            without_holes[present[failed]] = True
            labels[without_holes] = f"concave ratio={ratio:g} (no holes)"
        geoms[present] = hulls
        if bar is not None:
            bar.update(n_groups)
    else:
        for g in range(n_groups):
            with contextlib.suppress(InvalidInputError):  # too few or collinear
                geoms[g], used = knn_hull(sorted_xy[ptr[g] : ptr[g + 1]], k=k)
                labels[g] = f"knn k={used}"
            if bar is not None:
                bar.update(1)
    degenerate = (shapely.get_type_id(geoms) != 3) | shapely.is_empty(geoms)
    geoms[degenerate] = EMPTY_POLYGON
    area = shapely.area(geoms)  # in metres, before the vertices move to ``out``
    present = np.flatnonzero(~degenerate)
    geoms[present] = _to_input_vertices(geoms[present], present, xy, out, codes)
    return ComparisonHulls(geoms, area, labels, degenerate, without_holes)
