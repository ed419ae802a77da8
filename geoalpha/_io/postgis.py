"""Read points from PostGIS and write hulls back, safely (see ``docs/postgis.md``)."""

from __future__ import annotations

import contextlib
import gc
import os
import re
import warnings
from collections.abc import Iterator
from typing import TYPE_CHECKING, Any

from geoalpha._io.redact import redact as redact_text
from geoalpha.errors import DatabaseError, InvalidInputError, first_n, setting

if TYPE_CHECKING:  # pragma: no cover
    import geopandas as gpd
    import psycopg
    import sqlalchemy

__all__ = [
    "check_postgis_output",
    "is_postgres_url",
    "parse_table",
    "read_postgis",
    "redact",
    "write_postgis",
]

_SCHEMES = ("postgresql://", "postgres://", "postgresql+psycopg://")
_CONNECT_TIMEOUT = 15  # seconds, unless the URL says connect_timeout=...
_LOCK_TIMEOUT = "SET LOCAL lock_timeout = '30s'"
_IDENTIFIER_BYTES = 63  # PostgreSQL's NAMEDATALEN - 1
_secrets: set[str] = set()
# one part of schema.table: "quoted" ("" is a quote), or bare up to a dot
_NAME_PART = re.compile(r'"(?P<quoted>(?:[^"]|"")*)"|(?P<bare>(?!")[^.]*)')


def is_postgres_url(text: object) -> bool:
    """Tell whether ``text`` is a ``postgresql://`` (or ``postgres://``) URL.

    Examples
    --------
    >>> from geoalpha._io.postgis import is_postgres_url
    >>> is_postgres_url("postgresql://ga@127.0.0.1:5432/gadb")
    True
    >>> is_postgres_url("hulls.gpkg")
    False
    """
    return isinstance(text, str) and text.strip().lower().startswith(_SCHEMES)


def redact(text: object) -> str:
    """Return ``text`` with every database password replaced by ``***``.

    As :func:`geoalpha._io.redact.redact`, plus ``PGPASSWORD`` and the
    passwords of the URLs read in this process.

    Examples
    --------
    >>> from geoalpha._io.postgis import redact
    >>> redact("cannot connect to postgresql://ga:p%40ss@db:5432/gadb")
    'cannot connect to postgresql://ga:***@db:5432/gadb'
    """
    return redact_text(text, {*_secrets, os.environ.get("PGPASSWORD", "")})


def parse_table(name: str) -> tuple[str | None, str]:
    """Split ``schema.table`` into (schema or None, table).

    Names are taken as written (case and all), as ``to_postgis`` creates
    them; a part in double quotes may contain dots.

    Examples
    --------
    >>> from geoalpha._io.postgis import parse_table
    >>> parse_table("public.hulls")
    ('public', 'hulls')
    >>> parse_table("hulls")
    (None, 'hulls')
    >>> parse_table('"my.schema"."Hulls 2024"')
    ('my.schema', 'Hulls 2024')
    """
    text = (name or "").strip()
    parts: list[str] = []
    pos = 0
    while True:
        part = _NAME_PART.match(text, pos)
        if part is None:
            raise InvalidInputError(f"unbalanced quotes in table name {name!r}")
        quoted = part["quoted"]
        parts.append(part["bare"] if quoted is None else quoted.replace('""', '"'))
        pos = part.end()
        if pos == len(text):
            break
        if text[pos] != ".":
            raise InvalidInputError(f"cannot read table name {name!r}")
        pos += 1
    if len(parts) not in (1, 2) or not all(parts):
        raise InvalidInputError(
            f"table name {name!r} must be 'table' or 'schema.table'"
        )
    if any(len(p.encode("utf-8")) > _IDENTIFIER_BYTES for p in parts):
        raise InvalidInputError(
            f"table name {name!r} is longer than PostgreSQL's 63 bytes per name"
        )
    return (parts[0], parts[1]) if len(parts) == 2 else (None, parts[0])


def _quote(*parts: str | None) -> str:
    return ".".join('"' + p.replace('"', '""') + '"' for p in parts if p is not None)


def _import_drivers():
    try:
        import geoalchemy2  # noqa: F401
        import psycopg  # noqa: F401
        import sqlalchemy
    except ImportError as err:
        raise ImportError(
            f"reading and writing PostGIS needs SQLAlchemy, psycopg and "
            f'GeoAlchemy2 ({err.name} is missing): pip install "geoalpha[postgis]"'
        ) from err
    return sqlalchemy


def _parse_url(url: str) -> tuple[sqlalchemy.engine.URL, dict[str, Any]]:
    """Check a ``postgresql://`` URL; return it (psycopg driver) and connect args."""
    sqlalchemy = _import_drivers()
    if not is_postgres_url(url):
        raise InvalidInputError(
            f"{redact(url)} is not a postgresql://user@host:port/dbname URL"
        )
    try:
        parsed = sqlalchemy.engine.make_url(url.strip())
        port = parsed.port  # noqa: F841 - a bad port raises here
    except Exception as err:  # ArgumentError, ValueError for a bad port
        raise InvalidInputError(
            f"cannot read the database URL {redact(url)}: "
            + redact(one_line(err, sentences=True))
        ) from None
    if parsed.password:
        _secrets.add(str(parsed.password))
        _secrets.add(url.split("://", 1)[1].split("@", 1)[0].partition(":")[2])
    parsed = parsed.set(drivername="postgresql+psycopg")
    if not parsed.database:
        raise InvalidInputError(
            f"the database URL {redact(url)} names no database; "
            "give postgresql://user@host:port/dbname"
        )
    args: dict[str, Any] = {"application_name": "geoalpha"}
    if "connect_timeout" not in parsed.query:
        args["connect_timeout"] = _CONNECT_TIMEOUT
    return parsed, args


def _display(url) -> str:
    """Return the URL without its password (for a connection, its own URL)."""
    if isinstance(url, str):
        return redact(url.strip())
    info = getattr(url, "info", None)
    if not hasattr(info, "dbname"):  # not a psycopg connection
        raise InvalidInputError(
            "give a postgresql://user@host:port/dbname URL or an open psycopg "
            f"connection (got {type(url).__name__})"
        )
    return redact(f"postgresql://{info.user}@{info.host}:{info.port}/{info.dbname}")


def _message(err: BaseException) -> str:
    """Return the database's own message, on one line, without a password."""
    orig = getattr(err, "orig", None) or err
    primary = getattr(getattr(orig, "diag", None), "message_primary", None)
    line = one_line(primary or str(orig), sentences=True)
    # libpq: 'connection failed: connection to server at "h" (ip), port 5 failed:
    # FATAL:  password authentication failed for user "ga"' -> the last part
    return redact(re.sub(r"^.*failed:\s*(FATAL:\s*)?", "", line) or line)


@contextlib.contextmanager
def _connection(url: str, *, write: bool) -> Iterator[Any]:
    """Open a transaction: read-only on psycopg, or for to_postgis on SQLAlchemy."""
    sqlalchemy = _import_drivers()
    import psycopg

    engine = None
    if write:  # on the psycopg 3 driver
        parsed, args = _parse_url(url)
        pool = sqlalchemy.pool.NullPool
        engine = sqlalchemy.create_engine(parsed, poolclass=pool, connect_args=args)
    where = _display(url)
    connected = False
    try:
        with engine.begin() if write else _read_only(url) as conn:
            connected = True
            if write:  # one round trip (no parameters: the simple protocol)
                _execute(conn, "SET TRANSACTION READ WRITE; " + _LOCK_TIMEOUT)
            yield conn
    except BaseException as err:
        cause = _database_cause(err, (sqlalchemy.exc.DBAPIError, psycopg.Error))
        if cause is None:
            raise
        where = where if connected else f"cannot connect to {where}"
        raise DatabaseError(f"{where}: {_message(cause)}") from None
    finally:
        if engine is not None:
            engine.dispose()


@contextlib.contextmanager
def _read_only(url) -> Iterator[Any]:
    """Open a read-only transaction; an open connection stays open (or a savepoint)."""
    import psycopg

    if isinstance(url, psycopg.Connection):
        idle = url.info.transaction_status == psycopg.pq.TransactionStatus.IDLE
        with url.transaction():
            if idle:  # one round trip (no parameters: the simple protocol)
                url.execute("SET TRANSACTION READ ONLY; " + _LOCK_TIMEOUT)
            yield url
        return
    parsed, args = _parse_url(url)
    _, params = parsed.get_dialect()().create_connect_args(parsed)
    with psycopg.connect(**params, **args) as conn:  # commits, or rolls back
        conn.read_only = True
        conn.execute(_LOCK_TIMEOUT)
        yield conn


def _execute(conn, sql: str, params: tuple = ()):
    """Run ``sql`` on a SQLAlchemy or a psycopg connection; return the cursor."""
    run = getattr(conn, "exec_driver_sql", None) or conn.execute
    return run(sql, params or None)


def _database_cause(err: BaseException, kind) -> BaseException | None:
    """Return the database error behind ``err`` (pandas wraps them), or None."""
    for _ in range(5):  # a short chain: ours, pandas', SQLAlchemy's
        if err is None or isinstance(err, kind):
            return err
        err = err.__cause__ or err.__context__
    return None


_GEOMETRY_OID = "SELECT to_regtype('geometry')::oid"


def _check_postgis(oid, where: str) -> int:
    if oid is None:
        raise DatabaseError(
            f"{where} has no PostGIS: run CREATE EXTENSION postgis in that database"
        )
    return int(oid)


def read_postgis(
    url: str | psycopg.Connection,
    *,
    table: str | None = None,
    sql: str | None = None,
    geometry_column: str | None = None,
    crs: Any = "EPSG:4326",
) -> gpd.GeoDataFrame:
    """Read a PostGIS table, or the result of a query, into a GeoDataFrame.

    Parameters
    ----------
    url : str or psycopg.Connection
        ``postgresql://user@host:port/dbname``, or an open psycopg 3
        connection (left open: reading many times saves a login each time).
    table : str, optional
        ``schema.table`` or ``table`` (on the search path), names as written.
    sql : str, optional
        A ``SELECT`` query, instead of ``table``; it runs in a read-only transaction.
    geometry_column : str, optional
        The geometry column to use; needed only when there is more than one.
    crs : str, int, pyproj.CRS or None, default "EPSG:4326"
        CRS for geometries stored without SRID (SRID 0); the SRID wins.

    Returns
    -------
    geopandas.GeoDataFrame
        Every row; the geometry column keeps its name, in the CRS of its SRID.

    Raises
    ------
    geoalpha.errors.DatabaseError
        When the server, the login, PostGIS, the table or the query fails
        (one line, without the password).
    geoalpha.errors.InvalidInputError
        For a malformed URL or table name, both or neither of ``table`` and
        ``sql``, or a missing or ambiguous geometry column.

    Examples
    --------
    With a PostGIS database (``docs/postgis.md`` loads the bundled data into
    one; ``tests/test_postgis.py`` runs this against a real server):

    >>> import geoalpha
    >>> url = "postgresql://ga@127.0.0.1:5432/gadb"
    >>> points = geoalpha.read_postgis(url, table="public.accidents")  # doctest: +SKIP
    >>> points = geoalpha.read_postgis(
    ...     url, sql="SELECT * FROM public.accidents WHERE year = 2014"
    ... )  # doctest: +SKIP
    >>> hulls = points.alpha.hull(by="cluster")  # doctest: +SKIP
    """
    if (table is None) == (sql is None):
        raise InvalidInputError(
            "give the table to read (--layer schema.table) or a query (--sql "
            "'SELECT ...'), not both or neither"
        )
    where = _display(url)
    with _connection(url, write=False) as conn:
        qualified = None if table is None else _quote(*parse_table(table))
        oid, found = _execute(  # one round trip
            conn, _GEOMETRY_OID + ", to_regclass(%s)", (qualified,)
        ).fetchone()
        oid = _check_postgis(oid, where)
        if table is None:
            query = sql.strip().rstrip(";")
            source = "the query"
        elif found is None:
            rows = _execute(
                conn,
                "SELECT f_table_schema, f_table_name FROM geometry_columns "
                "ORDER BY 1, 2 LIMIT 21",
            ).fetchall()
            tables = first_n((f"{s}.{t}" for s, t in rows), 20) or "none"
            raise DatabaseError(
                f"table {table} not found in {where}; tables with a geometry "
                f"column: {tables}"
            )
        else:
            query = f"SELECT * FROM {qualified}"
            source = f"table {table}"
        # as written (no placeholders); binary: geometries as EWKB, not hex
        cursor = conn.cursor().execute(
            f"SELECT * FROM ({query}) AS _geoalpha_q LIMIT 0", binary=True
        )
        description = cursor.description
        names = [c.name for c in description]
        geometries = [c.name for c in description if c.type_code == oid]
        column = _pick_geometry(geometries, names, geometry_column, source)
        typmod = cursor.pgresult.fmod(names.index(column))  # geometry(Point, 4326)?
        frame = _read_frame(conn, query, description, column, typmod, source)
    if frame.crs is None and crs is not None:
        frame = frame.set_crs(crs)
    return frame


def _read_frame(conn, query: str, description, column: str, typmod: int, source):
    """Run ``query``: points as arrays (:func:`_read_points`), else rows of WKB."""
    import geopandas as gpd
    import pandas as pd
    import shapely

    names = [c.name for c in description]
    read = _read_points(conn, query, description, column, typmod)
    if read is None:
        with conn.cursor() as cursor:
            rows = cursor.execute(query, binary=True).fetchall()
        frame = pd.DataFrame.from_records(rows, columns=names, coerce_float=True)
        geometry = shapely.from_wkb(frame[column].to_numpy(dtype=object))
        srids = shapely.get_srid(geometry[~shapely.is_missing(geometry)])
        srids = sorted(set(srids.tolist()) - {0})
    else:
        frame, geometry, srid = read
        srids = [srid] if srid else []
    if len(srids) > 1:
        raise InvalidInputError(
            f"{source} has geometries in {len(srids)} SRIDs ({srids[:5]}); "
            "select one, or ST_Transform them to one"
        )
    crs = _crs_of(conn, srids[0]) if srids else None
    geometry = gpd.array.from_shapely(geometry, crs=crs)
    if column in frame:
        frame[column] = geometry
    else:
        frame.insert(names.index(column), column, geometry)
    return gpd.GeoDataFrame(frame, geometry=column, copy=False)


# column types read as one array each: as raw values in a bytea (the type's
# binary send function, read with numpy) or as array_agg (loaded by psycopg
# like the column itself)
_SENT_TYPES = {  # oid: (send function, numpy dtype of its bytes, of the column)
    16: ("boolsend", "?", "bool"),
    20: ("int8send", ">i8", "int64"),
    21: ("int2send", ">i2", "int64"),
    23: ("int4send", ">i4", "int64"),
    700: ("float4send", ">f4", "float64"),
    701: ("float8send", ">f8", "float64"),
}
_AGGREGATED_TYPES = frozenset((25, 1042, 1043, 1082, 1114, 1184, 1700))
# text, bpchar, varchar, date, timestamp, timestamptz, numeric
_ARRAY_ROWS = 2_000_000  # more rows come as rows (a bytea holds 1 GB at most)


def _read_points(conn, query: str, description, column: str, typmod: int):
    """Read 2D points as arrays in one aggregate row: (frame, points, SRID), or None."""
    import numpy as np
    import pandas as pd
    import psycopg
    import shapely

    names = [c.name for c in description]
    others = [c for c in description if c.name != column]
    if len(set(names)) < len(names) or any(n.startswith("_ga_") for n in names):
        return None
    if any(c.type_code not in _SENT_TYPES.keys() | _AGGREGATED_TYPES for c in others):
        return None
    g = f"_ga_q.{_quote(column)}"
    srid = _point_typmod_srid(typmod)
    checked = ""
    aggregates = ["count(*)", "count(_ga_x)"]
    aggregates += [f"string_agg(float8send(_ga_{a}), ''::bytea)" for a in "xy"]
    if srid is None:
        checked = f", ST_Zmflag({g}) AS _ga_zm, ST_SRID({g}) AS _ga_srid"
        aggregates += ["max(_ga_zm)", "min(_ga_srid)", "max(_ga_srid)"]
    for c in others:
        name = _quote(c.name)
        if c.type_code in _SENT_TYPES:
            send = _SENT_TYPES[c.type_code][0]
            aggregates += [f"count({name})", f"string_agg({send}({name}), ''::bytea)"]
        else:
            aggregates.append(f"array_agg({name})")
    sql = (
        f"SELECT {', '.join(aggregates)} FROM (SELECT _ga_q.*, "
        f"ST_X({g}) AS _ga_x, ST_Y({g}) AS _ga_y{checked} "
        f"FROM ({query}) AS _ga_q LIMIT {_ARRAY_ROWS + 1}) AS _ga_r"
    )
    try:
        with conn.transaction():  # a savepoint: a failure leaves the rows path
            values = list(conn.cursor().execute(sql, binary=True).fetchone())
    except psycopg.Error:
        return None
    n, n_points, x, y = values[:4]
    if srid is None:
        zm, srid, srid_max = values[4:7]
        del values[4:7]
        if zm != 0 or srid != srid_max:
            return None
    if not 0 < n == n_points <= _ARRAY_ROWS:
        return None
    columns = {}
    rest = iter(values[4:])
    for c in others:
        if c.type_code in _SENT_TYPES:
            _, raw, dtype = _SENT_TYPES[c.type_code]
            if next(rest) < n:  # NULLs: as rows, as pandas reads them
                return None
            columns[c.name] = np.frombuffer(next(rest), dtype=raw).astype(dtype)
        else:
            columns[c.name] = pd.DataFrame.from_records(
                [(v,) for v in next(rest)], coerce_float=True
            )[0]
    xy = np.empty((n, 2))  # native doubles, from the big-endian ones sent
    xy[:, 0], xy[:, 1] = np.frombuffer(x, dtype=">f8"), np.frombuffer(y, dtype=">f8")
    frame = pd.DataFrame(columns, index=pd.RangeIndex(n))
    # One geometry a row: the cyclic collector, were it to run on the way,
    # would walk every object of the process (3-5 ms on 9,000 points in a
    # benchmark's process); geometries hold no cycles, so it waits.
    enabled = gc.isenabled()
    gc.disable()
    try:
        points = shapely.points(xy)
    finally:
        if enabled:
            gc.enable()
    return frame, points, srid


def _point_typmod_srid(typmod: int) -> int | None:
    """Return the SRID of a ``geometry(Point, srid)`` column type (2D), or None.

    The type modifier holds the geometry type in bits 2-7 (Point: 1), M and Z in
    bits 0-1, the SRID (which inserted rows are checked against) in bits 8-28.
    """
    if typmod is None or typmod < 0 or typmod & 0xFF != 1 << 2:
        return None
    return ((typmod & 0x0FFFFF00) - (typmod & 0x10000000)) >> 8


def _crs_of(conn, srid: int):
    """Return the CRS of an SRID, from the database's own ``spatial_ref_sys``."""
    row = _execute(
        conn,
        "SELECT auth_name, auth_srid, srtext FROM spatial_ref_sys WHERE srid = %s",
        (srid,),
    ).fetchone()
    if row is None:
        raise DatabaseError(f"SRID {srid} is not in spatial_ref_sys")
    auth_name, auth_srid, srtext = row
    return f"{auth_name}:{auth_srid}" if auth_name and auth_srid else srtext


def _pick_geometry(geometries, names, wanted, source) -> str:
    if wanted is not None:
        if wanted not in names:
            raise InvalidInputError(
                f"geometry column {wanted!r} not found in {source}; its columns "
                f"are: {', '.join(names)}"
            )
        if wanted not in geometries:
            raise InvalidInputError(
                f"column {wanted!r} of {source} is not of type geometry"
            )
        return wanted
    if not geometries:
        raise InvalidInputError(
            f"{source} has no geometry column (columns: {', '.join(names)}); "
            "geography columns need a cast, e.g. SELECT geog::geometry AS geom ..."
        )
    if len(geometries) > 1:
        raise InvalidInputError(
            f"{source} has {len(geometries)} geometry columns "
            f"({', '.join(geometries)}); choose one with --geometry-column "
            "(geometry_column=)"
        )
    return geometries[0]


def check_postgis_output(
    url: str, table: str | None, *, overwrite: bool = False
) -> None:
    """Check, before any work, that :func:`write_postgis` can write ``table``.

    Connects, and checks the schema, and the table unless ``overwrite``.

    Raises
    ------
    geoalpha.errors.DatabaseError, geoalpha.errors.InvalidInputError
        As :func:`write_postgis`.
    """
    schema, name = _output_table(table)
    with _connection(url, write=False) as conn:
        _check_target(conn, schema, name, table, overwrite, _display(url))


def _output_table(table: str | None) -> tuple[str | None, str]:
    if not table:
        raise InvalidInputError(
            "a postgresql:// OUTPUT needs the table to write: --output-layer "
            "schema.table (table= in Python)"
        )
    return parse_table(table)


def _check_target(conn, schema, name, table, overwrite, where) -> tuple[str, bool]:
    oid, schema, found, exists = _execute(  # one round trip
        conn,
        f"{_GEOMETRY_OID}, s, to_regnamespace(quote_ident(s)), "
        "to_regclass(quote_ident(s) || '.' || quote_ident(%s)) "
        "FROM (SELECT coalesce(%s, current_schema()) AS s) AS _ga_s",
        (name, schema),
    ).fetchone()
    _check_postgis(oid, where)
    if schema is None:
        raise DatabaseError(f"{where} has no schema on its search path")
    if found is None:
        raise DatabaseError(f"schema {schema} does not exist in {where}")
    if exists is not None and not overwrite:
        raise DatabaseError(
            f"table {table} already exists in {where}; use "
            f"{setting('overwrite', True)} to replace it"
        )
    return schema, exists is not None


def write_postgis(
    gdf: gpd.GeoDataFrame, url: str, table: str, *, overwrite: bool = False
) -> str:
    """Write a GeoDataFrame to a PostGIS table in one transaction.

    Readers see the old table or the whole new one (see ``docs/postgis.md``).

    Parameters
    ----------
    gdf : geopandas.GeoDataFrame
        What to write (without its index), usually a :func:`geoalpha.hull` result.
    url : str
        ``postgresql://user@host:port/dbname``.
    table : str
        ``schema.table`` or ``table`` (in the first schema of the search
        path), names as written.
    overwrite : bool, default False
        Replace the table if it exists (otherwise refused).

    Returns
    -------
    str
        The table written, ``schema.table``.

    Raises
    ------
    geoalpha.errors.DatabaseError
        When the server, the login or the write fails, the schema is missing
        or the table exists (without ``overwrite``); one line, no password.
    geoalpha.errors.InvalidInputError
        For a malformed URL or table name, or a CRS without an EPSG code.

    Examples
    --------
    With a PostGIS database (``tests/test_postgis.py`` runs this against a
    real server):

    >>> import geoalpha
    >>> from geoalpha import datasets
    >>> hulls = datasets.load("us_airports").alpha.hull(by="state")
    >>> url = "postgresql://ga@127.0.0.1:5432/gadb"
    >>> geoalpha.write_postgis(hulls, url, "public.state_hulls")  # doctest: +SKIP
    'public.state_hulls'
    """
    import geopandas as gpd

    if not isinstance(gdf, gpd.GeoDataFrame):
        raise InvalidInputError(
            f"write_postgis() needs a GeoDataFrame; got {type(gdf).__name__}"
        )
    schema, name = _output_table(table)
    if gdf.crs is not None and gdf.crs.to_epsg() is None:
        raise InvalidInputError(
            f"PostGIS stores a CRS by SRID; {gdf.crs.to_string()[:80]} has no "
            "EPSG code: to_crs() to one that has"
        )
    frame = _promote_to_multi(gdf)
    where = _display(url)
    import uuid  # (here: its import costs the command's --help 5 ms)

    temporary = f"geoalpha_tmp_{uuid.uuid4().hex}"
    with _connection(url, write=True) as conn:
        schema, exists = _check_target(conn, schema, name, table, overwrite, where)
        with warnings.catch_warnings():
            # Without a CRS the table gets SRID 0, as documented: geopandas'
            # "Could not parse CRS from the GeoDataFrame" would only repeat it.
            warnings.filterwarnings("ignore", "Could not parse CRS", UserWarning)
            # GeoAlchemy2's Geometry column (spatial_index=True by default)
            # comes with its GiST index
            frame.to_postgis(temporary, conn, schema=schema, index=False)
        if exists:
            conn.exec_driver_sql(f"DROP TABLE {_quote(schema, name)}")
        conn.exec_driver_sql(
            f"ALTER TABLE {_quote(schema, temporary)} RENAME TO {_quote(name)}"
        )
        _rename_indexes(conn, schema, name, temporary)
        conn.exec_driver_sql(f"ANALYZE {_quote(schema, name)}")
    return f"{schema}.{name}"


def _promote_to_multi(gdf: gpd.GeoDataFrame) -> gpd.GeoDataFrame:
    """Make Polygons MultiPolygons when both occur (one typed column, as GPKG)."""
    import numpy as np
    import shapely

    geoms = np.array(gdf.geometry.array, dtype=object)  # a copy
    kinds = shapely.get_type_id(geoms)
    polygons = kinds == shapely.GeometryType.POLYGON
    if not (polygons.any() and (kinds == shapely.GeometryType.MULTIPOLYGON).any()):
        return gdf
    geoms[polygons] = shapely.multipolygons(geoms[polygons, np.newaxis])
    return gdf.set_geometry(gdf.geometry.__class__(geoms, index=gdf.index, crs=gdf.crs))


def _rename_indexes(conn, schema: str, name: str, temporary: str) -> None:
    """Give the new table's indexes names after the table, where free."""
    rows = conn.exec_driver_sql(
        "SELECT c.relname FROM pg_index i JOIN pg_class c ON c.oid = i.indexrelid "
        "WHERE i.indrelid = to_regclass(%s) AND strpos(c.relname, %s) > 0",
        (_quote(schema, name), temporary),
    ).fetchall()
    for (index,) in rows:
        new = truncate_bytes(index.replace(temporary, name), _IDENTIFIER_BYTES)
        free = conn.exec_driver_sql("SELECT to_regclass(%s)", (_quote(schema, new),))
        if free.scalar() is None:
            conn.exec_driver_sql(
                f"ALTER INDEX {_quote(schema, index)} RENAME TO {_quote(new)}"
            )


def truncate_bytes(name: str, limit: int) -> str:
    """Longest prefix of ``name`` whose UTF-8 encoding fits in ``limit`` bytes."""
    return name.encode("utf-8")[:limit].decode("utf-8", errors="ignore")


def one_line(err: BaseException | str, *, sentences: bool = False) -> str:
    """Return the text of ``err`` on one line (``sentences``: lines end in ".")."""
    lines = [" ".join(line.split()) for line in str(err).splitlines() if line.strip()]
    for i, line in enumerate(lines[:-1]):
        if sentences and line[-1] not in ".:;,!?":
            lines[i] = line + "."
    return " ".join(lines) or type(err).__name__
