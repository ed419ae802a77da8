"""What ``overlap="split"`` costs: ``hull(overlap="split")`` vs ``hull()``.

Run from the repository root::

    python benchmarks/bench_overlap.py [--rounds N]

Data, each hulled by the whole GeoDataFrame pipeline (``geoalpha.hull``):

- the 691 bundled UK accident DBSCAN clusters (15,255 points; few overlaps);
- 1M lon/lat points in 1,000 groups of about 100 km around the world
  (``bench_hull.world_groups``, the other benchmarks' data: random centres, so
  that 293 pairs of groups overlap, many of them widely);
- the same, the 1,000 centres on a 40 x 25 grid (no two groups overlap: what
  a mostly disjoint dataset costs);
- the bundled US airports by state (3,376 points; 9 pairs of states overlap),
  the heavily overlapping real dataset at hand (zip codes by county, the
  issue's third dataset, are not available offline);
- the Lansing Woods trees by species (2,251 points in 6 species, every hull
  overlapping every other; ``crs=None``, unit square).

Each round times ``"keep"`` and ``"split"`` one after the other (paired, on
the same machine load); the table gives the median over rounds of each time
and of the per-round ratio. The issue's targets: at most 1.3x on the UK
clusters and on 1M points in 1,000 groups; at most 2x on a heavily overlapping
dataset.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import warnings
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))  # timing.py, bench_hull.py
from timing import fmt_time, paired_ratio, rounds  # noqa: E402

try:
    import geoalpha
except ImportError:  # running from a source tree without installing
    sys.path.insert(0, str(HERE.parent))
    import geoalpha

import geopandas as gpd  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from bench_hull import world_groups  # noqa: E402

from geoalpha import datasets  # noqa: E402

LANSING = HERE.parent / "tests" / "data" / "lansing_trees_spatstat.csv"


def grid_groups(n: int = 1_000_000, seed: int = 0):
    """``world_groups`` with the 1,000 centres on a grid: groups far apart."""
    rng = np.random.default_rng(seed)
    lon, lat = np.meshgrid(np.linspace(-170, 170, 40), np.linspace(-60, 70, 25))
    centre = np.column_stack([lon.ravel(), lat.ravel()])
    code = rng.integers(0, len(centre), n)
    scale = np.cos(np.radians(centre[code, 1]))
    x = centre[code, 0] + rng.normal(0, 0.4, n) / scale
    y = centre[code, 1] + rng.normal(0, 0.4, n)
    return gpd.GeoDataFrame(
        {"g": code}, geometry=gpd.points_from_xy(x, y), crs="EPSG:4326"
    )


def cases() -> dict:
    """Name -> (frame, by, extra options, rounds factor)."""
    airports = datasets.load("us_airports").dropna(subset=["state"])
    trees = pd.read_csv(LANSING)
    trees = gpd.GeoDataFrame(trees, geometry=gpd.points_from_xy(trees.x, trees.y))
    return {
        "UK clusters (15,255 points, 691 groups)": (
            datasets.load("uk_clusters"),
            "Cluster",
            {},
            1,
        ),
        "1M points in 1,000 groups (world, 293 overlapping pairs)": (
            world_groups(),
            "g",
            {},
            0,
        ),
        "1M points in 1,000 groups (grid, none overlap)": (grid_groups(), "g", {}, 0),
        f"US airports by state ({len(airports):,} points, 56 groups)": (
            airports,
            "state",
            {},
            1,
        ),
        "Lansing trees by species (2,251 points, 6 groups, crs=None)": (
            trees,
            "species",
            {"crs": None},
            1,
        ),
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5, help="paired rounds (5)")
    args = parser.parse_args(argv)
    warnings.simplefilter("ignore", geoalpha.GeoAlphaWarning)
    print(f"median of {args.rounds} paired rounds (1M points: 2)\n")
    print('| data | hull() | overlap="split" | split / keep |')
    print("|---|---:|---:|---:|")
    for name, (frame, by, extra, factor) in cases().items():
        calls = {
            overlap: (
                lambda f=frame, b=by, o=overlap, e=extra: geoalpha.hull(
                    f, b, overlap=o, **e
                )
            )
            for overlap in ("keep", "split")
        }
        times = rounds(calls, args.rounds if factor else 2)
        keep, split = times["keep"], times["split"]
        print(
            f"| {name} | {fmt_time(statistics.median(keep))} | "
            f"{fmt_time(statistics.median(split))} | "
            f"{paired_ratio(split, keep):.2f}x |"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
