"""The ``geoalpha`` command: one tight polygon per group of points, file to file.

Modelled on rasterio's ``rio``: a click group with ``--version`` and
``-v/-q``, one function per subcommand, heavy imports (geopandas, the
computation) inside the commands so that ``geoalpha --help`` stays fast.

Errors on bad input end the command with exit status 1 and one line on
stderr, ``Error: ...``; ``geoalpha -v`` adds the traceback. Warnings are
shown as one ``Warning: ...`` line each unless ``-q``.
"""

from __future__ import annotations

import contextlib
import logging
import sys
import traceback
import warnings
from collections.abc import Iterator

import click

from geoalpha import __version__
from geoalpha.datasets import DATASETS
from geoalpha.errors import GeoAlphaError, InvalidInputError
from geoalpha.options import FIELDS, NAMES, OptionMeta

__all__ = ["main"]

_CONTEXT = {"help_option_names": ["-h", "--help"], "max_content_width": 88}
# Errors whose message is written for the user; anything else is reported
# with its type and a hint to rerun with -v.
_EXPECTED = (GeoAlphaError, OSError, ImportError)


def _configure_logging(verbosity: int) -> None:
    logging.basicConfig(stream=sys.stderr, level=max(10, 30 - 10 * verbosity))


def _one_line(text: object) -> str:
    return " ".join(str(text).split())


@contextlib.contextmanager
def _reporting(verbosity: int) -> Iterator[None]:
    """Show warnings as ``Warning:`` lines and turn errors into ``Error:`` lines."""
    shown: set[tuple[type, str]] = set()

    def show(message, category, filename, lineno, file=None, line=None):
        if verbosity < 0:
            return
        if not issubclass(category, UserWarning) and verbosity < 1:
            return  # library deprecations and numpy noise only with -v
        text = _one_line(message)
        if (category, text) not in shown:
            shown.add((category, text))
            click.echo(f"Warning: {text}", err=True)

    with warnings.catch_warnings():
        warnings.simplefilter("always")
        warnings.showwarning = show
        try:
            yield
        except (click.ClickException, click.exceptions.Exit, click.Abort):
            raise
        except Exception as err:
            if verbosity > 0:
                click.echo(traceback.format_exc().rstrip(), err=True)
            if isinstance(err, _EXPECTED):
                message = _one_line(err) or type(err).__name__
            else:
                message = (
                    f"{type(err).__name__}: {_one_line(err)} "
                    "(rerun as 'geoalpha -v ...' for the traceback)"
                )
            raise click.ClickException(message) from err


def _verbosity() -> int:
    ctx = click.get_current_context()
    return (ctx.find_root().obj or {}).get("verbosity", 0)


@click.group(context_settings=_CONTEXT)
@click.version_option(
    __version__, "--version", prog_name="geoalpha", message="%(prog)s %(version)s"
)
@click.option("-v", "--verbose", count=True, help="More output: tracebacks on error.")
@click.option("-q", "--quiet", count=True, help="Less output: errors only.")
@click.pass_context
def main(ctx: click.Context, verbose: int, quiet: int) -> None:
    """Exact optimal alpha shapes: one tight polygon per group of points.

    For each group of points (accidents by local authority, airports by
    state, ...) geoalpha finds the largest alpha whose alpha shape is one
    polygon containing every point, and writes those polygons to a file
    that QGIS, ArcGIS or geopandas opens.

    \b
    Try it on bundled real data (UK road accident clusters):
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
        found = ", ".join(str(c) for c in columns if c != "geometry")
        raise InvalidInputError(
            f"--by column {', '.join(map(repr, missing))} not found in {source}; "
            f"its columns are: {found}"
        )
    return by


def _run(
    points,
    output: str,
    *,
    source: str,
    by: list[str],
    layer: str | None,
    overwrite: bool,
    engine: str | None,
    verbosity: int,
    **options,
) -> None:
    """Compute the hulls, write them and report what was written."""
    from geoalpha.io import write_hulls
    from geoalpha.tools import hull

    if options.get("progress") is None and verbosity < 0:
        options["progress"] = False
    key = None if not by else by[0] if len(by) == 1 else by
    hulls = hull(points, by=key, **options)
    if len(hulls) == 0:
        raise InvalidInputError(
            f"no hull to write: every group of {source} was dropped"
        )
    mapping = write_hulls(
        hulls, output, layer=layer, overwrite=overwrite, engine=engine
    )
    if verbosity < 0:
        return
    for old, new in mapping.items():
        click.echo(f"Shapefile field {old!r} written as {new!r}", err=True)
    where = output
    if output.lower().endswith(".gpkg"):
        from pathlib import Path

        where += f" (layer {layer or Path(output).stem or 'hulls'!r})"
    count = len(hulls)
    click.echo(
        f"Wrote {count:,} hull{'s' if count != 1 else ''} of {len(points):,} "
        f"points to {where}",
        err=True,
    )


_engine_option = click.option(
    "--engine",
    type=click.Choice(["pyogrio", "fiona"]),
    default=None,
    help="Library that writes the file [default: geopandas' choice].",
)
_overwrite_option = click.option(
    "--overwrite", is_flag=True, help="Replace OUTPUT if it exists."
)


class _Number(click.ParamType):
    """An int when the text is one (``3``), else a float (``0.05``)."""

    name = "number"

    def convert(self, value, param, ctx):
        if not isinstance(value, str):
            return value
        for kind in (int, float):
            try:
                return kind(value)
            except ValueError:
                pass
        self.fail(f"{value!r} is not a number", param, ctx)


_NUMBER = _Number()


def _click_option(name: str, default, meta: OptionMeta):
    """Build the click option of one field of :class:`geoalpha.options.Options`."""
    kwargs: dict = {"help": meta.help, "default": default, "metavar": meta.metavar}
    if meta.kind == "choice":
        kwargs["type"] = click.Choice(meta.choices)
    elif meta.kind == "number":
        kwargs["type"] = _NUMBER
    elif meta.kind in ("int", "float"):
        if meta.low is not None or meta.high is not None:
            ranged = click.IntRange if meta.kind == "int" else click.FloatRange
            kwargs["type"] = ranged(min=meta.low, max=meta.high, min_open=meta.low_open)
        else:
            kwargs["type"] = int if meta.kind == "int" else float
    kwargs["show_default"] = default is not None and not (
        meta.kind == "bool" and "/" not in meta.flags[0]
    )
    return click.option(*meta.flags, name, **kwargs)


#: The click options of every option of ``hull()``, by name.
_OPTIONS = {
    f.name: _click_option(f.name, f.default, f.metadata["meta"]) for f in FIELDS
}


def _hull_options(func):
    """Add the click option of every option of ``hull()`` (see Options)."""
    for name in reversed(NAMES):
        func = _OPTIONS[name](func)
    return func


@main.command(context_settings=_CONTEXT)
@click.argument("input_path", metavar="INPUT", type=click.Path(dir_okay=True))
@click.argument("output", type=click.Path(dir_okay=False))
@click.option(
    "--by",
    "by",
    multiple=True,
    metavar="COL[,COL...]",
    help="Column(s) whose values form the groups: one hull per group. "
    "Without --by, one hull of all points.",
)
@click.option(
    "--x",
    "x",
    metavar="COLUMN",
    help="CSV column of x coordinates (longitude) [default: detect "
    "longitude, lon, lng, long, x, easting].",
)
@click.option(
    "--y",
    "y",
    metavar="COLUMN",
    help="CSV column of y coordinates (latitude) [default: detect "
    "latitude, lat, y, northing].",
)
@click.option(
    "--crs-in",
    "crs_in",
    metavar="CRS",
    default="EPSG:4326",
    show_default=True,
    help="CRS of the CSV coordinates (or of a file that has none), "
    "e.g. EPSG:27700 for British National Grid; 'none' for planar "
    "coordinates without CRS (alpha is then in 1/unit).",
)
@click.option(
    "--layer",
    metavar="NAME",
    help="Layer of INPUT to read (GeoPackage etc.) [default: the first].",
)
@click.option(
    "--output-layer",
    metavar="NAME",
    help="Layer name in a GeoPackage OUTPUT [default: OUTPUT's file name].",
)
@_hull_options
@_overwrite_option
@_engine_option
def hull(
    input_path: str,
    output: str,
    by: tuple[str, ...],
    x: str | None,
    y: str | None,
    crs_in: str,
    layer: str | None,
    output_layer: str | None,
    overwrite: bool,
    engine: str | None,
    **options,
) -> None:
    """Write one hull per group of the points in INPUT to OUTPUT.

    INPUT is a GeoPackage, Shapefile, GeoJSON, FlatGeobuf, GeoParquet or
    any other vector file GDAL reads, or a CSV file with coordinate columns
    (found by name, or named with --x/--y; lon/lat in EPSG:4326 unless
    --crs-in says otherwise).

    OUTPUT's extension chooses its format: .gpkg, .shp, .geojson, .fgb or
    .parquet. It holds one row per group: the --by columns, alpha (1/metre),
    radius (metres), n_points, area_m2, crs_used, method, and the polygon, in
    INPUT's CRS. Shapefile field names are cut to 10 characters.

    \b
    Examples:
        geoalpha hull accidents.csv hulls.gpkg --by Local_Authority
        geoalpha hull trees.shp hulls.shp --by species --holes
        geoalpha hull pts.csv out.fgb --x E --y N --crs-in EPSG:27700 --by zone
    """  # noqa: D301
    from geoalpha.io import check_output, read_points

    verbosity = _verbosity()
    with _reporting(verbosity):
        check_output(output, layer=output_layer, overwrite=overwrite)
        points = read_points(input_path, x=x, y=y, crs=_crs_option(crs_in), layer=layer)
        work_crs = _crs_option(options["crs"])
        if points.crs is None and work_crs == "auto":
            work_crs = None  # planar input: compute in its own units
        options["crs"] = work_crs
        columns = _group_columns(by, list(points.columns), input_path)
        _run(
            points,
            output,
            source=input_path,
            by=columns,
            layer=output_layer,
            overwrite=overwrite,
            engine=engine,
            verbosity=verbosity,
            **options,
        )


@main.command(context_settings=_CONTEXT)
@click.argument("output", type=click.Path(dir_okay=False))
@click.option(
    "--dataset",
    type=click.Choice(sorted(DATASETS)),
    default="uk_clusters",
    show_default=True,
    help="Bundled dataset to use.",
)
@_overwrite_option
@_engine_option
@_OPTIONS["progress"]
def demo(
    output: str,
    dataset: str,
    overwrite: bool,
    engine: str | None,
    progress: bool | None,
) -> None:
    """Write the optimal hulls of a bundled real dataset to OUTPUT.

    A first run that needs no data of your own; open OUTPUT in QGIS.

    \b
    Datasets (grouped by the column in brackets):
      uk_clusters  15,255 UK road accidents 2013-2016 in 691 DBSCAN
                   clusters [Cluster]
      stats19      1,017 UK road accidents of 2014 by highway local
                   authority [Local_Authority_(Highway)]
      us_airports  3,376 US airports by state [state]

    \b
    Example:
        geoalpha demo hulls.gpkg
        geoalpha demo airports.shp --dataset us_airports
    """  # noqa: D301
    from geoalpha import datasets
    from geoalpha.io import check_output

    verbosity = _verbosity()
    with _reporting(verbosity):
        check_output(output, overwrite=overwrite)
        points = datasets.load(dataset)
        _run(
            points,
            output,
            source=f"dataset {dataset}",
            by=[DATASETS[dataset][3]],
            layer=None,
            overwrite=overwrite,
            engine=engine,
            verbosity=verbosity,
            progress=progress,
        )
