"""geoalpha ``hull()`` against PostGIS ``ST_OptimalAlphaShape``, in one run.

Data: the 691 bundled UK accident clusters (``Cluster``), lon/lat projected
to EPSG:27700 (metres) and deduplicated per cluster, loaded into a PostGIS
table ``bench_uk(cluster int, geom geometry(Point, 27700))`` (the groups with
a triangle; the others into ``bench_uk_lines``, see below).

Timed, interleaved round by round on the same groups, each on one core (this
process and the server's backend pinned to the same CPU, one after the other;
no parallel query, one BLAS/OpenMP thread):

- PostGIS: ``SELECT cluster, ST_AsBinary(ST_OptimalAlphaShape(ST_Collect(geom),
  false, 1)) FROM bench_uk GROUP BY cluster``, rows fetched (SFCGAL 1.4 /
  CGAL; its alpha is the squared circumradius);
- PostGIS, the same shapes and their areas on the WGS84 spheroid
  (``ST_Area(ST_Transform(shape, 4326)::geography)``): the columns ``hull()``
  returns (its ``area_m2``), a side row; the goals compare with the first;
- geoalpha ``hull(points_27700, by="Cluster")`` (``holes=False,
  components=1``, the same problem), from a GeoDataFrame in memory;
- geoalpha ``hull`` from the lon/lat points (CRS estimation and two
  projections included);
- geoalpha ``read_postgis(url, table="bench_uk")`` then ``hull`` (the full
  trip a user makes from the same table: connect, read, build the frame,
  compute), and the same on an open psycopg connection (as the PostGIS
  query runs: no login, PostGIS already loaded by its backend, also pinned).

Groups without a triangle (fewer than 3 distinct points, or all collinear)
are kept out of ``bench_uk``: PostGIS 3.3 crashes the server on 4 or more
collinear points (the whole server restarts). Those with at most 3 points go
to ``bench_uk_lines`` and are run one by one afterwards, each in its own
query; those with 4 or more are not run, and the report names them.

Exactness: every group's PostGIS polygon is compared with geoalpha's exact
optimum (same points, same CRS; equal when the symmetric difference has area
<= 1e-9 of the polygon's). It is counted as ``equal``, ``next spectrum
value`` (equal to the alpha shape at the next larger circumradius of the
group's Delaunay spectrum, CGAL's ``find_optimal_alpha`` answer), ``2-5
spectrum values above``, ``a smaller spectrum value`` (below the optimum, so
it leaves points outside), ``empty`` (POLYGON EMPTY) or ``other`` (split by
whether the polygon covers every input point of the group).

Set-up (Debian 12): ``apt-get install postgresql-15-postgis-3`` and
``pip install "geoalpha[postgis]"``. The benchmark starts a throwaway server
itself (``tests/pgcluster.py``, as the tests do; as root the server runs as the
``postgres`` user) unless ``--url postgresql://user@host:port/db`` names one
(its database needs ``CREATE EXTENSION postgis_sfcgal``; the password from
``PGPASSWORD`` or ``~/.pgpass``)::

    python benchmarks/bench_postgis.py            # ~1 min
    python benchmarks/bench_postgis.py --rounds 9 --json out.json
    python benchmarks/bench_postgis.py --preload  # PostGIS loaded at start-up
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # one core: before numpy is imported

import argparse  # noqa: E402
import contextlib  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import warnings  # noqa: E402
from importlib.metadata import version  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests"))  # pgcluster.py, shared with tests
try:
    import geoalpha
except ImportError:  # pragma: no cover - run from a source tree
    sys.path.insert(0, str(HERE.parent))
    import geoalpha

import pgcluster  # noqa: E402
from timing import paired_ratio, rounds  # noqa: E402

from geoalpha import datasets  # noqa: E402

TABLE = "bench_uk"  # the groups with a triangle
LINES = "bench_uk_lines"  # the others with at most 3 points, one query each
QUERY = (
    "SELECT cluster, ST_AsBinary(ST_OptimalAlphaShape(ST_Collect(geom), false, 1)) "
    "FROM {table} {where} GROUP BY cluster ORDER BY cluster"
)
#: The same shapes with what hull() also returns for each: the area on the
#: WGS84 spheroid (geography's ST_Area, GeographicLib's algorithm, as
#: ``area_m2``). A side row: the goal is measured against QUERY.
QUERY_AREA = (
    "SELECT cluster, ST_AsBinary(shape), "
    "ST_Area(ST_Transform(shape, 4326)::geography) FROM ("
    "SELECT cluster, ST_OptimalAlphaShape(ST_Collect(geom), false, 1) AS shape "
    "FROM {table} GROUP BY cluster ORDER BY cluster) AS hulls"
)
EQUAL_TOLERANCE = 1e-9  # symmetric difference area / polygon area
VERDICTS = (
    "equal",
    "next spectrum value",
    "2-5 spectrum values above",
    "a smaller spectrum value (misses input points)",
    "empty",
    "other, misses input points",
    "other, covers every point",
)


def load_points():
    """UK clusters: lon/lat frame, EPSG:27700 frame, both deduplicated."""
    lonlat = datasets.load("uk_clusters")
    metric = lonlat.to_crs(27700)
    xy = np.round(metric.get_coordinates().to_numpy(), 6)
    keep = ~pd_duplicated(metric["Cluster"].to_numpy(), xy)
    lonlat = lonlat[keep].reset_index(drop=True)
    metric = metric[keep].reset_index(drop=True)
    return lonlat, metric


def pd_duplicated(codes, xy) -> np.ndarray:
    import pandas as pd

    frame = pd.DataFrame({"c": codes, "x": xy[:, 0], "y": xy[:, 1]})
    return frame.duplicated().to_numpy()


def triangulable(metric) -> tuple[np.ndarray, dict]:
    """Cluster ids with a triangle, and the others by reason."""
    res = geoalpha.alpha_shapes(
        metric.get_coordinates().to_numpy(), metric["Cluster"].to_numpy()
    )
    ids = np.unique(metric["Cluster"].to_numpy())
    sizes = metric.groupby("Cluster").size().reindex(ids).to_numpy()
    degenerate = np.asarray(res.degenerate, dtype=bool)
    return ids[~degenerate], {
        "at most 3 points, run one by one": ids[degenerate & (sizes <= 3)].tolist(),
        "4+ points on a line, not run (crash)": ids[degenerate & (sizes > 3)].tolist(),
    }


@contextlib.contextmanager
def server(url: str | None, preload: bool):
    """Yield a URL: ``url`` itself, or a throwaway server's database.

    ``preload`` starts the server with ``shared_preload_libraries =
    'postgis-3'``: its backends start with PostGIS loaded, instead of loading
    it at their first geometry (about 20 ms, paid by every new connection).
    """
    if url:
        yield url
        return
    settings = {"shared_preload_libraries": "postgis-3"} if preload else None
    with pgcluster.Cluster(settings=settings) as cluster:
        os.environ["PGPASSWORD"] = pgcluster.PASSWORD
        yield cluster.create_database("bench", extensions=("postgis", "postgis_sfcgal"))


def pin(pids: list[int]) -> str:
    """Pin these processes to one CPU (the last); say which, or why not."""
    try:
        cpu = max(os.sched_getaffinity(0))
        for pid in pids:
            os.sched_setaffinity(pid, {cpu})
    except (AttributeError, OSError) as err:
        return f"not pinned ({err})"
    return f"pinned to CPU {cpu}"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--url", help="a PostGIS database [default: start one]")
    parser.add_argument("--rounds", type=int, default=7, help="timed rounds [7]")
    parser.add_argument("--json", help="also write the results here")
    parser.add_argument(
        "--preload",
        action="store_true",
        help="start the server with shared_preload_libraries = 'postgis-3'",
    )
    args = parser.parse_args(argv)

    import psycopg
    import shapely
    import sqlalchemy

    from geoalpha._io.postgis import read_postgis

    lonlat, metric = load_points()
    ids, left_out = triangulable(metric)
    timed_metric = metric[metric["Cluster"].isin(ids)]
    timed_lonlat = lonlat[lonlat["Cluster"].isin(ids)]
    lines = metric["Cluster"].isin(left_out["at most 3 points, run one by one"])

    with server(args.url, args.preload) as url:
        engine = sqlalchemy.create_engine(
            url.replace("postgresql://", "postgresql+psycopg://", 1)
        )
        table = metric[["Cluster", "geometry"]].rename(columns={"Cluster": "cluster"})
        table = table.rename_geometry("geom")
        for name, rows in (
            (TABLE, table.loc[timed_metric.index]),
            (LINES, table[lines]),
        ):
            rows.to_postgis(name, engine, if_exists="replace", index=False)
        engine.dispose()
        conn = psycopg.connect(url, autocommit=True)
        conn.execute(f"VACUUM ANALYZE {TABLE}")
        conn.execute("SET max_parallel_workers_per_gather = 0")
        versions = conn.execute("SELECT postgis_full_version()").fetchone()[0]
        backend = conn.execute("SELECT pg_backend_pid()").fetchone()[0]
        reader = psycopg.connect(url)  # read_postgis(open connection)
        theirs = reader.execute("SELECT pg_backend_pid()").fetchone()[0]
        reader.rollback()
        pinned = pin([os.getpid(), backend, theirs])

        def postgis():
            return conn.execute(QUERY.format(table=TABLE, where="")).fetchall()

        def postgis_area():
            return conn.execute(QUERY_AREA.format(table=TABLE)).fetchall()

        def hull_metric():
            return timed_metric.alpha.hull(by="Cluster", progress=False)

        def hull_lonlat():
            return timed_lonlat.alpha.hull(by="Cluster", progress=False)

        def read_and_hull():
            points = read_postgis(url, table=TABLE)
            return points.alpha.hull(by="cluster", progress=False)

        def read_open_and_hull():
            points = read_postgis(reader, table=TABLE)
            return points.alpha.hull(by="cluster", progress=False)

        runs = {
            "PostGIS ST_OptimalAlphaShape GROUP BY": postgis,
            "PostGIS, the same + ST_Area(geography) (the columns hull() gives)": (
                postgis_area
            ),
            "geoalpha hull() on EPSG:27700 points": hull_metric,
            "geoalpha hull() on lon/lat points": hull_lonlat,
            "geoalpha read_postgis(url) + hull()": read_and_hull,
            "geoalpha read_postgis(open connection) + hull()": read_open_and_hull,
        }
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            results = {name: fn() for name, fn in runs.items()}  # the warm-up
            times = rounds(runs, args.rounds, warm_up=False)

        # exactness, group by group
        rows = results["PostGIS ST_OptimalAlphaShape GROUP BY"]
        pg_shapes = {int(c): shapely.from_wkb(bytes(w)) for c, w in rows}
        exact = results["geoalpha hull() on EPSG:27700 points"].set_index("Cluster")
        verdicts = {
            int(c): verdict(
                pg_shapes[int(c)],
                exact.loc[c],
                timed_metric.loc[timed_metric["Cluster"] == c],
            )
            for c in ids
        }
        separate = {}  # groups without a triangle and at most 3 points
        for c in left_out["at most 3 points, run one by one"]:
            try:
                where = "WHERE cluster = %s"
                row = conn.execute(QUERY.format(table=LINES, where=where), (int(c),))
                row = row.fetchone()
                separate[int(c)] = shapely.from_wkb(bytes(row[1])).wkt[:60]
            except psycopg.Error as err:
                separate[int(c)] = f"error: {str(err).splitlines()[0]}"
                conn = psycopg.connect(url, autocommit=True)
        left_out["at most 3 points, run one by one"] = separate
        conn.close()
        reader.close()

    report(times, verdicts, left_out, pinned, versions, len(ids), len(metric), args)
    return 0


def verdict(pg_shape, exact_row, points) -> str:
    """Compare PostGIS's polygon of one group with the exact optimum.

    Beyond ``equal``, the polygon is looked for among the alpha shapes (holes
    filled) at the group's other spectrum values, up to :data:`STEPS` values
    above or below the optimum.
    """
    import shapely

    if pg_shape is None or pg_shape.is_empty:
        return "empty"
    if same(pg_shape, exact_row.geometry):
        return "equal"
    xy = points.get_coordinates().to_numpy()
    radii = spectrum(xy)
    at = int(np.argmin(np.abs(radii - float(exact_row["radius"]))))
    for step in [k for i in range(1, STEPS + 1) for k in (i, -i)]:
        if not 0 <= at + step < len(radii):
            continue
        shape = geoalpha.alpha_shape(
            xy, alpha=(1 - 1e-12) / radii[at + step], holes=False
        )
        if not shape.is_empty and same(pg_shape, shapely.union_all(shape)):
            if step == 1:
                return "next spectrum value"
            if step > 1:
                return "2-5 spectrum values above"
            return "a smaller spectrum value (misses input points)"
    if not shapely.covers(pg_shape, points.geometry.array).all():
        return "other, misses input points"
    return "other, covers every point"


STEPS = 5


def same(a, b) -> bool:
    import shapely

    area = max(shapely.area(a), shapely.area(b))
    return shapely.area(shapely.symmetric_difference(a, b)) <= EQUAL_TOLERANCE * area


def spectrum(xy: np.ndarray) -> np.ndarray:
    """Distinct Delaunay circumradii, ascending (ties within 1e-10 merged)."""
    from scipy.spatial import Delaunay

    xy = xy - xy.mean(axis=0)
    tri = xy[Delaunay(xy).simplices]
    a = np.linalg.norm(tri[:, 1] - tri[:, 2], axis=1)
    b = np.linalg.norm(tri[:, 0] - tri[:, 2], axis=1)
    c = np.linalg.norm(tri[:, 0] - tri[:, 1], axis=1)
    d1, d2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    area2 = np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0])
    with np.errstate(divide="ignore", invalid="ignore"):
        radii = np.sort(a * b * c / (2 * area2))
    radii = radii[np.isfinite(radii)]
    keep = np.concatenate([[True], np.diff(radii) > 1e-10 * radii[1:]])
    return radii[keep]


def _fmt(seconds: float) -> str:
    return f"{seconds * 1e3:,.0f} ms" if seconds >= 0.1 else f"{seconds * 1e3:.1f} ms"


def report(times, verdicts, left_out, pinned, versions, n_groups, n_points, args):
    base = "PostGIS ST_OptimalAlphaShape GROUP BY"
    medians = {name: statistics.median(t) for name, t in times.items()}
    print(
        f"\n{n_groups} UK clusters with a triangle ({n_points:,} distinct points "
        f"in all 691), EPSG:27700; {args.rounds} rounds, median; {pinned}; "
        f"PostGIS {'preloaded' if args.preload else 'loaded by each new backend'}; "
        f"Python {platform.python_version()}, geoalpha {geoalpha.__version__} "
        f"({Path(geoalpha.__file__).parent}), "
        f"shapely {version('shapely')}, scipy {version('scipy')}\n{versions}\n"
    )
    print(
        "| work | median | / PostGIS | paired ratio (median of rounds) "
        "| best | best / best |"
    )
    print("|---|---:|---:|---:|---:|---:|")
    for name, t in times.items():
        paired = paired_ratio(t, times[base])
        print(
            f"| {name} | {_fmt(medians[name])} | {medians[name] / medians[base]:.2f}x "
            f"| {paired:.2f}x | {_fmt(min(t))} | {min(t) / min(times[base]):.2f}x |"
        )
    counts: dict[str, int] = {}
    for v in verdicts.values():
        counts[v] = counts.get(v, 0) + 1
    print("\nPostGIS's polygon against the exact optimum, per group:\n")
    print("| PostGIS polygon | groups |")
    print("|---|---:|")
    for name in VERDICTS:
        print(f"| {name} | {counts.get(name, 0)} |")
    for name in VERDICTS[2:]:
        clusters = sorted(c for c, v in verdicts.items() if v == name)
        print(f"\n{name}: clusters {clusters}")
    for reason, clusters in left_out.items():
        print(f"\n{reason}: {len(clusters)} cluster(s) {clusters}")
    if args.json:
        Path(args.json).write_text(
            json.dumps(
                {
                    "times": times,
                    "verdicts": {str(k): v for k, v in verdicts.items()},
                    "left_out": left_out,
                    "pinned": pinned,
                    "versions": versions,
                },
                indent=1,
            )
        )


if __name__ == "__main__":
    sys.exit(main())
