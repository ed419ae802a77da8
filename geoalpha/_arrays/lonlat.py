"""Longitude/latitude groups across the antimeridian: found, unwrapped, split back."""

from __future__ import annotations

from typing import Any

import numpy as np
import shapely

from geoalpha._core import ANTIMERIDIAN_SNAP
from geoalpha.errors import InvalidInputError, first_n

__all__ = [
    "check_codes",
    "crosses_antimeridian",
    "group_arcs",
    "output_lonlat",
    "restore_longitudes",
    "row_positions",
    "snap_meridian",
    "split_antimeridian",
    "unwrap_lon",
]


def row_positions(mask: np.ndarray, labels: Any = None) -> str:
    """Describe the rows where ``mask`` is true: "3 rows (positions 4, 9, 12)".

    >>> row_positions(np.array([True, False]), labels=np.array(["a", "b"]))
    '1 row (index a)'
    """
    where = np.flatnonzero(mask)
    s = "s" if where.size != 1 else ""
    if labels is None:
        kind, names = f"position{s}", (str(int(i)) for i in where)
    else:
        kind, names = "index", (str(v) for v in labels[where])
    return f"{where.size} row{s} ({kind} {first_n(names, limit=5)})"


def check_codes(codes: Any, n_groups: int, n_points: int) -> np.ndarray:
    """Return ``codes`` as integers, checked: one per point, ``0 .. n_groups - 1``."""
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
            f"got other values in {row_positions(outside)}"
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
    low[empty] = high[empty] = np.nan
    return low, high


def group_arcs(
    lon: np.ndarray, lat: np.ndarray | None, codes: np.ndarray, n_groups: int
) -> dict[str, np.ndarray]:
    """Smallest longitude arc (and latitude range) covering each group.

    Arrays by name: ``crossing``, ``west``, ``east`` (may exceed 180) and with
    ``lat`` ``south``, ``north``; NaN ends for empty groups.
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
    sorted_lon = lon[picked][np.lexsort((lon[picked], codes[picked]))]
    counts = np.bincount(codes[picked], minlength=n_groups)[wide]
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

    A group crosses when the smallest longitude interval covering it contains
    +-180 degrees (ties, and groups without points: not crossing).

    Parameters
    ----------
    lon, codes : array_like, shape (n,)
        Longitudes in [-180, 180] degrees, and group codes ``0 .. n_groups - 1``.
    n_groups : int

    Returns
    -------
    numpy.ndarray of bool, shape (n_groups,)

    Examples
    --------
    >>> lon = [177.5, 179.9, -179.5, -178.2, 10.0, 12.0]  # Fiji, then Italy
    >>> crosses_antimeridian(lon, [0, 0, 0, 0, 1, 1], 2)
    array([ True, False])
    """
    lon = np.asarray(lon, dtype=np.float64).ravel()
    codes = check_codes(codes, n_groups, lon.size)
    return group_arcs(lon, None, codes, n_groups)["crossing"]


def unwrap_lon(lon: Any, codes: Any, crossing: Any) -> np.ndarray:
    """Make the longitudes of antimeridian-crossing groups continuous.

    Parameters
    ----------
    lon, codes, crossing
        As for :func:`crosses_antimeridian`, and the groups that cross (its result).

    Returns
    -------
    numpy.ndarray of float64, shape (n,)
        ``lon``, plus 360 where negative in crossing groups.

    Examples
    --------
    >>> unwrap_lon([179.0, -179.0, -5.0], [0, 0, 1], [True, False]).tolist()
    [179.0, 181.0, -5.0]
    """
    lon = np.asarray(lon, dtype=np.float64).ravel()
    crossing = np.asarray(crossing, dtype=bool).ravel()
    codes = check_codes(codes, crossing.size, lon.size)
    return np.where(crossing[codes] & (lon < 0.0), lon + 360.0, lon)


def snap_meridian(coords: np.ndarray, x: float, west: float = 0.0) -> np.ndarray:
    """Shift ``coords`` ``west`` degrees west; snap x near ``x`` onto ``x``.

    Examples
    --------
    >>> snap_meridian(np.array([[540.0 - 1e-12, 5.0], [400.0, 6.0]]), 180.0, 360.0)
    array([[180.,   5.],
           [ 40.,   6.]])
    """
    coords = coords - (west, 0.0)
    coords[np.abs(coords[:, 0] - x) <= ANTIMERIDIAN_SNAP, 0] = x
    return coords


def split_antimeridian(geom: Any) -> Any:
    """Split polygons in unwrapped longitudes at the antimeridian (RFC 7946 3.1.9).

    Parameters
    ----------
    geom : shapely Polygon or MultiPolygon, or array_like of them
        In unwrapped longitudes (:func:`unwrap_lon`); None passes through.

    Returns
    -------
    shapely geometry or numpy.ndarray of geometries
        Those with some x > 180 as valid MultiPolygons of the same area.

    Examples
    --------
    >>> parts = split_antimeridian(shapely.box(178, -18, 182, -16))
    >>> parts.geom_type, [p.bounds for p in parts.geoms]
    ('MultiPolygon', [(178.0, -18.0, 180.0, -16.0), (-180.0, -18.0, -178.0, -16.0)])
    >>> split_antimeridian(shapely.box(10, 0, 11, 1)).bounds
    (10.0, 0.0, 11.0, 1.0)
    """
    geoms = np.asarray(geom, dtype=object)  # 0-d for one geometry
    out = geoms.copy()
    flat = out.ravel()  # (a view of out)
    bounds = shapely.bounds(flat)
    with np.errstate(invalid="ignore"):
        todo = np.flatnonzero(bounds[:, 2] > 180.0)  # NaN for None/empty -> False
    if todo.size:
        minx, miny, maxx, maxy = bounds[todo].T
        west = shapely.intersection(
            flat[todo], shapely.box(minx - 1.0, miny - 1.0, 180.0, maxy + 1.0)
        )
        east = shapely.intersection(
            flat[todo], shapely.box(180.0, miny - 1.0, maxx + 1.0, maxy + 1.0)
        )
        west = shapely.transform(west, lambda c: snap_meridian(c, 180.0))
        east = shapely.transform(east, lambda c: snap_meridian(c, -180.0, 360.0))
        parts, idx = shapely.get_parts(np.r_[west, east], return_index=True)
        # Keep areas only: touching the line gives points/lines, not parts.
        keep = (shapely.get_type_id(parts) == 3) & ~shapely.is_empty(parts)
        parts, idx = parts[keep], idx[keep]
        order = np.lexsort((idx >= todo.size, idx % todo.size))  # west, then east
        present, rank = np.unique(idx[order] % todo.size, return_inverse=True)
        if parts.size:
            flat[todo[present]] = shapely.multipolygons(parts[order], indices=rank)
    return out[()] if geoms.ndim == 0 else out


def restore_longitudes(
    geoms: np.ndarray, geom_group: Any, lon: Any, lat: Any, codes: Any
) -> np.ndarray:
    """Give split polygons the input points' own longitudes back.

    The round trip ``lon + 360 - 360`` can move a vertex by one ulp, leaving its
    point outside the polygon; vertices that match no input point stay as they are.

    Parameters
    ----------
    geoms, geom_group : ndarray of shape (k,)
        Polygons from :func:`split_antimeridian` and the group of each.
    lon, lat, codes : array_like, shape (n,)
        The input points' longitudes, latitudes and group codes.

    Returns
    -------
    ndarray of shapely geometries, shape (k,)

    Examples
    --------
    >>> lon = np.array([175.0, -114.6042657247226, -119.0])
    >>> lat = np.array([-38.0, 25.0, 33.0])
    >>> unwrapped = unwrap_lon(lon, [0, 0, 0], [True])
    >>> parts = split_antimeridian(np.array([shapely.Polygon(zip(unwrapped, lat))]))
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
    shifted = snap_meridian(
        np.column_stack([lon[mine] + 360.0, lat[mine]]), -180.0, 360.0
    )
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


def output_lonlat(
    coords: np.ndarray, codes: np.ndarray, n_groups: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Longitude/latitude points as the output polygons are built from them.

    Returns ``(out, crossing, wide)``: the coordinates unwrapped
    (:func:`unwrap_lon`), the crossing groups and those wider than 180 degrees.

    Examples
    --------
    >>> lonlat = np.array([[179.0, 0.0], [-179.0, 1.0], [10.0, 0.0]])
    >>> out, crossing, wide = output_lonlat(lonlat, np.array([0, 0, 1]), 2)
    >>> out[:, 0].tolist(), crossing.tolist(), wide.tolist()
    ([179.0, 181.0, 10.0], [True, False], [False, False])
    """
    lon = coords[:, 0]
    arcs = group_arcs(lon, None, codes, n_groups)  # (crosses_antimeridian's)
    crossing, low, high = arcs["crossing"], arcs["west"], arcs["east"]
    out = coords
    if crossing.any():  # unwrap_lon on the checked codes
        out = coords.copy()
        out[:, 0] = np.where(crossing[codes] & (lon < 0.0), lon + 360.0, lon)
        low, high = _group_min_max(out[:, 0], codes, n_groups)
    with np.errstate(invalid="ignore"):
        wide = high - low > 180.0
    return out, crossing, wide
