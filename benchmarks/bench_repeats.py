"""Exact repeated rows set aside before the triangulation, on and off.

``alpha_shapes`` computes the shapes of the rows that do not repeat an
earlier row of their group exactly (``core.exact_duplicates``) and copies
the per-row results to the repeats. This times ``hull()`` and
``alpha_shapes`` with that step and with it switched off (as if no row
repeated another), interleaved in one process, and prints the minima and the
median of the paired ratios. Workloads: the 691 UK clusters' rows (15,255
rows, 8,960 distinct points) in EPSG:27700 and in lon/lat, their 8,960
deduplicated points (no repeats: the cost of looking), and the 5 STATS19
authorities (1,003 rows). Both settings must give the same results (checked).
Run from the repository root::

    python benchmarks/bench_repeats.py [--rounds 25]
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

import bench_core  # noqa: E402
from geopandas.testing import assert_geodataframe_equal  # noqa: E402

import geoalpha  # noqa: E402
from geoalpha import core  # noqa: E402


def workloads() -> dict:
    """Name -> a call to time."""
    uk = bench_core.load_groups("uk_clusters")
    frame, by = bench_core.hull_frame("uk_clusters", uk.labels)
    metres = frame.to_crs("EPSG:27700")
    stats = bench_core.load_groups("stats19")
    stats_frame, stats_by = bench_core.hull_frame("stats19", stats.labels)
    return {
        "uk hull() EPSG:27700": lambda: metres.alpha.hull(by=by),
        "uk hull() lon/lat": lambda: frame.alpha.hull(by=by),
        "uk alpha_shapes, distinct points": lambda: geoalpha.alpha_shapes(
            uk.points, uk.codes, holes=False, components=1
        ),
        "stats19 hull() lon/lat": lambda: stats_frame.alpha.hull(by=stats_by),
    }


def main(argv=None) -> None:
    """Time every workload with the step on and off; print the table."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=25)
    args = parser.parse_args(argv)
    real = core.exact_duplicates
    settings = {"on": real, "off": lambda *args, **kwargs: None}
    warnings.simplefilter("ignore")  # the degenerate groups of the datasets
    calls = workloads()
    for call in calls.values():  # same results both ways (and warm-up)
        got = {}
        for setting, fn in settings.items():
            core.exact_duplicates = fn
            got[setting] = call()
        if hasattr(got["on"], "geometry") and hasattr(got["on"], "crs"):
            assert_geodataframe_equal(got["on"], got["off"], check_less_precise=False)
        else:
            np.testing.assert_array_equal(got["on"].alpha, got["off"].alpha)
    times = {(name, s): [] for name in calls for s in settings}
    for _ in range(args.rounds):
        for name, call in calls.items():
            for setting, fn in settings.items():
                core.exact_duplicates = fn
                start = time.perf_counter()
                call()
                times[name, setting].append(time.perf_counter() - start)
    core.exact_duplicates = real
    print("| workload | on: best | off: best | on / off (median of paired rounds) |")
    print("|---|---:|---:|---:|")
    for name in calls:
        on, off = np.array(times[name, "on"]), np.array(times[name, "off"])
        print(
            f"| {name} | {on.min() * 1e3:.2f} ms | {off.min() * 1e3:.2f} ms "
            f"| {np.median(on / off):.3f}x |"
        )


if __name__ == "__main__":
    main()
