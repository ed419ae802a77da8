"""The same timings in a fresh process and after a large array was freed.

geoalpha's batched steps work on arrays of a few hundred kilobytes to a few
megabytes (the UK clusters: ~12,700 triangles). glibc's ``malloc`` serves such
blocks with ``mmap`` at first and, once a block that large has been freed,
from its heap; it gives the top of the heap back to the system when more than
twice the largest freed block is free there. Both limits only grow, with the
largest block freed so far, up to 32 MiB: a process that has once freed a
block of several megabytes (any session that read a large file or projected
a large frame) keeps the memory of the next calls mapped, while a fresh
process that has only handled small data maps and faults in the same pages
again on every call. Page faults are not free (a few microseconds each on a
virtual machine), so the same call can take a different time depending on
what the process did before.

This runs the UK clusters' timings of ``bench_core.py`` and
``bench_postgis.py`` twice, each in its own child process: as those
benchmarks run them (a fresh process), and after one 16 MB array has been
allocated, written and freed. Nothing else differs. The scipy Delaunay loop,
whose arrays are small, is the reference of both. The goals of issue #12 are
judged on the fresh process, as the other benchmarks measure them; this only
shows how much of the time is the allocator's. Linux with glibc only.
Run from the repository root::

    python benchmarks/bench_allocator.py [--rounds 20]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

#: The array allocated, written and freed before timing in the "warm" state.
WARM_BYTES = 16 * 2**20


def child(warm: bool, rounds: int) -> dict[str, list[float]]:
    """Time the three workloads, interleaved; seconds per round."""
    import bench_core
    from scipy.spatial import Delaunay

    import geoalpha

    warnings.simplefilter("ignore")
    uk = bench_core.load_groups("uk_clusters")
    arrays = uk.arrays()
    frame, by = bench_core.hull_frame("uk_clusters", uk.labels)
    metres = frame.to_crs("EPSG:27700")

    def floor():
        for a in arrays:
            if len(a) >= 3:
                Delaunay(a)

    fns = {
        "scipy Delaunay loop": floor,
        "alpha_shapes, distinct points": lambda: geoalpha.alpha_shapes(
            uk.points, uk.codes
        ),
        "hull() lon/lat": lambda: frame.alpha.hull(by=by),
        "hull() EPSG:27700": lambda: metres.alpha.hull(by=by),
    }
    if warm:
        block = np.empty(WARM_BYTES // 8)
        block[:] = 1.0
        del block
    return bench_core.best_of(fns, rounds)


def main(argv=None) -> None:
    """Run both states in child processes and print the table."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=20)
    parser.add_argument("--child", choices=["fresh", "warm"], help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        print(json.dumps(child(args.child == "warm", args.rounds)))
        return
    results = {}
    for state in ("fresh", "warm"):
        out = subprocess.run(
            [sys.executable, __file__, "--child", state, "--rounds", str(args.rounds)],
            check=True,
            capture_output=True,
            text=True,
        ).stdout
        results[state] = {k: np.array(v) for k, v in json.loads(out).items()}
    floor = "scipy Delaunay loop"
    print(
        f"UK clusters, {args.rounds} rounds interleaved per process; "
        "ms = median; ratio = median of the paired ratios to the scipy loop\n"
    )
    print("| work | fresh process | ratio | after a 16 MB array was freed | ratio |")
    print("|---|---:|---:|---:|---:|")
    for name in results["fresh"]:
        cells = []
        for state in ("fresh", "warm"):
            t = results[state]
            ratio = np.median(t[name] / t[floor])
            cells += [f"{np.median(t[name]) * 1e3:.1f} ms", f"{ratio:.2f}x"]
        print(f"| {name} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
