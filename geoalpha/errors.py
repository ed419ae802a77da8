"""Exception and warning classes raised by geoalpha.

Every error geoalpha raises on bad input derives from :class:`GeoAlphaError`
(and from :class:`ValueError`, so ``except ValueError`` keeps working); every
warning derives from :class:`GeoAlphaWarning`.
"""

from __future__ import annotations

import difflib
import itertools
import sys
from collections.abc import Iterable

__all__ = [
    "AntimeridianWarning",
    "CRSWarning",
    "DatabaseError",
    "DegenerateGroupWarning",
    "DroppedRowsWarning",
    "GeoAlphaError",
    "GeoAlphaWarning",
    "GroupingWarning",
    "InvalidInputError",
    "OutlierWarning",
    "SearchWarning",
    "did_you_mean",
    "first_n",
]


class GeoAlphaError(ValueError):
    """Base class of the errors geoalpha raises on bad input."""


class InvalidInputError(GeoAlphaError):
    """Input points, groups or options that geoalpha cannot use."""


class DatabaseError(GeoAlphaError):
    """A PostgreSQL database could not be reached, read or written."""


class GeoAlphaWarning(UserWarning):
    """Base class of the warnings geoalpha emits."""


class DegenerateGroupWarning(GeoAlphaWarning):
    """Groups with fewer than 3 distinct points, or all collinear, have no alpha."""


class DroppedRowsWarning(GeoAlphaWarning):
    """Input rows were left out of the result (missing, empty, NaN geometry; no key)."""


class AntimeridianWarning(GeoAlphaWarning):
    """A group crosses the antimeridian; its hull was split at +-180 degrees."""


class OutlierWarning(GeoAlphaWarning):
    """Points were left out of their group's hull (``outliers=``)."""


class CRSWarning(GeoAlphaWarning):
    """A CRS given for the points or the computation looks wrong or distorts areas."""


class GroupingWarning(GeoAlphaWarning):
    """The groups look wrong: nearly as many groups as rows (a wrong ``by``?)."""


class SearchWarning(GeoAlphaWarning):
    """A non-exact alpha search (ladder or bisection) gave a weaker result."""


def user_stacklevel() -> int:
    """Return the ``stacklevel`` that points a warning at the user's own line."""
    frame, level = sys._getframe(1), 1
    while frame is not None and frame.f_globals.get("__name__", "").startswith(
        "geoalpha."
    ):
        frame, level = frame.f_back, level + 1
    return level


def first_n(items: Iterable, limit: int = 10, sep: str = ", ") -> str:
    """Join the first ``limit`` items as text, with ``", ..."`` when there are more.

    Examples
    --------
    >>> first_n([4, 9, 12])
    '4, 9, 12'
    >>> first_n(range(100), limit=3)
    '0, 1, 2, ...'
    >>> first_n(["'DC' (1 row)", "'GU' (1 row)"], sep="; ")
    "'DC' (1 row); 'GU' (1 row)"
    """
    shown = [str(item) for item in itertools.islice(items, limit + 1)]
    more = ", ..." if len(shown) > limit else ""
    return sep.join(shown[:limit]) + more


def did_you_mean(name: object, choices: Iterable) -> str:
    """Return ``" (did you mean 'x'?)"`` for the choice closest to ``name``, or ``""``.

    A close spelling (``difflib``), else the same name in another letter case.

    Examples
    --------
    >>> did_you_mean("stat", ["state", "code", "geometry"])
    " (did you mean 'state'?)"
    >>> did_you_mean("LATITUDE", ["lon", "latitude"])
    " (did you mean 'latitude'?)"
    >>> did_you_mean("zzz", ["state"])
    ''
    """
    names = [str(c) for c in choices]
    close = difflib.get_close_matches(str(name), names, n=1, cutoff=0.6)
    if not close:
        lower = {c.lower(): c for c in names}
        if str(name).lower() in lower:
            close = [lower[str(name).lower()]]
    return f" (did you mean {close[0]!r}?)" if close else ""
