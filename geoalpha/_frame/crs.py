"""The CRS round trip of :func:`geoalpha.hull` (:class:`Projection`) and its parts.

On numpy arrays; groups are integer codes ``0 .. n_groups - 1`` per point.
"""

from __future__ import annotations

import functools
import re
from typing import Any

import numpy as np
import pyproj
import shapely

from geoalpha._arrays.area import geodesic_areas as lonlat_areas
from geoalpha._arrays.lonlat import (
    check_codes,
    group_arcs,
    output_lonlat,
    restore_longitudes,
    row_positions,
    split_antimeridian,
)
from geoalpha._crs_parsing import (
    crs_name,
    is_mercator,
    parse_crs,
    target_crs,
    unit_factor,
)
from geoalpha.errors import InvalidInputError, setting

__all__ = [
    "Projection",
    "check_lonlat",
    "geodesic_areas",
    "metric_crs",
    "restore_longitudes",
    "split_antimeridian",
    "to_wgs84",
]

#: Degrees of longitude either side of a UTM zone's central meridian that "fit
#: the zone": its own 3 and a 1.5 margin (scale error at most about 0.3 %).
UTM_HALF_WIDTH = 4.5
#: Largest absolute latitude projected with UTM; beyond it a local CRS is used.
UTM_MAX_LAT = 84.0
#: Local LAEA CRSs are centred on the group centre rounded to this many degrees,
#: so that nearby groups share a CRS (the scale changes by less than 0.01 %).
LAEA_CENTRE_STEP = 1.0


def auto_mode(crs: Any) -> str | None:
    """Return ``"auto"`` or ``"auto-group"`` for those ``crs=`` options, else None."""
    mode = crs.strip().lower() if isinstance(crs, str) else None
    return mode if mode in ("auto", "auto-group") else None


def _as_coords(lon: Any, lat: Any) -> tuple[np.ndarray, np.ndarray]:
    lon = np.asarray(lon, dtype=np.float64).ravel()
    lat = np.asarray(lat, dtype=np.float64).ravel()
    if lon.shape != lat.shape:
        raise InvalidInputError(
            "lon and lat must have the same length; got "
            f"{lon.size} longitudes and {lat.size} latitudes"
        )
    return lon, lat


def check_lonlat(lon: Any, lat: Any, labels: Any = None) -> None:
    """Check that coordinates are finite longitude/latitude degrees.

    Parameters
    ----------
    lon, lat : array_like of float
        Longitudes (x) and latitudes (y) of the points, in degrees.
    labels : array_like, optional
        A label per point to name the offending rows by (default: positions).

    Raises
    ------
    InvalidInputError
        On NaN, infinite or out-of-range (or swapped) coordinates, naming the rows.
    """
    lon, lat = _as_coords(lon, lat)
    bad = ~(np.isfinite(lon) & np.isfinite(lat))
    if bad.any():
        raise InvalidInputError(
            "coordinates must be finite numbers; got NaN or infinite "
            f"longitude/latitude in {row_positions(bad, labels)}"
        )
    problems = [
        f"{name} outside [-{limit}, {limit}] in {row_positions(bad, labels)}"
        for name, limit, bad in (
            ("latitude", 90, np.abs(lat) > 90.0),
            ("longitude", 180, np.abs(lon) > 180.0),
        )
        if bad.any()
    ]
    if problems:
        message = "points in a geographic CRS must be longitude/latitude degrees; "
        message += "; ".join(problems)
        if np.all(np.abs(lon) <= 90.0) and np.all(np.abs(lat) <= 180.0):
            message += "; latitude and longitude look swapped (x holds latitudes?)"
        raise InvalidInputError(message)


_WGS84 = parse_crs("EPSG:4326")

_OWN_LAEA = re.compile(
    r"\+proj=laea \+lat_0=-?\d+ \+lon_0=-?\d+ \+datum=WGS84 \+units=m \+no_defs"
)


@functools.lru_cache(maxsize=1024)
def _transformer(source: str, target: str) -> pyproj.Transformer:
    """One cached transformer per pair of CRSs (to/from our LAEA: a fast pipeline)."""
    laea = target if source == _WGS84 else source if target == _WGS84 else ""
    if _OWN_LAEA.fullmatch(laea):
        params = laea.replace(" +datum=WGS84", " +ellps=WGS84").replace(" +no_defs", "")
        degrees = "+step +proj=unitconvert +xy_in={} +xy_out={}"
        steps = f"{degrees.format('deg', 'rad')} +step {params}"
        if laea == source:  # the way back
            steps = f"+step +inv {params} {degrees.format('rad', 'deg')}"
        return pyproj.Transformer.from_pipeline(f"+proj=pipeline {steps}")
    return pyproj.Transformer.from_crs(source, target, always_xy=True)


@functools.lru_cache(maxsize=512)
def _crs_from_key(key: int) -> pyproj.CRS:
    """Build the metric CRS encoded by an integer key (see :func:`_laea_key`)."""
    if key < 1_000_000:
        return pyproj.CRS.from_epsg(key)
    lat0, lon0 = divmod(key - 1_000_000, 1000)
    return pyproj.CRS.from_proj4(
        f"+proj=laea +lat_0={lat0 - 90} +lon_0={lon0 - 180} +datum=WGS84 +units=m "
        "+no_defs"
    )


def _crs_key(crs: pyproj.CRS) -> str:
    """Return a string that identifies ``crs`` (the transformer cache key)."""
    return re.sub(r"\s*\+type=crs\b", "", crs.srs).strip()


def _wrap180(lon: np.ndarray) -> np.ndarray:
    return (np.asarray(lon) + 180.0) % 360.0 - 180.0


def _utm_keys(west, east, south, north) -> tuple[np.ndarray, np.ndarray]:
    """UTM EPSG code of each extent's centre, and whether the extent fits it."""
    centre = _wrap180((west + east) / 2.0)
    zone = np.clip(np.floor((centre + 180.0) / 6.0).astype(np.int64), 0, 59) + 1
    meridian = zone * 6.0 - 183.0
    offset = _wrap180(centre - meridian)
    half = (east - west) / 2.0
    fits = (
        (offset - half >= -UTM_HALF_WIDTH)
        & (offset + half <= UTM_HALF_WIDTH)
        & (np.maximum(np.abs(south), np.abs(north)) <= UTM_MAX_LAT)
    )
    epsg = np.where((south + north) / 2.0 >= 0.0, 32600, 32700) + zone
    return epsg, fits


def _laea_key(west, east, south, north) -> np.ndarray:
    """Integer key of a local LAEA CRS centred on each extent (or its pole)."""
    lat0 = (south + north) / 2.0
    lon0 = _wrap180((west + east) / 2.0)
    polar = (east - west) > 180.0
    lat0 = np.where(polar, np.where(lat0 >= 0.0, 90.0, -90.0), lat0)
    step = LAEA_CENTRE_STEP
    lat0 = np.clip(np.round(lat0 / step) * step, -90, 90).astype(np.int64)
    lon0 = _wrap180(np.round(lon0 / step) * step).astype(np.int64)
    return 1_000_000 + (lat0 + 90) * 1000 + (lon0 + 180)


def metric_crs(
    lon: Any,
    lat: Any,
    codes: Any,
    n_groups: int,
    *,
    crs: Any = "auto",
    source_crs: Any = None,
    labels: Any = None,
) -> tuple[np.ndarray, list[pyproj.CRS], np.ndarray]:
    """Project longitude/latitude points to a metric CRS chosen per group.

    Parameters
    ----------
    lon, lat : array_like of float, shape (n,)
        Degrees in ``source_crs`` (checked with :func:`check_lonlat`).
    codes, n_groups : array_like of int, shape (n,), and int
        Group code of every point, ``0 .. n_groups - 1`` (no ``-1``).
    crs : "auto", "auto-group" or CRS, default "auto"
        The UTM zones and local LAEA CRSs of :doc:`/user_guide/crs`
        (``"auto-group"``: always per group), or one CRS for every group.
    source_crs : CRS, optional
        The geographic CRS of ``lon``/``lat``; default EPSG:4326 (WGS 84).
    labels : array_like, optional
        As for :func:`check_lonlat`.

    Returns
    -------
    xy : numpy.ndarray of float64, shape (n, 2)
        Coordinates in the CRS of each point's group, in metres (feet scaled).
    crs_list, crs_index : list of pyproj.CRS, numpy.ndarray of int (n_groups,)
        The distinct CRSs used, and the position in it of each group's CRS.

    Raises
    ------
    InvalidInputError
        On bad coordinates, codes or CRSs, or points the CRS cannot project.

    Examples
    --------
    >>> lon = [-0.13, -0.10, -0.12, -2.24, -2.20, -2.25]  # London, Manchester
    >>> lat = [51.50, 51.52, 51.49, 53.48, 53.47, 53.50]
    >>> xy, crs_list, crs_index = metric_crs(lon, lat, [0, 0, 0, 1, 1, 1], 2)
    >>> [c.to_epsg() for c in crs_list], crs_index.tolist()
    ([32630], [0, 0])
    """
    lon, lat = _as_coords(lon, lat)
    codes = check_codes(codes, n_groups, lon.size)
    source = parse_crs(source_crs) if source_crs is not None else None
    if source is not None and not source.is_geographic:
        raise InvalidInputError(
            "source_crs= must be a geographic (longitude/latitude) CRS, got "
            f"{crs_name(source)}"
        )
    source_key = _WGS84 if source is None else source.srs
    check_lonlat(lon, lat, labels)
    mode = auto_mode(crs)
    if mode is not None:
        crs_list, crs_index = _choose_auto(lon, lat, codes, n_groups, mode == "auto")
    else:
        crs_list, crs_index = [target_crs(crs)], np.zeros(n_groups, dtype=np.intp)
    xy = np.empty((lon.size, 2), dtype=np.float64)
    segments = [slice(None)]
    if len(crs_list) > 1:  # the points by CRS
        point_crs = crs_index[codes]
        order = np.argsort(point_crs, kind="stable")
        ends = np.searchsorted(point_crs[order], np.arange(1, len(crs_list)))
        segments = np.split(order, ends)
    for target, rows in zip(crs_list, segments, strict=False):
        transformer = _transformer(source_key, _crs_key(target))
        x, y = transformer.transform(lon[rows], lat[rows])
        xy[rows] = np.column_stack([x, y]) * unit_factor(target)
    failed = ~np.isfinite(xy).all(axis=1)
    if failed.any():
        names = sorted({crs_name(crs_list[k]) for k in crs_index[codes[failed]]})
        raise InvalidInputError(
            f"could not project {row_positions(failed, labels)} to {', '.join(names)}; "
            "the points lie outside what the CRS can represent, choose a CRS "
            f"that covers them or {setting('crs', 'auto')}"
        )
    return xy, crs_list, crs_index


def _choose_auto(
    lon, lat, codes, n_groups: int, whole: bool = True
) -> tuple[list[pyproj.CRS], np.ndarray]:
    """CRS choice of ``metric_crs(crs="auto")``; ``whole=False``: "auto-group"."""
    if lon.size == 0:
        return [], np.zeros(n_groups, dtype=np.intp)
    if whole:
        south, north = np.array([lat.min()]), np.array([lat.max()])
        west, east = np.array([lon.min()]), np.array([lon.max()])
        if east[0] - west[0] > 2 * UTM_HALF_WIDTH:
            # Maybe narrow the other way round the globe (data across +-180).
            arc = group_arcs(lon, None, np.zeros(lon.size, dtype=np.intp), 1)
            west, east = arc["west"], arc["east"]
        epsg, fits = _utm_keys(west, east, south, north)
        if fits[0]:
            return [_crs_from_key(int(epsg[0]))], np.zeros(n_groups, dtype=np.intp)
    arcs = group_arcs(lon, lat, codes, n_groups)
    filled = ~np.isnan(arcs["west"])
    sides = [arcs[side][filled] for side in ("west", "east", "south", "north")]
    epsg, fits = _utm_keys(*sides)
    laea = _laea_key(*sides)
    keys = np.empty(n_groups, dtype=np.int64)
    keys[filled] = np.where(fits, epsg, laea)
    keys[~filled] = keys[filled][0]  # groups without points: any CRS in use
    distinct, crs_index = np.unique(keys, return_inverse=True)
    crs_list = [_crs_from_key(int(key)) for key in distinct]
    return crs_list, crs_index.astype(np.intp).ravel()


def to_wgs84(source: Any, x: Any, y: Any, labels: Any = None):
    """Return the longitudes and latitudes (EPSG:4326) of points in ``source``.

    Raises
    ------
    InvalidInputError
        Naming the rows (by ``labels``) that cannot be moved.

    Examples
    --------
    >>> lon, lat = to_wgs84("EPSG:32630", [500000.0], [0.0])  # UTM 30N's origin
    >>> lon.round(6).tolist(), lat.round(6).tolist()
    ([-3.0], [0.0])
    """
    src = parse_crs(source)
    to = _transformer(_crs_key(src), "EPSG:4326")
    lon, lat = to.transform(np.asarray(x, dtype=float), np.asarray(y, dtype=float))
    lon, lat = np.asarray(lon, dtype=float), np.asarray(lat, dtype=float)
    failed = ~(np.isfinite(lon) & np.isfinite(lat))
    if failed.any():
        raise InvalidInputError(
            f"could not move {row_positions(failed, labels)} to longitude/latitude "
            "(EPSG:4326)"
        )
    return lon, lat


def geodesic_areas(
    geometry: np.ndarray, source: Any, *, n_jobs: int | None = None
) -> np.ndarray:
    """Return the areas (m²) on the WGS84 ellipsoid of polygons in ``source``.

    :func:`geoalpha._arrays.area.geodesic_areas` of the vertices moved to EPSG:4326.

    Parameters
    ----------
    geometry, source : numpy.ndarray of shapely geometries, CRS
        (Multi)polygons (other geometries get 0) and their CRS.
    n_jobs : int, optional
        Threads (None or -1: every core).

    Examples
    --------
    >>> import shapely
    >>> one_km = shapely.box(500000, 0, 501000, 1000)  # UTM 30N: scale 0.9996
    >>> float(geodesic_areas(np.array([one_km]), "EPSG:32630")[0].round(-2))
    1000800.0
    """
    src = parse_crs(source)
    to_lonlat = None if src == _WGS84 else functools.partial(to_wgs84, src)
    return lonlat_areas(geometry, to_lonlat=to_lonlat, n_jobs=n_jobs)


class Projection:
    """The whole CRS round trip of :func:`geoalpha.hull`: input -> metres -> input.

    ``crs=None``: the coordinates as they are; ``crs="auto"``: lon/lat and
    Mercator input through :func:`metric_crs`, other projected input kept;
    a projected ``crs=`` for every group. Feet are scaled to metres.

    Parameters
    ----------
    coords : numpy.ndarray, shape (n, 2)
        Point coordinates in ``source``, the input CRS (or None).
    codes, n_groups, labels
        As for :func:`metric_crs`.
    source, crs
        The input CRS and the ``crs=`` option.

    Attributes
    ----------
    xy : numpy.ndarray, shape (n, 2)
        Coordinates to compute in: metres (the input units with ``crs=None``).
    out, crossing, wide : numpy.ndarray
        As :func:`~geoalpha._arrays.lonlat.output_lonlat` (for lon/lat input).
    names, unit : numpy.ndarray of str (n_groups,), str
        Each group's computation CRS (output table); unit of :attr:`xy` ("m").

    Raises
    ------
    InvalidInputError
        Input without CRS (unless ``crs=None``), or as :func:`metric_crs`.

    Examples
    --------
    >>> lonlat = np.array([[-0.13, 51.50], [-0.10, 51.52], [-0.12, 51.49]])
    >>> proj = Projection(lonlat, np.zeros(3, dtype=int), 1, "EPSG:4326", "auto")
    >>> proj.names.tolist(), proj.unit, bool((proj.out == lonlat).all())
    (['EPSG:32630'], 'm', True)
    >>> feet = Projection(np.array([[0.0, 0.0], [1000.0, 0.0]]), np.zeros(2, int),
    ...                   1, "EPSG:2263", "auto")
    >>> feet.xy[1, 0].round(3)  # 1000 US survey feet, in metres
    np.float64(304.801)
    """

    def __init__(
        self,
        coords: np.ndarray,
        codes: np.ndarray,
        n_groups: int,
        source: Any,
        crs: Any,
        labels: Any = None,
    ) -> None:
        self.source = src = parse_crs(source)
        self.out = coords
        self.crossing, self.wide = np.zeros((2, n_groups), dtype=bool)
        self._crs_list: list[pyproj.CRS] = []
        self._crs_index = np.zeros(n_groups, dtype=np.intp)
        if crs is None:  # planar: the coordinates as they are
            self.xy = coords
            self.unit = src.axis_info[0].unit_name if src and src.axis_info else "unit"
            self.names = np.full(n_groups, crs_name(src) if src else "planar")
            return
        self.unit = "m"
        if src is None:
            raise InvalidInputError(
                "the input has no CRS, so it cannot be projected to metres; set it "
                "with gdf.set_crs(...) or pass crs=None to use the coordinates as "
                "planar values"
            )
        auto = auto_mode(crs) is not None
        if src.is_geographic:
            self.xy, self._crs_list, self._crs_index = metric_crs(
                *coords.T, codes, n_groups, crs=crs, source_crs=src, labels=labels
            )
            self.out, self.crossing, self.wide = output_lonlat(coords, codes, n_groups)
        elif auto and is_mercator(src):
            geodetic = src.geodetic_crs
            to_lonlat = _transformer(_crs_key(src), _crs_key(geodetic))
            lon, lat = to_lonlat.transform(coords[:, 0], coords[:, 1])
            self.xy, self._crs_list, self._crs_index = metric_crs(
                lon, lat, codes, n_groups, crs=crs, source_crs=geodetic, labels=labels
            )
        elif auto:  # projected input is used as it is, in metres
            self._crs_list = [src]
            factor = unit_factor(src)
            self.xy = coords * factor if factor != 1.0 else coords
        else:
            target = target_crs(crs)
            forward = _transformer(_crs_key(src), _crs_key(target))
            x, y = forward.transform(coords[:, 0], coords[:, 1])
            self.xy = np.column_stack([x, y]) * unit_factor(target)
            failed = ~np.isfinite(self.xy).all(axis=1)
            if failed.any():
                raise InvalidInputError(
                    f"could not project {row_positions(failed, labels)} to "
                    f"{crs_name(target)}; choose a CRS that covers them or "
                    f"{setting('crs', 'auto')}"
                )
            self._crs_list = [target]
        used = [crs_name(c) for c in self._crs_list] or [crs_name(src)]  # no point
        self.names = np.array(used, dtype=object)[self._crs_index]

    def to_output(self, geoms: np.ndarray, groups: np.ndarray) -> np.ndarray:
        """Move geometries of ``groups`` from :attr:`xy`'s coordinates to the output's.

        Longitudes of groups across the antimeridian come back in [0, 360).
        """
        if not self._crs_list:
            return geoms
        out, src = geoms.copy(), self.source
        for k, target in enumerate(self._crs_list):
            sel = self._crs_index[groups] == k
            factor = unit_factor(target)
            same = target == src
            if not sel.any() or (same and factor == 1.0):
                continue
            back = None if same else _transformer(_crs_key(target), _crs_key(src))
            move = functools.partial(_moved, back=back, factor=factor)
            out[sel] = shapely.transform(geoms[sel], move)
        wrap = self.crossing[groups]
        if wrap.any():
            out[wrap] = shapely.transform(
                out[wrap], lambda c: np.column_stack([c[:, 0] % 360.0, c[:, 1]])
            )
        return out


def _moved(c: np.ndarray, back, factor: float) -> np.ndarray:
    """Coordinates ``c`` of a computation CRS in feet or metres back to the input's."""
    c = c / factor if factor != 1.0 else c
    return c if back is None else np.column_stack(back.transform(c[:, 0], c[:, 1]))
