"""Read point files and write hull files, safely.

:func:`read_points` turns any vector file GDAL reads, a GeoParquet file or a
CSV table with coordinate columns into a GeoDataFrame of points.
:func:`write_hulls` writes the result of :func:`geoalpha.hull` in the format
its file extension names, atomically (a failed write never leaves a
half-written file, and never damages the file it was meant to replace), and
renames the columns a Shapefile cannot hold.

This module does pure file handling; the ``geoalpha`` command
(:mod:`geoalpha.cli`) is a thin layer over it.
"""

from __future__ import annotations

import csv
import os
import shutil
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Any

from geoalpha.errors import InvalidInputError

if TYPE_CHECKING:  # pragma: no cover
    import geopandas as gpd
    import pandas as pd

__all__ = [
    "COORDINATE_NAMES",
    "WRITE_FORMATS",
    "check_output",
    "read_points",
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

PathLike = str | os.PathLike


# --------------------------------------------------------------------------
# reading


def read_points(
    path: PathLike,
    *,
    x: str | None = None,
    y: str | None = None,
    crs: Any = "EPSG:4326",
    layer: str | int | None = None,
) -> gpd.GeoDataFrame:
    """Read a file of points into a GeoDataFrame.

    Parameters
    ----------
    path : str or os.PathLike
        A vector file GDAL reads (GeoPackage, Shapefile, GeoJSON, FlatGeobuf,
        ...), a GeoParquet file, or a CSV table (``.csv``, ``.tsv``,
        ``.txt``; the delimiter is detected) whose rows are points given by two
        coordinate columns. A ``.parquet`` file without geometry metadata is
        read as a table too.
    x, y : str, optional
        Names of the coordinate columns of a table. When omitted, the first
        pair found among ``longitude/latitude``, ``lon/lat``, ``lng/lat``,
        ``long/lat``, ``x/y`` and ``easting/northing`` (any letter case) is
        used. Not allowed for files that store geometries.
    crs : str, int, pyproj.CRS or None, default "EPSG:4326"
        CRS of the coordinates of a table, or of a vector file that stores
        none (a Shapefile without ``.prj``); None leaves them without CRS
        (planar coordinates). A file's own CRS always wins.
    layer : str or int, optional
        Layer to read from a multi-layer file such as a GeoPackage; the first
        layer by default.

    Returns
    -------
    geopandas.GeoDataFrame
        Every row of the file; for a table, all its columns plus point
        geometries (missing where a coordinate is missing).

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    geoalpha.errors.InvalidInputError
        If the file cannot be read, the coordinate columns are not found or
        not numeric, or lon/lat coordinates are out of range.

    Examples
    --------
    >>> from geoalpha import datasets
    >>> from geoalpha.io import read_points
    >>> gdf = read_points(datasets.path("stats19"))  # Longitude/Latitude found
    >>> gdf.crs.to_epsg(), gdf.geom_type.unique().tolist()
    (4326, ['Point'])
    """
    from geoalpha.crs import parse_crs

    source = os.fspath(path)
    local = "://" not in source and not source.startswith("/vsi")
    if local and not Path(source).exists():
        raise FileNotFoundError(f"input file {source} does not exist")
    crs = parse_crs(crs)

    suffix = Path(source).suffix.lower()
    if suffix in _TABLE_SUFFIXES:
        if layer is not None:
            raise InvalidInputError(
                f"{source} is a table; layer= (--layer) applies to multi-layer files"
            )
        return _points_from_table(_read_csv(source), source, x, y, crs)
    if suffix in _PARQUET_SUFFIXES and not _has_geo_metadata(source):
        return _points_from_table(_read_parquet_table(source), source, x, y, crs)

    if x is not None or y is not None:
        raise InvalidInputError(
            f"{source} stores geometries; x= and y= (--x, --y) apply to tables "
            "(CSV) only"
        )
    gdf = _read_vector(source, suffix, layer)
    if gdf.crs is None and crs is not None:
        import shapely

        xy = shapely.get_coordinates(gdf.geometry.array)
        _check_lonlat(xy[:, 0], xy[:, 1], crs, source, "x", "y")
        gdf = gdf.set_crs(crs)
    return gdf


def _read_vector(source: str, suffix: str, layer: str | int | None):
    import geopandas as gpd

    try:
        if suffix in _PARQUET_SUFFIXES:
            if layer is not None:
                raise InvalidInputError(
                    f"{source} is a GeoParquet file; it has no layers"
                )
            return gpd.read_parquet(source)
        return gpd.read_file(source, layer=layer)
    except (ImportError, InvalidInputError):
        raise
    except Exception as err:  # GDAL/pyogrio/fiona/pyarrow errors vary
        raise InvalidInputError(f"cannot read {source}: {_one_line(err)}") from err


def _read_csv(source: str):
    import pandas as pd

    try:
        with open(source, encoding="utf-8-sig", newline="") as handle:
            sample = handle.read(65536)
        try:
            sep = csv.Sniffer().sniff(sample, delimiters=",;\t|").delimiter
        except csv.Error:
            sep = ","
        return pd.read_csv(source, sep=sep, encoding="utf-8-sig", low_memory=False)
    except UnicodeDecodeError as err:
        raise InvalidInputError(
            f"cannot read {source}: it is not UTF-8 text ({err.reason} at byte "
            f"{err.start}); save it as UTF-8 CSV"
        ) from err
    except (OSError, ValueError, pd.errors.ParserError) as err:
        raise InvalidInputError(f"cannot read {source}: {_one_line(err)}") from err


def _has_geo_metadata(source: str) -> bool:
    pq = _import_pyarrow_parquet()
    try:
        metadata = pq.read_schema(source).metadata or {}
    except Exception as err:  # pyarrow raises ArrowInvalid, OSError, ...
        raise InvalidInputError(f"cannot read {source}: {_one_line(err)}") from err
    return b"geo" in metadata


def _read_parquet_table(source: str):
    import pandas as pd

    try:
        return pd.read_parquet(source)
    except Exception as err:  # pragma: no cover - schema was readable just before
        raise InvalidInputError(f"cannot read {source}: {_one_line(err)}") from err


def _import_pyarrow_parquet():
    try:
        import pyarrow.parquet as pq
    except ImportError as err:
        raise ImportError(
            "reading and writing GeoParquet needs pyarrow: "
            "pip install 'geoalpha[parquet]' (or pip install pyarrow)"
        ) from err
    return pq


def _find_coordinate_columns(
    columns: list[str], x: str | None, y: str | None, source: str
) -> tuple[str, str]:
    found = ", ".join(map(str, columns)) or "none"
    if (x is None) != (y is None):
        raise InvalidInputError(
            f"give both x= and y= (--x and --y) for {source}, or neither to detect them"
        )
    if x is not None and y is not None:
        missing = [name for name in (x, y) if name not in columns]
        if missing:
            raise InvalidInputError(
                f"coordinate column {', '.join(map(repr, missing))} not found in "
                f"{source}; its columns are: {found}"
            )
        return x, y
    lower = {str(column).lower(): column for column in reversed(columns)}
    for x_name, y_name in COORDINATE_NAMES:
        if x_name in lower and y_name in lower:
            return lower[x_name], lower[y_name]
    pairs = ", ".join(f"{a}/{b}" for a, b in COORDINATE_NAMES)
    raise InvalidInputError(
        f"no coordinate columns found in {source} (looked for {pairs}); its "
        f"columns are: {found}; name them with x= and y= (--x and --y)"
    )


def _points_from_table(frame: pd.DataFrame, source, x, y, crs) -> gpd.GeoDataFrame:
    import geopandas as gpd
    import numpy as np
    import pandas as pd

    x, y = _find_coordinate_columns(list(frame.columns), x, y, source)
    values = {}
    for name in (x, y):
        raw = frame[name]
        numeric = pd.to_numeric(raw, errors="coerce")
        bad = numeric.isna() & raw.notna()
        if bad.any():
            examples = ", ".join(repr(v) for v in raw[bad].unique()[:3])
            raise InvalidInputError(
                f"coordinate column {name!r} of {source} has {int(bad.sum())} "
                f"non-numeric values (e.g. {examples})"
            )
        values[name] = numeric.to_numpy(dtype=float)
    xs, ys = values[x], values[y]
    _check_lonlat(xs, ys, crs, source, x, y)
    geometry = gpd.points_from_xy(xs, ys)
    missing = np.isnan(xs) | np.isnan(ys)
    if missing.any():
        geometry[missing] = None  # missing, not POINT (NaN NaN)
    return gpd.GeoDataFrame(frame, geometry=geometry, crs=crs)


def _check_lonlat(xs, ys, crs, source: str, x: str, y: str) -> None:
    import numpy as np

    if crs is None or not crs.is_geographic:
        return
    xs = np.asarray(xs, dtype=float)
    ys = np.asarray(ys, dtype=float)
    with np.errstate(invalid="ignore"):
        outside = (np.abs(xs) > 180) | (np.abs(ys) > 90)
    if outside.any():
        raise InvalidInputError(
            f"{int(outside.sum())} points of {source} have {x}/{y} outside the "
            f"longitude/latitude range of {crs.to_string()}; if they are "
            "projected coordinates, give their CRS with crs= (--crs-in), "
            "e.g. EPSG:27700"
        )


# --------------------------------------------------------------------------
# writing


def write_hulls(
    gdf: gpd.GeoDataFrame,
    path: PathLike,
    *,
    layer: str | None = None,
    overwrite: bool = False,
    engine: str | None = None,
) -> dict[str, str]:
    """Write hulls to a file, in the format its extension names, atomically.

    The file is written to a temporary directory beside ``path`` (so on the
    same file system) and then moved into place, so a failure while writing
    leaves no half-written file and leaves an existing file untouched.

    Parameters
    ----------
    gdf : geopandas.GeoDataFrame
        What to write, usually the result of :func:`geoalpha.hull`.
    path : str or os.PathLike
        Output file. Its extension chooses the format: ``.gpkg``
        (GeoPackage), ``.shp`` (Shapefile), ``.geojson`` or ``.json``
        (GeoJSON), ``.fgb`` (FlatGeobuf), ``.parquet`` (GeoParquet).
    layer : str, optional
        GeoPackage layer name; default the file name without extension
        (``"hulls"`` if that is empty). Only for ``.gpkg``.
    overwrite : bool, default False
        Replace ``path`` if it exists (for a GeoPackage: the whole file,
        other layers included; for a Shapefile: all its sidecar files).
    engine : {None, "pyogrio", "fiona"}
        Library geopandas writes vector files with; None lets geopandas
        choose. Not used for GeoParquet.

    Returns
    -------
    dict of str to str
        Columns renamed to fit the Shapefile limit of 10 characters per field
        name, ``{old: new}``; empty for the other formats or when nothing was
        renamed.

    Raises
    ------
    FileExistsError
        If ``path`` exists and ``overwrite`` is False.
    FileNotFoundError
        If the directory of ``path`` does not exist.
    geoalpha.errors.InvalidInputError
        For an unknown extension or engine, or ``layer`` for a format without
        layers.

    Notes
    -----
    Shapefile field names longer than 10 characters (bytes, in UTF-8) are
    truncated; a truncated name that would collide with another (compared
    ignoring case, as the dBASE format does) gets a numbered suffix:
    ``Local_Authority_(Highway)`` becomes ``Local_Auth``, and a second
    ``Local_Authority_Name`` becomes ``Local_Au_1``. The ``.prj`` file holding
    the CRS is always written; its absence is an error.

    Examples
    --------
    >>> import geopandas as gpd
    >>> from shapely import box
    >>> from geoalpha.io import write_hulls
    >>> hulls = gpd.GeoDataFrame(
    ...     {"Local_Authority_(Highway)": ["E09000020"], "alpha": [0.01]},
    ...     geometry=[box(-0.2, 51.5, -0.1, 51.6)], crs="EPSG:4326")
    >>> write_hulls(hulls, "hulls.shp")  # doctest: +SKIP
    {'Local_Authority_(Highway)': 'Local_Auth'}
    >>> write_hulls(hulls, "hulls.gpkg", overwrite=True)  # doctest: +SKIP
    {}
    """
    import geopandas as gpd

    if not isinstance(gdf, gpd.GeoDataFrame):
        raise InvalidInputError(
            f"write_hulls() needs a GeoDataFrame; got {type(gdf).__name__}"
        )
    if engine not in _ENGINES:
        raise InvalidInputError(
            f"unknown engine {engine!r}; expected 'pyogrio', 'fiona' or None"
        )
    target, suffix, targets = _check_target(path, layer, overwrite)
    parent = target.parent

    frame = _index_as_columns(gdf)
    mapping: dict[str, str] = {}
    if suffix == ".shp":
        mapping = _shapefile_names(
            [c for c in frame.columns if c != frame.geometry.name]
        )
        if mapping:
            frame = frame.rename(columns=mapping)

    staging = Path(tempfile.mkdtemp(prefix=f".{target.name}.", dir=parent))
    try:
        staged = staging / target.name
        if suffix == ".parquet":
            _import_pyarrow_parquet()
            gdf.to_parquet(staged)
        else:
            kwargs: dict[str, Any] = {"driver": WRITE_FORMATS[suffix], "index": False}
            if engine is not None:
                kwargs["engine"] = engine
            if suffix == ".gpkg":
                kwargs["layer"] = layer or target.stem or "hulls"
            if suffix == ".shp":
                kwargs["encoding"] = "UTF-8"
            frame.to_file(staged, **kwargs)
        if suffix == ".shp" and frame.crs is not None:
            prj = staged.with_suffix(".prj")
            if not prj.exists():
                raise OSError(
                    f"the Shapefile writer did not write {prj.name} for CRS "
                    f"{frame.crs.to_string()}; write another format instead"
                )
        _move_into_place(staging, target, targets)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    return mapping


def check_output(
    path: PathLike, *, layer: str | None = None, overwrite: bool = False
) -> None:
    """Check, before any work, that :func:`write_hulls` can write ``path``.

    Parameters
    ----------
    path : str or os.PathLike
        Output file; see :func:`write_hulls` for the extensions understood.
    layer : str, optional
        GeoPackage layer name, as for :func:`write_hulls`.
    overwrite : bool, default False
        Whether an existing file may be replaced.

    Raises
    ------
    FileExistsError, FileNotFoundError, IsADirectoryError
        If ``path`` exists (without ``overwrite``), its directory does not,
        or it is a directory.
    geoalpha.errors.InvalidInputError
        For an unknown extension, or ``layer`` with a format without layers.

    Examples
    --------
    >>> from geoalpha.io import check_output
    >>> check_output("hulls.gpkg")  # doctest: +SKIP
    >>> try:
    ...     check_output("hulls.csv")
    ... except ValueError as err:
    ...     print(err)  # doctest: +ELLIPSIS
    cannot tell the output format of hulls.csv: its extension must be one of .gpkg, ...
    """
    _check_target(path, layer, overwrite)


def _check_target(path, layer, overwrite) -> tuple[Path, str, list[Path]]:
    target = Path(path)
    suffix = target.suffix.lower()
    if suffix not in WRITE_FORMATS:
        raise InvalidInputError(
            f"cannot tell the output format of {target}: its extension must be "
            f"one of {', '.join(WRITE_FORMATS)}"
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
    targets = _target_files(target, suffix)
    existing = [p for p in targets if p.exists() or p.is_symlink()]
    if existing and not overwrite:
        raise FileExistsError(
            f"output {existing[0]} already exists; use --overwrite "
            "(overwrite=True) to replace it"
        )

    return target, suffix, targets


def _target_files(target: Path, suffix: str) -> list[Path]:
    """Files that make up the output (a Shapefile has sidecars)."""
    if suffix != ".shp":
        return [target]
    upper = target.suffix.isupper()
    return [target] + [
        target.with_suffix(ext.upper() if upper else ext) for ext in _SHAPEFILE_SIDECARS
    ]


def _move_into_place(staging: Path, target: Path, targets: list[Path]) -> None:
    """Move the staged files over the targets; the main file goes last."""
    written = {p.name for p in staging.iterdir() if p.is_file()}
    if target.name not in written:
        raise OSError(f"the writer did not create {target.name}")
    sidecars = sorted(written - {target.name})
    for name in [*sidecars, target.name]:
        os.replace(staging / name, target.parent / name)
    for stale in targets:  # e.g. an old .cpg the new Shapefile does not have
        if stale.name not in written and (stale.exists() or stale.is_symlink()):
            stale.unlink()


def _index_as_columns(gdf):
    """Turn an index geopandas would write into ordinary columns."""
    import pandas as pd

    index = gdf.index
    named = any(name is not None for name in index.names)
    if (
        named
        or isinstance(index, pd.MultiIndex)
        or not pd.api.types.is_integer_dtype(index.dtype)
    ):
        return gdf.reset_index()
    return gdf


def _truncate_bytes(name: str, limit: int) -> str:
    """Longest prefix of ``name`` whose UTF-8 encoding fits in ``limit`` bytes."""
    encoded = name.encode("utf-8")[:limit]
    return encoded.decode("utf-8", errors="ignore")


def _shapefile_names(columns: list) -> dict[str, str]:
    """Map column names that do not fit a dBASE field to unique short names.

    Names that already fit keep theirs (and are reserved first, so a
    truncated name never takes one); the others are cut to 10 bytes, or to
    fewer plus ``_1``, ``_2``, ... when the cut name is taken. Names compare
    ignoring case, as in dBASE.
    """
    used: set[str] = set()
    keep: set[str] = set()
    for column in columns:
        name = str(column)
        fits = len(name.encode("utf-8")) <= _DBF_NAME_BYTES
        if fits and name.lower() not in used:
            used.add(name.lower())
            keep.add(name)
    mapping: dict[str, str] = {}
    for column in columns:
        name = str(column)
        if name in keep:
            continue
        new = _truncate_bytes(name, _DBF_NAME_BYTES)
        number = 0
        while not new or new.lower() in used:
            number += 1
            tail = f"_{number}"
            new = _truncate_bytes(name, _DBF_NAME_BYTES - len(tail)) + tail
        used.add(new.lower())
        mapping[column] = new
    return mapping


def _one_line(err: BaseException) -> str:
    """Return an exception's message on one line."""
    text = " ".join(str(err).split())
    return text or type(err).__name__
