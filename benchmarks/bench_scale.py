"""Scale benchmark: ``hull(by=...)`` on a million points, and ten million via dask.

Run from the repository root::

    python benchmarks/bench_scale.py              # 1M points / 1,000 groups;
                                                  # then 10M / 10,000 via dask
    python benchmarks/bench_scale.py --quick      # 100k / 100; then 1M via dask
    python benchmarks/bench_scale.py --skip-dask --repeat 5

Data, generated (``make_groups`` / ``make_points``, seed 20240606): points in
EPSG:32633 (WGS 84 / UTM zone 33N, metres). Group centres are uniform over
eastings 200-800 km and northings 4,000-6,000 km. Each group is 1-4 Gaussian
blobs (count uniform), blob centres N(0, 3 km) around the group centre, blob
sigma uniform in 300-1,500 m; each point picks its group with probability
proportional to a lognormal(0, 0.5) weight (group sizes about 200-4,000 for a
mean of 1,000) and then one of the group's blobs uniformly. Rows come in
random order (not sorted by group). Dask partition ``p`` draws its points
from every group with the seed ``[seed, 1, p]``, so every group is spread over
every partition and the shuffle by group does real work.

(a) Eager, in this process, repeated ``--repeat`` times side by side (each
repeat runs every case once, so that the ratios compare runs under the same
load): the floor (group the rows with one argsort, then a bare loop of
``scipy.spatial.Delaunay`` over the groups), ``gdf.alpha.hull(by="group")``
with ``n_jobs=1`` and ``n_jobs=2``, the same hull with all groups in one pass
of the batched steps instead of runs of about 50,000 points (to check
``geoalpha.parallel.BATCH_POINTS``), the floor loop split over two threads
(to check whether Qhull releases the GIL), and one ``shapely.delaunay_triangles``
call over all groups (GEOS's triangles alone, no indices: what geoalpha's
triangulation backend starts from). Peak memory: each case once more in a
fresh subprocess, ``ru_maxrss`` (the input frame included); the forked
workers' peak is the largest of one worker (shared pages counted).

(b) Dask: a ``distributed.LocalCluster`` (2 worker processes, 1 thread each,
``--memory-limit`` each), the points generated per partition with
``dask.dataframe.from_map`` (they never sit in one process), then
``geoalpha.hull(ddf, by="group").compute()``; peak memory is the largest sum
of the workers' RSS sampled by ``distributed.diagnostics.MemorySampler``, and
the client's own ``ru_maxrss``.
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import platform
import resource
import statistics
import subprocess
import sys
import tempfile
import time
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
try:
    import geoalpha
except ImportError:  # running from a source tree without installing
    sys.path.insert(0, str(HERE.parent))
    import geoalpha

from geoalpha import core, delaunay, parallel, pipeline, shapes  # noqa: E402

SEED = 20240606
CRS = "EPSG:32633"
EASTING = (200_000.0, 800_000.0)
NORTHING = (4_000_000.0, 6_000_000.0)


# --- data ---------------------------------------------------------------------------


def make_groups(n_groups: int, seed: int = SEED) -> dict:
    """Blob layout of every group (see the module docstring)."""
    rng = np.random.default_rng([seed, 0])
    centre = np.column_stack(
        [rng.uniform(*EASTING, n_groups), rng.uniform(*NORTHING, n_groups)]
    )
    n_blobs = rng.integers(1, 5, n_groups)
    weight = rng.lognormal(0.0, 0.5, n_groups)
    blob_group = np.repeat(np.arange(n_groups), n_blobs)
    return {
        "weight": weight / weight.sum(),
        "n_blobs": n_blobs,
        "first_blob": np.cumsum(n_blobs) - n_blobs,
        "blob_xy": centre[blob_group] + rng.normal(0.0, 3000.0, (len(blob_group), 2)),
        "blob_sigma": rng.uniform(300.0, 1500.0, len(blob_group)),
    }


def make_points(groups: dict, n: int, seed: int = SEED, part: int = 0):
    """``n`` points ``(x, y, group)`` of partition ``part``, rows in random order."""
    rng = np.random.default_rng([seed, 1, part])
    g = rng.choice(len(groups["weight"]), n, p=groups["weight"])
    blob = groups["first_blob"][g] + (rng.random(n) * groups["n_blobs"][g]).astype(
        np.int64
    )
    xy = (
        groups["blob_xy"][blob]
        + rng.normal(0.0, 1.0, (n, 2)) * groups["blob_sigma"][blob, None]
    )
    return xy[:, 0], xy[:, 1], g


def make_frame(x, y, g):
    import geopandas as gpd

    return gpd.GeoDataFrame(
        {"group": g}, geometry=gpd.points_from_xy(x, y), crs=CRS, copy=False
    )


def make_partition(part: int, groups: dict, n: int, seed: int):
    """One dask partition: ``n`` points drawn from every group."""
    return make_frame(*make_points(groups, n, seed, part))


# --- measuring ------------------------------------------------------------------------


def cpu_seconds() -> float:
    """CPU time of this process and its finished children."""
    me = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return me.ru_utime + me.ru_stime + kids.ru_utime + kids.ru_stime


def maxrss_mb(who=resource.RUSAGE_SELF) -> float:
    return resource.getrusage(who).ru_maxrss / 1024.0  # kB on Linux


def peak_rss_mb() -> float:
    """Peak RSS of this process (VmHWM; unlike ``ru_maxrss`` it is not raised
    by the parent's size at fork and can be reset, see :func:`reset_peak`)."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024.0
    except OSError:  # pragma: no cover - not Linux
        pass
    return maxrss_mb()


def reset_peak() -> None:
    """Reset this process's peak RSS to its current RSS (Linux >= 4.0)."""
    try:
        Path("/proc/self/clear_refs").write_text("5")
    except OSError:  # pragma: no cover - elsewhere the peak includes the set-up
        pass


def floor_loop(x, y, g, n_groups: int, threads: int = 1) -> None:
    """Group the rows, then a bare Delaunay loop (the floor any method pays)."""
    from scipy.spatial import Delaunay

    order = np.argsort(g, kind="stable")
    xy = np.column_stack([x, y])[order]
    ptr = np.searchsorted(g[order], np.arange(n_groups + 1))

    def run(groups):
        for k in groups:
            if ptr[k + 1] - ptr[k] >= 3:
                Delaunay(xy[ptr[k] : ptr[k + 1]])

    if threads == 1:
        run(range(n_groups))
        return
    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(threads) as pool:
        list(pool.map(run, np.array_split(np.arange(n_groups), threads)))


def hull_one_pass(gdf):
    """``hull`` with all groups in one pass of the batched steps (no runs)."""
    saved = parallel.BATCH_POINTS
    parallel.BATCH_POINTS = 10**12
    try:
        return gdf.alpha.hull(by="group")
    finally:
        parallel.BATCH_POINTS = saved


def cases(x, y, g, gdf, n_groups: int) -> dict[str, Callable[[], object]]:
    return {
        "floor": lambda: floor_loop(x, y, g, n_groups),
        "hull n_jobs=1": lambda: gdf.alpha.hull(by="group"),
        "hull n_jobs=2": lambda: gdf.alpha.hull(by="group", n_jobs=2),
        "hull n_jobs=1, one pass (no runs)": lambda: hull_one_pass(gdf),
        "floor, 2 threads": lambda: floor_loop(x, y, g, n_groups, threads=2),
        "GEOS triangles only (one shapely call)": lambda: geos_only(x, y, g),
    }


def geos_only(x, y, g) -> None:
    """Group the rows, then one ``shapely.delaunay_triangles`` call (no indices)."""
    import shapely

    order = np.argsort(g, kind="stable")
    lines = shapely.linestrings(np.column_stack([x, y])[order], indices=g[order])
    shapely.delaunay_triangles(lines)


def run_eager(n: int, n_groups: int, repeat: int, seed: int) -> dict:
    from geopandas.testing import assert_geodataframe_equal

    x, y, g = make_points(make_groups(n_groups, seed), n, seed)
    gdf = make_frame(x, y, g)
    fns = cases(x, y, g, gdf, n_groups)
    times = {name: [] for name in fns}
    cpu = {name: [] for name in fns}
    load = []
    for _ in range(repeat):
        load.append(os.getloadavg()[0])
        for name, fn in fns.items():
            c0, t0 = cpu_seconds(), time.perf_counter()
            fn()
            times[name].append(time.perf_counter() - t0)
            cpu[name].append(cpu_seconds() - c0)
        load.append(os.getloadavg()[0])

    one = fns["hull n_jobs=1"]()
    assert_geodataframe_equal(fns["hull n_jobs=2"](), one)
    assert_geodataframe_equal(fns["hull n_jobs=1, one pass (no runs)"](), one)
    with tempfile.TemporaryDirectory() as tmp:
        points = Path(tmp) / "points.npz"
        np.savez(points, x=x, y=y, g=g)
        memory = {name: measure_memory(name, points, n_groups) for name in fns}
    return {
        "points": n,
        "groups": n_groups,
        "times": times,
        "cpu": cpu,
        "load": load,
        "memory": memory,
        "stages": stage_times(gdf),
        "identical": True,
    }


def measure_memory(name: str, points: Path, n_groups: int) -> dict:
    """Run one case in a fresh interpreter and read its peak RSS."""
    command = [sys.executable, __file__, "--_memory", name, "--_points", str(points)]
    command += ["--groups", str(n_groups)]
    out = subprocess.run(command, capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def _memory_child(name: str, points: Path, n_groups: int) -> None:
    # The points come from a file: the generator's temporaries would leave
    # freed memory in the allocator that the run then reuses unseen.
    with np.load(points) as data:
        x, y, g = data["x"], data["y"], data["g"]
    gdf = make_frame(x, y, g)
    fn = cases(x, y, g, gdf, n_groups)[name]
    gc.collect()
    reset_peak()  # the peak of the run only, from here
    before = peak_rss_mb()
    fn()
    print(
        json.dumps(
            {
                "input_mb": before,
                "peak_mb": peak_rss_mb(),
                "worker_peak_mb": maxrss_mb(resource.RUSAGE_CHILDREN),
            }
        )
    )


class Stopwatch:
    """Wrap module functions to add up the time spent in them."""

    def __init__(self):
        self.total: dict[str, float] = {}
        self._saved: list = []

    def wrap(self, owner, attr: str, label: str, static: bool = False):
        fn = getattr(owner, attr)  # a classmethod comes bound to its class

        def timed(*args, **kwargs):
            t0 = time.perf_counter()
            try:
                return fn(*args, **kwargs)
            finally:
                self.total[label] = self.total.get(label, 0.0) + (
                    time.perf_counter() - t0
                )

        self._saved.append((owner, attr, owner.__dict__[attr]))
        if static:
            setattr(owner, attr, classmethod(lambda cls, *a, **k: timed(*a, **k)))
        else:
            setattr(owner, attr, timed)

    def restore(self):
        for owner, attr, value in reversed(self._saved):
            setattr(owner, attr, value)


def stage_times(gdf) -> dict[str, float]:
    """One ``hull(n_jobs=1)`` with its stages timed."""
    import shapely

    watch = Stopwatch()
    watch.wrap(shapely, "delaunay_triangles", "GEOS (shapely.delaunay_triangles)")
    watch.wrap(delaunay, "triangulate_groups", "backend")
    watch.wrap(core, "Delaunay", "Qhull (fallback groups)")
    watch.wrap(core, "triangulate", "triangulate")
    watch.wrap(core, "fill_radius", "fill radii (maximum spanning tree)")
    watch.wrap(
        core.Spectrum,
        "build",
        "spectrum (Euler counts; spanning forest if holes)",
        True,
    )
    watch.wrap(core.Spectrum, "optimum", "optimum search")
    watch.wrap(core, "piece_labels", "pieces")
    watch.wrap(core, "boundary_rings", "boundary rings")
    watch.wrap(shapes, "assemble", "polygons (shapely)")
    watch.wrap(shapes, "enforce", "guarantee (valid, covering; repairs)")
    watch.wrap(pipeline, "alpha_shapes", "alpha_shapes")
    try:
        t0 = time.perf_counter()
        gdf.alpha.hull(by="group")
        total = time.perf_counter() - t0
    finally:
        watch.restore()
    t = dict(watch.total)
    geos = t.pop("GEOS (shapely.delaunay_triangles)", 0.0)
    backend = t.pop("backend", 0.0)
    qhull = t.pop("Qhull (fallback groups)", 0.0)
    inner = t.pop("alpha_shapes")
    out = {
        "GEOS (shapely.delaunay_triangles)": geos,
        "backend: index arrays, neighbours, checks": backend - geos,
        "Qhull (fallback groups)": qhull,
        "triangulate: batched numpy (radii, ties, orientation)": t.pop("triangulate")
        - backend
        - qhull,
        **t,
    }
    out["alpha_shapes: rest (masks, areas)"] = inner - sum(out.values())
    out["hull(): frame in/out, grouping, CRS"] = total - inner
    out["total"] = total
    return out


# --- dask ---------------------------------------------------------------------------


def _process_cpu() -> float:
    """CPU seconds of the calling (worker) process so far."""
    import psutil

    t = psutil.Process().cpu_times()
    return t.user + t.system


def run_dask(n: int, n_groups: int, nparts: int, memory_limit: str, seed: int):
    import logging

    import dask.dataframe as dd
    import dask_geopandas
    import distributed
    from distributed.diagnostics import MemorySampler

    import geoalpha.dask  # registers the accessor on dask frames

    reset_peak()  # the client's peak from here (the eager part came before)
    client_start = peak_rss_mb()
    groups = make_groups(n_groups, seed)
    per_part = n // nparts
    meta = make_partition(0, groups, 0, seed)
    result: dict = {"points": per_part * nparts, "groups": n_groups}
    result.update(partitions=nparts, workers=2, memory_limit=memory_limit)
    with (
        distributed.LocalCluster(
            n_workers=2,
            threads_per_worker=1,
            processes=True,
            memory_limit=memory_limit,
            dashboard_address=None,
            silence_logs=logging.ERROR,
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        ddf = dd.from_map(
            make_partition,
            range(nparts),
            groups=groups,
            n=per_part,
            seed=seed,
            meta=meta,
            enforce_metadata=False,
        )
        assert isinstance(ddf, dask_geopandas.GeoDataFrame)
        sampler = MemorySampler()
        shuffle_meta = geoalpha.dask._for_shuffle(meta, "geometry")
        steps = {
            "generate only": ddf.map_partitions(len, meta=(None, int)),
            # The rows as geoalpha.dask shuffles them (geometries as WKB).
            "generate + shuffle by group": ddf.map_partitions(
                geoalpha.dask._for_shuffle, "geometry", meta=shuffle_meta
            )
            .shuffle(on="group")
            .map_partitions(len, meta=(None, int)),
            "hull (generate, shuffle, hull, gather)": geoalpha.hull(ddf, by="group"),
        }
        times = {}
        for name, lazy in steps.items():
            load = os.getloadavg()[0]
            cpu0 = sum(client.run(_process_cpu).values())
            t0 = time.perf_counter()
            with sampler.sample(name, measure="process", interval=0.25):
                out = client.compute(lazy).result()
            seconds = time.perf_counter() - t0
            cpu = sum(client.run(_process_cpu).values()) - cpu0
            times[name] = {"seconds": seconds, "worker_cpu": cpu, "load": load}
        hulls = out
        peaks = sampler.to_pandas().max() / 2**20
        result["times"] = times
        result["cluster_peak_mb"] = {k: float(v) for k, v in peaks.items()}
        result["rows"] = len(hulls)
        result["points_in_hulls"] = int(hulls["n_points"].sum())
    result["client_peak_mb"] = peak_rss_mb()
    result["client_start_mb"] = client_start
    return result


# --- report ---------------------------------------------------------------------------


def spread(values) -> str:
    return f"{statistics.median(values):.2f} ({min(values):.2f}-{max(values):.2f})"


def report(eager: dict | None, dask_res: dict | None, command: str) -> str:
    lines = [f"`{command}`", ""]
    lines.append(
        f"Python {platform.python_version()}, numpy {np.__version__}, "
        f"geoalpha {geoalpha.__version__}, {os.cpu_count()} CPUs "
        f"({platform.machine()}), shared with other jobs."
    )
    if eager:
        t, c, floor = eager["times"], eager["cpu"], eager["times"]["floor"]
        load = eager["load"]
        lines += [
            "",
            f"**(a) {eager['points']:,} points, {eager['groups']:,} groups, "
            f"EPSG:32633; {len(floor)} repeats side by side, load average "
            f"{min(load):.1f}-{max(load):.1f} on {os.cpu_count()} cores; "
            "median (min-max)**",
            "",
            "| case | wall s | CPU s | wall / floor (same repeat) "
            "| peak RSS MB (input frame) |",
            "|---|---|---|---|---|",
        ]
        for name in t:
            ratio = [a / b for a, b in zip(t[name], floor, strict=True)]
            m = eager["memory"][name]
            mem = f"{m['peak_mb']:.0f} ({m['input_mb']:.0f})"
            if m["worker_peak_mb"] > 0:
                mem += f"; workers {m['worker_peak_mb']:.0f} each"
            lines.append(
                f"| {name} | {spread(t[name])} | {spread(c[name])} "
                f"| {spread(ratio)} | {mem} |"
            )
        lines += [
            "",
            "n_jobs=2 and the one-pass run give the same GeoDataFrame as "
            "n_jobs=1 (checked).",
            "",
            "Where the time of one `hull(n_jobs=1)` goes:",
            "",
            "| stage | s | share |",
            "|---|---|---|",
        ]
        stages = eager["stages"]
        for name, value in stages.items():
            share = value / stages["total"]
            lines.append(f"| {name} | {value:.2f} | {share:.0%} |")
    if dask_res:
        lines += [
            "",
            f"**(b) dask: {dask_res['points']:,} points, {dask_res['groups']:,} "
            f"groups, {dask_res['partitions']} partitions, LocalCluster of "
            f"{dask_res['workers']} worker processes x 1 thread, memory_limit "
            f"{dask_res['memory_limit']} each**",
            "",
            "| step | wall s | workers' CPU s | load at start "
            "| peak RSS of the workers, summed MB |",
            "|---|---|---|---|---|",
        ]
        for name, v in dask_res["times"].items():
            peak = dask_res["cluster_peak_mb"].get(name, float("nan"))
            lines.append(
                f"| {name} | {v['seconds']:.1f} | {v['worker_cpu']:.1f} "
                f"| {v['load']:.1f} | {peak:.0f} |"
            )
        lines += [
            "",
            f"{dask_res['rows']:,} hulls covering {dask_res['points_in_hulls']:,} "
            f"points; client process peak RSS {dask_res['client_peak_mb']:.0f} MB "
            f"({dask_res['client_start_mb']:.0f} MB when (b) started).",
        ]
    return "\n".join(lines)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="100k / 1M points")
    parser.add_argument("--repeat", type=int, default=None)
    parser.add_argument("--seed", type=int, default=SEED)
    parser.add_argument("--points", type=int, default=None)
    parser.add_argument("--groups", type=int, default=None)
    parser.add_argument("--dask-points", type=int, default=None)
    parser.add_argument("--partitions", type=int, default=None)
    parser.add_argument("--memory-limit", default="2GiB")
    parser.add_argument("--skip-eager", action="store_true")
    parser.add_argument("--skip-dask", action="store_true")
    parser.add_argument("--json", type=Path, help="also write the numbers here")
    parser.add_argument("--_memory", help=argparse.SUPPRESS)
    parser.add_argument("--_points", type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    warnings.simplefilter("ignore", geoalpha.GeoAlphaWarning)

    n = args.points or (100_000 if args.quick else 1_000_000)
    n_groups = args.groups or max(n // 1000, 1)
    if args._memory:
        _memory_child(args._memory, args._points, n_groups)
        return
    repeat = args.repeat or (2 if args.quick else 3)
    dask_n = args.dask_points or (1_000_000 if args.quick else 10_000_000)
    nparts = args.partitions or max(dask_n // 500_000, 4)

    eager = None if args.skip_eager else run_eager(n, n_groups, repeat, args.seed)
    dask_res = None
    if not args.skip_dask:
        dask_res = run_dask(
            dask_n, max(dask_n // 1000, 1), nparts, args.memory_limit, args.seed
        )
    command = "python benchmarks/bench_scale.py " + " ".join(
        sys.argv[1:] if argv is None else argv
    )
    print(report(eager, dask_res, command.strip()))
    if args.json:
        args.json.write_text(json.dumps({"eager": eager, "dask": dask_res}, indent=1))


if __name__ == "__main__":
    main()
