"""The options of :func:`geoalpha.hull`, defined once (``docs/architecture.md``).

:class:`Options` declares each option's default, check, documentation and flag.
Imports only the standard library, so that ``geoalpha --help`` stays fast.
"""

from __future__ import annotations

import dataclasses
import inspect
import math
import numbers
from collections.abc import Callable, Mapping
from typing import Any

from geoalpha.errors import InvalidInputError, first_n, setting, spelled

__all__ = [
    "DEGENERATE_POLICIES",
    "FIELDS",
    "META",
    "METHODS",
    "OUTLIER_UNITS",
    "OVERLAPS",
    "SEARCHES",
    "OptionMeta",
    "Options",
    "Request",
    "check",
    "check_outliers",
    "defaults",
    "docstring",
    "signature",
]

#: Hull methods of :func:`geoalpha.hull`.
METHODS = ("alpha", "convex", "concave", "knn")
#: How the optimal alpha is searched.
SEARCHES = ("exact", "ladder", "bisect")
#: What :func:`geoalpha.hull` does with groups that have no alpha shape.
DEGENERATE_POLICIES = ("buffer", "empty", "drop")
#: What ``outliers=`` counts: rows, or locations (distinct points, 1 each).
OUTLIER_UNITS = ("rows", "locations")

#: What :func:`geoalpha.hull` does where neighbouring groups' hulls overlap.
OVERLAPS = ("keep", "split")


@dataclasses.dataclass(frozen=True)
class OptionMeta:
    """How one option is typed, checked, documented and spelled on the command line.

    Attributes
    ----------
    doc : str
        numpydoc text of the parameter: a type line (from the field), then ``doc``.
    kind : str
        ``"bool"``, ``"int"``, ``"float"``, ``"number"`` (int or float),
        ``"choice"`` or ``"crs"``; by default from the field's annotation.
    choices, low, high, low_open, optional
        Allowed values, bounds (``low_open`` excludes ``low``), None allowed.
    what : str, optional
        The allowed values in words, when the fields above do not say it.
    flags, metavar, help
        Command-line spelling (default ``--name``; ``--name/--no-name`` for a
        bool), metavar, help.
    validate : callable, optional
        Its own check instead of the generic one (returns the value or raises).
    """

    doc: str
    kind: str = ""
    choices: tuple = ()
    low: float | None = None
    high: float | None = None
    low_open: bool = False
    optional: bool = False
    what: str | None = None
    flags: tuple[str, ...] = ()
    metavar: str | None = None
    help: str = ""
    validate: Callable[[Any], Any] | None = None

    def describe(self) -> str:
        """Say in words what values are allowed (for error messages)."""
        if self.what is not None:
            return self.what
        if self.kind == "choice":
            text = "one of " + ", ".join(map(repr, self.choices))
        elif self.kind == "bool":
            text = "True or False"
        elif self.kind == "crs":
            text = "'auto', 'sphere', a projected CRS or None"
        else:
            text = "an integer" if self.kind == "int" else "a finite number"
            if self.low is not None:
                text += f" {'>' if self.low_open else '>='} {self.low:g}"
            if self.high is not None:
                text += f" and <= {self.high:g}"
        return text + (" (or None)" if self.optional and self.kind != "crs" else "")

    def check(self, name: str, value: Any) -> Any:
        """Return ``value`` normalised, or raise :class:`InvalidInputError`."""
        if self.validate is not None:
            return self.validate(value)
        if value is None and (self.optional or self.kind == "crs"):
            return None
        if self.kind == "crs":
            return _check_crs(value)
        if self.kind == "choice":
            if isinstance(value, str) and value in self.choices:
                return value
        elif self.kind == "bool":
            if _is_bool(value):
                return bool(value)
        elif isinstance(value, numbers.Real) and not _is_bool(value):
            integral = isinstance(value, numbers.Integral)
            if (
                (integral or self.kind != "int")
                and math.isfinite(value)
                and (self.low is None or value >= self.low)
                and not (self.low_open and value == self.low)
                and (self.high is None or value <= self.high)
            ):
                return int(value) if integral and self.kind != "float" else float(value)
        raise InvalidInputError(
            f"{spelled(name)} must be {self.describe()}; got {_shown(value)!r}"
        )


def _is_bool(value) -> bool:
    """Tell True and False apart from numbers (numpy booleans too, without numpy)."""
    return isinstance(value, bool) or (
        type(value).__module__ == "numpy" and type(value).__name__ in ("bool", "bool_")
    )


def _shown(value):
    """Show a numpy scalar as the number it holds (``0``, not ``np.int64(0)``)."""
    if type(value).__module__ == "numpy" and getattr(value, "ndim", None) == 0:
        return value.item()
    return value


def _check_crs(value):
    word = value.strip().lower() if isinstance(value, str) else None
    if word == "sphere":
        return "sphere"
    if word not in ("auto", "auto-group"):
        from geoalpha._crs_parsing import target_crs

        target_crs(value)  # raises on anything but a projected CRS
    return value


def check_outliers(outliers):
    """Return ``outliers``, or raise :class:`InvalidInputError` unless a valid budget.

    Parameters
    ----------
    outliers : float or int
        A float in ``[0, 1)`` (a fraction of each group's rows) or an int
        ``>= 0`` (a count of rows per group).

    Examples
    --------
    >>> check_outliers(0.02), check_outliers(3)
    (0.02, 3)
    >>> check_outliers(1.5)
    Traceback (most recent call last):
    ...
    geoalpha.errors.InvalidInputError: outliers must be a fraction in [0, 1) or ...
    """
    integral = isinstance(outliers, numbers.Integral)
    if (
        _is_bool(outliers)
        or not isinstance(outliers, numbers.Real)
        or not (outliers >= 0 and (integral or outliers < 1))
    ):
        raise InvalidInputError(
            f"{spelled('outliers')} must be a fraction in [0, 1) or a count >= 0 "
            f"(an int); got {outliers!r}"
        )
    return outliers


def option(default: Any, **meta) -> Any:
    """Declare one field of :class:`Options`: its default and :class:`OptionMeta`."""
    return dataclasses.field(default=default, metadata={"meta": OptionMeta(**meta)})


def _check_n_jobs(value):
    if value is None:
        return None
    if (
        _is_bool(value)
        or not isinstance(value, numbers.Integral)
        or value == 0
        or value < -1
    ):
        raise InvalidInputError(
            f"{spelled('n_jobs')} must be a positive integer, or -1 or None (every "
            f"core); got {value!r}"
        )
    return int(value)


@dataclasses.dataclass(frozen=True)
class Options:
    """Every option of :func:`geoalpha.hull`, checked, with their defaults.

    An error names the option and what it accepts; :data:`FIELDS` lists them.

    Examples
    --------
    >>> from geoalpha._options import Options
    >>> Options(holes=True).holes, Options().method
    (True, 'alpha')
    >>> Options(method="magic")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    geoalpha.errors.InvalidInputError: method must be one of 'alpha', ...; got 'magic'
    """

    alpha: float | None = option(
        None,
        low=0.0,
        optional=True,
        doc="Use this alpha (1/metre) for every group instead of the optimum;\n"
        "0 is the convex hull.",
        metavar="FLOAT",
        help="Use this alpha (1/metre) instead of searching for the optimum; "
        "0 gives convex hulls.",
    )
    holes: bool = option(
        False,
        doc="Keep holes (True) or fill every hole (False: no empty space in\n"
        "the middle).",
        help="Keep holes inside the shapes, or fill them.",
    )
    components: int = option(
        1,
        low=1,
        doc="Largest number of separate pieces per group (a MultiPolygon when\n"
        "more than 1).",
        help="Most pieces a group's shape may have (1: one Polygon).",
    )
    crs: Any = option(
        "auto",
        kind="crs",
        doc='Metric CRS of the computation: ``"auto"`` (a UTM zone, or a local\n'
        "CRS per group, for lon/lat input; projected input is kept), a projected\n"
        'CRS, None (the coordinates as planar numbers) or ``"sphere"`` (no\n'
        "projection); see :doc:`/user_guide/crs` and :doc:`/user_guide/sphere`.",
        metavar="auto|sphere|CRS|none",
        help="Metric CRS the shapes are computed in; 'auto' picks a UTM zone "
        "(or a local CRS per group) for lon/lat input and keeps projected input "
        "as it is. 'none' computes in INPUT's coordinates as they are (lon/lat: "
        "alpha in 1/degree, as in the seed paper; for input without a CRS the same "
        "as --crs-in none); 'sphere' computes on the sphere, with no projection "
        "(continent-wide groups). The output keeps INPUT's CRS.",
    )
    method: str = option(
        "alpha",
        choices=METHODS,
        doc='``"alpha"``: the optimal alpha shape; ``"convex"``: convex hulls;\n'
        '``"concave"``: ``shapely.concave_hull(ratio=ratio)``; ``"knn"``: the\n'
        "Moreira-Santos k-nearest-neighbour hull from ``k``. Same table for all.",
        help="Shape: optimal alpha shape, convex hull, shapely concave hull "
        "(see --ratio) or k-nearest-neighbour concave hull.",
    )
    search: str = option(
        "exact",
        choices=SEARCHES,
        doc='How the optimum is searched; ``"ladder"`` and ``"bisect"`` reproduce\n'
        "the seed paper's and alphashape's searches (:func:`geoalpha.alpha_shapes`).",
        help="How the optimal alpha is found: exactly, or (for comparison) with "
        "the integer ladder or float bisection.",
    )
    max_iterations: int = option(
        10_000,
        low=1,
        doc='Bisection steps before ``search="bisect"`` gives up.',
        metavar="N",
        help="Bisection steps before --search bisect gives up.",
    )
    ratio: float = option(
        0.3,
        low=0.0,
        high=1.0,
        doc='For ``method="concave"``: 0 is the tightest, 1 the convex hull.',
        help="Concaveness for --method concave (0: tightest, 1: convex).",
    )
    k: int = option(
        3,
        low=1,
        doc='For ``method="knn"``: the number of neighbours to start with.',
        help="Starting number of neighbours for --method knn.",
    )
    degenerate: str = option(
        "buffer",
        choices=DEGENERATE_POLICIES,
        doc="Groups with fewer than 3 distinct points or all collinear have no\n"
        'alpha shape: ``"buffer"`` gives them a polygon ``buffer`` metres around\n'
        'their points, ``"empty"`` an empty Polygon, ``"drop"`` no row.',
        help="Groups with fewer than 3 distinct or only collinear points: a small "
        "buffer polygon, an empty geometry, or no row.",
    )
    buffer: float = option(
        1.0,
        low=0.0,
        low_open=True,
        doc='Width for ``degenerate="buffer"``, in metres (in the coordinate\n'
        "units with ``crs=None``: degrees for lon/lat input).",
        metavar="M",
        help="Width of the polygon around a degenerate group with --degenerate "
        "buffer, in metres (in the coordinate units with --crs none).",
    )
    vertices: bool = option(
        False,
        doc="Accept non-point geometries and use their vertices as points\n"
        "(otherwise they are an error).",
        flags=("--vertices",),
        help="Accept lines and polygons in INPUT and use their vertices as points "
        "(otherwise they are an error).",
    )
    dropna: bool = option(
        True,
        doc="Drop rows whose group key is missing (a :class:`DroppedRowsWarning`\n"
        "counts them), as in ``dissolve``; False makes them a group of their own.",
        help="Leave out rows whose --by value is missing, or make them a group.",
    )
    sort: bool = option(
        True,
        doc="Sort the groups by key, as in ``dissolve``; False keeps the order\n"
        "of first appearance.",
        help="Write the groups sorted by --by value, or in order of first appearance.",
    )
    progress: bool | None = option(
        None,
        optional=True,
        doc="Show one progress bar through every phase (needs ``pip install\n"
        '"geoalpha[progress]"``). Default: only for long runs on a terminal.',
        help="Show a progress bar [default: when there are many groups].",
    )
    n_jobs: int | None = option(
        None,
        doc="Threads of the compiled kernel, which spreads the groups over them.\n"
        "None or -1: every core; more than the cores the process may run on is\n"
        "capped to them. The result is the same for every value.",
        flags=("-j", "--jobs"),
        metavar="N",
        validate=_check_n_jobs,
        help="Threads for the groups [default: every core]; the result is the same.",
    )

    outliers: int | float = option(
        0,
        validate=check_outliers,
        doc='Rows each group may leave out (``method="alpha"``, exact search):\n'
        "a fraction in ``[0, 1)`` of its rows or a count; see\n"
        ":doc:`/user_guide/outliers` and :func:`outlier_rows`.",
        metavar="FRACTION|COUNT",
        help="Rows each group may leave out: a fraction of its rows (0.02) or a "
        "count (3); the hull is then the tightest shape around the others. The "
        "output's n_outliers column counts the rows left out.",
    )
    outlier_unit: str = option(
        "rows",
        choices=OUTLIER_UNITS,
        doc='What ``outliers`` counts: ``"rows"``, or ``"locations"`` (a distinct\n'
        "point with all its rows counts 1: a wrong geocode that put 50 rows on\n"
        "one spot is one location); see :doc:`/user_guide/outliers`.",
        help="What --outliers counts: rows, or locations (a distinct point with "
        "all its rows counts 1).",
    )
    suspicious: bool = option(
        True,
        doc="Warn (:class:`SuspiciousHullWarning`) when leaving out one location\n"
        "would divide a group's optimal radius by at least\n"
        ":data:`geoalpha._core.SUSPICIOUS_FACTOR` (:doc:`/user_guide/why`).",
        help="Warn when one location forces a group's shape far beyond its "
        "other points (leaving it out divides the radius several times over).",
    )
    grow: float = option(
        0.0,
        low=0.0,
        what="a distance >= 0 (metres)",
        doc="Grow every hull (not the degenerate buffers) by this distance in\n"
        "metres (coordinate units with ``crs=None``), so that every point\n"
        "is strictly inside; ``area_m2`` is the grown polygon's area.",
        metavar="M",
        help="Grow every hull by M metres (in coordinate units with --crs none) so "
        "that every point is strictly inside, for QGIS 'Count points in polygon' "
        "and within/contains joins; alpha and radius stay those of the optimal "
        "shape, area_m2 is the grown area. 0: the exact shape, whose vertices are "
        "input points.",
    )
    overlap: str = option(
        "keep",
        choices=OVERLAPS,
        doc='Where groups\' hulls overlap: ``"keep"`` the overlaps (each group\n'
        'hulled on its own), ``"split"`` them: each part of an overlap goes to the\n'
        "group of the nearest input point, so that the hulls are interior-disjoint\n"
        "and every point is strictly inside no other group's hull (adds the\n"
        "columns ``area_ceded_m2`` and ``neighbours``; :doc:`/user_guide/neighbours`).",
        help="Where the hulls of groups overlap: keep the overlaps, or split each "
        "overlap between the groups by nearest input point (the hulls then do not "
        "overlap, every point stays in its own group's hull and strictly inside no "
        "other); split adds the columns area_ceded_m2 and neighbours.",
    )

    def __post_init__(self) -> None:
        for field in FIELDS:
            value = getattr(self, field.name)
            if value is field.default:  # checked once (tests/test_options.py)
                continue
            value = field.metadata["meta"].check(field.name, value)
            object.__setattr__(self, field.name, value)
        if self.outliers and self.method != "alpha":
            raise InvalidInputError(
                f"outliers applies to {setting('method', 'alpha')}; got "
                f"{setting('method', self.method)}"
            )
        if self.outliers and (self.alpha is not None or self.search != "exact"):
            raise InvalidInputError(
                "outliers applies to the exact optimum: use it without alpha and "
                f"with {setting('search', 'exact')}; got "
                f"{setting('alpha', self.alpha)}, {setting('search', self.search)}"
            )

    def request(self, **asked: Any) -> Request:
        """Return what the kernel is asked for these options (``asked``: more).

        Examples
        --------
        >>> Options(holes=True, outliers=2).request(explain=True).budget_kind
        'count'
        """
        return Request(
            holes=self.holes,
            components=self.components,
            outliers=self.outliers,
            outlier_unit=self.outlier_unit,
            n_jobs=self.n_jobs,
            search=self.search,
            max_iterations=self.max_iterations,
            **asked,
        )

    @classmethod
    def from_kwargs(cls, kwargs: Mapping[str, Any], caller: str = "hull()") -> Options:
        """Check ``kwargs`` (unknown names are an error) and build the options."""
        unknown = sorted(set(kwargs) - set(NAMES))
        if unknown:
            raise InvalidInputError(
                f"{caller} got unknown option(s) {', '.join(unknown)}; the options "
                f"are {first_n(NAMES, limit=len(NAMES))}"
            )
        return cls(**kwargs)


@dataclasses.dataclass(frozen=True)
class Request:
    """What the kernel computes for every group: one value, passed down whole.

    Built by :meth:`Options.request` (or by the array API from its checked
    arguments); :func:`geoalpha._core.solve` hands it to the compiled kernel,
    which reads its attributes (``src/lib.rs``, ``Request``).

    Attributes
    ----------
    holes, components, outliers, outlier_unit, n_jobs, search, max_iterations
        As the options of :func:`geoalpha.hull` (checked).
    alpha : float or ndarray of shape (G,), optional
        A given alpha (>= 0; one for every group, or one per group) instead of
        the optimum; None: the optimum (``search`` finds it).
    sphere : bool
        Longitudes/latitudes computed on the sphere.
    curve : bool
        Also the validity curves (``search="ladder"``/``"bisect"``).
    explain : bool
        Also why: the critical triangle, ``limited_by``, the points covered last.
    max_left_out : int
        Also the outlier optima for ``k = 1 .. max_left_out`` (the curve).
    left_out_unit : str
        What those ``k`` count (``"rows"`` or ``"locations"``).
    suspicious_factor : float
        Flag groups whose radius one left-out location divides by at least
        this factor (0: no check).

    Examples
    --------
    >>> Request(outliers=0.2, outlier_unit="locations").fraction
    0.2
    """

    holes: bool = False
    components: int = 1
    outliers: int | float = 0
    outlier_unit: str = "rows"
    n_jobs: int | None = None
    search: str = "exact"
    max_iterations: int = 10_000
    alpha: Any = None  # float | ndarray | None (a per-group array: not hashed)
    sphere: bool = False
    curve: bool = False
    explain: bool = False
    max_left_out: int = 0
    left_out_unit: str = "locations"
    suspicious_factor: float = 0.0

    @property
    def budget_kind(self) -> str:
        """``"none"``, ``"count"`` (an int per group) or ``"fraction"``."""
        if not self.outliers:
            return "none"
        return "count" if isinstance(self.outliers, numbers.Integral) else "fraction"

    @property
    def fraction(self) -> float:
        """``outliers`` as a fraction of each group's rows or locations (else 0)."""
        return float(self.outliers) if self.budget_kind == "fraction" else 0.0

    @property
    def locations(self) -> bool:
        """``outliers`` counts locations."""
        return self.outlier_unit == "locations"

    @property
    def left_out_locations(self) -> bool:
        """The alternatives (``max_left_out``) leave out locations."""
        return self.left_out_unit == "locations"


#: The ``kind`` of an option by its annotation (strings: PEP 563).
_KINDS = {"bool": "bool", "int": "int", "float": "float", "int | float": "number"}


def _completed(fields: tuple[dataclasses.Field, ...]) -> tuple[dataclasses.Field, ...]:
    """Give each field's :class:`OptionMeta` its kind, default flag and type line."""
    for f in fields:
        meta = f.metadata["meta"]
        if not meta.kind:  # OptionMeta is frozen for its users; completed here, once
            kind = "choice" if meta.choices else _KINDS[f.type.removesuffix(" | None")]
            object.__setattr__(meta, "kind", kind)
        dashed = f.name.replace("_", "-")
        flag = f"--{dashed}/--no-{dashed}" if meta.kind == "bool" else f"--{dashed}"
        kind = {"number": "float or int", "crs": '"auto", "sphere", CRS or None'}
        if meta.choices:
            kind[meta.kind] = "{" + ", ".join(f'"{c}"' for c in meta.choices) + "}"
        default = "optional" if f.default is None else f"default {f.default!r}"
        default = default.replace("'", '"')  # numpydoc's quotes: default "auto"
        doc = f"{kind.get(meta.kind, meta.kind)}, {default}\n    "
        object.__setattr__(meta, "flags", meta.flags or (flag,))
        object.__setattr__(meta, "doc", doc + meta.doc.replace("\n", "\n    "))
    return fields


#: The fields of :class:`Options`, in signature order.
FIELDS: tuple[dataclasses.Field, ...] = _completed(dataclasses.fields(Options))
#: The option names, in signature order.
NAMES: tuple[str, ...] = tuple(f.name for f in FIELDS)
#: The :class:`OptionMeta` of every option, by name.
META: dict[str, OptionMeta] = {f.name: f.metadata["meta"] for f in FIELDS}


def check(**values: Any) -> dict[str, Any]:
    """Check some options on their own (for the array API), as hull() does.

    Parameters
    ----------
    **values
        Option names and their values.

    Returns
    -------
    dict
        The values, normalised (``numpy.True_`` -> ``True``, ...).

    Raises
    ------
    InvalidInputError
        Naming the first option whose value is not allowed.

    Examples
    --------
    >>> check(holes=True, components=2)
    {'holes': True, 'components': 2}
    >>> check(search="fast")
    Traceback (most recent call last):
    ...
    geoalpha.errors.InvalidInputError: search must be one of 'exact', 'ladder', \
'bisect'; got 'fast'
    """
    unknown = sorted(set(values) - set(NAMES))
    if unknown:
        raise TypeError(f"not options of hull(): {', '.join(unknown)}")
    return {name: META[name].check(name, value) for name, value in values.items()}


def defaults(*names: str) -> dict[str, Any]:
    """Return the defaults of the named options (all when none is named).

    Parameters
    ----------
    *names : str

    Returns
    -------
    dict
        Option name -> default, in signature order.

    Examples
    --------
    >>> defaults("search", "max_iterations")
    {'search': 'exact', 'max_iterations': 10000}
    """
    return {f.name: f.default for f in FIELDS if not names or f.name in names}


def signature(func: Callable) -> inspect.Signature:
    """Return the signature of ``func(..., **options)`` with the options spelled out."""
    params = list(inspect.signature(func).parameters.values())
    fixed = [p for p in params if p.kind is not inspect.Parameter.VAR_KEYWORD]
    fixed += [
        inspect.Parameter(
            f.name, inspect.Parameter.KEYWORD_ONLY, default=f.default, annotation=f.type
        )
        for f in FIELDS
        if f.name not in {p.name for p in fixed}
    ]
    return inspect.Signature(fixed)


def docstring(template: str, indent: str = "    ") -> str:
    """Fill ``{options}`` in ``template`` with the numpydoc entries of the options."""
    entries = "\n".join(f"{name} : {meta.doc}" for name, meta in META.items())
    return template.replace("{options}", entries.replace("\n", "\n" + indent))
