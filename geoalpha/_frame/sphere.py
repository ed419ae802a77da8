"""``crs="sphere"`` in the frame: the CRS round trip (:class:`SphereProjection`)."""

from __future__ import annotations

import functools
from typing import Any

import numpy as np

from geoalpha._arrays.sphere import sphere_output
from geoalpha._crs_parsing import parse_crs
from geoalpha._frame import crs as gcrs
from geoalpha.errors import InvalidInputError

__all__ = ["SphereProjection"]

_WGS84 = parse_crs("EPSG:4326")


class SphereProjection(gcrs.Projection):
    """The CRS round trip of ``crs="sphere"``.

    :attr:`lonlat`: the EPSG:4326 coordinates the kernel computes in;
    :attr:`out`: as with ``crs="auto"``; :attr:`xy`: metres for the other
    stages (``crs="auto"``'s projection, made on first use).

    Parameters
    ----------
    coords, codes, n_groups, source, labels
        As for :class:`geoalpha._frame.crs.Projection`.

    Raises
    ------
    InvalidInputError
        Input without a CRS, or bad coordinates (named).

    Examples
    --------
    >>> lonlat = np.array([[0.0, 51.0], [1.0, 51.0], [0.5, 52.0]])
    >>> proj = SphereProjection(lonlat, np.zeros(3, dtype=int), 1, "EPSG:4326")
    >>> proj.lonlat.tolist() == lonlat.tolist(), bool((proj.out == lonlat).all())
    (True, True)
    """

    sphere = True

    def __init__(
        self,
        coords: np.ndarray,
        codes: np.ndarray,
        n_groups: int,
        source: Any,
        labels: Any = None,
    ) -> None:
        src = parse_crs(source)
        if src is None:
            raise InvalidInputError(
                "the input has no CRS, so its points cannot be put on the sphere; "
                "set it with gdf.set_crs(...)"
            )
        self.source = src
        self._args = (coords, codes, n_groups, source, labels)
        self.unit = "m"
        self.names = np.full(n_groups, "sphere", dtype=object)
        self.out = coords
        self.crossing, self.wide, self.polar = np.zeros((3, n_groups), dtype=bool)
        lon, lat = coords[:, 0], coords[:, 1]
        if src.is_geographic:  # around a pole: closed along it, input longitudes
            gcrs.check_lonlat(lon, lat, labels)
            self.out, self.crossing, self.wide, self.polar = sphere_output(
                coords, codes, n_groups
            )
        if src != _WGS84:
            lon, lat = gcrs.to_wgs84(src, lon, lat, labels)
        self.lonlat = np.ascontiguousarray(np.column_stack([lon, lat]), dtype=float)

    @functools.cached_property
    def _metric(self) -> gcrs.Projection:
        return gcrs.Projection(*self._args[:4], "auto", self._args[4])

    def metric_of(self, sel: np.ndarray, which: np.ndarray):
        """Metres for the points ``sel`` of the groups ``which`` only; the way back."""
        coords, codes, _, source, labels = self._args
        mine = np.searchsorted(which, codes[sel])
        labels = None if labels is None else labels[sel]
        local = gcrs.Projection(coords[sel], mine, len(which), source, "auto", labels)
        groups = np.arange(len(which))
        return local.xy, lambda geoms: local.to_output(geoms, groups)

    # Metres (``crs="auto"``'s projection) for the stages other than the shape,
    # and their way back (:meth:`to_output`), made on first use.
    xy = property(lambda self: self._metric.xy)
    _crs_list = property(lambda self: self._metric._crs_list)
    _crs_index = property(lambda self: self._metric._crs_index)
