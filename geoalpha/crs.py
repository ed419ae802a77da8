"""Metric CRS choice, longitude/latitude checks and antimeridian handling.

Pure functions on numpy arrays (no pandas, no geopandas) that the GeoDataFrame
layer calls before and after the alpha-shape computation:

- :func:`parse_crs` is the one helper that parses every user CRS;
- :func:`check_lonlat` validates coordinates given in a geographic CRS;
- :func:`crosses_antimeridian`, :func:`unwrap_lon` and
  :func:`split_antimeridian` keep groups that span the +-180 degree meridian
  (Fiji, the Aleutians) in one piece and split their polygons back;
- :func:`metric_crs` projects every group to a metric CRS (one UTM zone when
  the whole dataset fits one, else a UTM zone or a local Lambert azimuthal
  equal-area CRS per group), with one cached transformer per distinct CRS;
- :func:`crs_name` gives a short label of a CRS for the output table.

Group membership is given as integer codes ``0 .. n_groups - 1`` per point
(what :func:`pandas.factorize` returns), so that every per-group quantity is a
``np.bincount`` or a ``ufunc.reduceat`` instead of a Python loop over groups.
"""

from __future__ import annotations

import functools
import re
from typing import Any

import numpy as np
import pyproj
import shapely
from pyproj.exceptions import CRSError

from geoalpha.errors import InvalidInputError, first_n

__all__ = [
    "Projection",
    "check_lonlat",
    "crosses_antimeridian",
    "crs_name",
    "is_mercator",
    "is_sphere",
    "metric_crs",
    "output_lonlat",
    "parse_crs",
    "restore_longitudes",
    "split_antimeridian",
    "target_crs",
    "to_wgs84",
    "unit_factor",
    "unwrap_lon",
]

#: Half width, in degrees of longitude, of the band around a UTM zone's central
#: meridian that counts as "fits the zone": the zone's own 3 degrees plus a
#: 1.5 degree margin (scale error at most about 0.3 % at the equator, less
#: towards the poles).
UTM_HALF_WIDTH = 4.5
#: Largest absolute latitude projected with UTM; beyond it a local CRS is used.
UTM_MAX_LAT = 84.0
#: Local LAEA CRSs are centred on the group centre rounded to this many degrees,
#: so that nearby groups share a CRS (and a transformer). Rounding moves the
#: centre by at most 0.7 degrees, which changes the scale by less than 0.01 %.
LAEA_CENTRE_STEP = 1.0

_WGS84 = "EPSG:4326"
_MAX_POSITIONS = 5


def parse_crs(crs: Any) -> pyproj.CRS | None:
    """Parse any CRS a user may pass into a :class:`pyproj.CRS`.

    Parameters
    ----------
    crs : None, pyproj.CRS, int, str, dict or object with ``to_wkt``
        ``None`` stays ``None``; a :class:`pyproj.CRS` is returned as is;
        anything :meth:`pyproj.CRS.from_user_input` accepts (an EPSG code such
        as ``32630``, ``"EPSG:32630"``, WKT, a PROJ string, a PROJ JSON dict,
        an object with a ``to_wkt`` method such as a rasterio CRS) is parsed.

    Returns
    -------
    pyproj.CRS or None

    Raises
    ------
    InvalidInputError
        If the input cannot be parsed as a CRS.

    Examples
    --------
    >>> from geoalpha.crs import parse_crs
    >>> parse_crs(32630).to_string()
    'EPSG:32630'
    >>> parse_crs("EPSG:4326").is_geographic
    True
    >>> parse_crs(None) is None
    True
    """
    if crs is None or isinstance(crs, pyproj.CRS):
        return crs
    try:
        return pyproj.CRS.from_user_input(crs)
    except (CRSError, TypeError, ValueError) as err:
        shown = repr(crs)
        if len(shown) > 80:
            shown = shown[:77] + "..."
        raise InvalidInputError(
            f"unknown CRS {shown}: expected a CRS: an EPSG code (e.g. 32630 or "
            "'EPSG:32630'), WKT, a PROJ string or a pyproj.CRS; got "
            f"{type(crs).__name__} ({err})"
        ) from err


def crs_name(crs: Any) -> str:
    """Return a short human-readable label of a CRS.

    Parameters
    ----------
    crs : pyproj.CRS or anything :func:`parse_crs` accepts

    Returns
    -------
    str
        ``"AUTHORITY:CODE"`` (e.g. ``"EPSG:32630"``) when the CRS is exactly a
        registered one, else its PROJ string (e.g. the local Lambert azimuthal
        equal-area CRSs of :func:`metric_crs`), else its name.

    Examples
    --------
    >>> from geoalpha.crs import crs_name
    >>> crs_name(32630)
    'EPSG:32630'
    >>> crs_name("+proj=laea +lat_0=64 +lon_0=-153 +datum=WGS84 +units=m")
    '+proj=laea +lat_0=64 +lon_0=-153 +datum=WGS84 +units=m'
    """
    parsed = parse_crs(crs)
    if parsed is None:
        return "None"
    srs = parsed.srs.strip()
    if re.fullmatch(r"[A-Za-z]+:\d+", srs):
        return srs.upper()
    if srs.startswith("+"):
        # Cheap: the CRSs built here are PROJ strings; no database search.
        return re.sub(r"\s*\+type=crs\b", "", srs).strip()
    authority = parsed.to_authority(min_confidence=100)
    if authority is not None:
        return f"{authority[0]}:{authority[1]}"
    return parsed.name


def _positions(mask: np.ndarray, labels: Any = None) -> str:
    """Describe the rows where ``mask`` is true: "3 rows (positions 4, 9, 12)".

    With ``labels`` (one label per row, e.g. the index labels of the frame the
    points came from) the rows are named by label: "3 rows (index 4, 9, 12)".
    """
    where = np.flatnonzero(mask)
    count = where.size
    if labels is None:
        kind = "position" if count == 1 else "positions"
        names = (str(int(i)) for i in where)
    else:
        kind = "index"
        names = (str(v) for v in labels[where])
    shown = first_n(names, limit=_MAX_POSITIONS)
    return f"{count} row{'s' if count != 1 else ''} ({kind} {shown})"


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
        A label per point to name the offending rows by (e.g. the index
        labels of a frame); default: their positions.

    Raises
    ------
    InvalidInputError
        If any coordinate is NaN or infinite, any latitude is outside
        [-90, 90] or any longitude outside [-180, 180]. The message gives the
        number of offending rows and their first positions, and says when
        latitude and longitude look swapped.

    Examples
    --------
    >>> from geoalpha.crs import check_lonlat
    >>> check_lonlat([-0.1, 2.35], [51.5, 48.86])
    >>> check_lonlat([51.5, 48.86], [-0.1, 102.0])  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    geoalpha.errors.InvalidInputError: ...latitude outside [-90, 90] in 1 row \
(position 1); latitude and longitude look swapped (x holds latitudes?)
    """
    lon, lat = _as_coords(lon, lat)
    bad = ~(np.isfinite(lon) & np.isfinite(lat))
    if bad.any():
        raise InvalidInputError(
            "coordinates must be finite numbers; got NaN or infinite "
            f"longitude/latitude in {_positions(bad, labels)}"
        )
    bad_lat = np.abs(lat) > 90.0
    bad_lon = np.abs(lon) > 180.0
    problems = []
    if bad_lat.any():
        problems.append(f"latitude outside [-90, 90] in {_positions(bad_lat, labels)}")
    if bad_lon.any():
        problems.append(
            f"longitude outside [-180, 180] in {_positions(bad_lon, labels)}"
        )
    if problems:
        message = (
            "points in a geographic CRS must be longitude/latitude degrees; "
            + "; ".join(problems)
        )
        if np.all(np.abs(lon) <= 90.0) and np.all(np.abs(lat) <= 180.0):
            message += "; latitude and longitude look swapped (x holds latitudes?)"
        raise InvalidInputError(message)


def _as_codes(codes: Any, n_groups: int, n_points: int) -> np.ndarray:
    codes = np.asarray(codes).ravel()
    if codes.size != n_points:
        raise InvalidInputError(
            f"codes must have one group code per point; got {codes.size} codes "
            f"for {n_points} points"
        )
    if codes.size and not np.issubdtype(codes.dtype, np.integer):
        raise InvalidInputError(
            f"codes must be integers 0 .. n_groups - 1; got dtype {codes.dtype}"
        )
    codes = codes.astype(np.intp, copy=False)
    outside = (codes < 0) | (codes >= n_groups)
    if outside.any():
        raise InvalidInputError(
            f"codes must be integers 0 .. {n_groups - 1} (n_groups={n_groups}); "
            f"got other values in {_positions(outside)}"
        )
    return codes


def _group_min_max(
    values: np.ndarray, codes: np.ndarray, n_groups: int
) -> tuple[np.ndarray, np.ndarray]:
    """Per-group minimum and maximum (NaN for groups without points)."""
    low = np.full(n_groups, np.inf)
    high = np.full(n_groups, -np.inf)
    np.minimum.at(low, codes, values)
    np.maximum.at(high, codes, values)
    empty = np.isinf(low)
    low[empty] = np.nan
    high[empty] = np.nan
    return low, high


def _group_arcs(
    lon: np.ndarray, lat: np.ndarray | None, codes: np.ndarray, n_groups: int
) -> dict[str, np.ndarray]:
    """Smallest longitude arc (and latitude range) covering each group.

    Returns arrays of shape (n_groups,): ``crossing`` (the arc contains
    +-180), ``west``/``east`` (arc ends in unwrapped longitudes, so that
    ``west <= east`` and ``east`` may exceed 180), and with ``lat`` given
    ``south``/``north``. Empty groups get ``crossing=False`` and NaN ends.
    """
    west, east = _group_min_max(lon, codes, n_groups)
    out = {"crossing": np.zeros(n_groups, dtype=bool), "west": west, "east": east}
    if lat is not None:
        out["south"], out["north"] = _group_min_max(lat, codes, n_groups)
    # A group narrower than 180 degrees in plain longitudes cannot cross: the
    # gap containing +-180 is then wider than any gap between its points. Only
    # the wider groups need the gaps between their sorted longitudes.
    with np.errstate(invalid="ignore"):
        wide = east - west >= 180.0
    if not wide.any():
        return out
    picked = wide[codes]
    sub_lon = lon[picked]
    sub_codes = codes[picked]
    order = np.lexsort((sub_lon, sub_codes))
    sorted_lon = sub_lon[order]
    counts = np.bincount(sub_codes, minlength=n_groups)[wide]
    last = np.cumsum(counts) - 1
    first = last - counts + 1
    gaps = np.empty_like(sorted_lon)
    np.subtract(sorted_lon[1:], sorted_lon[:-1], out=gaps[1:])
    gaps[first] = -np.inf
    inner_gap = np.maximum.reduceat(gaps, first)
    wrap_gap = sorted_lon[first] + 360.0 - sorted_lon[last]
    crossing = inner_gap > wrap_gap
    out["crossing"][wide] = crossing
    if crossing.any():
        # The arc starts after the largest gap and ends before it (+360).
        segment = np.repeat(np.arange(first.size), counts)
        at_max = np.flatnonzero(gaps == inner_gap[segment])
        _, first_max = np.unique(segment[at_max], return_index=True)
        after_gap = at_max[first_max]
        ids = np.flatnonzero(wide)[crossing]
        west[ids] = sorted_lon[after_gap[crossing]]
        east[ids] = sorted_lon[after_gap[crossing] - 1] + 360.0
    return out


def crosses_antimeridian(lon: Any, codes: Any, n_groups: int) -> np.ndarray:
    """Tell which groups span the +-180 degree meridian.

    A group crosses when the smallest longitude interval (on the circle) that
    covers all its points contains +-180 degrees. Ties (two equally small
    intervals) count as not crossing.

    Parameters
    ----------
    lon : array_like of float, shape (n,)
        Longitudes in degrees, in [-180, 180].
    codes : array_like of int, shape (n,)
        Group code of every point, ``0 .. n_groups - 1`` (as returned by
        :func:`pandas.factorize`).
    n_groups : int
        Number of groups.

    Returns
    -------
    numpy.ndarray of bool, shape (n_groups,)
        True for the groups that cross; False for the others and for groups
        without points.

    Examples
    --------
    >>> from geoalpha.crs import crosses_antimeridian
    >>> lon = [177.5, 179.9, -179.5, -178.2, 10.0, 12.0]  # Fiji, then Italy
    >>> crosses_antimeridian(lon, [0, 0, 0, 0, 1, 1], 2)
    array([ True, False])
    """
    lon = np.asarray(lon, dtype=np.float64).ravel()
    codes = _as_codes(codes, n_groups, lon.size)
    return _group_arcs(lon, None, codes, n_groups)["crossing"]


def unwrap_lon(lon: Any, codes: Any, crossing: Any) -> np.ndarray:
    """Make the longitudes of antimeridian-crossing groups continuous.

    Parameters
    ----------
    lon : array_like of float, shape (n,)
        Longitudes in degrees, in [-180, 180].
    codes : array_like of int, shape (n,)
        Group code of every point, ``0 .. len(crossing) - 1``.
    crossing : array_like of bool, shape (n_groups,)
        Which groups cross the antimeridian, from :func:`crosses_antimeridian`.

    Returns
    -------
    numpy.ndarray of float64, shape (n,)
        A copy of ``lon`` in which the negative longitudes of the points of
        crossing groups have 360 added, so that each such group lies in
        [0, 360) without a jump; the other points are unchanged. Polygons
        built from these longitudes go back to [-180, 180] with
        :func:`split_antimeridian`.

    Notes
    -----
    A group whose points span more than 180 degrees of longitude (around a
    pole, or half the globe) has no meaningful single polygon in
    longitude/latitude; its unwrapped longitudes may still jump.

    Examples
    --------
    >>> from geoalpha.crs import unwrap_lon
    >>> unwrap_lon([179.0, -179.0, -5.0], [0, 0, 1], [True, False]).tolist()
    [179.0, 181.0, -5.0]
    """
    lon = np.asarray(lon, dtype=np.float64).ravel()
    crossing = np.asarray(crossing, dtype=bool).ravel()
    codes = _as_codes(codes, crossing.size, lon.size)
    return np.where(crossing[codes] & (lon < 0.0), lon + 360.0, lon)


def _snap(coords: np.ndarray, x: float) -> np.ndarray:
    """Put x coordinates within 1e-9 degrees of ``x`` exactly on ``x``."""
    near = np.abs(coords[:, 0] - x) <= 1e-9
    coords[near, 0] = x
    return coords


def _back_east(coords: np.ndarray) -> np.ndarray:
    """Unwrapped coordinates east of 180 degrees, shifted back by -360."""
    return _snap(coords - (360.0, 0.0), -180.0)


def split_antimeridian(geom: Any) -> Any:
    """Split polygons in unwrapped longitudes at the antimeridian.

    The part east of 180 degrees is shifted by -360 degrees, as RFC 7946
    (GeoJSON) section 3.1.9 asks, so that every longitude is in
    [-180, 180] again.

    Parameters
    ----------
    geom : shapely Polygon or MultiPolygon, or array_like of them
        Geometries whose x are unwrapped longitudes (see :func:`unwrap_lon`):
        some x may exceed 180. ``None`` and empty geometries pass through.

    Returns
    -------
    shapely geometry or numpy.ndarray of geometries
        Same shape as the input. A geometry with some x > 180 becomes a valid
        MultiPolygon whose parts west of the line end at x = 180 and whose
        parts east of it start at x = -180 (one part only if the geometry lies
        entirely east of 180); the total area is unchanged. Geometries with
        every x <= 180 are returned unchanged.

    Examples
    --------
    >>> from shapely import box
    >>> from geoalpha.crs import split_antimeridian
    >>> parts = split_antimeridian(box(178, -18, 182, -16))
    >>> parts.geom_type, [p.bounds for p in parts.geoms]
    ('MultiPolygon', [(178.0, -18.0, 180.0, -16.0), (-180.0, -18.0, -178.0, -16.0)])
    >>> split_antimeridian(box(10, 0, 11, 1)).bounds
    (10.0, 0.0, 11.0, 1.0)
    """
    scalar = np.ndim(geom) == 0
    geoms = np.empty(1, dtype=object)
    if scalar:
        geoms[0] = geom
    else:
        geoms = np.asarray(geom, dtype=object)
    out = geoms.copy()
    flat = geoms.ravel()
    bounds = shapely.bounds(flat)
    with np.errstate(invalid="ignore"):
        needs = bounds[:, 2] > 180.0  # NaN for None/empty -> False
    todo = np.flatnonzero(needs)
    if todo.size:
        sub = flat[todo]
        minx, miny, maxx, maxy = bounds[todo].T
        west = shapely.intersection(
            sub, shapely.box(minx - 1.0, miny - 1.0, 180.0, maxy + 1.0)
        )
        east = shapely.intersection(
            sub, shapely.box(180.0, miny - 1.0, maxx + 1.0, maxy + 1.0)
        )
        west = shapely.transform(west, lambda c: _snap(c, 180.0))
        east = shapely.transform(east, _back_east)
        west_parts, west_idx = shapely.get_parts(west, return_index=True)
        east_parts, east_idx = shapely.get_parts(east, return_index=True)
        parts = np.concatenate([west_parts, east_parts])
        idx = np.concatenate([west_idx, east_idx])
        side = np.repeat([0, 1], [west_idx.size, east_idx.size])
        # Keep areas only: touching the line gives points/lines, not parts.
        keep = (shapely.get_type_id(parts) == 3) & ~shapely.is_empty(parts)
        parts, idx, side = parts[keep], idx[keep], side[keep]
        order = np.lexsort((side, idx))
        parts, idx = parts[order], idx[order]
        has_parts = np.zeros(todo.size, dtype=bool)
        has_parts[idx] = True
        rank = np.cumsum(has_parts) - 1
        if parts.size:
            multi = shapely.multipolygons(parts, indices=rank[idx])
            result = flat.copy()
            result[todo[has_parts]] = multi
            out = result.reshape(geoms.shape)
    return out[0] if scalar else out


def restore_longitudes(
    geoms: np.ndarray, geom_group: Any, lon: Any, lat: Any, codes: Any
) -> np.ndarray:
    """Give split polygons the input points' own longitudes back.

    :func:`unwrap_lon` adds 360 degrees to negative longitudes and
    :func:`split_antimeridian` subtracts it again from the part east of the
    line; between -128 and 0 degrees that round trip rounds (``lon + 360``
    has a coarser spacing than ``lon``), so a vertex that was an input point
    comes back up to one unit in the last place away from it, and the point
    can fall outside its polygon. This puts every such vertex back on the
    longitude of the input point it came from (same group, same latitude,
    same round-tripped longitude).

    Parameters
    ----------
    geoms : ndarray of shapely geometries, shape (k,)
        Polygons from :func:`split_antimeridian`.
    geom_group : array_like of int, shape (k,)
        Group code of each geometry.
    lon, lat : array_like of float, shape (n,)
        The input points' longitudes (in [-180, 180]) and latitudes.
    codes : array_like of int, shape (n,)
        Group code of each point.

    Returns
    -------
    ndarray of shapely geometries, shape (k,)
        New geometries (the input array is not changed); vertices that match
        no input point (on the antimeridian, say) are left as they are.

    Examples
    --------
    >>> from shapely import Polygon
    >>> lon = np.array([175.0, -114.6042657247226, -119.0])
    >>> lat = np.array([-38.0, 25.0, 33.0])
    >>> unwrapped = unwrap_lon(lon, [0, 0, 0], [True])
    >>> parts = split_antimeridian(np.array([Polygon(zip(unwrapped, lat))]))
    >>> float(parts[0].geoms[1].exterior.coords[1][0])  # lon + 360 - 360
    -114.60426572472261
    >>> fixed = restore_longitudes(parts, [0], lon, lat, [0, 0, 0])
    >>> float(fixed[0].geoms[1].exterior.coords[1][0])
    -114.6042657247226
    """
    geoms = np.array(geoms, dtype=object)
    geom_group = np.asarray(geom_group, dtype=np.int64)
    lon = np.asarray(lon, dtype=np.float64)
    lat = np.asarray(lat, dtype=np.float64)
    codes = np.asarray(codes, dtype=np.int64)
    coords, which = shapely.get_coordinates(geoms, return_index=True)
    mine = np.isin(codes, geom_group) & (lon < 0.0)
    if len(coords) == 0 or not mine.any():
        return geoms
    # What each shifted point's longitude became in split_antimeridian.
    shifted = _back_east(np.column_stack([lon[mine] + 360.0, lat[mine]]))
    table = np.column_stack([codes[mine].astype(np.float64), shifted])
    query = np.column_stack([geom_group[which].astype(np.float64), coords])
    _, key = np.unique(np.concatenate([table, query]), axis=0, return_inverse=True)
    key = key.ravel()
    entry = np.full(key.max() + 1, -1, dtype=np.int64)
    entry[key[: len(table)]] = np.arange(len(table))
    hit = entry[key[len(table) :]]
    found = hit >= 0
    if not found.any():
        return geoms
    coords[found, 0] = lon[mine][hit[found]]
    return shapely.set_coordinates(geoms, coords)


_OWN_LAEA = re.compile(
    r"\+proj=laea \+lat_0=-?\d+ \+lon_0=-?\d+ \+datum=WGS84 \+units=m \+no_defs"
)


@functools.lru_cache(maxsize=1024)
def _transformer(source: str, target: str) -> pyproj.Transformer:
    """Return one cached (thread-safe) transformer per pair of CRS definitions.

    From WGS 84 longitude/latitude to the local LAEA CRSs built here, and
    back, the operation is a plain conversion: build it as a PROJ pipeline,
    which is about 100 times faster than searching the operation database
    (that matters with thousands of distinct group CRSs).
    """
    if source == _WGS84 and _OWN_LAEA.fullmatch(target):
        params = target.replace(" +datum=WGS84", " +ellps=WGS84")
        params = params.replace(" +no_defs", "")
        return pyproj.Transformer.from_pipeline(
            "+proj=pipeline +step +proj=unitconvert +xy_in=deg +xy_out=rad "
            f"+step {params}"
        )
    if target == _WGS84 and _OWN_LAEA.fullmatch(source):  # the way back
        params = source.replace(" +datum=WGS84", " +ellps=WGS84")
        params = params.replace(" +no_defs", "")
        return pyproj.Transformer.from_pipeline(
            f"+proj=pipeline +step +inv {params} "
            "+step +proj=unitconvert +xy_in=rad +xy_out=deg"
        )
    return pyproj.Transformer.from_crs(
        pyproj.CRS.from_user_input(source),
        pyproj.CRS.from_user_input(target),
        always_xy=True,
    )


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


def _utm_keys(
    west: np.ndarray, east: np.ndarray, south: np.ndarray, north: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """UTM EPSG code of each extent's centre, and whether the extent fits it.

    The zone is the one containing the centre of the extent (as
    ``GeoDataFrame.estimate_utm_crs`` picks it); the extent fits when it lies
    within ``UTM_HALF_WIDTH`` degrees of the zone's central meridian and
    within ``UTM_MAX_LAT`` degrees of the equator.
    """
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


def _laea_key(
    west: np.ndarray, east: np.ndarray, south: np.ndarray, north: np.ndarray
) -> np.ndarray:
    """Integer key of a local LAEA CRS centred on each extent.

    The centre is the middle of the (unwrapped) longitude arc and of the
    latitude range, rounded to ``LAEA_CENTRE_STEP``; a group spanning more
    than 180 degrees of longitude surrounds a pole and is centred on it.
    """
    lat0 = (south + north) / 2.0
    lon0 = _wrap180((west + east) / 2.0)
    polar = (east - west) > 180.0
    lat0 = np.where(polar, np.where(lat0 >= 0.0, 90.0, -90.0), lat0)
    step = LAEA_CENTRE_STEP
    lat0 = np.clip(np.round(lat0 / step) * step, -90, 90).astype(np.int64)
    lon0 = _wrap180(np.round(lon0 / step) * step).astype(np.int64)
    return 1_000_000 + (lat0 + 90) * 1000 + (lon0 + 180)


def target_crs(crs: Any) -> pyproj.CRS:
    """Check a ``crs=`` option that names a computation CRS: the one check.

    Parameters
    ----------
    crs : anything :func:`parse_crs` accepts
        The CRS the shapes are to be computed in.

    Returns
    -------
    pyproj.CRS
        The parsed CRS. It is projected; its unit may be another than the
        metre (feet): :class:`Projection` and :func:`metric_crs` scale its
        coordinates to metres (see :func:`unit_factor`), for every input.

    Raises
    ------
    InvalidInputError
        If ``crs`` is None, cannot be parsed, or is not a projected CRS.

    Examples
    --------
    >>> from geoalpha.crs import target_crs
    >>> target_crs("EPSG:27700").name
    'OSGB36 / British National Grid'
    >>> target_crs(4326)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    geoalpha.errors.InvalidInputError: crs= must be a projected (metric) CRS, \
got EPSG:4326 (geographic); ...
    """
    parsed = parse_crs(crs)
    if parsed is None:
        raise InvalidInputError(
            "crs= must be 'auto' or a projected (metric) CRS here, got None"
        )
    if not parsed.is_projected:
        kind = "geographic" if parsed.is_geographic else "not projected"
        raise InvalidInputError(
            "crs= must be a projected (metric) CRS, got "
            f"{crs_name(parsed)} ({kind}); pass crs='auto' to let geoalpha choose "
            "a UTM zone or a local CRS per group, or crs=None to use the "
            "coordinates as they are"
        )
    return parsed


def unit_factor(crs: Any) -> float:
    """Return metres per coordinate unit of a projected CRS (1.0 if unknown).

    Examples
    --------
    >>> from geoalpha.crs import unit_factor
    >>> unit_factor("EPSG:32630"), round(unit_factor("EPSG:2263"), 7)
    (1.0, 0.3048006)
    """
    parsed = parse_crs(crs)
    if parsed is None or not parsed.axis_info:
        return 1.0
    return parsed.axis_info[0].unit_conversion_factor or 1.0


def is_mercator(crs: Any) -> bool:
    """Tell whether a CRS is a (normal aspect) Mercator projection, e.g. EPSG:3857.

    Its scale grows as 1/cos(latitude) (1.6 at London), so its coordinates are
    no metres for areas or alphas; :class:`Projection` treats such input as
    longitude/latitude.

    Examples
    --------
    >>> from geoalpha.crs import is_mercator
    >>> is_mercator(3857), is_mercator(3395), is_mercator(32630)
    (True, True, False)
    """
    parsed = parse_crs(crs)
    if parsed is None or not parsed.is_projected:
        return False
    operation = parsed.coordinate_operation
    method = operation.method_name.lower() if operation is not None else ""
    return "mercator" in method and "transverse" not in method


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
        Coordinates in degrees in ``source_crs``; checked with
        :func:`check_lonlat`.
    codes : array_like of int, shape (n,)
        Group code of every point, ``0 .. n_groups - 1`` (as returned by
        :func:`pandas.factorize`; drop the ``-1`` of missing groups first).
    n_groups : int
        Number of groups.
    crs : "auto" or CRS, default "auto"
        ``"auto"``: if every point lies within ``UTM_HALF_WIDTH`` (4.5)
        degrees of longitude of one UTM zone's central meridian (the zone
        containing the centre of the data's extent, as
        ``GeoDataFrame.estimate_utm_crs`` picks it; antimeridian-aware) and
        within 84 degrees of the equator, that WGS 84 UTM zone (EPSG 326xx
        north, 327xx south, by the centre's hemisphere) is used for every
        group. Otherwise each group gets the UTM zone of its own centre when
        it fits that zone by the same rule, else a Lambert azimuthal
        equal-area CRS centred on the group (centre rounded to whole degrees;
        groups around a pole are centred on the pole; antimeridian-crossing
        groups are centred with unwrapped longitudes). Anything else is
        checked by :func:`target_crs` and used for every group; it must be
        a projected CRS, and coordinates in another unit than the metre
        (feet) are scaled to metres. ``"auto-group"``: the per-group choice of
        ``"auto"`` without the whole-dataset check (for a subset of the data
        whose whole-dataset check was done elsewhere, as
        :mod:`geoalpha.dask` does for each partition).
    source_crs : CRS, optional
        The geographic CRS of ``lon``/``lat``; default EPSG:4326 (WGS 84).
    labels : array_like, optional
        A label per point to name rows by in error messages (default: their
        positions).

    Returns
    -------
    xy : numpy.ndarray of float64, shape (n, 2)
        Metric coordinates of every point, in the CRS of its group (scaled
        to metres when that CRS is in feet).
    crs_list : list of pyproj.CRS
        The distinct CRSs used.
    crs_index : numpy.ndarray of int, shape (n_groups,)
        Position in ``crs_list`` of the CRS of each group.

    Raises
    ------
    InvalidInputError
        On invalid coordinates or codes, a forced ``crs`` that is not a
        projected metric CRS, a ``source_crs`` that is not geographic, or
        points the chosen CRS cannot project (their positions are named).

    Notes
    -----
    One cached :class:`pyproj.Transformer` per distinct CRS transforms all the
    points that use it in one vectorised call; the CRS choice itself is
    vectorised over groups.

    Examples
    --------
    >>> from geoalpha.crs import metric_crs, crs_name
    >>> lon = [-0.13, -0.10, -0.12, -2.24, -2.20, -2.25]  # London, Manchester
    >>> lat = [51.50, 51.52, 51.49, 53.48, 53.47, 53.50]
    >>> xy, crs_list, crs_index = metric_crs(lon, lat, [0, 0, 0, 1, 1, 1], 2)
    >>> [crs_name(c) for c in crs_list], crs_index.tolist()
    (['EPSG:32630'], [0, 0])
    >>> xy.shape
    (6, 2)
    """
    lon, lat = _as_coords(lon, lat)
    codes = _as_codes(codes, n_groups, lon.size)
    source = parse_crs(source_crs) if source_crs is not None else None
    if source is not None and not source.is_geographic:
        raise InvalidInputError(
            "source_crs= must be a geographic (longitude/latitude) CRS, got "
            f"{crs_name(source)}"
        )
    source_key = _WGS84 if source is None else source.srs
    check_lonlat(lon, lat, labels)

    mode = crs.strip().lower() if isinstance(crs, str) else None
    if mode in ("auto", "auto-group"):
        crs_list, crs_index = _choose_auto(
            lon, lat, codes, n_groups, whole=mode == "auto"
        )
    else:
        forced = target_crs(crs)
        crs_list, crs_index = [forced], np.zeros(n_groups, dtype=np.intp)

    xy = np.empty((lon.size, 2), dtype=np.float64)
    if len(crs_list) == 1:
        segments = [(crs_list[0], slice(None))]
    else:
        point_crs = crs_index[codes]
        order = np.argsort(point_crs, kind="stable")
        bounds = np.concatenate(
            [[0], np.cumsum(np.bincount(point_crs, minlength=len(crs_list)))]
        )
        segments = [
            (target, order[bounds[k] : bounds[k + 1]])
            for k, target in enumerate(crs_list)
        ]
    for target, rows in segments:
        transformer = _transformer(source_key, _crs_key(target))
        x, y = transformer.transform(lon[rows], lat[rows])
        factor = unit_factor(target)
        xy[rows, 0] = x if factor == 1.0 else np.multiply(x, factor)
        xy[rows, 1] = y if factor == 1.0 else np.multiply(y, factor)
    failed = ~(np.isfinite(xy[:, 0]) & np.isfinite(xy[:, 1]))
    if failed.any():
        names = sorted({crs_name(crs_list[k]) for k in crs_index[codes[failed]]})
        raise InvalidInputError(
            f"could not project {_positions(failed, labels)} to {', '.join(names)}; "
            "the points lie outside what the CRS can represent, choose a CRS "
            "that covers them or crs='auto'"
        )
    return xy, crs_list, crs_index


def _choose_auto(
    lon: np.ndarray,
    lat: np.ndarray,
    codes: np.ndarray,
    n_groups: int,
    whole: bool = True,
) -> tuple[list[pyproj.CRS], np.ndarray]:
    """CRS choice of ``metric_crs(crs="auto")``: (crs_list, crs_index).

    ``whole=False`` skips the whole-dataset check (``crs="auto-group"``).
    """
    if lon.size == 0:
        return [], np.zeros(n_groups, dtype=np.intp)
    if whole:
        south, north = np.array([lat.min()]), np.array([lat.max()])
        west, east = np.array([lon.min()]), np.array([lon.max()])
        if east[0] - west[0] > 2 * UTM_HALF_WIDTH:
            # Maybe narrow the other way round the globe (data across +-180).
            arc = _group_arcs(lon, None, np.zeros(lon.size, dtype=np.intp), 1)
            west, east = arc["west"], arc["east"]
        epsg, fits = _utm_keys(west, east, south, north)
        if fits[0]:
            return [_crs_from_key(int(epsg[0]))], np.zeros(n_groups, dtype=np.intp)

    arcs = _group_arcs(lon, lat, codes, n_groups)
    filled = ~np.isnan(arcs["west"])
    sub = {name: values[filled] for name, values in arcs.items()}
    epsg, fits = _utm_keys(sub["west"], sub["east"], sub["south"], sub["north"])
    laea = _laea_key(sub["west"], sub["east"], sub["south"], sub["north"])
    keys = np.empty(n_groups, dtype=np.int64)
    keys[filled] = np.where(fits, epsg, laea)
    keys[~filled] = keys[filled][0]  # groups without points: any CRS in use
    distinct, crs_index = np.unique(keys, return_inverse=True)
    crs_list = [_crs_from_key(int(key)) for key in distinct]
    return crs_list, crs_index.astype(np.intp).ravel()


def output_lonlat(
    coords: np.ndarray, codes: np.ndarray, n_groups: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Longitude/latitude points as the output polygons are built from them.

    Returns ``(out, crossing, wide)``: the coordinates with the longitudes of
    antimeridian-crossing groups unwrapped (:func:`unwrap_lon`; ``coords``
    itself when no group crosses), the crossing groups, and the groups that
    span more than 180 degrees of longitude.
    """
    lon = coords[:, 0]
    # crosses_antimeridian(lon, codes, n_groups), keeping its ranges
    arcs = _group_arcs(lon, None, codes, n_groups)
    crossing = arcs["crossing"]
    low, high = arcs["west"], arcs["east"]
    out = coords
    if crossing.any():
        out = coords.copy()
        out[:, 0] = unwrap_lon(lon, codes, crossing)
        low, high = _group_min_max(out[:, 0], codes, n_groups)
    with np.errstate(invalid="ignore"):
        wide = high - low > 180.0
    return out, crossing, wide


def to_wgs84(source: Any, x: Any, y: Any, labels: Any = None):
    """Return the longitudes and latitudes (EPSG:4326) of points in ``source``.

    Raises
    ------
    InvalidInputError
        Naming the rows (by ``labels``) that cannot be moved.
    """
    src = parse_crs(source)
    to = _transformer(_crs_key(src), "EPSG:4326")
    lon, lat = to.transform(np.asarray(x, dtype=float), np.asarray(y, dtype=float))
    lon, lat = np.asarray(lon, dtype=float), np.asarray(lat, dtype=float)
    failed = ~(np.isfinite(lon) & np.isfinite(lat))
    if failed.any():
        raise InvalidInputError(
            f"could not move {_positions(failed, labels)} to longitude/latitude "
            "(EPSG:4326)"
        )
    return lon, lat


def is_sphere(crs: Any) -> bool:
    """Whether a ``crs=`` option is ``"sphere"`` (computed on the sphere)."""
    return isinstance(crs, str) and crs.strip().lower() == "sphere"


class Projection:
    """The whole CRS round trip of :func:`geoalpha.hull`: input -> metres -> input.

    Built once per call from the points' coordinates in the input CRS and the
    ``crs=`` option; holds the coordinates to compute in (:attr:`xy`, metres)
    and the coordinates to build output geometries from (:attr:`out`, the
    input coordinates), and moves metric geometries back
    (:meth:`to_output`).

    The rules, the same for every input:

    - ``crs=None``: the coordinates as they are (planar; alpha in 1/unit).
    - ``crs="auto"`` (or ``"auto-group"``, see :func:`metric_crs`):
      geographic input goes to a UTM zone or a local equal-area CRS per
      group; Mercator input (EPSG:3857, EPSG:3395; see :func:`is_mercator`)
      too, through its longitude/latitude, since its own scale is off by
      1/cos(latitude); any other projected input is used as it is.
    - ``crs=<projected CRS>`` (checked by :func:`target_crs`): every group in
      that CRS, whatever the input CRS.
    - Coordinates in feet (or any unit other than the metre) are scaled to
      metres, so alpha is in 1/metre and areas in square metres.

    Parameters
    ----------
    coords : numpy.ndarray, shape (n, 2)
        Point coordinates in ``source``.
    codes : numpy.ndarray of int, shape (n,)
        Group code of each point, ``0 .. n_groups - 1``.
    n_groups : int
        Number of groups.
    source : CRS or None
        The input CRS.
    crs : "auto", "auto-group", CRS or None
        The ``crs=`` option.
    labels : array_like, optional
        A label per point to name rows by in error messages.

    Attributes
    ----------
    xy : numpy.ndarray, shape (n, 2)
        Coordinates to compute in: metres (the input units with ``crs=None``).
    out : numpy.ndarray, shape (n, 2)
        Coordinates of the output geometries' vertices: the input coordinates
        (longitudes of antimeridian-crossing groups unwrapped).
    crossing, wide : numpy.ndarray of bool, shape (n_groups,)
        Groups across +-180 degrees; groups spanning more than 180 degrees of
        longitude (lon/lat input only).
    names : numpy.ndarray of str, shape (n_groups,)
        The computation CRS of each group, for the output table.
    unit : str
        Unit of :attr:`xy`, for messages ("m" unless ``crs=None``).

    Raises
    ------
    InvalidInputError
        Input without CRS (unless ``crs=None``), a bad ``crs=``, lon/lat out
        of range or points the CRS cannot project (rows named by ``labels``).

    Examples
    --------
    >>> import numpy as np
    >>> from geoalpha.crs import Projection
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
        src = parse_crs(source)
        self.source = src
        self.out = coords
        self.crossing = np.zeros(n_groups, dtype=bool)
        self.wide = np.zeros(n_groups, dtype=bool)
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
        auto = isinstance(crs, str) and crs.strip().lower() in ("auto", "auto-group")
        if src.is_geographic:
            lon, lat = coords[:, 0], coords[:, 1]
            self.xy, self._crs_list, self._crs_index = metric_crs(
                lon, lat, codes, n_groups, crs=crs, source_crs=src, labels=labels
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
            failed = ~(np.isfinite(self.xy[:, 0]) & np.isfinite(self.xy[:, 1]))
            if failed.any():
                raise InvalidInputError(
                    f"could not project {_positions(failed, labels)} to "
                    f"{crs_name(target)}; choose a CRS that covers them or "
                    "crs='auto'"
                )
            self._crs_list = [target]
        used = [crs_name(c) for c in self._crs_list] or [crs_name(src)]  # no point
        self.names = np.array(used, dtype=object)[self._crs_index]

    def to_output(self, geoms: np.ndarray, groups: np.ndarray) -> np.ndarray:
        """Move metric geometries of ``groups`` to the output (input) CRS.

        Parameters
        ----------
        geoms : numpy.ndarray of shapely geometries
            In the coordinates of :attr:`xy`.
        groups : numpy.ndarray of int
            The group of each geometry.

        Returns
        -------
        numpy.ndarray of shapely geometries
            In the input CRS (longitudes of crossing groups in [0, 360)).
        """
        if not self._crs_list:
            return geoms
        out = geoms.copy()
        for k, target in enumerate(self._crs_list):
            sel = self._crs_index[groups] == k
            factor = unit_factor(target)
            same = target == self.source
            if not sel.any() or (same and factor == 1.0):
                continue
            back = (
                None if same else _transformer(_crs_key(target), _crs_key(self.source))
            )

            def move(c, back=back, factor=factor):
                if factor != 1.0:
                    c = c / factor
                if back is None:
                    return c
                return np.column_stack(back.transform(c[:, 0], c[:, 1]))

            out[sel] = shapely.transform(geoms[sel], move)
        wrap = self.crossing[groups]
        if wrap.any():
            out[wrap] = shapely.transform(
                out[wrap], lambda c: np.column_stack([c[:, 0] % 360.0, c[:, 1]])
            )
        return out
