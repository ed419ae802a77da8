"""PostGIS in and out (geoalpha._io.postgis and the command), on a real server.

The ``cluster`` fixture starts a throwaway PostgreSQL + PostGIS server
(``tests/pgcluster.py``) when the server binaries are installed. Without them
these tests are skipped, except where ``GEOALPHA_REQUIRE_POSTGRES`` is set (CI
sets it, after installing ``postgresql-15-postgis-3``): there a missing
server is an error.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import geopandas as gpd
import numpy as np
import pytest
import shapely
from cli_runner import run

import geoalpha
from geoalpha import datasets
from geoalpha._io.postgis import parse_table, read_postgis, redact, write_postgis
from geoalpha.errors import DatabaseError, InvalidInputError

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))
import pgcluster  # noqa: E402

pytestmark = pytest.mark.filterwarnings(
    "ignore::geoalpha.errors.DegenerateGroupWarning"  # cluster 530 is a line
)
WRONG = "Wr0ng-pa55word"
GROUP = "Local_Authority_(Highway)"  # must never show up in any output


def _unavailable(reason: str):
    if os.environ.get("GEOALPHA_REQUIRE_POSTGRES"):
        pytest.fail(f"GEOALPHA_REQUIRE_POSTGRES is set but {reason}")
    pytest.skip(reason)


@pytest.fixture(scope="module")
def cluster():
    """A PostgreSQL + PostGIS server on 127.0.0.1, stopped after the module."""
    try:
        import geoalchemy2  # noqa: F401
        import psycopg  # noqa: F401
        import sqlalchemy  # noqa: F401
    except ImportError as err:
        _unavailable(f"the PostGIS drivers are missing ({err.name})")
    if pgcluster.find_bindir() is None:
        _unavailable(
            "no PostgreSQL server with PostGIS "
            "(apt-get install postgresql-15-postgis-3)"
        )
    with pgcluster.Cluster() as server:
        yield server


@pytest.fixture(autouse=True)
def pgpassword(monkeypatch):
    """The password comes from PGPASSWORD unless a test says otherwise."""
    monkeypatch.setenv("PGPASSWORD", pgcluster.PASSWORD)
    monkeypatch.delenv("PGPASSFILE", raising=False)


@pytest.fixture(scope="module")
def uk_points():
    """The bundled UK accident clusters, geometry column ``geom``."""
    return datasets.load("uk_clusters").rename_geometry("geom")


@pytest.fixture(scope="module")
def db(cluster, uk_points):
    """URL (no password) of a database holding ``public.uk_clusters``."""
    url = cluster.create_database("gadb")
    engine = _engine(cluster.url("gadb", password=True))
    uk_points.to_postgis("uk_clusters", engine, index=False)
    engine.dispose()
    return url


def _engine(url):
    import sqlalchemy

    return sqlalchemy.create_engine(
        url.replace("postgresql://", "postgresql+psycopg://")
    )


def _query(cluster, sql, database="gadb"):
    return cluster.psql(sql, database).strip()


# --------------------------------------------------------------------------
# without a server


def test_redact_hides_url_passwords_and_pgpassword(monkeypatch):
    monkeypatch.setenv("PGPASSWORD", "env-secret-1")
    text = "postgresql://ga:p%40ss@db:5432/x and postgres://u:pw@h/y, env-secret-1"
    assert redact(text) == "postgresql://ga:***@db:5432/x and postgres://u:***@h/y, ***"


def test_table_names():
    assert parse_table("uk.hulls") == ("uk", "hulls")
    assert parse_table('"Ü.x"."Hüllen ""2024"""') == ("Ü.x", 'Hüllen "2024"')
    with pytest.raises(InvalidInputError, match=r"schema\.table"):
        parse_table("a.b.c")


def test_gdal_pg_string_is_refused_with_the_url_to_give(tmp_path):
    result = run("hull", "PG:host=127.0.0.1 dbname=gadb", tmp_path / "out.gpkg")
    assert result.exit_code == 1
    assert "PG:... connection strings are not supported" in result.stderr
    assert "give the URL postgresql://127.0.0.1/gadb instead" in result.stderr
    result = run("hull", datasets.path("stats19"), "PG:dbname=gadb")
    assert result.exit_code == 1
    assert "not supported" in result.stderr
    assert not list(tmp_path.iterdir())


def test_output_url_needs_a_table(tmp_path):
    result = run("hull", datasets.path("stats19"), "postgresql://ga@127.0.0.1/gadb")
    assert result.exit_code == 1
    assert "needs the table to write: --output-layer schema.table" in result.stderr


def test_sql_needs_a_database_input(tmp_path):
    out = tmp_path / "out.gpkg"
    result = run("hull", datasets.path("stats19"), out, "--sql", "SELECT 1")
    assert result.exit_code == 1
    assert "--sql and --geometry-column apply to a postgresql:// INPUT" in result.stderr


def test_hull_keeps_the_geometry_column_name():
    points = datasets.load("stats19").rename_geometry("geom")
    points = points[
        points["Local_Authority_(Highway)"].isin(["E09000033", "E09000013"])
    ]
    hulls = points.alpha.hull(by=GROUP)
    assert hulls.geometry.name == "geom"
    assert "geometry" not in hulls.columns
    assert hulls.alpha.hull(vertices=True).geometry.name == "geom"  # and again
    assert points.geometry.alpha.hull().geometry.name == "geometry"  # a GeoSeries


def test_dask_hull_keeps_the_geometry_column_name():
    dask_geopandas = pytest.importorskip("dask_geopandas")
    points = datasets.load("stats19").rename_geometry("geom")
    points = points[
        points["Local_Authority_(Highway)"].isin(["E09000033", "E09000013"])
    ]
    lazy = dask_geopandas.from_geopandas(points, npartitions=2)
    hulls = geoalpha.hull(lazy, by=GROUP).compute()
    assert hulls.geometry.name == "geom"
    assert len(hulls) == 2


# --------------------------------------------------------------------------
# reading


def test_read_by_table(db, uk_points):
    points = read_postgis(db, table="public.uk_clusters")
    assert len(points) == len(uk_points) == 15255
    assert points.geometry.name == "geom"
    assert points.crs.to_epsg() == 4326
    np.testing.assert_array_equal(
        shapely.get_coordinates(points.geometry.array),
        shapely.get_coordinates(uk_points.geometry.array),
    )
    assert points["Cluster"].tolist() == uk_points["Cluster"].tolist()


def test_read_by_table_on_the_search_path(db):
    assert len(read_postgis(db, table="uk_clusters")) == 15255


def test_read_by_sql(db, uk_points):
    sql = 'SELECT "Cluster", geom FROM uk_clusters WHERE "Cluster" < 10'
    points = read_postgis(db, sql=sql)
    assert len(points) == int((uk_points["Cluster"] < 10).sum())
    assert list(points.columns) == ["Cluster", "geom"]
    assert points.crs.to_epsg() == 4326
    # % and : are plain characters in the query, not parameter markers
    like = "SELECT 'a%b:c' AS t, geom FROM uk_clusters WHERE 'x%' LIKE 'x%%' LIMIT 3"
    assert read_postgis(db, sql=like)["t"].tolist() == ["a%b:c"] * 3


def test_read_projected_and_mixed_srids(db):
    sql = "SELECT ST_Transform(geom, 27700) AS geom FROM uk_clusters LIMIT 4"
    assert read_postgis(db, sql=sql).crs.to_epsg() == 27700
    mixed = (
        'SELECT geom FROM uk_clusters WHERE "Cluster" = 1 UNION ALL '
        'SELECT ST_Transform(geom, 27700) FROM uk_clusters WHERE "Cluster" = 2'
    )
    with pytest.raises(InvalidInputError, match=r"2 SRIDs \(\[4326, 27700\]\)"):
        read_postgis(db, sql=mixed)


def test_sql_runs_read_only(db, cluster):
    cluster.psql("CREATE SEQUENCE IF NOT EXISTS counter", "gadb")
    with pytest.raises(DatabaseError, match="cannot execute nextval"):
        read_postgis(db, sql="SELECT geom, nextval('counter') FROM uk_clusters")
    assert _query(cluster, "SELECT last_value FROM counter") == "1"  # not called


def test_geometry_column_chosen_or_asked_for(db):
    sql = 'SELECT "Cluster", geom, ST_Buffer(geom, 0.01) AS area FROM uk_clusters'
    with pytest.raises(InvalidInputError, match=r"2 geometry columns \(geom, area\)"):
        read_postgis(db, sql=sql)
    points = read_postgis(db, sql=sql, geometry_column="geom")
    assert points.geometry.name == "geom"
    assert (points.geom_type == "Point").all()
    with pytest.raises(InvalidInputError, match="no geometry column"):
        read_postgis(db, sql='SELECT "Cluster" FROM uk_clusters')


def test_every_row_read_as_geopandas_reads_it(db, cluster):
    """Points come as arrays, other rows as WKB: the frame is the same."""
    cluster.psql(
        "CREATE TABLE mixed AS SELECT * FROM (VALUES "
        "(1, 'a', 1.5, 'SRID=4326;POINT(1 2)'::geometry), (2, NULL, NULL, NULL), "
        "(3, 'c', 2, 'SRID=4326;POINT EMPTY'), "
        "(4, 'd', 3, 'SRID=4326;LINESTRING(0 0,1 1)'), "
        "(5, 'e', 4, 'SRID=4326;POINT Z (1 2 3)')) AS t(id, name, v, geom)",
        "gadb",
    )
    engine = _engine(cluster.url("gadb", password=True))
    for sql in (
        "SELECT * FROM mixed ORDER BY id",
        "SELECT * FROM mixed WHERE id = 1",
        'SELECT "Cluster" AS id, "Cluster"::text AS name, 1.5::numeric AS v, geom '
        'FROM uk_clusters ORDER BY "Cluster" DESC',
    ):
        expected = gpd.read_postgis(sql, engine, geom_col="geom")
        points = read_postgis(db, sql=sql)
        assert list(points.columns) == list(expected.columns)
        assert points.dtypes.astype(str).tolist() == [
            "int64",
            str(points["name"].dtype),
            "float64",
            "geometry",
        ]
        assert points["id"].tolist() == expected["id"].tolist()
        assert points["name"].tolist() == expected["name"].tolist()
        assert points.geometry.to_wkt().tolist() == expected.geometry.to_wkt().tolist()
    engine.dispose()


def test_read_on_an_open_connection(db, cluster):
    import psycopg

    cluster.psql("CREATE SEQUENCE IF NOT EXISTS counter2", "gadb")
    with psycopg.connect(db) as conn:
        assert len(read_postgis(conn, table="uk_clusters")) == 15255
        with pytest.raises(DatabaseError, match="cannot execute nextval"):
            read_postgis(conn, sql="SELECT geom, nextval('counter2') FROM uk_clusters")
        sql = 'SELECT geom FROM uk_clusters WHERE "Cluster" = 1'
        assert len(read_postgis(conn, sql=sql)) == 38  # still open, still usable
        assert not conn.closed
    engine = _engine(db)
    with pytest.raises(
        InvalidInputError, match=r"open psycopg connection \(got Engine"
    ):
        read_postgis(engine, table="uk_clusters")


def test_geometry_without_srid_takes_crs_in(db):
    sql = 'SELECT "Cluster", ST_SetSRID(geom, 0) AS g FROM uk_clusters LIMIT 5'
    assert read_postgis(db, sql=sql).crs.to_epsg() == 4326
    assert read_postgis(db, sql=sql, crs=None).crs is None


# --------------------------------------------------------------------------
# writing, through the command


def _srid(cluster, table, column="geom"):
    schema, name = table.split(".")
    return _query(cluster, f"SELECT Find_SRID('{schema}', '{name}', '{column}')")


def _has_gist_index(cluster, table):
    sql = (
        "SELECT count(*) FROM pg_index i JOIN pg_class c ON c.oid = i.indexrelid "
        f"JOIN pg_am a ON a.oid = c.relam WHERE i.indrelid = '{table}'::regclass "
        "AND a.amname = 'gist'"
    )
    return _query(cluster, sql) == "1"


def test_command_database_to_database(db, cluster, uk_points):
    result = run(
        "hull", db, db, "--layer", "public.uk_clusters", "--by", "Cluster",
        "--output-layer", "public.cluster_hulls",
    )  # fmt: skip
    assert result.exit_code == 0, result.stderr
    assert result.stdout.strip().endswith(
        f"Wrote 691 hulls of 15,255 points to {db} (table public.cluster_hulls)"
    )
    assert _srid(cluster, "public.cluster_hulls") == "4326"
    assert _has_gist_index(cluster, "public.cluster_hulls")
    # every input point lies in its own cluster's hull, in the database too
    covered = _query(
        cluster,
        'SELECT count(*) FROM uk_clusters p JOIN cluster_hulls h USING ("Cluster") '
        "WHERE ST_Covers(h.geom, p.geom)",
    )
    assert covered == "15255"
    hulls = read_postgis(db, table="public.cluster_hulls")
    expected = uk_points.alpha.hull(by="Cluster")
    assert hulls["Cluster"].tolist() == expected["Cluster"].tolist()
    np.testing.assert_array_equal(hulls["alpha"], expected["alpha"])
    assert shapely.equals(hulls.geometry.array, expected.geometry.array).all()
    assert _query(cluster, "SELECT count(*) FROM pg_tables WHERE tablename LIKE "
                  "'geoalpha_tmp%'") == "0"  # fmt: skip


def test_command_sql_input_to_file(db, tmp_path):
    out = tmp_path / "hulls.gpkg"
    result = run(
        "hull", db, out, "--sql", 'SELECT "Cluster", geom FROM uk_clusters '
        'WHERE "Cluster" BETWEEN 100 AND 109', "--by", "Cluster",
    )  # fmt: skip
    assert result.exit_code == 0, result.stderr
    hulls = gpd.read_file(out)
    assert hulls["Cluster"].tolist() == list(range(100, 110))
    two = 'SELECT "Cluster", ST_Buffer(geom, 1) AS disc, geom FROM uk_clusters'
    result = run("hull", db, out, "--sql", two, "--by", "Cluster", "--overwrite")
    assert result.exit_code == 1
    assert "choose one with --geometry-column" in result.stderr
    result = run("hull", db, out, "--sql", two, "--by", "Cluster",
                 "--geometry-column", "geom", "--overwrite")  # fmt: skip
    assert result.exit_code == 0, result.stderr
    assert len(gpd.read_file(out)) == 691


def test_overwrite_refused_then_allowed(db, cluster):
    args = ["hull", db, db, "--by", "Cluster", "--output-layer", "public.ow_hulls"]
    first = run(*args, "--sql", 'SELECT * FROM uk_clusters WHERE "Cluster" < 5')
    assert first.exit_code == 0, first.stderr
    again = run(*args, "--layer", "uk_clusters")
    assert again.exit_code == 1
    assert again.stderr.strip() == (
        f"Error: table public.ow_hulls already exists in {db}; use --overwrite "
        "to replace it"
    )
    assert _query(cluster, "SELECT count(*) FROM ow_hulls") == "5"
    replaced = run(*args, "--layer", "uk_clusters", "--overwrite")
    assert replaced.exit_code == 0, replaced.stderr
    assert _query(cluster, "SELECT count(*) FROM ow_hulls") == "691"
    assert _has_gist_index(cluster, "public.ow_hulls")
    # a view on the table: the database refuses the drop, nothing changes
    cluster.psql("CREATE VIEW ow_view AS SELECT * FROM ow_hulls", "gadb")
    refused = run(*args, "--sql", 'SELECT * FROM uk_clusters WHERE "Cluster" < 2',
                  "--overwrite")  # fmt: skip
    _assert_one_line_without_secret(
        refused, "cannot drop table ow_hulls because other objects depend on it"
    )
    assert _query(cluster, "SELECT count(*) FROM ow_view") == "691"


def test_killed_run_leaves_no_half_table(db, cluster):
    """SIGKILL in the middle of the write: the old table stays, nothing new."""
    sql = 'SELECT * FROM uk_clusters WHERE "Cluster" < 3'
    first = run(
        "hull", db, db, "--sql", sql, "--by", "Cluster", "--output-layer", "killed"
    )
    assert first.exit_code == 0, first.stderr
    script = textwrap.dedent(
        f"""
        import sys, time
        import geoalpha._io.postgis as pg
        from geoalpha import datasets
        def pause(*args):  # after the rename, before the commit
            print("renamed", flush=True)
            time.sleep(120)
        pg._rename_indexes = pause
        hulls = datasets.load("uk_clusters").alpha.hull(by="Cluster")
        pg.write_postgis(hulls, {db!r}, "public.killed", overwrite=True)
        """
    )
    env = {**os.environ, "PYTHONPATH": str(REPO), "PYTHONWARNINGS": "ignore"}
    proc = subprocess.Popen(
        [sys.executable, "-c", script], stdout=subprocess.PIPE, text=True, env=env
    )
    try:
        assert proc.stdout.readline().strip() == "renamed"
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    deadline = time.monotonic() + 30
    while _query(cluster, "SELECT count(*) FROM pg_stat_activity WHERE "
                 "application_name = 'geoalpha'") != "0":  # fmt: skip
        assert time.monotonic() < deadline, "the killed session never ended"
        time.sleep(0.1)
    assert _query(cluster, "SELECT count(*) FROM killed") == "3"  # the old table
    leftovers = "SELECT count(*) FROM pg_class WHERE relname LIKE 'geoalpha_tmp%'"
    assert _query(cluster, leftovers) == "0"


def test_mixed_polygons_and_multipolygons_become_one_column_type(db, cluster):
    result = run("hull", db, db, "--layer", "uk_clusters", "--by", "Cluster",
                 "--components", "2", "--output-layer", "two_parts")  # fmt: skip
    assert result.exit_code == 0, result.stderr
    column_type = _query(
        cluster,
        "SELECT type || ',' || srid FROM geometry_columns "
        "WHERE f_table_name = 'two_parts'",
    )
    assert column_type == "MULTIPOLYGON,4326"
    parts = _query(cluster, "SELECT sum(ST_NumGeometries(geom)) FROM two_parts")
    assert parts == _query(cluster, "SELECT sum(n_parts) FROM two_parts")


def test_planar_hulls_are_written_without_a_geopandas_warning(db, cluster, tmp_path):
    # "Warning: Could not parse CRS from the GeoDataFrame. Inserting data
    # without defined CRS." leaked from geopandas: SRID 0 is what --crs-in
    # none asks for, and the summary says "no CRS".
    path = tmp_path / "xy.csv"
    path.write_text("x,y,g\n0,0,a\n10,0,a\n0,10,a\n10,10,a\n5,5,a\n")
    result = run(
        "hull", path, db, "--crs-in", "none", "--by", "g",
        "--output-layer", "public.planar_hulls",
    )  # fmt: skip
    assert result.exit_code == 0, result.stderr
    assert "Warning" not in result.stderr, result.stderr
    assert "(columns x/y, no CRS)" in result.stdout
    assert _srid(cluster, "public.planar_hulls", "geometry") == "0"


def test_python_write_and_refusal(db, cluster, uk_points):
    hulls = uk_points[uk_points["Cluster"] < 20].alpha.hull(by="Cluster")
    assert write_postgis(hulls, db, "py_hulls") == "public.py_hulls"
    with pytest.raises(DatabaseError, match="already exists"):
        write_postgis(hulls, db, "py_hulls")
    assert write_postgis(hulls.head(3), db, "py_hulls", overwrite=True)
    assert _query(cluster, "SELECT count(*) FROM py_hulls") == "3"


def test_readme_round_trip_keeps_the_geometry_column(db, cluster):
    """gpd.read_postgis -> hull -> to_postgis, as docs/postgis.md shows it."""
    engine = _engine(db)  # password from PGPASSWORD
    points = gpd.read_postgis(
        'SELECT "Cluster", geom FROM uk_clusters', engine, geom_col="geom"
    )
    hulls = points.alpha.hull(by="Cluster")
    assert hulls.geometry.name == "geom"
    hulls.to_postgis("readme_hulls", engine, if_exists="replace", index=False)
    engine.dispose()
    assert _srid(cluster, "public.readme_hulls") == "4326"
    assert _query(cluster, "SELECT count(*) FROM readme_hulls") == "691"


def test_readme_postgis_examples_run(cluster, tmp_path):
    """The PostGIS blocks of docs/postgis.md, as written, against this server."""
    import re

    readme = (REPO / "docs" / "postgis.md").read_text()
    blocks = re.findall(
        r"<!-- readme-test: with a PostGIS database[^\n]*\n```python\n(.*?)\n```",
        readme,
        re.S,
    )
    # the first loads the bundled data itself: the page needs nothing else
    assert len(blocks) == 3 and "datasets.load(" in blocks[0]
    cluster.create_database("readme")
    here = f"geoalpha@127.0.0.1:{cluster.port}/readme"
    env = {**os.environ, "PYTHONPATH": str(REPO), "PGPASSWORD": pgcluster.PASSWORD}
    for code in blocks:
        assert "ga@127.0.0.1:5432/gadb" in code
        done = subprocess.run(
            [sys.executable, "-c", code.replace("ga@127.0.0.1:5432/gadb", here)],
            cwd=tmp_path,
            env=env,
            capture_output=True,
            text=True,
            timeout=300,
            check=False,
        )
        assert done.returncode == 0, done.stderr
    assert _query(cluster, "SELECT count(*) FROM cluster_hulls", "readme") == "691"
    assert _query(cluster, "SELECT count(*) FROM uk_clusters", "readme") == "15255"
    # the page's command lines, on the table its first block made
    url = cluster.url("readme")
    result = run(
        "hull", url, url, "--layer", "public.uk_clusters", "--by", "cluster",
        "--output-layer", "public.cli_hulls",
    )  # fmt: skip
    assert result.exit_code == 0, result.stderr
    assert "Wrote 691 hulls of 15,255 points to " in result.stdout + result.stderr
    sql = re.search(r'--sql "([^"]+)"', readme)[1]
    assert sql == "SELECT cluster, geom FROM uk_clusters WHERE cluster < 100"
    out = tmp_path / "hulls.gpkg"
    result = run("hull", url, out, "--by", "cluster", "--sql", sql)
    assert result.exit_code == 0, result.stderr
    assert gpd.read_file(out)["cluster"].tolist() == list(range(100))


# --------------------------------------------------------------------------
# errors: one line, never the password


def _assert_one_line_without_secret(result, *needles):
    assert result.exit_code == 1
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("Error: "), result.stderr
    for needle in needles:
        assert needle in lines[0]
    assert WRONG not in result.stderr + result.stdout
    assert pgcluster.PASSWORD not in result.stderr + result.stdout


def test_wrong_password(db, cluster, tmp_path, monkeypatch):
    monkeypatch.delenv("PGPASSWORD")
    url = db.replace("geoalpha@", f"geoalpha:{WRONG}@")
    result = run("hull", url, tmp_path / "o.gpkg", "--layer", "uk_clusters")
    _assert_one_line_without_secret(
        result,
        "cannot connect to postgresql://geoalpha:***@127.0.0.1:",
        'password authentication failed for user "geoalpha"',
    )
    verbose = run("-v", "hull", url, tmp_path / "o.gpkg", "--layer", "uk_clusters")
    assert "Traceback" in verbose.stderr
    assert WRONG not in verbose.stderr + verbose.stdout
    # as an OUTPUT too, before any work is done
    out = run("hull", datasets.path("stats19"), url, "--output-layer", "h")
    _assert_one_line_without_secret(out, "password authentication failed")


def test_password_from_pgpass(db, tmp_path, monkeypatch):
    monkeypatch.delenv("PGPASSWORD")
    with pytest.raises(DatabaseError, match="no password supplied"):
        read_postgis(db, table="uk_clusters")
    pgpass = tmp_path / ".pgpass"
    pgpass.write_text(f"127.0.0.1:*:*:geoalpha:{pgcluster.PASSWORD}\n")
    pgpass.chmod(0o600)
    monkeypatch.setenv("HOME", str(tmp_path))  # ~/.pgpass
    assert len(read_postgis(db, table="uk_clusters")) == 15255


def test_password_in_the_url_is_never_printed(db, cluster, tmp_path, monkeypatch):
    monkeypatch.delenv("PGPASSWORD")
    url = cluster.url("gadb", password=True)
    result = run("-v", "hull", url, tmp_path / "o.gpkg", "--layer", "nope")
    assert result.exit_code == 1
    assert pgcluster.PASSWORD not in result.stderr + result.stdout
    assert "postgresql://geoalpha:***@127.0.0.1" in result.stderr
    ok = run("hull", url, url, "--sql", 'SELECT * FROM uk_clusters WHERE "Cluster" = 7',
             "--by", "Cluster", "--output-layer", "url_hulls")  # fmt: skip
    assert ok.exit_code == 0, ok.stderr
    assert "to postgresql://geoalpha:***@127.0.0.1:" in ok.stdout
    assert pgcluster.PASSWORD not in ok.stderr + ok.stdout


def test_bad_urls(cluster, tmp_path):
    out = tmp_path / "o.gpkg"
    bad_port = f"postgresql://geoalpha:{WRONG}@127.0.0.1:notaport/gadb"
    _assert_one_line_without_secret(
        run("hull", bad_port, out, "--layer", "t"),
        "cannot read the database URL postgresql://geoalpha:***@127.0.0.1:notaport",
    )
    no_db = f"postgresql://geoalpha:{WRONG}@127.0.0.1:{cluster.port}"
    _assert_one_line_without_secret(
        run("hull", no_db, out, "--layer", "t"), "names no database"
    )
    refused = f"postgresql://geoalpha:{WRONG}@127.0.0.1:{_closed_port()}/gadb"
    _assert_one_line_without_secret(
        run("hull", refused, out, "--layer", "t"), "cannot connect to", "refused"
    )
    missing_db = cluster.url("nodb")
    _assert_one_line_without_secret(
        run("hull", missing_db, out, "--layer", "t"), 'database "nodb" does not exist'
    )


def test_connection_refused_reads_as_sentences(tmp_path):
    # libpq's "Connection refused\n\tIs the server running ..." was joined
    # into "Connection refused Is the server ...".
    pytest.importorskip("psycopg")
    pytest.importorskip("sqlalchemy")
    url = f"postgresql://geoalpha@127.0.0.1:{_closed_port()}/gadb"
    result = run("hull", url, tmp_path / "o.gpkg", "--layer", "t")
    assert result.exit_code == 1
    assert result.stderr == (
        f"Error: cannot connect to {url}: Connection refused. Is the server "
        "running on that host and accepting TCP/IP connections?\n"
    )


def _closed_port():
    import socket

    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def test_missing_table_lists_the_tables(db, tmp_path):
    result = run("hull", db, tmp_path / "o.gpkg", "--layer", "public.nope")
    _assert_one_line_without_secret(
        result,
        f"table public.nope not found in {db}; tables with a geometry column: ",
        "public.uk_clusters",
    )
    result = run("hull", db, tmp_path / "o.gpkg", "--sql", "SELECT * FROM nope")
    _assert_one_line_without_secret(result, 'relation "nope" does not exist')


# --------------------------------------------------------------------------
# data that must survive the trip


def test_non_ascii_group_keys_and_table_names(db, cluster):
    rng = np.random.default_rng(3)
    names = ["Zürich", "Łódź", "東京", "São Paulo", "Ελλάδα"]
    xy = rng.normal(size=(len(names) * 12, 2)) * 1000 + [400000, 300000]
    points = gpd.GeoDataFrame(
        {"Stadt": np.repeat(names, 12)},
        geometry=gpd.points_from_xy(xy[:, 0], xy[:, 1]),
        crs="EPSG:27700",
    ).rename_geometry("geom")
    engine = _engine(cluster.url("gadb", password=True))
    points.to_postgis("städte", engine, index=False)
    engine.dispose()
    result = run("hull", db, db, "--layer", "städte", "--by", "Stadt",
                 "--output-layer", "public.Hüllen")  # fmt: skip
    assert result.exit_code == 0, result.stderr
    hulls = read_postgis(db, table='public."Hüllen"')
    assert hulls["Stadt"].tolist() == sorted(names)
    assert hulls.crs.to_epsg() == 27700
    assert _srid(cluster, "public.Hüllen") == "27700"


def test_100k_points_round_trip(db, cluster):
    rng = np.random.default_rng(16)
    n, groups = 100_000, 1_000
    group = rng.integers(0, groups, n)
    centres = rng.uniform(0, 500_000, size=(groups, 2))
    xy = centres[group] + rng.normal(size=(n, 2)) * 2_000
    points = gpd.GeoDataFrame(
        {"grp": group, "row": np.arange(n)},
        geometry=gpd.points_from_xy(xy[:, 0], xy[:, 1]),
        crs="EPSG:27700",
    ).rename_geometry("geom")
    engine = _engine(cluster.url("gadb", password=True))
    points.to_postgis("big", engine, index=False)
    engine.dispose()
    back = read_postgis(db, table="big").sort_values("row")
    np.testing.assert_array_equal(
        shapely.get_coordinates(back.geometry.array), xy
    )  # bit for bit
    result = run("-q", "hull", db, db, "--layer", "big", "--by", "grp",
                 "--output-layer", "big_hulls")  # fmt: skip
    assert result.exit_code == 0, result.stderr
    assert _query(cluster, "SELECT count(*), sum(n_points) FROM big_hulls") == (
        f"{groups}|{n}"
    )
    covered = _query(
        cluster,
        "SELECT count(*) FROM big p JOIN big_hulls h USING (grp) "
        "WHERE ST_Covers(h.geom, p.geom)",
    )
    assert covered == str(n)


def test_zip_codes_keep_their_leading_zeros_in_postgis(db, cluster, tmp_path):
    # A --by column of a CSV is text (issue #36): 00501 stays '00501'.
    csv = tmp_path / "zips.csv"
    csv.write_text(
        "zip,lon,lat\n00501,-73.0,40.8\n00501,-73.1,40.81\n00501,-73.05,40.9\n"
        ",-72.0,42.0\n01002,-72.5,42.3\n01002,-72.6,42.4\n01002,-72.55,42.5\n",
        encoding="utf-8",
    )
    result = run("hull", csv, db, "--by", "zip", "--output-layer", "public.zip_hulls")
    assert result.exit_code == 0, result.stderr
    assert "1 with a missing group key (index 3;" in result.stderr
    assert _query(cluster, "SELECT string_agg(zip, ',' ORDER BY zip) FROM "
                  "zip_hulls") == "00501,01002"  # fmt: skip
    column_type = _query(
        cluster,
        "SELECT data_type FROM information_schema.columns "
        "WHERE table_name = 'zip_hulls' AND column_name = 'zip'",
    )
    assert column_type == "text"
