"""Warnings about the set-up: a ``by`` that looks wrong, a CRS that stretches areas."""

from __future__ import annotations

import contextlib
from functools import lru_cache
from typing import Any

import numpy as np
import pyproj

from geoalpha._crs_parsing import crs_name, is_mercator, is_sphere, parse_crs
from geoalpha._frame.crs import auto_mode, metric_crs
from geoalpha.errors import CRSWarning, GroupingWarning, setting, warn_user

__all__ = [
    "AREA_TOLERANCE",
    "MANY_GROUPS_MIN_ROWS",
    "MANY_GROUPS_SHARE",
    "area_scale",
    "check_distortion",
    "check_grouping",
    "computation_crs",
]

#: Warn about ``by`` from this share of groups per row ...
MANY_GROUPS_SHARE = 0.5
#: ... and this many rows.
MANY_GROUPS_MIN_ROWS = 50
#: Areal scale factors further than this from 1 are reported (2 %; a UTM
#: zone within its own width stays under 0.3 %).
AREA_TOLERANCE = 0.02
#: Points the scale is measured at, evenly spaced through the input, and those
#: at the extremes of x and y (the scale varies most towards the edges).
_SAMPLE = 256


def area_scale(crs: Any, x: Any, y: Any, source_crs: Any) -> np.ndarray:
    """Return the areal scale factor of ``crs`` at some of the given points.

    Parameters
    ----------
    crs : CRS
        A projected CRS.
    x, y : array_like of float
        Coordinates of the points in ``source_crs`` (a CRS).

    Returns
    -------
    numpy.ndarray of float
        Area on the map / true area at up to 260 of the points (``inf``
        where ``crs`` cannot represent a point); empty without finite points.

    Examples
    --------
    >>> from geoalpha._frame.checks import area_scale
    >>> float(area_scale("EPSG:3857", [-0.12], [51.5], "EPSG:4326")[0])
    2.58...
    >>> float(area_scale("EPSG:32630", [-3.0], [51.5], "EPSG:4326")[0])
    0.999...
    """
    x = np.asarray(x, dtype=float).ravel()
    y = np.asarray(y, dtype=float).ravel()
    finite = np.isfinite(x) & np.isfinite(y)
    if not finite.all():
        x, y = x[finite], y[finite]
    pick = _sample(x, y)
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


def _sample(x: np.ndarray, y: np.ndarray) -> np.ndarray | slice:
    """Rows of at most :data:`_SAMPLE` points evenly spaced, and the extremes.

    The extremes of x and y keep the extent; every point when there are few.
    """
    if x.size <= _SAMPLE:
        return slice(None)
    pick = np.linspace(0, x.size - 1, _SAMPLE).astype(np.intp)
    ends = [np.argmin(x), np.argmax(x), np.argmin(y), np.argmax(y)]
    return np.concatenate([pick, ends])


def _key(crs: Any) -> str:
    """Return a hashable spelling of a CRS (the cache key of :func:`_factors_of`)."""
    return pyproj.CRS.from_user_input(crs).srs


@lru_cache(maxsize=32)
def _factors_of(source: str, target: str) -> tuple[pyproj.Transformer, pyproj.Proj]:
    """Return the way from ``source`` to lon/lat on ``target``'s datum, and it."""
    crs = pyproj.CRS.from_user_input(target)
    geographic = crs.geodetic_crs or pyproj.CRS.from_epsg(4326)
    to_lonlat = pyproj.Transformer.from_crs(source, geographic, always_xy=True)
    return to_lonlat, pyproj.Proj(crs)


def check_grouping(n_groups: int, n_rows: int, by: Any) -> None:
    """Warn when ``by`` makes nearly one group per row.

    Parameters
    ----------
    n_groups, n_rows : int
        Groups that ``by`` makes, and input rows.
    by : str, list or array_like or None
        The ``by`` of :func:`geoalpha.hull` (None: one group, never warned).

    Warns
    -----
    GroupingWarning
        From :data:`MANY_GROUPS_SHARE` groups per row and
        :data:`MANY_GROUPS_MIN_ROWS` rows on.
    """
    few = n_groups <= MANY_GROUPS_SHARE * n_rows
    if by is None or n_rows < MANY_GROUPS_MIN_ROWS or few:
        return
    names = by if isinstance(by, list) else [by]
    if not all(isinstance(n, str) for n in names):
        text, question = setting("by"), "is this the right grouping?"
    elif len(names) > 1:
        text, question = setting("by", names), "are these the right columns?"
    else:
        text, question = setting("by", names[0]), "is this the right column?"
    warn_user(
        f"{text} makes {n_groups:,} groups of {n_rows:,} rows; groups of 1-2 "
        f"points have no alpha shape, so {question}",
        GroupingWarning,
    )


def computation_crs(source: Any, crs: Any) -> tuple[pyproj.CRS | None, str]:
    """Return the one projected CRS a run computes every group in, and who chose it.

    Parameters
    ----------
    source : CRS or None
        The input CRS.
    crs : "auto", "auto-group", CRS or None
        The ``crs=`` option.

    Returns
    -------
    (pyproj.CRS or None, str)
        The CRS and ``"crs="`` (forced) or ``"input"`` (kept by ``"auto"``);
        ``(None, "")`` when there is no one such CRS.

    Examples
    --------
    >>> computation_crs("EPSG:4326", "auto"), computation_crs("EPSG:27700", "auto")[1]
    ((None, ''), 'input')
    """
    src = parse_crs(source)
    if src is None or crs is None or is_sphere(crs):
        return None, ""
    if auto_mode(crs) is not None:
        kept = src.is_projected and not is_mercator(src)
        return (src, "input") if kept else (None, "")
    try:
        parsed = parse_crs(crs)
    except Exception:  # the projection stage reports a bad crs=
        return None, ""
    if parsed is None or not parsed.is_projected:
        return None, ""
    return parsed, "crs="


def _suggestion(coords: np.ndarray, source: pyproj.CRS) -> str:
    """``, e.g. crs='EPSG:32630'``: the UTM zone of the points, if one fits.

    Chosen from a sample (:func:`_sample`: the extremes and 256 points), as
    ``crs="auto"`` chooses from a group's extent: a constant cost, not one
    per point.
    """
    with contextlib.suppress(Exception):
        geographic = source.geodetic_crs or pyproj.CRS.from_epsg(4326)
        to_lonlat = pyproj.Transformer.from_crs(source, geographic, always_xy=True)
        coords = coords[_sample(coords[:, 0], coords[:, 1])]  # (NaN: left out below)
        lon, lat = to_lonlat.transform(coords[:, 0], coords[:, 1])
        ok = np.isfinite(lon) & np.isfinite(lat)
        codes = np.zeros(int(ok.sum()), dtype=np.intp)
        _, chosen, _ = metric_crs(
            lon[ok], lat[ok], codes, 1, crs="auto", source_crs=geographic
        )
        name = crs_name(chosen[0])
        if name.startswith("EPSG:"):
            return f", e.g. {setting('crs', name)}"
    return ""


def check_distortion(coords: np.ndarray, source: Any, crs: Any) -> None:
    """Warn when the computation CRS stretches areas where the points are.

    Parameters
    ----------
    coords : numpy.ndarray, shape (n, 2)
        The points (or a sample of them) in ``source``.
    source, crs
        As for :func:`computation_crs`.

    Warns
    -----
    CRSWarning
        When the computation CRS's areal scale is further than
        :data:`AREA_TOLERANCE` from 1 at a point.
    """
    target, chosen_by = computation_crs(source, crs)
    coords = np.asarray(coords, dtype=float).reshape(-1, 2)
    if target is None or not len(coords):
        return
    src = parse_crs(source)
    scale = area_scale(target, coords[:, 0], coords[:, 1], src)
    if scale.size == 0 or np.abs(scale - 1.0).max() <= AREA_TOLERANCE:
        return
    if chosen_by == "crs=":
        how = setting("crs")
        advice = (
            f"leave out {how} (the default {setting('crs', 'auto')} picks a UTM "
            "zone or a local equal-area CRS per group) for true metres"
        )
    else:
        how = "the input's CRS"
        advice = f"pass {setting('crs')} with a UTM zone or an equal-area CRS for "
        advice += f"these points{_suggestion(coords, src)}"
    warn_user(
        f"the shapes are computed in {crs_name(target)} ({how}), which stretches "
        f"areas {float(np.median(scale)):.3g} times (median at the points; "
        f"{float(scale.min()):.3g}-{float(scale.max()):.3g}), so 'radius' and "
        "'alpha' are not in true metres ('area_m2' is: it is measured on the "
        f"WGS84 ellipsoid): {advice}",
        CRSWarning,
    )
