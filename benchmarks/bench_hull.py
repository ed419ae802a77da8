"""Benchmark ``gdf.alpha.hull(by=...)`` against GeoPandas' convex hull per group.

Issue #3's target: the whole hull pipeline on the 691 bundled UK accident
clusters (lon/lat input) within 3x of
``gdf.to_crs(gdf.estimate_utm_crs()).dissolve(by="Cluster").convex_hull``,
measured side by side in one run (interleaved rounds, best of N).

    python benchmarks/bench_hull.py [--repeat 7]
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))  # timing.py
from timing import best_of, fmt_time

import geoalpha
from geoalpha import datasets


def main(argv=None) -> None:
    """Print a markdown table of the timings and their ratio."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7)
    args = parser.parse_args(argv)

    points = datasets.load("uk_clusters")
    warnings.simplefilter("ignore", geoalpha.GeoAlphaWarning)

    def dissolve_convex():
        return (
            points.to_crs(points.estimate_utm_crs()).dissolve(by="Cluster").convex_hull
        )

    def geoalpha_hull():
        return points.alpha.hull(by="Cluster")

    def geoalpha_convex():
        return points.alpha.hull(by="Cluster", method="convex")

    methods = {
        "`to_crs(estimate_utm_crs()).dissolve(by).convex_hull`": dissolve_convex,
        "`gdf.alpha.hull(by)` (exact optimal alpha)": geoalpha_hull,
        '`gdf.alpha.hull(by, method="convex")`': geoalpha_convex,
    }
    best = best_of(methods, args.repeat)
    base = best["`to_crs(estimate_utm_crs()).dissolve(by).convex_hull`"]
    print(f"{len(points):,} points (EPSG:4326) in 691 groups, best of {args.repeat}\n")
    print("| method | time | / dissolve convex hull |")
    print("|---|---:|---:|")
    for name, seconds in best.items():
        print(f"| {name} | {fmt_time(seconds)} | {seconds / base:.2f}x |")


if __name__ == "__main__":
    main()
