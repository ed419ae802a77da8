"""Near-duplicates taken in by construction: issue #37's goals, in one run.

Each figure is ``alpha_shapes`` end to end (the kernel, the polygons, the
guarantee), best of ``--repeat`` interleaved rounds (``timing.py``), on one
thread (``n_jobs=1``), and the polygon is checked to cover every point:

- 1M points on a circle of radius 1 km at random angles (seed 0): the
  closest are below the merge tolerance (2e-6 m), so thousands of points are
  merged, and each merged point off its representative's chord must be a
  vertex; goal <= 3 s;
- the same at 250k points, and the growth from 250k to 1M; goal <= 5x;
- a chain of 16,000 points 0.5 x the tolerance apart (all one point) beside
  a triangle 1 km across (repro 03); goal <= 0.5 s.

    python benchmarks/bench_near_duplicates.py [--repeat 3]
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np
import shapely

sys.path.insert(0, str(Path(__file__).resolve().parent))

from timing import best_of, fmt_time

import geoalpha


def circle(n: int, seed: int = 0) -> np.ndarray:
    """``n`` points on a circle of radius 1000 at random angles."""
    theta = np.random.default_rng(seed).random(n) * 2 * np.pi
    return np.c_[1000 * np.cos(theta), 1000 * np.sin(theta)]


def chain(n: int) -> np.ndarray:
    """A chain of ``n`` points 0.5e-6 apart (tolerance 1e-6) beside a triangle."""
    points = np.c_[200 + np.arange(n) * 0.5e-6, np.full(n, 200.0)]
    return np.r_[[[0, 0], [1000, 0], [0, 1000]], points]


def run(xy: np.ndarray):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return geoalpha.alpha_shapes(xy, n_jobs=1)


def covers_all(res, xy: np.ndarray) -> bool:
    shapely.prepare(res.geometry[0])
    return bool(shapely.intersects_xy(res.geometry[0], xy[:, 0], xy[:, 1]).all())


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args(argv)
    data = {
        "circle 250k": circle(250_000),
        "circle 1M": circle(1_000_000),
        "chain 16k": chain(16_000),
    }
    fns = {name: (lambda xy=xy: run(xy)) for name, xy in data.items()}
    best = best_of(fns, args.repeat)
    for name, xy in data.items():
        res = run(xy)
        merged = len(xy) - int(res.n_distinct[0])
        print(
            f"{name:12s} {fmt_time(best[name]):>9s}  merged {merged:6d}  "
            f"covers every point: {covers_all(res, xy)}"
        )
    growth = best["circle 1M"] / best["circle 250k"]
    print(f"growth 250k -> 1M: {growth:.2f}x (goal <= 5x)")
    print(f"circle 1M: {best['circle 1M']:.2f} s (goal <= 3 s)")
    print(f"chain 16k: {best['chain 16k']:.3f} s (goal <= 0.5 s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
