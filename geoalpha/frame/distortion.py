"""How much a projected CRS stretches areas where the points are.

A forced computation CRS that distorts areas (Web Mercator: 2.6 times at
London; a UTM zone far from the data) makes ``radius`` and ``alpha`` wrong
without any error (not ``area_m2``, measured on the WGS84 ellipsoid).
:func:`area_scale` measures the distortion at the points so that
:func:`geoalpha.hull` and the ``geoalpha`` command can say so.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any

import numpy as np
import pyproj

__all__ = ["AREA_TOLERANCE", "area_scale"]

#: Areal scale factors further than this from 1 are reported (2 %; a UTM
#: zone within its own width stays under 0.3 %).
AREA_TOLERANCE = 0.02
#: Points the scale is measured at: evenly spaced through the input, plus the
#: points at the extremes of x and y (the scale of a CRS varies smoothly,
#: most towards the edges of the data).
_SAMPLE = 256


def area_scale(crs: Any, x: Any, y: Any, source_crs: Any) -> np.ndarray:
    """Return the areal scale factor of ``crs`` at some of the given points.

    Parameters
    ----------
    crs : pyproj.CRS or anything pyproj accepts
        A projected CRS.
    x, y : array_like of float
        Coordinates of the points in ``source_crs``.
    source_crs : pyproj.CRS or anything pyproj accepts
        CRS of ``x``/``y``.

    Returns
    -------
    numpy.ndarray of float
        Area on the map / true area at up to 1,000 evenly spaced points
        (``inf`` where ``crs`` cannot represent a point); empty without
        finite points.

    Examples
    --------
    >>> from geoalpha.frame.distortion import area_scale
    >>> float(area_scale("EPSG:3857", [-0.12], [51.5], "EPSG:4326")[0])
    ... # doctest: +ELLIPSIS
    2.58...
    >>> float(area_scale("EPSG:32630", [-3.0], [51.5], "EPSG:4326")[0])
    ... # doctest: +ELLIPSIS
    0.999...
    """
    x = np.asarray(x, dtype=float).ravel()
    y = np.asarray(y, dtype=float).ravel()
    finite = np.isfinite(x) & np.isfinite(y)
    x, y = x[finite], y[finite]
    if x.size > _SAMPLE:
        pick = np.linspace(0, x.size - 1, _SAMPLE).astype(np.intp)
        ends = [np.argmin(x), np.argmax(x), np.argmin(y), np.argmax(y)]
        pick = np.concatenate([pick, ends])
        x, y = x[pick], y[pick]
    if x.size == 0:
        return np.empty(0)
    to_lonlat, proj = _factors_of(_key(source_crs), _key(crs))
    lon, lat = to_lonlat.transform(x, y)
    with np.errstate(all="ignore"):
        factors = proj.get_factors(lon, lat, errcheck=False)
        scale = np.asarray(factors.areal_scale, dtype=float)
    scale[~np.isfinite(scale)] = np.inf
    return scale


def _key(crs: Any) -> str:
    """Return a hashable spelling of a CRS (for the cache of :func:`_factors_of`)."""
    return pyproj.CRS.from_user_input(crs).srs


@lru_cache(maxsize=32)
def _factors_of(source: str, target: str) -> tuple[pyproj.Transformer, pyproj.Proj]:
    """Return the way from ``source`` to lon/lat on ``target``'s datum, and it."""
    crs = pyproj.CRS.from_user_input(target)
    geographic = crs.geodetic_crs or pyproj.CRS.from_epsg(4326)
    to_lonlat = pyproj.Transformer.from_crs(
        pyproj.CRS.from_user_input(source), geographic, always_xy=True
    )
    return to_lonlat, pyproj.Proj(crs)
