"""What "why this shape" costs (issue #35): the flag, explain() and curve().

Run from the repository root::

    python benchmarks/bench_why.py [--rounds N] [--quick]

Data: the 691 bundled UK accident DBSCAN clusters (lon/lat, ``crs="auto"``)
and 1M points in 1,000 normal clusters (seed 0, EPSG:32630, as
``bench_kernel.py``). Each round times, one after the other so that the ratios
are taken on the same machine load: ``hull(suspicious=False)`` (the base),
``hull()`` (with the suspicious check), ``explain()`` and
``curve(max_left_out=5)`` (locations). The table gives the median time and the
median per-round ratio to the base. The issue's goals: the check <= 1.15x,
``explain()`` <= 1.5x, ``curve(max_left_out=5)`` <= 3x.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
import warnings
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))  # timing.py
from bench_kernel import many_groups  # noqa: E402
from timing import fmt_time, paired_ratio, rounds  # noqa: E402

try:
    import geoalpha
except ImportError:  # running from a source tree without installing
    sys.path.insert(0, str(HERE.parent))
    import geoalpha

from geoalpha import datasets  # noqa: E402

GOALS = {"hull()": 1.15, "explain()": 1.5, "curve(max_left_out=5)": 3.0}


def calls(gdf, by):
    return {
        "hull(suspicious=False)": lambda: geoalpha.hull(gdf, by, suspicious=False),
        "hull()": lambda: geoalpha.hull(gdf, by),
        "explain()": lambda: geoalpha.explain(gdf, by),
        "curve(max_left_out=5)": lambda: geoalpha.curve(
            gdf, by, max_left_out=5, outlier_unit="locations"
        ),
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3, help="paired rounds (3)")
    parser.add_argument("--quick", action="store_true", help="100k points, not 1M")
    args = parser.parse_args(argv)
    n = 100_000 if args.quick else 1_000_000
    sets = {
        "691 UK clusters": (datasets.load("uk_clusters"), "Cluster"),
        f"{n:,} points in 1,000 groups": (many_groups(n, 1_000)[0], "g"),
    }
    print(f"{args.rounds} paired rounds (wall time)\n")
    print("| data | call | time (median) | / hull(suspicious=False) | goal |")
    print("|---|---|---:|---:|---:|")
    for name, (gdf, by) in sets.items():
        fns = calls(gdf, by)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            times = rounds(fns, args.rounds, clock=time.perf_counter)
        base = times["hull(suspicious=False)"]
        for call, t in times.items():
            goal = "" if call not in GOALS else f"<= {GOALS[call]}x"
            print(
                f"| {name} | `{call}` | {fmt_time(statistics.median(t))} | "
                f"{paired_ratio(t, base):.2f}x | {goal} |"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
