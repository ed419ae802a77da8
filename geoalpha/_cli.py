"""The ``geoalpha`` command: one tight polygon per group of points, file to file.

A click group as rasterio's ``rio``; heavy imports inside the commands, so that
``geoalpha --help`` stays fast. Errors and warnings: see ``docs/cli.md``.
"""

from __future__ import annotations

import contextlib
import functools
import glob
import logging
import os
import sys
import traceback
import warnings
from collections.abc import Iterator
from pathlib import Path

import click

from geoalpha._frame.schema import RESULT_COLUMNS
from geoalpha._io.postgis import is_postgres_url
from geoalpha._io.redact import redact, secrets_in
from geoalpha._options import META, defaults
from geoalpha.datasets import DATASETS
from geoalpha.errors import FLAGS, GeoAlphaError, InvalidInputError, did_you_mean

__all__ = ["main"]

_CONTEXT = {"help_option_names": ["-h", "--help"], "max_content_width": 88}
# Errors whose message is written for the user; anything else is reported
# with its type and a hint to rerun with -v.
_EXPECTED = (GeoAlphaError, OSError, ImportError)
_LOG_FORMAT = logging.Formatter(logging.BASIC_FORMAT)


class _RedactingHandler(logging.Handler):
    """Log records to the current stderr (tests swap it), without credentials."""

    def emit(self, record: logging.LogRecord) -> None:
        try:
            sys.stderr.write(redact(_LOG_FORMAT.format(record)) + "\n")
        except Exception:  # as logging.StreamHandler does
            self.handleError(record)


def _configure_logging(verbosity: int) -> None:
    root = logging.getLogger()
    if not any(isinstance(h, _RedactingHandler) for h in root.handlers):
        root.addHandler(_RedactingHandler())
    root.setLevel(max(10, 30 - 10 * verbosity))


def _secrets() -> list[str]:
    """Secret values in the command's arguments (passwords of INPUT, ...)."""
    found: set[str] = set()
    ctx = click.get_current_context(silent=True)
    while ctx is not None:
        for value in ctx.params.values():
            for item in value if isinstance(value, tuple | list) else [value]:
                if isinstance(item, str):
                    found.update(secrets_in(item))
        ctx = ctx.parent
    return sorted(found, key=len, reverse=True)


def _flags(command: click.Command) -> dict[str, str]:
    """Return the command's flag of each option of hull() and its own (``FLAGS``)."""
    own = {
        p.name: "/".join(p.opts[-1:] + p.secondary_opts[-1:])
        for p in command.params
        if isinstance(p, click.Option) and p.name
    }
    return {"hull()": "geoalpha", **{n: m.flags[-1] for n, m in META.items()}, **own}


@contextlib.contextmanager
def _in_flags() -> Iterator[None]:
    """Let the library name options by the current command's flags (``FLAGS``)."""
    token = FLAGS.set(_flags(click.get_current_context().command))
    try:
        yield
    finally:
        FLAGS.reset(token)


@contextlib.contextmanager
def _reporting(verbosity: int) -> Iterator[None]:
    """Show warnings as ``Warning:`` lines, errors as ``Error:``; no credentials."""
    shown: set[tuple[type, str]] = set()
    secrets = _secrets()

    def clean(text: object) -> str:
        return redact(" ".join(str(text).split()), secrets)

    def show(message, category, filename, lineno, file=None, line=None):
        # none with -q; library deprecations and numpy noise only with -v
        if verbosity < 0 or (verbosity < 1 and not issubclass(category, UserWarning)):
            return
        text = clean(message)
        if (category, text) not in shown:
            shown.add((category, text))
            click.echo(f"Warning: {text}", err=True)

    with warnings.catch_warnings(), _in_flags():
        warnings.simplefilter("always")
        warnings.showwarning = show
        try:
            yield
        except (click.ClickException, click.exceptions.Exit, click.Abort):
            raise
        except Exception as err:
            if verbosity > 0:
                click.echo(redact(traceback.format_exc().rstrip(), secrets), err=True)
            if isinstance(err, _EXPECTED):
                message = clean(err) or type(err).__name__
            else:
                message = (
                    f"{type(err).__name__}: {clean(err)} "
                    "(rerun as 'geoalpha -v ...' for the traceback)"
                )
            raise click.ClickException(message) from None


_verbose_option = click.option(
    "-v", "--verbose", count=True, help="More output: tracebacks on error."
)
_quiet_option = click.option(
    "-q", "--quiet", count=True, help="Less output: errors only."
)


def _print_version(ctx: click.Context, _param, value: bool) -> None:
    """``--version``: the package, its compiled kernel and spade (no numpy import)."""
    if not value or ctx.resilient_parsing:
        return
    from geoalpha import __version__, _kernel

    click.echo(
        f"geoalpha {__version__} (kernel {_kernel.__version__}, "
        f"spade {_kernel.SPADE_VERSION})"
    )
    ctx.exit()


@click.group(context_settings=_CONTEXT)
@click.option(
    "--version",
    is_flag=True,
    expose_value=False,
    is_eager=True,
    callback=_print_version,
    help="Show the version of geoalpha, its kernel and spade, and exit.",
)
@_verbose_option
@_quiet_option
@click.pass_context
def main(ctx: click.Context, verbose: int, quiet: int) -> None:
    """Exact optimal alpha shapes: one tight polygon per group of points.

    For each group of points (accidents by local authority, airports by
    state, ...) geoalpha finds the largest alpha whose alpha shape is one
    polygon containing every point, and writes those polygons to a file
    that QGIS, ArcGIS or geopandas opens.

    \b
    Try it on bundled real data (US airports by state):
        geoalpha demo hulls.gpkg
    then on your own points:
        geoalpha hull accidents.csv hulls.gpkg --by Local_Authority
    """  # noqa: D301
    ctx.obj = {"verbosity": verbose - quiet}
    _configure_logging(verbose - quiet)


def _crs_option(value: str) -> str | None:
    """``none`` (any case) means no CRS."""
    return None if value.strip().lower() == "none" else value


def _group_columns(values: tuple[str, ...], columns, source: str) -> list[str]:
    """Resolve ``--by`` values (repeatable, comma-separated) to columns."""
    by: list[str] = []
    for value in values:
        names = [value] if value in columns else value.split(",")
        by.extend(name.strip() for name in names if name.strip())
    missing = [name for name in by if name not in columns]
    if missing:
        others = [c for c in columns if c != "geometry"]
        hints = "".join(did_you_mean(name, others) for name in missing)
        raise InvalidInputError(
            f"--by column {', '.join(map(repr, missing))} not found in {source}"
            f"{hints}; its columns are: {', '.join(map(str, others))}"
        )
    return by


def _key_names(values: tuple[str, ...]) -> list[str]:
    """Every column name ``--by`` may mean (``a,b`` is a column or two)."""
    names = []
    for value in values:
        names += [value, *(name.strip() for name in value.split(","))]
    return names


#: ``--unit``: metres in one unit of planar coordinates without CRS.
METRES_PER_UNIT = {"m": 1.0, "km": 1000.0, "mi": 1609.344, "ft": 0.3048}


def _in_metres(hulls, factor: float):
    """Return ``hulls`` of planar coordinates with ``factor`` metres a unit, in m."""
    table = hulls.copy()
    area = "area" if "area" in table.columns else "area_m2"  # (m² or unit²)
    table[area] = table[area] * factor**2
    table = table.rename(columns={area: "area_m2"}).drop(
        columns="unit", errors="ignore"
    )
    table["radius"] = table["radius"] * factor
    table["alpha"] = table["alpha"] / factor
    return table


def _input_size(path) -> int | None:
    """Bytes of an input file (or of the files of a folder); None for a database."""
    path = os.fspath(path)
    if os.path.isfile(path):
        return os.path.getsize(path)
    if os.path.isdir(path):
        return sum(e.stat().st_size for e in os.scandir(path) if e.is_file())
    return None


@contextlib.contextmanager
def _session(params: dict, size, points_layer=False, source=None) -> Iterator:
    """Check OUTPUT (flags popped from ``params``); yield :func:`_run` bound to it.

    ``source``: ``(INPUT, its --layer)``, which OUTPUT must not overwrite.
    """
    from geoalpha._frame.progress import HULL_PHASES, hull_costs, phases
    from geoalpha._io.files import check_not_input, check_output

    preview = params.pop("preview")
    explain = params.pop("explain", False)
    target = {k: params.pop(k) for k in ("overwrite", "engine")}
    target |= {"path": params.pop("output"), "layer": params.pop("output_layer")}
    verbose, quiet = params.pop("verbose"), params.pop("quiet")  # after the command
    root = click.get_current_context().find_root()
    verbosity = (root.obj or {}).get("verbosity", 0) + verbose - quiet
    if verbose or quiet:
        _configure_logging(verbosity)
    if params["progress"] is None and verbosity < 0:
        params["progress"] = False  # -q: no bar (in hull() too) unless --progress

    # Importing geopandas (read) and matplotlib (preview) takes about a second.
    load = {m: 0 if m in sys.modules else 800_000 for m in ("geopandas", "matplotlib")}

    def after_hull(n_rows: float, n_groups: float) -> dict:
        """Estimated microseconds (as hull_costs), measured on the demo data."""
        return {
            "write": 20_000 + 15 * n_groups + (5 * n_rows if points_layer else 0),
            "preview": load["matplotlib"] + 100_000 + 5 * n_rows + 400 * n_groups,
        }

    names = ("read", *HULL_PHASES, "write")
    names += ("preview",) if preview is not None else ()
    with (
        _reporting(verbosity),
        phases(names, params["progress"], costs=after_hull) as bar,
    ):
        rows = size / 50 if size else 100_000  # a guess until INPUT is read
        costs = hull_costs(rows, rows / 100, per_group_crs=False)
        costs["read"] = load["geopandas"] + (0.04 * size if size else 2 * rows)
        bar.estimate(costs | after_hull(rows, rows / 100))
        if source is not None:
            check_not_input(target["path"], target["layer"], *source)
        sides = _explain_targets(target, params, points_layer) if explain else None
        check_output(
            target["path"], layer=target["layer"], overwrite=target["overwrite"]
        )
        bar.start("read")
        _check_preview(preview)
        yield functools.partial(_run, target, preview, verbosity, bar, sides)


#: The layers of ``--explain`` (``docs/cli.md``): explain()'s critical
#: triangles and the rows left out by --outliers.
EXPLAIN_LAYERS = ("why", "left_out")


def _explain_targets(target: dict, params: dict, points_layer: bool) -> dict:
    """Check, before computing, where ``--explain`` writes its two layers.

    Return ``{layer: path}``: OUTPUT itself for a GeoPackage (new layers in
    it), else ``<stem>_why<ext>`` and ``<stem>_left_out<ext>`` beside it, each
    checked as OUTPUT is (refused if it exists, without ``--overwrite``).
    """
    from geoalpha._io.files import check_output

    if params.get("method", "alpha") != "alpha":
        raise InvalidInputError(
            "--explain explains the optimal alpha shape: use it with --method "
            f"alpha (the default); got --method {params['method']}"
        )
    path = target["path"]
    if is_postgres_url(path):
        raise InvalidInputError(
            "--explain writes its layers 'why' and 'left_out' to files only, not "
            "to PostGIS: write a GeoPackage (.gpkg) OUTPUT, or run without --explain"
        )
    if path.lower().endswith(".gpkg"):
        layer = target["layer"] or Path(path).stem or "hulls"
        taken = {layer, "points"} if points_layer else {layer}
        clash = sorted(taken & set(EXPLAIN_LAYERS))
        if clash:
            raise InvalidInputError(
                f"--explain writes the layers 'why' and 'left_out' beside the "
                f"hulls' layer {clash[0]!r}: name the hulls' layer otherwise with "
                "--output-layer (or OUTPUT's file name)"
            )
        return dict.fromkeys(EXPLAIN_LAYERS, path)
    base = Path(path)
    sides = {
        n: str(base.with_name(f"{base.stem}_{n}{base.suffix}")) for n in EXPLAIN_LAYERS
    }
    for side in sides.values():
        check_output(side, overwrite=target["overwrite"])
    return sides


def _explain_frames(why, points, left_out, metres: str | None) -> dict:
    """Return the ``why`` and ``left_out`` layers as files can hold them.

    With a planar unit, explain()'s area column is ``area_without_1`` and
    ``unit`` says it (as the hulls' ``area``); with ``--unit`` (``metres``)
    the radii, alpha and area are in metres, as the hulls.
    """
    why = why.copy()
    if metres is not None:
        factor = METRES_PER_UNIT[metres]
        for column in ("radius", "radius_without_1"):
            why[column] = why[column] * factor
        why["alpha"] = why["alpha"] / factor
        planar = "area_without_1" in why.columns  # (--unit: no CRS, so always)
        area = "area_without_1" if planar else "area_m2_without_1"
        why["area_m2_without_1"] = why.pop(area) * factor**2
        why = why.drop(columns="unit", errors="ignore")
        # back in explain()'s order: the area after radius_without_1
        order = [c for c in why.columns if c != "area_m2_without_1"]
        order.insert(order.index("radius_without_1") + 1, "area_m2_without_1")
        why = why[order]
    for column in ("critical_rows", "rows_without_1"):  # lists of labels: text
        why[column] = [", ".join(map(str, labels)) for labels in why[column]]
    return {"why": why, "left_out": points[left_out.to_numpy()]}


def _write_explained(target: dict, sides: dict, layers: dict, created: list) -> dict:
    """Write ``--explain``'s files beside OUTPUT; return each one's renamed fields.

    Each file is written atomically (as OUTPUT); the ones this run creates
    are added to ``created``, for :func:`_remove_created` should a later
    write fail.
    """
    from geoalpha._io.files import write_hulls

    mappings = {}
    for name, path in sides.items():
        new = not Path(path).exists()
        mappings[name] = write_hulls(
            layers[name], path, overwrite=target["overwrite"], engine=target["engine"]
        )
        if new:
            created.append(Path(path))
    return mappings


def _remove_created(created: list[Path]) -> None:
    """Remove the files (a Shapefile with its sidecars) a failed run created."""
    for path in created:
        for file in path.parent.glob(f"{glob.escape(path.stem)}.*"):
            if file.suffix.lower() in _SIDECARS:
                file.unlink(missing_ok=True)


#: The extensions of a file :func:`_remove_created` removes (with its sidecars).
_SIDECARS = {".shp", ".shx", ".dbf", ".prj", ".cpg", ".geojson", ".fgb", ".parquet"}


def _flagged(why, by: list[str]) -> str:
    """``"3 groups flagged as suspicious: 'HI', 'AK', ..."``, or ``""``."""
    from geoalpha.errors import first_n

    flagged = why[why["suspicious"].to_numpy(dtype=bool)]
    if flagged.empty:
        return ""
    if len(by) == 1:
        names = [repr(v) for v in flagged[by[0]].tolist()]
    elif by:
        names = [str(v) for v in flagged[by].itertuples(index=False, name=None)]
    else:
        names = ["all points"]
    return (
        f"{_plural(len(flagged), 'group')} flagged as suspicious (one location "
        f"forces the shape far beyond the others; see the layer 'why'): "
        f"{first_n(names)}"
    )


def _plural(n: int, noun: str) -> str:
    return f"{n:,} {noun}{'s' if n != 1 else ''}"


def _left_out(points, hulls, by: list[str], options: dict) -> str:
    """``"; 12 of 3,376 rows left out: 12 without a --by value ..."``, or ``""``."""
    from geoalpha._frame.pipeline import row_report

    left = len(points) - int(hulls["n_points"].sum())
    if left <= 0:
        return ""
    dropna, vertices = options.get("dropna", True), bool(options.get("vertices"))
    counts = row_report(points, by, dropna=dropna, vertices=vertices).counts
    dropped = left - counts["missing"] - counts["no_key"]
    reasons = [
        (counts["missing"], "without a point (a missing, empty or NaN geometry)"),
        (counts["no_key"], "without a --by value (--no-dropna keeps them)"),
        (dropped, "in groups without alpha shape (--degenerate drop)"),
    ]
    shown = ", ".join(f"{n:,} {why}" for n, why in reasons if n > 0)
    return f"; {left:,} of {len(points):,} rows left out: {shown}"


def _summary(
    points, hulls, source: str, by: list[str], options: dict, unit, metres=None
) -> list:
    """Return a few lines that say what was read, computed and found."""
    import numpy as np
    import shapely

    from geoalpha._crs_parsing import crs_name

    columns = points.attrs.get("geoalpha_coordinates")
    where = f"columns {columns[0]}/{columns[1]}" if columns else "geometries"
    if points.attrs.get("geoalpha_layer") is not None:  # chosen: the point layer
        where = f"layer {points.attrs['geoalpha_layer']!r}, the only point layer"
    in_crs = crs_name(points.crs) if points.crs is not None else "no CRS"
    used = hulls["crs_used"].astype(str).unique().tolist()
    shown = used[0] if len(used) == 1 else f"{len(used)} CRSs (one chosen per group)"
    if len(used) == 2:
        shown += f" ({used[0]}, {used[1]})"
    if metres is not None:
        shown = (
            f"the input coordinates, in {metres} (--unit {metres}), written in "
            "metres (alpha in 1/metre, radius in metres, area_m2)"
        )
    elif options.get("crs", "auto") is None:
        u = unit or "metre"
        shown = (
            f"the input coordinates as they are (alpha in 1/{u}, radius in {u}, "
            f"area in square {u})"
        )
    method = hulls["method"].astype(str)  # degenerate rows: "buffer" (or kept)
    no_shape = hulls["alpha"].isna() & method.isin(["alpha", "buffer"])
    lines = [
        f"Read {_plural(len(points), 'point')} of {source} ({where}, {in_crs})",
        f"Computed in {shown}: {_plural(len(hulls), 'group')}"
        + (f", {no_shape.sum():,} without alpha shape" if no_shape.any() else "")
        + _left_out(points, hulls, by, options),
    ]
    shaped = ~no_shape
    geoms = np.asarray(hulls.geometry.array, dtype=object)[shaped.to_numpy()]
    facts = []
    radius = hulls.loc[shaped, "radius"].to_numpy(dtype=float)
    radius = radius[np.isfinite(radius)]
    if radius.size:
        middle = float(np.median(radius))
        if unit is None and middle >= 10_000:
            facts.append(f"median radius {middle / 1000:,.0f} km")
        else:
            facts.append(f"median radius {middle:,.4g} {unit or 'm'}")
    if geoms.size:
        with np.errstate(invalid="ignore", divide="ignore"):
            share = shapely.area(geoms) / shapely.area(shapely.convex_hull(geoms))
        share = share[np.isfinite(share)]
        if share.size:
            facts.append(f"median area {np.median(share):.0%} of the convex hull")
    if facts:
        lines.append(facts[0][0].upper() + "; ".join(facts)[1:])
    return lines


def _run(
    target,
    preview,
    verbosity,
    bar,
    sides,
    points,
    *,
    source,
    by,
    extra_layers=None,
    metres=None,
    **options,
):
    """Compute the hulls (in the command's ``bar``), write them, draw ``preview``.

    With ``sides`` (``--explain``: :func:`_explain_targets`) also explain()'s
    table and the rows left out, from the same run.
    """
    from geoalpha._frame.schema import planar_unit, with_area_unit
    from geoalpha._io.files import write_hulls

    key = None if not by else by[0] if len(by) == 1 else by
    if sides is None:
        from geoalpha._hulls import hull

        hulls, explained = hull(points, by=key, **options), None
    else:
        from geoalpha._hulls import hull_and_why

        hulls, why, left_out = hull_and_why(points, by=key, **options)
    if len(hulls) == 0:
        raise InvalidInputError(
            f"no hull to write: every group of {source} was dropped"
        )
    unit = planar_unit(points.crs, options.get("crs", "auto"))
    if metres is not None:  # --unit: planar numbers in a known unit
        hulls = _in_metres(hulls, METRES_PER_UNIT[metres])
        unit = None
    if sides is not None:
        explained = _explain_frames(why, points, left_out, metres)
    table = with_area_unit(hulls, unit)  # say the unit instead of a wrong "m2"
    bar.start("write")
    mappings, created = {}, []
    try:
        if explained is not None and target["path"].lower().endswith(".gpkg"):
            extra_layers = {**(extra_layers or {}), **explained}
        elif explained is not None:
            mappings = _write_explained(target, sides, explained, created)
        mapping = write_hulls(table, **target, extra_layers=extra_layers)
    except BaseException:
        _remove_created(created)  # nothing half-written stays behind
        raise
    output, layer = target["path"], target["layer"]
    if preview is not None:
        bar.start("preview")
        _write_preview(hulls, points, preview, by)
    bar.close()  # full, before the summary
    if verbosity < 0:
        return
    for line in _summary(points, hulls, source, by, options, unit, metres):
        click.echo(line)  # the summary on stdout; warnings and errors on stderr
    if explained is not None and options.get("suspicious", True) and _flagged(why, by):
        click.echo(_flagged(why, by))
    for old, new in mapping.items():
        click.echo(f"Shapefile field {old!r} written as {new!r}")
    for name, renamed in mappings.items():
        for old, new in renamed.items():
            click.echo(f"Shapefile field {old!r} of {name!r} written as {new!r}")
    where = redact(output)
    if is_postgres_url(output):
        where += f" (table {layer})"
    elif output.lower().endswith(".gpkg"):
        where += f" (layer {layer or Path(output).stem or 'hulls'!r}"
        where += "".join(f", {name!r}" for name in extra_layers or ()) + ")"
    rows = int(hulls["n_points"].sum())  # the points in the hulls' groups
    click.echo(
        f"Wrote {_plural(len(hulls), 'hull')} of {_plural(rows, 'point')} to "
        f"{redact(where)}"
    )
    if explained is not None:
        shown = " and ".join(
            f"{_plural(len(explained[n]), 'row')} to "
            + (f"layer {n!r}" if sides[n] == output else redact(sides[n]))
            for n in EXPLAIN_LAYERS
        )
        click.echo(f"Wrote --explain: {shown}")
    if preview is not None:
        click.echo(f"Wrote a preview to {preview}")


def _check_preview(path: str | None) -> None:
    """Check, before computing, that --preview can be written."""
    if path is None:
        return
    target = Path(path)
    if target.suffix.lower() not in (".png", ".svg", ".pdf", ".jpg", ".jpeg"):
        raise InvalidInputError(
            f"--preview needs a .png, .svg, .pdf or .jpg file name; got {path}"
        )
    if not target.parent.is_dir():
        raise FileNotFoundError(f"preview directory {target.parent} does not exist")
    try:
        import matplotlib  # noqa: F401
    except ImportError as err:
        raise ImportError(
            '--preview needs matplotlib: pip install "geoalpha[plot]"'
        ) from err


def _write_preview(hulls, points, path: str, by: list[str]) -> None:
    """Draw the hulls over the points, one colour per group."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 8), dpi=100)
    try:
        # Readable from a few points to many (42k): the points shrink and fade
        # as they grow in number, under the hulls' fill; the outlines on top.
        n = max(len(points), 1)
        colours = [plt.get_cmap("tab20")(i % 20) for i in range(len(hulls))]
        points.plot(
            ax=ax,
            color="0.15",
            markersize=min(2.0, max(0.1, 2000 / n)),
            alpha=0.7 if n <= 5000 else 0.5,
            linewidth=0,
            zorder=1,
            rasterized=True,
        )
        hulls.plot(ax=ax, color=colours, alpha=0.45, linewidth=0, zorder=2)
        hulls.boundary.plot(ax=ax, color=colours, linewidth=0.9, zorder=3)
        ax.set_title(
            f"{len(hulls):,} hulls of {len(points):,} points"
            + (f" by {', '.join(by)}" if by else "")
        )
        fig.savefig(path, bbox_inches="tight")
    finally:
        plt.close(fig)


def _parsed(kind: str, text):
    """Return a flag's text as its check takes it: a number, None for ``none``."""
    if not isinstance(text, str):
        return text  # a default
    if kind == "crs":
        return _crs_option(text)
    if kind in ("int", "float", "number"):  # an integer is a count (--outliers 3)
        for number in (int, float):
            with contextlib.suppress(ValueError):
                return number(text)
    return text


def _checked(ctx: click.Context, param: click.Parameter, value):
    """Check a flag's value at the flag, by its option's check in options.py."""
    meta = META[param.name]
    try:
        with _in_flags():
            return meta.check(param.name, _parsed(meta.kind, value))
    except InvalidInputError as err:
        raise click.BadParameter(str(err), ctx, param) from None


def _options(*names: str):
    """Add the click options of hull()'s ``names`` (all if none), from ``META``."""

    def decorate(command):
        for name in reversed(names or tuple(META)):
            meta = META[name]
            if meta.kind == "bool":  # a switch, or a flag alone (--vertices)
                typed = {"is_flag": "/" not in meta.flags[-1] or None}
            else:
                choices = f"[{'|'.join(meta.choices)}]" if meta.choices else None
                metavar = meta.metavar or choices or meta.kind.upper()
                typed = {"type": click.STRING, "callback": _checked, "metavar": metavar}
            command = click.option(
                *meta.flags,
                name,
                default=defaults(name)[name],
                show_default=True,
                help=meta.help,
                **typed,
            )(command)
        return command

    return decorate


_engine_option = click.option(
    "--engine",
    type=click.Choice(["pyogrio", "fiona"]),
    default=None,
    help="Library that writes the file [default: geopandas' choice].",
)
_overwrite_option = click.option(
    "--overwrite",
    is_flag=True,
    help="Replace OUTPUT if it exists; in a GeoPackage, only the layer written "
    "(its other layers are kept).",
)
_explain_option = click.option(
    "--explain",
    is_flag=True,
    help="Also write why each group got its radius (layer 'why': the critical "
    "triangles, as geoalpha.explain()) and the rows --outliers left out (layer "
    "'left_out'): into a GeoPackage OUTPUT, else beside it as "
    "<OUTPUT>_why and <OUTPUT>_left_out.",
)
_preview_option = click.option(
    "--preview",
    metavar="IMAGE",
    type=click.Path(dir_okay=False),
    help="Also draw the hulls over the points to IMAGE (.png, .svg, .pdf; "
    'needs pip install "geoalpha[plot]").',
)


@main.command(context_settings=_CONTEXT)
@click.argument(
    "input_path", metavar="INPUT", type=click.Path(dir_okay=True, readable=False)
)
@click.argument("output", type=click.Path(dir_okay=False))
@click.option(
    "--by",
    multiple=True,
    metavar="COL[,COL...]",
    help="Column(s) whose values form the groups: one hull per group. "
    "Without --by, one hull of all points.",
)
@click.option(
    "--x",
    metavar="COLUMN",
    help="CSV column of x coordinates (longitude) [default: detect "
    "longitude, lon, lng, long, x, easting].",
)
@click.option(
    "--y",
    metavar="COLUMN",
    help="CSV column of y coordinates (latitude) [default: detect "
    "latitude, lat, y, northing].",
)
@click.option(
    "--crs-in",
    metavar="auto|CRS|none",
    default="auto",
    show_default=True,
    help="CRS of the coordinates of a CSV, or of a file that has none, e.g. "
    "EPSG:27700 for British National Grid. 'auto' never guesses: CSV columns "
    "named longitude/latitude (lon/lat, ...) are EPSG:4326, a file keeps its "
    "own CRS, anything else without a CRS is an error. 'none': planar "
    "coordinates without CRS (alpha, radius and area are then in their unit).",
)
@click.option(
    "--unit",
    type=click.Choice(sorted(METRES_PER_UNIT)),
    help="Unit of planar coordinates without CRS (--crs-in none), e.g. km: "
    "the output then has area_m2, radius in metres and alpha in 1/metre, and "
    "--grow, --buffer and --alpha are in metres too.",
)
@click.option(
    "--layer",
    metavar="NAME",
    help="Layer of INPUT to read (GeoPackage etc.) [default: the only layer, "
    "or the only point layer; else an error names the layers]; the "
    "schema.table of a postgresql:// INPUT.",
)
@click.option(
    "--sql",
    metavar="QUERY",
    help="For a postgresql:// INPUT: read the result of this SELECT "
    "(read-only) instead of a --layer.",
)
@click.option(
    "--geometry-column",
    metavar="COLUMN",
    help="For a postgresql:// INPUT: the geometry column, when there is more "
    "than one [default: the only one].",
)
@click.option(
    "--output-layer",
    metavar="NAME",
    help="Layer name in a GeoPackage OUTPUT [default: OUTPUT's file name], "
    "added beside the layers an existing GeoPackage has; the schema.table to "
    "create for a postgresql:// OUTPUT.",
)
@_options()
@_overwrite_option
@_engine_option
@_explain_option
@_preview_option
@_verbose_option
@_quiet_option
def hull(
    input_path: str, by: tuple[str, ...], crs_in: str, unit: str | None, **options
) -> None:
    """Write one hull per group of the points in INPUT to OUTPUT.

    INPUT is a GeoPackage, Shapefile, GeoJSON, FlatGeobuf, GeoParquet or
    any other vector file GDAL reads, or a CSV file with coordinate columns
    (found by name, or named with --x/--y). The CRS is never guessed: a file
    keeps its own, columns named as longitude/latitude are EPSG:4326, and
    anything else needs --crs-in (a CRS, or none for planar numbers). INPUT
    may also be a PostGIS database, postgresql://user@host:port/dbname, with
    --layer schema.table or --sql "SELECT ..." (the password from PGPASSWORD
    or ~/.pgpass).

    OUTPUT's extension chooses its format: .gpkg, .shp, .geojson, .fgb or
    .parquet; a postgresql:// URL with --output-layer schema.table writes a
    PostGIS table (in one transaction; --overwrite replaces it). It holds one
    row per group: the --by columns, RESULT_COLUMNS, and the polygon, in
    INPUT's CRS (with planar input, area and unit instead of area_m2).
    Shapefile field names are cut to 10 characters; GeoPackages are version
    1.2. A short summary of what was read and computed follows the run.

    \b
    Examples:
        geoalpha hull accidents.csv hulls.gpkg --by Local_Authority
        geoalpha hull trees.shp hulls.shp --by species --holes
        geoalpha hull pts.csv out.fgb --x E --y N --crs-in EPSG:27700 --by zone
        geoalpha hull postgresql://ga@localhost/gis postgresql://ga@localhost/gis
            --layer public.trees --by species --output-layer public.tree_hulls
    """  # noqa: D301
    from geoalpha._io.files import read_input_points

    source = (input_path, options["layer"])
    with _session(options, _input_size(input_path), source=source) as run:
        work_crs = options["crs"]  # checked at the flag: none is None
        reading = {
            k: options.pop(k) for k in ("x", "y", "layer", "sql", "geometry_column")
        }
        # --crs none on input without CRS: planar, as --crs-in none would be.
        # A --by column of a CSV is text: a key is a label (zip 00501 stays).
        points = read_input_points(
            input_path,
            crs=_crs_option(crs_in),
            planar_if_missing=work_crs is None,
            text=_key_names(by),
            **reading,
        )
        if points.crs is None:
            work_crs = None  # planar input: compute in its own units
        if unit is not None and points.crs is not None:
            raise InvalidInputError(
                f"--unit {unit} applies to planar coordinates without CRS "
                f"(--crs-in none); {redact(input_path)} has a CRS, whose unit is "
                "used"
            )
        if unit is not None:  # metres (--grow, --buffer, --alpha) in the unit
            factor = METRES_PER_UNIT[unit]
            for name in ("grow", "buffer"):
                if options.get(name) is not None:
                    options[name] = options[name] / factor
            if options.get("alpha") is not None:
                options["alpha"] = options["alpha"] * factor
        columns = _group_columns(by, list(points.columns), redact(input_path))
        run(
            points,
            source=redact(input_path),
            by=columns,
            metres=unit,
            **options | {"crs": work_crs},
        )


_UNITS = {"alpha": " (1/metre)", "radius": " (metres)"}
hull.help = hull.help.replace(
    "RESULT_COLUMNS", ", ".join(c + _UNITS.get(c, "") for c in RESULT_COLUMNS)
)


@main.command(context_settings=_CONTEXT)
@click.argument("output", type=click.Path(dir_okay=False))
@click.option(
    "--dataset",
    type=click.Choice(sorted(DATASETS)),
    default="us_airports",
    show_default=True,
    help="Bundled dataset to use.",
)
@_options("grow")
@_overwrite_option
@_engine_option
@_options("progress")
@_explain_option
@_preview_option
@_verbose_option
@_quiet_option
def demo(dataset: str, **params) -> None:
    """Write the optimal hulls of a bundled real dataset to OUTPUT.

    A first run that needs no data of your own; open OUTPUT in QGIS. A
    GeoPackage OUTPUT holds two layers: the hulls (named after the file) and
    the input points ('points').

    \b
    Datasets (grouped by the column in brackets):
      us_airports  3,376 US airports by state [state]: hulls the size of
                   states, visible at once
      uk_clusters  15,255 UK road accidents 2013-2016 in 691 DBSCAN
                   clusters [Cluster]: hulls 50-300 m across, zoom in on
                   a town to see them
      stats19      1,017 UK road accidents of 2014 by highway local
                   authority [Local_Authority_(Highway)]

    \b
    Example:
        geoalpha demo hulls.gpkg
        geoalpha demo accidents.shp --dataset uk_clusters
    """  # noqa: D301
    from geoalpha import datasets

    gpkg = params["output"].lower().endswith(".gpkg")
    params["output_layer"] = None  # the hulls' layer is named after the file
    with _session(params, _input_size(datasets.path(dataset)), gpkg) as run:
        points = datasets.load(dataset)
        run(
            points,
            source=f"dataset {dataset}",
            by=[DATASETS[dataset][3]],
            extra_layers={"points": points} if gpkg else None,
            **params,  # grow and progress
        )
