"""Compare ``gdf.alpha.hull(by)`` of two source trees, call by call.

Two worker processes, one importing geoalpha from each tree, time one hull of
the 691 bundled UK accident clusters in turn (the order alternates every
round), so that load on the machine hits both alike. Prints the best times
and the median of the paired ratios (new / old).

    git worktree add /tmp/old main   # or: git archive main | tar -x -C /tmp/old
    python benchmarks/compare_trees.py /tmp/old . [--method alpha] [--rounds 25]
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
from pathlib import Path

WORKER = """
import sys, time, warnings
from geoalpha import datasets
import geoalpha
warnings.simplefilter("ignore")
points = datasets.load("uk_clusters")
points.alpha.hull(by="Cluster", method=sys.argv[1])
for line in sys.stdin:
    start = time.perf_counter()
    points.alpha.hull(by="Cluster", method=sys.argv[1])
    print(time.perf_counter() - start, flush=True)
"""


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("old")
    parser.add_argument("new")
    parser.add_argument("--method", default="alpha")
    parser.add_argument("--rounds", type=int, default=25)
    args = parser.parse_args(argv)

    def start(tree):
        env = {**os.environ, "PYTHONPATH": str(Path(tree).resolve())}
        return subprocess.Popen(
            [sys.executable, "-c", WORKER, args.method],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
            env=env,
            cwd=Path(tree).resolve().parent,
        )

    procs = {"old": start(args.old), "new": start(args.new)}
    times: dict[str, list[float]] = {"old": [], "new": []}
    for r in range(args.rounds):
        for name in ("old", "new") if r % 2 == 0 else ("new", "old"):
            procs[name].stdin.write("go\n")
            procs[name].stdin.flush()
            times[name].append(float(procs[name].stdout.readline()))
    for proc in procs.values():
        proc.stdin.close()
        proc.wait()
    ratios = [n / o for n, o in zip(times["new"], times["old"], strict=True)]
    print(
        f"method={args.method}, {args.rounds} rounds: old best "
        f"{min(times['old']) * 1e3:.1f} ms, new best {min(times['new']) * 1e3:.1f} ms, "
        f"best new/old {min(times['new']) / min(times['old']):.3f}, "
        f"median paired new/old {statistics.median(ratios):.3f}"
    )


if __name__ == "__main__":
    main()
