"""What a ``crs=`` value means: parse it, name it, check a computation CRS."""

from __future__ import annotations

import re
from typing import Any

import pyproj
from pyproj.exceptions import CRSError

from geoalpha.errors import InvalidInputError, setting

__all__ = [
    "crs_name",
    "is_mercator",
    "is_sphere",
    "parse_crs",
    "target_crs",
    "unit_factor",
]


def parse_crs(crs: Any) -> pyproj.CRS | None:
    """Parse any CRS a user may pass into a :class:`pyproj.CRS`.

    Parameters
    ----------
    crs : None, pyproj.CRS, int, str, dict or object with ``to_wkt``
        Anything :meth:`pyproj.CRS.from_user_input` accepts; None stays None.

    Returns
    -------
    pyproj.CRS or None

    Raises
    ------
    InvalidInputError
        If the input cannot be parsed as a CRS.

    Examples
    --------
    >>> parse_crs(32630).to_string(), parse_crs(None)
    ('EPSG:32630', None)
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
        ``"AUTHORITY:CODE"`` if exactly a registered CRS, else PROJ string or name.

    Examples
    --------
    >>> crs_name(32630), crs_name("+proj=laea +lat_0=64 +datum=WGS84 +units=m")
    ('EPSG:32630', '+proj=laea +lat_0=64 +datum=WGS84 +units=m')
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


def target_crs(crs: Any) -> pyproj.CRS:
    """Check a ``crs=`` option that names a computation CRS: the one check.

    Parameters
    ----------
    crs : anything :func:`parse_crs` accepts

    Returns
    -------
    pyproj.CRS
        The parsed, projected CRS (in feet or metres: see :func:`unit_factor`).

    Raises
    ------
    InvalidInputError
        If ``crs`` is None, cannot be parsed, or is not a projected CRS.

    Examples
    --------
    >>> target_crs(4326)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    geoalpha.errors.InvalidInputError: crs= must be a projected (metric) CRS, \
got EPSG:4326 (geographic); ...
    """
    parsed = parse_crs(crs)
    if parsed is None:
        raise InvalidInputError(
            f"{setting('crs')} must be 'auto' or a projected (metric) CRS here, got "
            "None"
        )
    if not parsed.is_projected:
        kind = "geographic" if parsed.is_geographic else "not projected"
        raise InvalidInputError(
            f"{setting('crs')} must be a projected (metric) CRS, got "
            f"{crs_name(parsed)} ({kind}); pass {setting('crs', 'auto')} to let "
            "geoalpha choose a UTM zone or a local CRS per group, or "
            f"{setting('crs', None)} to use the coordinates as they are"
        )
    return parsed


def unit_factor(crs: Any) -> float:
    """Return metres per coordinate unit of a projected CRS (1.0 if unknown).

    Examples
    --------
    >>> unit_factor("EPSG:32630"), round(unit_factor("EPSG:2263"), 7)
    (1.0, 0.3048006)
    """
    parsed = parse_crs(crs)
    if parsed is None or not parsed.axis_info:
        return 1.0
    return parsed.axis_info[0].unit_conversion_factor or 1.0


def is_mercator(crs: Any) -> bool:
    """Tell whether a CRS is a (normal aspect) Mercator projection, e.g. EPSG:3857.

    Its scale grows as 1/cos(latitude), so it is no metres for areas.

    Examples
    --------
    >>> is_mercator(3857), is_mercator(3395), is_mercator(32630)
    (True, True, False)
    """
    parsed = parse_crs(crs)
    if parsed is None or not parsed.is_projected:
        return False
    operation = parsed.coordinate_operation
    method = operation.method_name.lower() if operation is not None else ""
    return "mercator" in method and "transverse" not in method


def is_sphere(crs: Any) -> bool:
    """Whether a ``crs=`` option is ``"sphere"`` (computed on the sphere).

    Examples
    --------
    >>> is_sphere("Sphere"), is_sphere("EPSG:4326")
    (True, False)
    """
    return isinstance(crs, str) and crs.strip().lower() == "sphere"
