"""Benchmark ``gdf.alpha.hull(by=...)`` against GeoPandas' convex hull per group.

Issue #3's target: the whole hull pipeline on the 691 bundled UK accident
clusters (lon/lat input) within 3x of
``gdf.to_crs(gdf.estimate_utm_crs()).dissolve(by="Cluster").convex_hull``,
measured side by side in one run (interleaved rounds, best of N).

Issue #26's goal (``--sphere``): ``hull(crs="sphere")`` within 1.3x of
``hull(crs="auto")`` on the bundled airports by state and on 1M lon/lat points
in 1,000 groups spread over the world (``benchmarks/timing.py``, one run).

    python benchmarks/bench_hull.py [--repeat 7] [--sphere]
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))  # timing.py
import geopandas as gpd
import numpy as np
from timing import best_of, fmt_time

import geoalpha
from geoalpha import datasets


def main(argv=None) -> None:
    """Print a markdown table of the timings and their ratio."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument(
        "--sphere", action="store_true", help='crs="sphere" against crs="auto"'
    )
    args = parser.parse_args(argv)
    if args.sphere:
        sphere_table(args.repeat)
        return

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


def world_groups(n: int = 1_000_000, k: int = 1_000, seed: int = 0):
    """``n`` lon/lat points in ``k`` groups of about 100 km around the world."""
    rng = np.random.default_rng(seed)
    centre = np.column_stack([rng.uniform(-170, 170, k), rng.uniform(-60, 70, k)])
    code = rng.integers(0, k, n)
    lon = centre[code, 0] + rng.normal(0, 0.4, n) / np.cos(np.radians(centre[code, 1]))
    lat = centre[code, 1] + rng.normal(0, 0.4, n)
    return gpd.GeoDataFrame(
        {"g": code}, geometry=gpd.points_from_xy(lon, lat), crs="EPSG:4326"
    )


def sphere_table(repeat: int) -> None:
    """Issue #26: ``crs="sphere"`` against ``crs="auto"``, a markdown table."""
    warnings.simplefilter("ignore", geoalpha.GeoAlphaWarning)
    airports = datasets.load("us_airports").dropna(subset=["state"])
    cases = {
        f"airports by state ({len(airports):,} points)": (airports, "state"),
        "1M points in 1,000 groups (world)": (world_groups(), "g"),
    }
    print(f"best of {repeat}\n")
    print('| data | crs="auto" | crs="sphere" | sphere / auto |')
    print("|---|---:|---:|---:|")
    for name, (frame, by) in cases.items():
        best = best_of(
            {
                crs: (lambda f=frame, b=by, crs=crs: geoalpha.hull(f, by=b, crs=crs))
                for crs in ("auto", "sphere")
            },
            repeat,
        )
        auto, sphere = best["auto"], best["sphere"]
        print(
            f"| {name} | {fmt_time(auto)} | {fmt_time(sphere)} | {sphere / auto:.2f}x |"
        )


if __name__ == "__main__":
    main()
