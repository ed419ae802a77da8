"""Benchmark ``geoalpha.hull`` on dask-geopandas against the eager call (issue #36).

Issue #36's goal: on points in 16 GeoParquet files, grouped by a county-like
key, ``geoalpha.hull(ddf, by="county").compute()`` on a
``distributed.LocalCluster`` of 2 workers within 2x of the eager
``geoalpha.hull(gpd.read_parquet(files), by="county")`` on the same machine,
both reading the same files, measured in one run (interleaved rounds, best of
N; ``timing.py``), with each side's peak memory.

The data (``make_data``, seeded): ``--counties`` county centres uniform in the
contiguous US (lon -124..-67, lat 25..49), each county's share of the points
log-normal, its points normal around the centre (sigma 0.05-0.25 degrees),
lon/lat (EPSG:4326); the rows shuffled and cut into ``--files`` files, so
every county spans every file. Keys are FIPS-like text (``"01234"``).

    python benchmarks/bench_dask.py [--points 5000000] [--repeat 3]
    python benchmarks/bench_dask.py --points 1000000 --profile  # where time goes

Peak memory: the eager side's is the high-water mark of a fresh process that
reads the files and computes the hulls once; the dask side's is the sum of
the workers' high-water marks plus the client's (its process reads nothing).
CPU: the least CPU seconds of a round, of every process (the eager process
and its threads; the workers, and the client with the LocalCluster's
scheduler): on a shared machine, less moved by the other load than the wall
time. The header gives the 1-minute load average before and after.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))  # timing.py
import geopandas as gpd
import numpy as np
import pandas as pd
import shapely
from timing import fmt_time, peak_memory_mb, rounds

import geoalpha


def make_data(folder: Path, n_points: int, n_files: int, counties: int, seed: int):
    """Write the seeded points to ``n_files`` GeoParquet files; return their paths."""
    rng = np.random.default_rng(seed)
    lon0 = rng.uniform(-124.0, -67.0, counties)
    lat0 = rng.uniform(25.0, 49.0, counties)
    share = rng.lognormal(0.0, 1.0, counties)
    county = rng.choice(counties, size=n_points, p=share / share.sum())
    sigma = rng.uniform(0.05, 0.25, counties)[county]
    lon = lon0[county] + rng.normal(0.0, 1.0, n_points) * sigma
    lat = lat0[county] + rng.normal(0.0, 1.0, n_points) * sigma
    names = np.array([f"{i:05d}" for i in range(counties)], dtype=object)
    frame = gpd.GeoDataFrame(
        {"county": names[county], "value": rng.integers(0, 100, n_points)},
        geometry=shapely.points(lon, lat),
        crs="EPSG:4326",
    )
    paths = []
    for i, part in enumerate(np.array_split(np.arange(n_points), n_files)):
        path = folder / f"points_{i:02d}.parquet"
        frame.iloc[part].reset_index(drop=True).to_parquet(path)
        paths.append(path)
    return paths


def eager(paths):
    """The eager call: read every file, one ``hull()``."""
    frame = pd.concat([gpd.read_parquet(p) for p in paths], ignore_index=True)
    return geoalpha.hull(frame, by="county")


def lazy(paths):
    """The dask call: ``dask_geopandas.read_parquet`` of the files, ``hull()``."""
    import dask_geopandas

    ddf = dask_geopandas.read_parquet([str(p) for p in paths])
    return geoalpha.hull(ddf, by="county").compute()


_EAGER_PEAK = """
import warnings
warnings.simplefilter("ignore")
import bench_dask
from pathlib import Path
bench_dask.eager([Path(p) for p in {paths!r}])
"""


def _cpu(client=None) -> float:
    """CPU seconds of this process (and its threads), plus the workers' with a client.

    The scheduler of a ``LocalCluster`` runs in this process.
    """
    import time

    workers = client.run(time.process_time).values() if client is not None else ()
    return time.process_time() + sum(workers)


def _counted(fn, cpu: list, client=None):
    """``fn``, appending the CPU seconds of each call (:func:`_cpu`) to ``cpu``."""

    def call():
        start = _cpu(client)
        fn()
        cpu.append(_cpu(client) - start)

    return call


def _max_rss() -> int:
    """This process' high-water mark (``VmHWM``) in KiB."""
    return int(open("/proc/self/status").read().split("VmHWM:")[1].split()[0])


def profile(paths, client) -> None:
    """Print the dask run's task-stream time per task prefix (where time goes)."""
    import time

    from distributed import get_task_stream

    lazy(paths)  # warm: the workers' imports and caches are not the run's cost
    with get_task_stream(client) as ts:
        start = time.perf_counter()
        lazy(paths)
        wall = time.perf_counter() - start
    per: dict[str, float] = {}
    for task in ts.data:
        prefix = task["key"][0] if isinstance(task["key"], tuple) else task["key"]
        prefix = str(prefix).rsplit("-", 1)[0]
        for part in task["startstops"]:
            name = f"{prefix} [{part['action']}]"
            per[name] = per.get(name, 0.0) + part["stop"] - part["start"]
    total = sum(per.values())
    workers = len(client.scheduler_info()["workers"])
    print(
        f"wall {wall:.2f} s; the workers busy {total:.2f} of {workers * wall:.2f} "
        "worker seconds\n"
    )
    print("| task prefix [action] | worker seconds | share |\n|---|---:|---:|")
    for name, seconds in sorted(per.items(), key=lambda kv: -kv[1])[:15]:
        print(f"| {name} | {seconds:.2f} | {seconds / total:.0%} |")


def main(argv=None) -> None:
    """Print a markdown table of the two calls' times, ratio and peak memory."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=5_000_000)
    parser.add_argument("--files", type=int, default=16)
    parser.add_argument("--counties", type=int, default=3000)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--seed", type=int, default=36)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--profile", action="store_true")
    args = parser.parse_args(argv)
    warnings.simplefilter("ignore", geoalpha.GeoAlphaWarning)

    import os

    from distributed import Client, LocalCluster

    load = [os.getloadavg()[0]]
    cpu: dict[str, list[float]] = {"eager": [], "dask": []}
    with tempfile.TemporaryDirectory() as tmp:
        paths = make_data(Path(tmp), args.points, args.files, args.counties, args.seed)
        eager_peak = peak_memory_mb(_EAGER_PEAK.format(paths=[str(p) for p in paths]))
        with (
            LocalCluster(
                n_workers=args.workers, threads_per_worker=1, processes=True
            ) as cluster,
            Client(cluster) as client,
        ):
            if args.profile:
                profile(paths, client)
                return
            a, b = eager(paths), lazy(paths)
            same = len(a) == len(b) and bool(
                a.geom_equals_exact(b.set_index(a.index), 0).all()
            )
            times = rounds(
                {
                    "eager": _counted(lambda: eager(paths), cpu["eager"]),
                    "dask": _counted(lambda: lazy(paths), cpu["dask"], client),
                },
                args.repeat,
                warm_up=False,
            )
            peaks = client.run(_max_rss)
            load.append(os.getloadavg()[0])
        dask_peak = (sum(peaks.values()) + _max_rss()) / 1024
    best = {k: min(v) for k, v in times.items()}
    used = {k: min(v) for k, v in cpu.items()}
    print(
        f"{args.points:,} points, {args.counties:,} counties, {args.files} "
        f"GeoParquet files, LocalCluster({args.workers} workers x 1 thread), "
        f"best of {args.repeat}; results equal: {same}; load average (1 min) "
        f"{load[0]:.1f} before, {load[1]:.1f} after\n"
    )
    print(
        "| call | best | ratio | CPU (all processes) | peak memory |\n"
        "|---|---:|---:|---:|---:|"
    )
    print(
        f"| eager `hull()` | {fmt_time(best['eager'])} | 1.00x | "
        f"{used['eager']:.2f} s | {eager_peak:,.0f} MiB |"
    )
    print(
        f"| dask `hull().compute()` | {fmt_time(best['dask'])} | "
        f"{best['dask'] / best['eager']:.2f}x | {used['dask']:.2f} s "
        f"({used['dask'] / used['eager']:.2f}x) | {dask_peak:,.0f} MiB |"
    )


if __name__ == "__main__":
    main()
