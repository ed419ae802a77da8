"""Exception and warning classes of geoalpha, and their wording (:func:`setting`)."""

from __future__ import annotations

import contextvars
import difflib
import itertools
import sys
import warnings
from collections.abc import Iterable, Mapping
from typing import Any

#: The exceptions and warnings; the helpers below are geoalpha's own.
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
    "SharedLocationWarning",
    "SuspiciousHullWarning",
]

#: The ``geoalpha`` command's flag of each keyword while it runs
#: (``{"n_jobs": "--jobs", "hull()": "geoalpha", ...}``); None in Python.
FLAGS: contextvars.ContextVar[Mapping[str, str] | None] = contextvars.ContextVar(
    "geoalpha_flags", default=None
)


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


class SuspiciousHullWarning(GeoAlphaWarning):
    """One location forces a group's shape far beyond its other points.

    Leaving that location (a distinct point, with all its rows) out divides the
    group's optimal radius by at least :data:`geoalpha._core.SUSPICIOUS_FACTOR`
    (:doc:`/user_guide/why`); ``suspicious=False`` turns the check off.
    """


class SearchWarning(GeoAlphaWarning):
    """A non-exact alpha search (ladder or bisection) gave a weaker result."""


class SharedLocationWarning(GeoAlphaWarning):
    """Rows of two groups at the same location in an overlap (``overlap="split"``).

    The location became a boundary vertex of both groups' polygons.
    """


def warn_user(message: str, category: type[Warning]) -> None:
    """Warn with ``category``, pointing at the user's own line (outside geoalpha).

    Examples
    --------
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     warn_user("2 rows dropped", DroppedRowsWarning)
    >>> caught[0].category.__name__, str(caught[0].message)
    ('DroppedRowsWarning', '2 rows dropped')
    """
    frame, level = sys._getframe(0), 1
    while frame and frame.f_globals.get("__name__", "").startswith("geoalpha."):
        frame, level = frame.f_back, level + 1
    warnings.warn(message, category, stacklevel=level)


def first_n(items: Iterable, limit: int = 10, sep: str = ", ") -> str:
    """Join the first ``limit`` items as text, with ``", ..."`` when there are more.

    Examples
    --------
    >>> first_n(range(100), limit=3), first_n(["'DC'", "'GU'"], sep="; ")
    ('0, 1, 2, ...', "'DC'; 'GU'")
    """
    shown = [str(item) for item in itertools.islice(items, limit + 1)]
    more = ", ..." if len(shown) > limit else ""
    return sep.join(shown[:limit]) + more


def did_you_mean(name: object, choices: Iterable) -> str:
    """Return ``" (did you mean 'x'?)"`` for the choice closest to ``name``, or ``""``.

    A close spelling (``difflib``), else the same name in another letter case.

    Examples
    --------
    >>> did_you_mean("stat", ["state", "code"]), did_you_mean("zzz", ["state"])
    (" (did you mean 'state'?)", '')
    >>> did_you_mean("LATITUDE", ["lon", "latitude"])
    " (did you mean 'latitude'?)"
    """
    names = [str(c) for c in choices]
    close = difflib.get_close_matches(str(name), names, n=1, cutoff=0.6)
    lower = {c.lower(): c for c in names}
    if not close and str(name).lower() in lower:
        close = [lower[str(name).lower()]]
    return f" (did you mean {close[0]!r}?)" if close else ""


def spelled(term: str) -> str:
    """Return a keyword or ``"hull()"`` as the user knows it: its flag in the command.

    Examples
    --------
    >>> spelled("n_jobs"), spelled("hull()")
    ('n_jobs', 'hull()')
    """
    return (FLAGS.get() or {}).get(term, term)


def setting(name: str, *value: Any) -> str:
    """Spell option ``name`` (set to ``value``) as the user gives it.

    Parameters
    ----------
    name : str
        The keyword, e.g. ``"crs"``.
    *value
        Its value, if the message names one.

    Returns
    -------
    str
        ``"crs='auto'"`` in Python; in the command the flag of :data:`FLAGS`,
        ``"--crs auto"`` (None: ``none``, a list comma-separated, False ``--no-``).

    Examples
    --------
    >>> setting("degenerate", "drop"), setting("crs")
    ("degenerate='drop'", 'crs=')
    >>> token = FLAGS.set({"by": "--by", "dropna": "--dropna/--no-dropna"})
    >>> setting("by", ["a", "b"]), setting("dropna", False)
    ('--by a,b', '--no-dropna')
    >>> FLAGS.reset(token)
    """
    flag = (FLAGS.get() or {}).get(name)
    if flag is None:
        return f"{name}={value[0]!r}" if value else f"{name}="
    on, _, off = flag.partition("/")
    if not value or value[0] is True:
        return on
    if value[0] is False:
        return off
    shown = "none" if value[0] is None else value[0]
    if isinstance(shown, list | tuple):
        shown = ",".join(map(str, shown))
    return f"{on} {shown}"
