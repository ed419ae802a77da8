"""Read point files and write hull files, safely (``docs/user_guide/files.md``)."""

from __future__ import annotations

import csv
import errno
import hashlib
import os
import re
import shutil
import socket
import tempfile
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from geoalpha._io.postgis import (
    check_postgis_output,
    is_postgres_url,
    one_line,
    read_postgis,
    truncate_bytes,
    write_postgis,
)
from geoalpha._io.redact import redact, secrets_in
from geoalpha.errors import FLAGS, CRSWarning, InvalidInputError, did_you_mean

if TYPE_CHECKING:  # pragma: no cover
    import geopandas as gpd
    import pandas as pd

__all__ = [
    "COORDINATE_NAMES",
    "GPKG_VERSION",
    "WRITE_FORMATS",
    "check_not_input",
    "check_output",
    "geopackage_layers",
    "pg_url",
    "read_points",
    "remove_stale_staging",
    "write_hulls",
]

#: Column-name pairs (x, y) that :func:`read_points` recognises, in order of
#: preference, compared case-insensitively.
COORDINATE_NAMES: tuple[tuple[str, str], ...] = (
    ("longitude", "latitude"),
    ("lon", "lat"),
    ("lng", "lat"),
    ("long", "lat"),
    ("x", "y"),
    ("easting", "northing"),
)

#: Output file extension -> format written by :func:`write_hulls`.
WRITE_FORMATS: dict[str, str] = {
    ".gpkg": "GPKG",
    ".shp": "ESRI Shapefile",
    ".geojson": "GeoJSON",
    ".json": "GeoJSON",
    ".fgb": "FlatGeobuf",
    ".parquet": "GeoParquet",
}

_TABLE_SUFFIXES = {".csv", ".tsv", ".tab", ".txt"}
_PARQUET_SUFFIXES = {".parquet", ".geoparquet"}
_SHAPEFILE_SIDECARS = (".shx", ".dbf", ".prj", ".cpg", ".qix", ".sbn", ".sbx")
_ENGINES = (None, "pyogrio", "fiona")
_DBF_NAME_BYTES = 10
#: GeoPackage version written: 1.2 opens without a warning in the QGIS LTRs in
#: the field (QGIS 3.22 warns on GDAL's default 1.4).
GPKG_VERSION = "1.2"

PathLike = str | os.PathLike


def _term(python: str, cli: str) -> str:
    """Name options as the ``geoalpha`` command does while it runs (--crs-in)."""
    return cli if FLAGS.get() else python


def read_points(
    path: PathLike,
    *,
    x: str | None = None,
    y: str | None = None,
    crs: Any = "auto",
    layer: str | int | None = None,
    text: str | Sequence[str] = (),
) -> gpd.GeoDataFrame:
    """Read a file of points into a GeoDataFrame.

    Parameters
    ----------
    path : str or os.PathLike
        A vector file GDAL reads, GeoParquet, a table with two coordinate columns
        (CSV, Parquet without geometry metadata), or a ``postgresql://`` URL
        (:func:`~geoalpha._io.postgis.read_postgis` of the table ``layer``).
    x, y : str, optional
        The coordinate columns of a table (tables only); by default the first
        pair of :data:`COORDINATE_NAMES` found, in any letter case.
    crs : "auto", str, int, pyproj.CRS or None, default "auto"
        CRS of a table's coordinates, or of a vector file that stores none (a
        file's own CRS wins). ``"auto"`` never guesses (see :doc:`/cli`); None:
        planar numbers without CRS.
    layer : str or int, optional
        Layer of a multi-layer file such as a GeoPackage. By default the only
        layer, or the only point layer of a file with several layers (as a
        GeoPackage with the points and their hulls); with more than one point
        layer, or none, an error names the layers and their geometry types.
    text : str or sequence of str, optional
        Columns of a CSV read as text, as written: keys such as zip codes
        (``00501`` stays ``'00501'``, not the number 501); a blank cell is
        missing. The ``geoalpha`` command reads its ``--by`` columns so.

    Returns
    -------
    geopandas.GeoDataFrame
        Every row; a table's columns plus points (missing where a coordinate is).

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    geoalpha.errors.InvalidInputError
        If the file cannot be read, has no CRS (with ``crs="auto"``) or unusable
        coordinates. Messages never show a password.

    Warns
    -----
    geoalpha.errors.CRSWarning
        When a projected ``crs`` meets coordinates that look like lon/lat, or
        ``crs`` differs from the file's own CRS.

    Examples
    --------
    >>> from geoalpha import datasets
    >>> from geoalpha._io.files import read_points
    >>> gdf = read_points(datasets.path("stats19"))  # Longitude/Latitude found
    >>> gdf.crs.to_epsg(), gdf.geom_type.unique().tolist()
    (4326, ['Point'])
    >>> codes = read_points(datasets.path("stats19"), text=["Accident_Index"])
    >>> codes["Accident_Index"].iloc[0]
    '201401BS70001'
    """
    text = [text] if isinstance(text, str) else list(text)  # one name, or several
    return read_input_points(path, x=x, y=y, crs=crs, layer=layer, text=text)


def read_input_points(
    path,
    *,
    x,
    y,
    crs,
    layer,
    planar_if_missing=False,
    sql=None,
    geometry_column=None,
    text=(),
):
    """:func:`read_points`, PostGIS ``sql=``; ``planar_if_missing``: no CRS is ok."""
    from geoalpha._crs_parsing import crs_name, parse_crs

    source = os.fspath(path)
    shown = redact(source)
    auto = isinstance(crs, str) and crs.strip().lower() == "auto"
    crs = None if auto else crs  # "auto" decides below, per kind of source
    if _database(source, None):  # layer: schema.table, or sql=
        if x is not None or y is not None:
            raise InvalidInputError(
                f"{_term('x= and y=', '--x and --y')} apply to tables (CSV) only"
            )
        gdf = read_postgis(
            source, table=layer, sql=sql, geometry_column=geometry_column, crs=crs
        )
        if gdf.crs is None and auto and not planar_if_missing:
            raise _missing_crs(f"the geometries of {shown} (SRID 0)")
        return gdf
    if sql is not None or geometry_column is not None:
        raise InvalidInputError(
            f"{_term('sql= and geometry_column=', '--sql and --geometry-column')} "
            "apply to a postgresql:// INPUT"
        )
    local = "://" not in source and not source.startswith("/vsi")  # (PG: refused)
    if local and not Path(source).exists():
        raise FileNotFoundError(f"input file {shown} does not exist")
    if local and Path(source).is_file() and not os.access(source, os.R_OK):
        raise PermissionError(f"cannot read input file {shown}: permission denied")
    crs = parse_crs(crs)

    suffix = Path(source).suffix.lower()
    if suffix in _TABLE_SUFFIXES or (
        suffix in _PARQUET_SUFFIXES and not _has_geo_metadata(source)
    ):
        if layer is not None:
            raise InvalidInputError(
                f"{shown} is a table; {_term('layer=', '--layer')} applies to "
                "multi-layer files"
            )
        frame = _read_table(source, suffix, text)
        x, y = _find_coordinate_columns(list(frame.columns), x, y, shown)
        if auto and _looks_lonlat(x, y):
            crs = parse_crs(4326)
        elif auto and _looks_lonlat(y, x):
            raise InvalidInputError(
                f"{_term('x=', '--x ')}{x!r} and {_term('y=', '--y ')}{y!r} "
                f"of {shown}: " + _swap_hint(x, y)
            )
        elif auto and not planar_if_missing:
            raise _missing_crs(f"the coordinate columns {x!r}, {y!r} of {shown}")
        return _points_from_table(frame, shown, x, y, crs)

    if x is not None or y is not None:
        raise InvalidInputError(
            f"{shown} stores geometries; {_term('x= and y=', '--x and --y')} "
            "apply to tables (CSV) only"
        )
    gdf = _read_vector(source, shown, suffix, layer)
    if gdf.crs is None and auto and not planar_if_missing:
        raise _missing_crs(f"the points of {shown}")
    if gdf.crs is not None and crs is not None and not gdf.crs.equals(crs):
        warnings.warn(
            f"{shown} has its own CRS {crs_name(gdf.crs)}, which is used; "
            f"{_term('crs=', '--crs-in')} {crs_name(crs)} is ignored",
            CRSWarning,
            stacklevel=2,
        )
    elif gdf.crs is None and crs is not None:
        import shapely

        xy = shapely.get_coordinates(gdf.geometry.array)
        _check_lonlat(xy[:, 0], xy[:, 1], crs, shown, "x", "y")
        gdf = gdf.set_crs(crs)
    return gdf


def _looks_lonlat(x: str, y: str) -> bool:
    """Tell whether column names say longitude/latitude (lon/lat, lng/lat, ...)."""
    x, y = str(x).lower(), str(y).lower()
    return ("lon" in x or "lng" in x) and "lat" in y


def _missing_crs(what: str) -> InvalidInputError:
    if FLAGS.get():
        how = (
            "give it with --crs-in, e.g. --crs-in EPSG:4326 for "
            "longitude/latitude degrees or --crs-in EPSG:27700 for British "
            "National Grid metres, or --crs-in none to use the coordinates as "
            "planar numbers without a CRS (then alpha, radius and area are in "
            "their unit)"
        )
    else:
        how = (
            "give it with crs=, e.g. crs='EPSG:4326' for longitude/latitude "
            "degrees or crs='EPSG:27700' for British National Grid metres, or "
            "crs=None to use the coordinates as planar numbers without a CRS"
        )
    return InvalidInputError(f"{what} have no CRS, and geoalpha does not guess: {how}")


def _cannot_read(source: str, err: BaseException) -> InvalidInputError:
    return InvalidInputError(f"cannot read {redact(source)}: {one_line(err)}")


def _read_vector(source: str, shown: str, suffix: str, layer: str | int | None):
    import geopandas as gpd

    if suffix in _PARQUET_SUFFIXES and layer is not None:
        raise InvalidInputError(f"{shown} is a GeoParquet file; it has no layers")
    try:
        if suffix in _PARQUET_SUFFIXES:
            return gpd.read_parquet(source)
        chosen = _only_point_layer(source, shown) if layer is None else None
        gdf = gpd.read_file(source, layer=layer if chosen is None else chosen)
        if chosen is not None:  # the summary says which layer was read
            gdf.attrs["geoalpha_layer"] = chosen
        return gdf
    except (ImportError, InvalidInputError):
        raise
    except Exception as err:  # GDAL/pyogrio/fiona/pyarrow errors vary
        error = _cannot_read(source, err)
        safe = redact(str(error), secrets_in(source))
        if safe != str(error):  # the library's own message showed a secret
            raise InvalidInputError(safe) from None
        raise error from err


_POINT_TYPES = ("Point", "MultiPoint")  # with Z/M: "Point Z", "3D Point"


def _layers_and_types(source: str) -> list[tuple[str, str]]:
    """``(name, geometry type)`` of every layer of ``source`` (GDAL's order)."""
    try:
        import pyogrio
    except ImportError:
        import fiona

        found = []
        for name in fiona.listlayers(source):
            with fiona.open(source, layer=name) as layer:
                found.append((name, str(layer.schema.get("geometry"))))
        return found
    return [(str(n), str(t)) for n, t in pyogrio.list_layers(source)]


def _only_point_layer(source: str, shown: str) -> str | None:
    """Without a layer: the only layer, or the only point layer, else an error."""
    layers = _layers_and_types(source)
    if len(layers) <= 1:
        return None  # the only one (or none: the reader says so)
    points = [
        name
        for name, kind in layers
        if (kind.replace("3D ", "").split() or [""])[0] in _POINT_TYPES
    ]
    if len(points) == 1:
        return points[0]
    listed = ", ".join(f"{name} ({kind or 'no geometry'})" for name, kind in layers)
    which = "more than one point layer" if points else "no point layer"
    flag = _term("layer=", "--layer ")
    raise InvalidInputError(
        f"{shown} has {len(layers)} layers and {which}: {listed}; choose one "
        f"with {flag}{(points or [layers[0][0]])[0]!r}"
        + (
            ""
            if points
            else f" (with {_term('vertices=True', '--vertices')} for lines or polygons)"
        )
    )


def _read_table(source: str, suffix: str, text=()):
    """Read a CSV table (its delimiter detected) or a Parquet table.

    The columns ``text`` of a CSV are read as text (str), as written.
    """
    import pandas as pd

    try:
        if suffix in _PARQUET_SUFFIXES:  # (its schema was just read)
            return pd.read_parquet(source)
        with open(source, encoding="utf-8-sig", newline="") as handle:
            sample = handle.read(65536)
        try:
            sep = csv.Sniffer().sniff(sample, delimiters=",;\t|").delimiter
        except csv.Error:
            sep = ","
        dtype = {str(name): str for name in text}  # (names not in it are ignored)
        return pd.read_csv(
            source, sep=sep, encoding="utf-8-sig", low_memory=False, dtype=dtype
        )
    except UnicodeDecodeError as err:
        raise InvalidInputError(
            f"cannot read {redact(source)}: it is not UTF-8 text ({err.reason} at byte "
            f"{err.start}); save it as UTF-8 CSV"
        ) from err
    except (OSError, ValueError, pd.errors.ParserError) as err:
        raise _cannot_read(source, err) from err


def _has_geo_metadata(source: str) -> bool:
    pq = _import_pyarrow_parquet()
    try:
        metadata = pq.read_schema(source).metadata or {}
    except Exception as err:  # pyarrow raises ArrowInvalid, OSError, ...
        raise _cannot_read(source, err) from err
    return b"geo" in metadata


def _import_pyarrow_parquet():
    try:
        import pyarrow.parquet as pq
    except ImportError as err:
        raise ImportError(
            "reading and writing GeoParquet needs pyarrow: "
            'pip install "geoalpha[parquet]" (or pip install pyarrow)'
        ) from err
    return pq


def _find_coordinate_columns(
    columns: list[str], x: str | None, y: str | None, source: str
) -> tuple[str, str]:
    found = ", ".join(map(str, columns)) or "none"
    names = _term("x= and y=", "--x and --y")
    if (x is None) != (y is None):
        raise InvalidInputError(
            f"give both {names} for {source}, or neither to detect them"
        )
    if x is not None and y is not None:
        missing = [name for name in (x, y) if name not in columns]
        if missing:
            hints = "".join(did_you_mean(name, columns) for name in missing)
            raise InvalidInputError(
                f"coordinate column {', '.join(map(repr, missing))} not found in "
                f"{source}{hints}; its columns are: {found}"
            )
        return x, y
    lower = {str(column).lower(): column for column in reversed(columns)}
    for x_name, y_name in COORDINATE_NAMES:
        if x_name in lower and y_name in lower:
            return lower[x_name], lower[y_name]
    pairs = ", ".join(f"{a}/{b}" for a, b in COORDINATE_NAMES)
    guess = _guess_pair(columns)
    if guess is None:
        how = f"name them with {names}"
    else:
        gx, gy = guess
        how = f"name them, e.g. {_term(f'x={gx!r}, y={gy!r}', f'--x {gx} --y {gy}')}"
        if not _looks_lonlat(gx, gy):
            how += (
                f", with their CRS ({_term('crs=', '--crs-in ')}EPSG:...) or "
                f"{_term('crs=None', '--crs-in none')} for planar numbers"
            )
    raise InvalidInputError(
        f"no coordinate columns found in {source} (looked for {pairs}); its "
        f"columns are: {found}; {how}"
    )


def _guess_pair(columns: list) -> tuple[str, str] | None:
    """Two columns that look like x and y (``x_km``/``y_km``, ``X1``/``Y1``)."""
    names = [str(c) for c in columns]
    for starts in (("x", "y"), ("lon", "lat"), ("e", "n")):
        for name in names:
            low = name.lower()
            if not low.startswith(starts[0]):
                continue
            tail = low[len(starts[0]) :]
            for other in names:
                if other != name and other.lower() == starts[1] + tail:
                    return name, other
    return None


def _points_from_table(frame: pd.DataFrame, source, x, y, crs) -> gpd.GeoDataFrame:
    import geopandas as gpd
    import numpy as np
    import pandas as pd

    values = {}
    for name in (x, y):
        raw = frame[name]
        numeric = pd.to_numeric(raw, errors="coerce")
        bad = numeric.isna() & raw.notna()
        if bad.any():
            first = raw[bad].head(3)
            examples = ", ".join(f"{v!r} at index {i}" for i, v in first.items())
            raise InvalidInputError(
                f"coordinate column {name!r} of {source} has {int(bad.sum())} "
                f"non-numeric values (e.g. {examples}; the index counts data "
                "rows from 0)"
            )
        values[name] = numeric.to_numpy(dtype=float)
    xs, ys = values[x], values[y]
    _check_lonlat(xs, ys, crs, source, x, y)
    geometry = gpd.points_from_xy(xs, ys)
    geometry[np.isnan(xs) | np.isnan(ys)] = None  # missing, not POINT (NaN NaN)
    gdf = gpd.GeoDataFrame(frame, geometry=geometry, crs=crs)
    gdf.attrs["geoalpha_coordinates"] = (str(x), str(y))
    return gdf


def _swap_hint(x: str, y: str) -> str:
    """Return the hint for longitude/latitude columns given the wrong way round."""
    return (
        f"longitude and latitude look swapped: {x} holds latitudes? Give the "
        f"longitude column as {_term('x=', '--x')} and the latitude column as "
        f"{_term('y=', '--y')}"
    )


def _check_lonlat(xs, ys, crs, source: str, x: str, y: str) -> None:
    """Refuse lon/lat out of range; warn when projected values look like lon/lat."""
    import numpy as np

    from geoalpha._crs_parsing import crs_name

    if crs is None:
        return
    finite = np.isfinite(xs) & np.isfinite(ys)
    with np.errstate(invalid="ignore"):
        inside = (np.abs(xs) <= 180) & (np.abs(ys) <= 90)
    if not crs.is_geographic:
        if crs.is_projected and finite.any() and inside[finite].all():
            unit = crs.axis_info[0].unit_name if crs.axis_info else "unit"
            warnings.warn(
                f"every point of {source} has {x} within [-180, 180] and {y} "
                "within [-90, 90], as longitude/latitude degrees do, but "
                f"{_term('crs=', '--crs-in')} {crs_name(crs)} says they are "
                f"in {unit}s; if they are longitude/latitude, use "
                f"{_term('crs=', '--crs-in ')}EPSG:4326",
                CRSWarning,
                stacklevel=4,
            )
        return
    outside = finite & ~inside
    if outside.any():
        message = (
            f"{int(outside.sum())} points of {source} have {x}/{y} outside the "
            f"longitude/latitude range of {crs.to_string()}"
        )
        if (np.abs(xs[finite]) <= 90).all() and (np.abs(ys[finite]) <= 180).all():
            message += "; " + _swap_hint(x, y)
        else:
            message += (
                "; if they are projected coordinates, give their CRS with "
                f"{_term('crs=', '--crs-in')}, e.g. EPSG:27700"
            )
        raise InvalidInputError(message)


def write_hulls(
    gdf: gpd.GeoDataFrame,
    path: PathLike,
    *,
    layer: str | None = None,
    overwrite: bool = False,
    engine: str | None = None,
    extra_layers: dict[str, gpd.GeoDataFrame] | None = None,
) -> dict[str, str]:
    """Write hulls atomically to a file in the format of its extension (:doc:`/cli`).

    Parameters
    ----------
    gdf : geopandas.GeoDataFrame
        What to write, usually the result of :func:`geoalpha.hull`.
    path : str or os.PathLike
        Output file, in the format of its extension (:data:`WRITE_FORMATS`), or
        a ``postgresql://`` URL (:func:`geoalpha._io.postgis.write_postgis`).
    layer : str, optional
        GeoPackage layer name (``.gpkg`` only); default the file name without
        extension, or ``"hulls"``. Required for a URL: ``schema.table``. An
        existing GeoPackage keeps its other layers: the layer is added to it.
    overwrite : bool, default False
        Replace what is written if it exists: in a GeoPackage only the layers
        written (the others are kept), otherwise the file (a Shapefile with all
        its sidecar files), or the PostGIS table.
    engine : {None, "pyogrio", "fiona"}
        Library geopandas writes vector files with (None: its choice; not for
        GeoParquet). GeoPackages are version :data:`GPKG_VERSION` with either.
    extra_layers : dict of str to GeoDataFrame, optional
        More layers of a GeoPackage, by name (e.g. the points), in the same file.

    Returns
    -------
    dict of str to str
        ``{old: new}`` for the columns renamed to fit a Shapefile's 10-byte
        field names (``Local_Au_1``: see :doc:`/cli`); empty for other formats.

    Raises
    ------
    FileExistsError, FileNotFoundError, PermissionError
        As :func:`check_output`; also when ``path`` appeared while writing.
    OSError
        When a GeoPackage ``path`` changed while its copy was written (it is
        then left as it was), or is open in another program (a ``-wal`` file).
    geoalpha.errors.InvalidInputError
        As :func:`check_output`, and for an unknown engine.

    Examples
    --------
    >>> import os, tempfile, geopandas as gpd, shapely
    >>> hulls = gpd.GeoDataFrame({"Local_Authority_(Highway)": ["E09000020"]},
    ...                          geometry=[shapely.box(0, 51, 1, 52)], crs=4326)
    >>> folder = tempfile.mkdtemp()
    >>> write_hulls(hulls, os.path.join(folder, "hulls.shp"))
    {'Local_Authority_(Highway)': 'Local_Auth'}

    A GeoPackage gains a layer; the layers it had are kept:

    >>> write_hulls(hulls, os.path.join(folder, "both.gpkg"), layer="points")
    {}
    >>> write_hulls(hulls, os.path.join(folder, "both.gpkg"), layer="state_hulls")
    {}
    >>> geopackage_layers(os.path.join(folder, "both.gpkg"))
    ['points', 'state_hulls']
    """
    import geopandas as gpd

    if not isinstance(gdf, gpd.GeoDataFrame):
        raise InvalidInputError(
            f"write_hulls() needs a GeoDataFrame; got {type(gdf).__name__}"
        )
    frame = _index_as_columns(gdf)
    if _database(path, engine):
        if extra_layers:
            raise InvalidInputError(
                "extra layers apply to GeoPackage (.gpkg) output only, not PostGIS"
            )
        write_postgis(frame, os.fspath(path), layer, overwrite=overwrite)
        return {}
    if engine not in _ENGINES:
        raise InvalidInputError(
            f"unknown engine {engine!r}; expected 'pyogrio', 'fiona' or None"
        )
    names = [layer or Path(path).stem or "hulls", *(extra_layers or {})]
    target, suffix, targets, merge = _check_target(path, layer, overwrite, names[1:])
    if extra_layers and suffix != ".gpkg":
        raise InvalidInputError(
            f"extra layers apply to GeoPackage (.gpkg) output only, not {suffix}"
        )
    mapping = _shapefile_names(frame) if suffix == ".shp" else {}
    if mapping:
        frame = frame.rename(columns=mapping)
    layers = [
        (frame, gdf, layer),
        *((x, x, n) for n, x in (extra_layers or {}).items()),
    ]
    staging = _make_staging(target)
    try:
        staged = staging / target.name
        # An existing GeoPackage: its layers are kept, in a staged copy that
        # replaces it in one rename (the old file or the new one, never neither).
        before = _copy_geopackage(target, staged) if merge else None
        if before is not None and not overwrite:  # a layer that came meanwhile
            _check_layers(staged, names, overwrite, shown=target)
        _write_layers(layers, staged, suffix, engine, target)
        if before is not None:
            _replace_geopackage(staged, target, before)
        else:
            _move_into_place(staging, target, targets, overwrite)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    return mapping


def _write_layers(layers, staged: Path, suffix: str, engine, target: Path) -> None:
    """Write ``(frame, source, layer)`` triples into the staged file."""
    kwargs: dict[str, Any] = {"driver": WRITE_FORMATS[suffix], "index": False}
    if engine is not None:
        kwargs["engine"] = engine
    if suffix == ".gpkg" and engine == "fiona":
        kwargs["VERSION"] = GPKG_VERSION
    elif suffix == ".gpkg":
        kwargs["dataset_options"] = {"VERSION": GPKG_VERSION}
    elif suffix == ".shp":
        kwargs["encoding"] = "UTF-8"
    try:
        for frame, source, layer in layers:
            if suffix == ".parquet":
                _import_pyarrow_parquet()
                source.to_parquet(staged)
                continue
            if suffix == ".gpkg":
                kwargs["layer"] = layer or staged.stem or "hulls"
            with warnings.catch_warnings():
                # Output without CRS (planar input) is deliberate and reported
                # by the caller; pyogrio's generic warning would only confuse.
                warnings.filterwarnings("ignore", message=".*'crs' was not provided")
                frame.to_file(staged, **kwargs)
    except (ImportError, InvalidInputError):
        raise
    except Exception as err:
        text = one_line(err).replace(str(staged.parent), str(target.parent))
        raise OSError(f"cannot write {target}: {text}") from err
    if suffix == ".shp":
        _fit_decimals(staged.with_suffix(".dbf"), layers[0][0])
    crs = layers[0][0].crs
    prj = staged.with_suffix(".prj")
    if suffix == ".shp" and crs is not None and not prj.exists():
        raise OSError(
            f"the Shapefile writer did not write {prj.name} for CRS "
            f"{crs.to_string()}; write another format instead"
        )


def _fit_decimals(dbf: Path, frame) -> None:
    """Declare, for each decimal field of a Shapefile, decimals its values fit.

    GDAL declares every float column ``N(24, 15)`` and stores each value in the
    24 characters (fewer decimals for large values). Programs that copy the
    field as declared (QGIS's "Save Features As", processing outputs) then
    format 2.4e12 m² with 15 decimals, which does not fit: "Value ... not
    successfully written". The declared decimals are lowered so that the
    column's largest value fits the width with them; the stored text is the
    same.
    """
    import numpy as np

    with open(dbf, "r+b") as handle:
        header = handle.read(32)
        header_size = int.from_bytes(header[8:10], "little")
        offset = 32
        while offset + 32 <= header_size:
            handle.seek(offset)
            field = handle.read(32)
            if not field or field[0] == 0x0D:
                break
            name = field[:11].split(b"\0")[0].decode("utf-8", "replace")
            kind, width, decimals = chr(field[11]), field[16], field[17]
            if kind in "NF" and decimals > 0 and name in frame.columns:
                values = np.asarray(frame[name], dtype=float)
                values = values[np.isfinite(values)]
                if values.size:
                    digits = len(str(int(np.abs(values).max())))
                    digits += int((values < 0).any())  # the minus sign
                    fitting = max(0, min(decimals, width - digits - 1))
                    if fitting != decimals:
                        handle.seek(offset + 17)
                        handle.write(bytes([fitting]))
            offset += 32


def check_output(
    path: PathLike, *, layer: str | None = None, overwrite: bool = False
) -> None:
    """Check, before any work, that :func:`write_hulls` can write ``path``.

    Parameters
    ----------
    path, layer, overwrite
        As for :func:`write_hulls`.

    Raises
    ------
    FileExistsError, FileNotFoundError, IsADirectoryError, PermissionError
        If ``path`` exists (without ``overwrite``; for a GeoPackage: if its
        ``layer`` exists), its directory does not, it is a directory, or its
        folder is not writable.
    geoalpha.errors.InvalidInputError
        For an unknown extension (or an upper-case ``.SHP``), or ``layer``
        with a format without layers.

    Examples
    --------
    >>> from geoalpha._io.files import check_output
    >>> check_output("hulls.csv")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    geoalpha.errors.InvalidInputError: cannot tell the output format of hulls.csv: ...
    """
    if _database(path, None):
        check_postgis_output(os.fspath(path), layer, overwrite=overwrite)
        return
    target, _, _, _ = _check_target(path, layer, overwrite)
    _probe_folder(target.parent)  # it can be written


def check_not_input(
    output: PathLike, layer: str | None, source: PathLike, source_layer
) -> None:
    """Refuse to write over the layer being read (OUTPUT is INPUT, same layer).

    Parameters
    ----------
    output, layer
        The output file and layer (None: the file name without extension).
    source, source_layer
        The input file and the layer read (None: the one :func:`read_points`
        reads without a layer).

    Raises
    ------
    geoalpha.errors.InvalidInputError
        If ``output`` is the GeoPackage ``source`` and ``layer`` the layer read.

    Examples
    --------
    >>> check_not_input("hulls.gpkg", None, "points.csv", None)  # other files
    """
    target, source = Path(output), Path(source)
    if target.suffix.lower() != ".gpkg" or _database(source, None):
        return
    try:
        same = os.path.samefile(target, source)
    except OSError:  # one of them does not exist (or is a URL)
        return
    if not same:
        return
    read = source_layer if source_layer is not None else _layer_read(source)
    written = layer or target.stem or "hulls"
    if read is not None and str(read).lower() == written.lower():
        other = f"{written}_hulls"
        raise InvalidInputError(
            f"OUTPUT {target} is INPUT and its layer {written!r} is the layer "
            "read: geoalpha does not write over its input; give another "
            f"{_term('layer=', '--output-layer')}, e.g. "
            f"{_term(f'layer={other!r}', f'--output-layer {other}')}, to add the "
            "hulls beside the points"
        )


def _layer_read(path: Path) -> str | None:
    """Return the layer :func:`read_points` reads from ``path`` without a layer."""
    try:
        chosen = _only_point_layer(str(path), str(path))
        return chosen if chosen is not None else _layers_and_types(str(path))[0][0]
    except Exception:  # no layer to choose: reading it reports the error
        return None


_CONNINFO = re.compile(r"(\w+)\s*=\s*('(?:[^'\\]|\\.)*'|[^\s']+)")
#: GDAL's own PG: keys, not libpq's: the table to read is --layer.
_GDAL_PG_KEYS = ("tables", "schemas", "active_schema", "list_all_tables")


def pg_url(dsn: str) -> tuple[str, str | None]:
    """Convert a GDAL ``PG:`` string to a ``postgresql://`` URL, without password.

    Parameters
    ----------
    dsn : str
        ``PG:host=... port=... dbname=... user=... password=...`` (libpq's
        keywords; values may be quoted).

    Returns
    -------
    url : str
        ``postgresql://user@host:port/dbname``, with libpq's other keywords
        (``sslmode``, ...) as query parameters; never the password.
    table : str or None
        GDAL's ``tables=`` (the first), which geoalpha reads as ``--layer``.

    Examples
    --------
    >>> pg_url("PG:host=db.example port=5433 dbname=gis user=ga password=s3cr3t")
    ('postgresql://ga@db.example:5433/gis', None)
    >>> pg_url("PG:dbname='my gis' tables=public.zips sslmode=require")
    ('postgresql:///my%20gis?sslmode=require', 'public.zips')
    """
    from urllib.parse import quote, urlencode

    pairs = {
        key.lower(): _unquote_conninfo(value)
        for key, value in _CONNINFO.findall(dsn.strip()[3:])
    }
    pairs.pop("password", None)
    table = (pairs.pop("tables", "") or "").split(",")[0].strip() or None
    for key in _GDAL_PG_KEYS:
        pairs.pop(key, None)
    host = pairs.pop("host", "") or pairs.pop("hostaddr", "")
    if ":" in host:  # IPv6
        host = f"[{host}]"
    user = pairs.pop("user", "")
    port = pairs.pop("port", "")
    dbname = pairs.pop("dbname", "")
    url = "postgresql://" + (f"{quote(user, safe='')}@" if user else "") + host
    url += (f":{port}" if port else "") + f"/{quote(dbname, safe='')}"
    if pairs:
        url += "?" + urlencode(pairs)
    return url, table


def _unquote_conninfo(value: str) -> str:
    if len(value) >= 2 and value[0] == value[-1] == "'":
        return re.sub(r"\\(.)", r"\1", value[1:-1])
    return value


def _database(path, engine) -> bool:
    """Tell whether ``path`` is a ``postgresql://`` URL; refuse ``PG:`` strings."""
    if isinstance(path, str) and path.strip()[:3].upper() == "PG:":
        url, table = pg_url(path)
        layer = f" and {_term('layer=', '--layer ')}{table}" if table else ""
        raise InvalidInputError(
            "PG:... connection strings are not supported (the GDAL in the Python "
            f"wheels has no PostgreSQL driver); give the URL {url}{layer} "
            "instead, with the password in PGPASSWORD or ~/.pgpass"
        )
    if not is_postgres_url(path):
        return False
    if engine is not None:
        raise InvalidInputError("engine= (--engine) applies to files, not PostGIS")
    return True


def _check_target(
    path, layer, overwrite, extra_layers=()
) -> tuple[Path, str, list[Path], bool]:
    """Check the output; the last value: add layers to an existing GeoPackage."""
    target = Path(path)
    suffix = target.suffix.lower()
    if suffix not in WRITE_FORMATS:
        raise InvalidInputError(
            f"cannot tell the output format of {target}: its extension must be "
            f"one of {', '.join(WRITE_FORMATS)}"
        )
    if suffix == ".shp" and target.suffix != ".shp":
        raise InvalidInputError(
            f"a Shapefile needs the lower-case extension .shp (GDAL writes "
            f"{target.stem}.shp for {target.name}): use {target.with_suffix('.shp')}"
        )
    if layer is not None and suffix != ".gpkg":
        raise InvalidInputError(
            f"a layer name applies to GeoPackage (.gpkg) output only, not {suffix}"
        )
    parent = target.parent
    if not parent.is_dir():
        raise FileNotFoundError(f"output directory {parent} does not exist")
    if target.is_dir():
        raise IsADirectoryError(f"output {target} is a directory")
    if suffix == ".gpkg" and _is_sqlite(target):
        names = [layer or target.stem or "hulls", *extra_layers]
        _check_layers(target, names, overwrite)
        return target, suffix, [target], True
    targets = [target]  # with a Shapefile's sidecars
    if suffix == ".shp":
        targets += [target.with_suffix(ext) for ext in _SHAPEFILE_SIDECARS]
    existing = [p for p in targets if p.exists() or p.is_symlink()]
    if existing and not overwrite:
        raise FileExistsError(
            f"output {existing[0]} already exists; use "
            f"{_term('overwrite=True', '--overwrite')} to replace it"
        )
    return target, suffix, targets, False


_SQLITE_HEADER = b"SQLite format 3\x00"
#: Files beside a GeoPackage that SQLite still needs: a write-ahead log or a
#: rollback journal (another program has it open, or did not close it).
_SQLITE_SIDECARS = ("-wal", "-journal")


def _is_sqlite(path: Path) -> bool:
    """Tell whether ``path`` is an SQLite database (a GeoPackage is one)."""
    try:
        with open(path, "rb") as handle:
            return handle.read(len(_SQLITE_HEADER)) == _SQLITE_HEADER
    except OSError:
        return False


def _connect_read_only(path: Path):
    import sqlite3

    return sqlite3.connect(f"{path.resolve().as_uri()}?mode=ro", uri=True)


def geopackage_layers(path: PathLike) -> list[str]:
    """Return the layers (tables) of a GeoPackage, read without changing it.

    Parameters
    ----------
    path : str or os.PathLike
        A GeoPackage file.

    Returns
    -------
    list of str
        Its layer names, as ``gpkg_contents`` lists them.

    Raises
    ------
    geoalpha.errors.InvalidInputError
        If ``path`` is not a GeoPackage that SQLite can read.

    Examples
    --------
    >>> import os, tempfile, geopandas as gpd, shapely
    >>> path = os.path.join(tempfile.mkdtemp(), "both.gpkg")
    >>> points = gpd.GeoDataFrame(geometry=[shapely.Point(0, 0)], crs=4326)
    >>> points.to_file(path, layer="zips")
    >>> geopackage_layers(path)
    ['zips']
    """
    import sqlite3

    path = Path(path)
    try:
        connection = _connect_read_only(path)
        try:
            rows = connection.execute(
                "SELECT table_name FROM gpkg_contents ORDER BY rowid"
            ).fetchall()
        finally:
            connection.close()
    except sqlite3.Error as err:
        raise InvalidInputError(
            f"cannot read the layers of {path}: {err}; it is not a GeoPackage "
            "geoalpha can add a layer to (choose another OUTPUT)"
        ) from err
    return [str(name) for (name,) in rows]


def _check_layers(
    target: Path, names: list[str], overwrite: bool, shown: Path | None = None
) -> None:
    """Refuse to add ``names`` to the GeoPackage ``target`` when it is not safe.

    ``shown``: the output, when ``target`` is its staged copy.
    """
    if shown is not None:  # the staged copy: only the layers
        present = {name.lower() for name in geopackage_layers(target)}
        taken = [n for n in names if n.lower() in present]
        if taken:
            raise FileExistsError(
                f"layer {taken[0]!r} of output {shown} appeared while geoalpha was "
                "computing (another run writing the same layer?) and was not "
                f"replaced; use {_term('overwrite=True', '--overwrite')} to "
                "replace it"
            )
        return
    for ending in _SQLITE_SIDECARS:
        sidecar = Path(f"{target}{ending}")
        if sidecar.exists():
            raise OSError(
                f"output {target} is open in another program or was not closed "
                f"({sidecar.name} exists beside it); close it (e.g. in QGIS) "
                "and run again"
            )
    present = {name.lower(): name for name in geopackage_layers(target)}
    taken = [present[n.lower()] for n in names if n.lower() in present]
    if taken and not overwrite:
        raise FileExistsError(
            f"layer {taken[0]!r} of output {target} already exists; use "
            f"{_term('overwrite=True', '--overwrite')} to replace that layer "
            f"(its other layers are kept), or another "
            f"{_term('layer=', '--output-layer')}"
        )


def _signature(path: Path) -> tuple[int, int, int, int]:
    stat = os.stat(path)
    return (stat.st_dev, stat.st_ino, stat.st_size, stat.st_mtime_ns)


def _copy_geopackage(target: Path, staged: Path) -> tuple[int, int, int, int]:
    """Copy the GeoPackage ``target`` to ``staged`` (SQLite's backup: consistent).

    Returns the signature of ``target`` before the copy, which
    :func:`_replace_geopackage` compares.
    """
    import sqlite3

    before = _signature(target)
    try:
        source = _connect_read_only(target)
        try:
            copy = sqlite3.connect(staged)
            try:
                source.backup(copy)
            finally:
                copy.close()
        finally:
            source.close()
    except sqlite3.Error as err:
        raise OSError(f"cannot copy {target} to add a layer: {err}") from err
    shutil.copymode(target, staged)
    return before


def _replace_geopackage(staged: Path, target: Path, before) -> None:
    """Move the staged copy over ``target`` unless ``target`` changed meanwhile."""
    left = {p.name for p in staged.parent.iterdir()} - {staged.name}
    if left:  # e.g. a -wal the writer left open: the copy is not complete
        raise OSError(f"the writer left {sorted(left)[0]} beside {target.name}")
    try:
        now = _signature(target)
    except FileNotFoundError:
        now = None
    if now != before:
        raise OSError(
            f"output {target} changed while geoalpha was writing it (another "
            "program or run writing the same file?); it was not replaced: run again"
        )
    _replace(staged, target)


# Staging folders are named "geoalpha-<host>-<pid>-<random>" in the temporary
# folder (".<output name>.geoalpha-..." beside the output when the temporary
# folder is on another file system, as the final rename must not cross one),
# so that a later run can tell a folder left by a killed process (same host,
# pid gone) from one another run is still writing.
_STAGING = re.compile(r"(?:\..+\.)?geoalpha-(?P<host>[0-9a-f]{8})-(?P<pid>\d+)-[^/]+")


def _host_tag() -> str:
    return hashlib.sha1(
        socket.gethostname().encode(), usedforsecurity=False
    ).hexdigest()[:8]


def _staging_folder(target: Path) -> tuple[Path, str]:
    """Where to stage ``target``: the temporary folder if on its file system."""
    parent = target.parent
    prefix = f"geoalpha-{_host_tag()}-{os.getpid()}-"
    try:
        temporary = Path(tempfile.gettempdir())
        if os.stat(temporary).st_dev == os.stat(parent).st_dev and os.access(
            temporary, os.W_OK | os.X_OK
        ):
            return temporary, prefix
    except OSError:
        pass
    return parent, f".{target.name}.{prefix}"


def _make_staging(target: Path) -> Path:
    """Create the staging folder for ``target``, cleaning stale ones first."""
    folder, prefix = _staging_folder(target)
    remove_stale_staging(target.parent)  # (left beside it by older versions)
    if folder != target.parent:
        remove_stale_staging(folder)
    try:
        return Path(tempfile.mkdtemp(prefix=prefix, dir=folder))
    except OSError as err:
        raise _unwritable(target.parent, err) from err


def _unwritable(parent: Path, err: OSError) -> OSError:
    denied = isinstance(err, PermissionError)
    why = "permission denied" if denied else err.strerror or err
    kind = PermissionError if denied else OSError
    return kind(f"cannot write to the output folder {parent}: {why}")


def _probe_folder(parent: Path) -> None:
    """Check that files can be created in ``parent`` (a probe, removed at once)."""
    remove_stale_staging(parent)
    prefix = f".probe.geoalpha-{_host_tag()}-{os.getpid()}-"
    try:
        os.rmdir(tempfile.mkdtemp(prefix=prefix, dir=parent))
    except OSError as err:
        raise _unwritable(parent, err) from err


def _pid_alive(pid: int) -> bool:
    if pid == os.getpid() or os.name == "nt":  # Windows: os.kill would end it
        return True
    try:
        os.kill(pid, 0)
    except OSError as err:  # no such process, or another user's live one
        return isinstance(err, PermissionError)
    return True


def remove_stale_staging(folder: PathLike) -> list[Path]:
    """Remove staging folders that killed geoalpha runs left in ``folder``.

    Folders of live runs and of other hosts are kept.

    Parameters
    ----------
    folder : str or os.PathLike

    Returns
    -------
    list of pathlib.Path
        The folders removed.
    """
    removed = []
    host = _host_tag()
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    for entry in entries:
        match = _STAGING.fullmatch(entry.name)
        ours = match and match["host"] == host and entry.is_dir(follow_symlinks=False)
        if ours and not _pid_alive(int(match["pid"])):
            shutil.rmtree(entry.path, ignore_errors=True)
            removed.append(Path(entry.path))
    return removed


def _move_into_place(
    staging: Path, target: Path, targets: list[Path], overwrite: bool
) -> None:
    """Move the staged files into place; without ``overwrite``, one racing run wins."""
    written = {p.name for p in staging.iterdir() if p.is_file()}
    if target.name not in written:
        raise OSError(f"the writer did not create {target.name}")
    sidecars = sorted(written - {target.name})
    if overwrite:
        for name in [*sidecars, target.name]:
            _replace(staging / name, target.parent / name)
        for stale in targets:  # e.g. an old .cpg the new Shapefile does not have
            if stale.name not in written and (stale.exists() or stale.is_symlink()):
                stale.unlink()
        return
    placed: list[Path] = []
    try:
        for name in [target.name, *sidecars]:
            _place_new(staging / name, target.parent / name)
            placed.append(target.parent / name)
    except FileExistsError as err:
        for path in placed:
            path.unlink(missing_ok=True)
        raise FileExistsError(
            f"output {err.filename or target} appeared while geoalpha was "
            "computing (another run writing the same file?) and was not "
            f"replaced; use {_term('overwrite=True', '--overwrite')} to replace it"
        ) from None


def _replace(source: Path, destination: Path) -> None:
    """``os.replace``; across mount points, through a copy beside ``destination``.

    The temporary folder can be on the output's file system but another mount
    (a container's bind mount), where a rename fails with EXDEV: the file is
    then copied into a staging folder beside ``destination`` first (which the
    next run removes, should this one be killed), and renamed from there.
    """
    try:
        os.replace(source, destination)
        return
    except OSError as err:
        if err.errno != errno.EXDEV:
            raise
    prefix = f".{destination.name}.geoalpha-{_host_tag()}-{os.getpid()}-"
    beside = Path(tempfile.mkdtemp(prefix=prefix, dir=destination.parent))
    try:
        shutil.copy2(source, beside / destination.name)
        os.replace(beside / destination.name, destination)
    finally:
        shutil.rmtree(beside, ignore_errors=True)


def _place_new(source: Path, destination: Path) -> None:
    """Move ``source`` to ``destination``; FileExistsError if that name is taken."""
    try:
        os.link(source, destination)
    except FileExistsError:  # (its filename is the source)
        raise FileExistsError(errno.EEXIST, "file exists", str(destination)) from None
    except OSError:
        # No hard links here (some network or FAT file systems): claim the
        # name with an exclusive create, then replace that placeholder.
        os.close(os.open(destination, os.O_CREAT | os.O_EXCL | os.O_WRONLY))
        _replace(source, destination)
        return
    source.unlink()


def _index_as_columns(gdf):
    """Turn an index geopandas would write into ordinary columns."""
    import pandas as pd

    index = gdf.index  # (a MultiIndex has dtype object)
    plain = pd.api.types.is_integer_dtype(index.dtype)
    return gdf if plain and set(index.names) == {None} else gdf.reset_index()


def _shapefile_names(frame) -> dict[str, str]:
    """Map column names too long for a dBASE field to unique short names."""
    columns = [c for c in frame.columns if c != frame.geometry.name]
    kept: dict[str, str] = {}  # lower case -> the first name that fits
    for name in map(str, columns):
        if len(name.encode("utf-8")) <= _DBF_NAME_BYTES:
            kept.setdefault(name.lower(), name)
    used = set(kept)
    mapping: dict[str, str] = {}
    for column in columns:
        name = str(column)
        if kept.get(name.lower()) == name:  # (also a 1 beside a "1")
            continue
        new = truncate_bytes(name, _DBF_NAME_BYTES)
        number = 0
        while not new or new.lower() in used:
            number += 1
            tail = f"_{number}"
            new = truncate_bytes(name, _DBF_NAME_BYTES - len(tail)) + tail
        used.add(new.lower())
        mapping[column] = new
    return mapping
