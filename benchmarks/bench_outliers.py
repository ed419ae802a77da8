"""What ``outliers=`` costs: the exact outlier-tolerant optimum vs ``outliers=0``.

Run from the repository root::

    python benchmarks/bench_outliers.py [--rounds N]

Data: the 691 bundled UK accident DBSCAN clusters (lon/lat projected to
EPSG:27700). Every round times ``alpha_shapes`` (the exact optimum and the
polygons, all groups in one batched call) and ``hull`` (the whole GeoDataFrame
pipeline) once per setting, the settings one after the other, so that the
ratios are taken within a round on the same machine load; the table gives the
median over rounds of each time and of each ratio to ``outliers=0``. The
issue's target: ``outliers > 0`` costs at most 1.3x ``outliers=0``.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
import warnings
from functools import partial
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))  # timing.py
from timing import fmt_time, paired_ratio, rounds  # noqa: E402

try:
    import geoalpha
except ImportError:  # running from a source tree without installing
    sys.path.insert(0, str(HERE.parent))
    import geoalpha

import pandas as pd  # noqa: E402
import pyproj  # noqa: E402

from geoalpha import datasets  # noqa: E402

SETTINGS = [0, 0.02, 0.05, 1, 3]


def load():
    """(points in metres, group codes, the GeoDataFrame) of the UK clusters."""
    gdf = datasets.load("uk_clusters")
    to_bng = pyproj.Transformer.from_crs(4326, 27700, always_xy=True)
    xy = np.column_stack(to_bng.transform(gdf["Longitude"], gdf["Latitude"]))
    codes, _ = pd.factorize(gdf["Cluster"])
    return xy, codes, gdf


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=9, help="paired rounds (9)")
    args = parser.parse_args(argv)
    xy, codes, gdf = load()
    calls = {
        "alpha_shapes": lambda o: geoalpha.alpha_shapes(xy, codes, outliers=o),
        "hull": lambda o: gdf.alpha.hull(by="Cluster", outliers=o),
    }
    fns = {(api, o): partial(call, o) for api, call in calls.items() for o in SETTINGS}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        results = {key: fn() for key, fn in fns.items()}  # the warm-up
        times = rounds(fns, args.rounds, warm_up=False, clock=time.process_time)
    left_out = {o: int(results["hull", o]["n_outliers"].sum()) for o in SETTINGS}
    print(f"691 UK clusters, {len(xy):,} points; {args.rounds} paired rounds\n")
    print("| call | outliers | rows left out | CPU time (median) | / outliers=0 |")
    print("|---|---:|---:|---:|---:|")
    for (api, o), t in times.items():
        print(
            f"| `{api}` | {o} | {left_out[o]:,} | {fmt_time(statistics.median(t))} "
            f"| {paired_ratio(t, times[api, 0]):.2f}x |"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
