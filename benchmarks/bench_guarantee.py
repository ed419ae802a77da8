"""What the robustness guarantee costs: alpha_shapes before and after, one run.

Times ``geoalpha.alpha_shapes`` on the 691 bundled UK accident clusters
(EPSG:27700, as in ``bench_core.py``) with two source trees of geoalpha, in
alternating subprocesses (so both see the same machine load), and reports
the ratio of the medians::

    git worktree add /tmp/before <commit before the change>
    python benchmarks/bench_guarantee.py --before /tmp/before --rounds 9

Each round runs each tree once: a fresh process that loads the data,
warms up, and reports its best of ``--repeat`` calls in CPU time (process
time), which other load on the machine disturbs far less than wall time.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent

SNIPPET = """
import time, warnings
import numpy as np, pandas as pd, shapely
import geoalpha
from geoalpha import datasets
warnings.simplefilter("ignore")
pts = datasets.load("uk_clusters").to_crs(27700)
xy = shapely.get_coordinates(pts.geometry.to_numpy())
codes = pd.factorize(pts["Cluster"])[0]
geoalpha.alpha_shapes(xy, codes)
best = min(
    (lambda t: (geoalpha.alpha_shapes(xy, codes), time.process_time() - t)[1])(
        time.process_time()
    )
    for _ in range({repeat})
)
print(geoalpha.__file__, best)
"""


def time_tree(tree: Path, repeat: int) -> float:
    env = dict(os.environ, PYTHONPATH=str(tree))
    out = subprocess.run(
        [sys.executable, "-c", SNIPPET.format(repeat=repeat)],
        env=env,
        capture_output=True,
        text=True,
        check=True,
        cwd=tree,
        timeout=600,
    ).stdout.split()
    if not out[0].startswith(str(tree)):
        raise RuntimeError(f"{tree} did not provide geoalpha (got {out[0]})")
    return float(out[1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", type=Path, required=True)
    parser.add_argument("--after", type=Path, default=HERE.parent)
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--repeat", type=int, default=15)
    args = parser.parse_args()
    before, after = [], []
    for _ in range(args.rounds):
        before.append(time_tree(args.before.resolve(), args.repeat))
        after.append(time_tree(args.after.resolve(), args.repeat))
    b, a = statistics.median(before), statistics.median(after)
    ratios = sorted(x / y for x, y in zip(after, before, strict=True))
    print(f"alpha_shapes on 691 UK clusters, median of {args.rounds} rounds:")
    print(f"  before {b * 1e3:.2f} ms  after {a * 1e3:.2f} ms  ratio {a / b:.3f}")
    print(f"  per-round ratios {ratios[0]:.3f} .. {ratios[-1]:.3f}")
    print(f"  load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
