"""What compiled code would save after the GEOS triangulation (an estimate).

Issue #12's remaining goals ask the UK clusters' ``alpha_shapes`` for 0.6x
of the scipy Delaunay loop. The GEOS call, with building its input and
reading and freeing its ~12,700 triangles, takes about 0.3x on its own; the
rest is some twenty numpy passes over triangles and edges, each cheap but
each a full pass with its own temporaries. This measures one of them against
the same work written as a single compiled loop: reading the point indices
from GEOS's corners, checking them against the points, the orientation and
shortest edge of every triangle (``delaunay._check_corners``), and the
triangle across every edge (``delaunay._neighbors``, a radix sort in numpy, a
hash table in the loop). The loop is compiled with numba, which is not a
dependency of geoalpha (``pip install numba`` to run this); it stands for any
compiled kernel (C, C++ or Cython would be about as fast). Both must give
the same neighbours (checked).

Run from the repository root::

    python benchmarks/bench_compiled.py [--rounds 50]
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import shapely

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

import bench_core  # noqa: E402

from geoalpha import delaunay  # noqa: E402


def numpy_steps(corners, local, tri_group, max_size):
    """The library's own steps (as ``delaunay.triangulate_groups`` runs them)."""
    tri = corners[:, 2].reshape(-1, 4)[:, :3].astype(np.int64)
    area2, shortest2, same = delaunay._check_corners(local, tri, corners)
    failed = np.zeros(int(tri_group[-1]) + 1, dtype=bool)
    neighbors, _ = delaunay._neighbors(tri, len(local), max_size, tri_group, failed)
    return tri, neighbors, area2, shortest2, same


#: Fibonacci hashing's multiplier (2**64 / golden ratio), as a signed int64.
HASH = 0x9E3779B97F4A7C15 - 2**64


def compiled_steps():
    """The same steps as one loop, compiled with numba (None without numba)."""
    try:
        import numba
    except ImportError:
        return None

    @numba.njit(cache=False)
    def steps(corners, local):  # pragma: no cover - compiled
        m = corners.shape[0] // 4
        p = local.shape[0]
        tri = np.empty((m, 3), np.int64)
        area2 = np.empty(m)
        shortest2 = np.empty(m)
        same = np.ones(m, np.bool_)
        for t in range(m):
            for j in range(3):
                v = np.int64(corners[4 * t + j, 2])
                tri[t, j] = v
                if (
                    local[v, 0] != corners[4 * t + j, 0]
                    or local[v, 1] != corners[4 * t + j, 1]
                ):
                    same[t] = False
            x0, y0 = corners[4 * t, 0], corners[4 * t, 1]
            x1, y1 = corners[4 * t + 1, 0], corners[4 * t + 1, 1]
            x2, y2 = corners[4 * t + 2, 0], corners[4 * t + 2, 1]
            dx0, dy0 = x1 - x0, y1 - y0  # edge j: vertex j -> vertex j + 1
            dx1, dy1 = x2 - x1, y2 - y1
            dx2, dy2 = x0 - x2, y0 - y2
            e0 = dx0 * dx0 + dy0 * dy0
            e1 = dx1 * dx1 + dy1 * dy1
            e2 = dx2 * dx2 + dy2 * dy2
            # The cross product at the vertex opposite the longest edge.
            if e0 >= e1 and e0 >= e2:
                area2[t] = dy2 * dx1 - dx2 * dy1
            elif e1 >= e2:
                area2[t] = dy0 * dx2 - dx0 * dy2
            else:
                area2[t] = dy1 * dx0 - dx1 * dy0
            shortest2[t] = min(e0, e1, e2)
        size = 1
        while size < 6 * m:
            size *= 2
        keys = np.full(size, -1, np.int64)
        slot = np.empty(size, np.int64)
        for t in range(m):  # directed edge opposite vertex j -> its slot
            for j in range(3):
                key = tri[t, (j + 1) % 3] * p + tri[t, (j + 2) % 3]
                h = (key * HASH) & (size - 1)
                while keys[h] != -1:
                    h = (h + 1) & (size - 1)
                keys[h] = key
                slot[h] = 3 * t + j
        neighbors = np.full((m, 3), -1, np.int64)
        for t in range(m):  # the same edge the other way round
            for j in range(3):
                key = tri[t, (j + 2) % 3] * p + tri[t, (j + 1) % 3]
                h = (key * HASH) & (size - 1)
                while keys[h] != -1:
                    if keys[h] == key:
                        neighbors[t, j] = slot[h] // 3
                        break
                    h = (h + 1) & (size - 1)
        return tri, neighbors, area2, shortest2, same

    return steps


def main(argv=None) -> None:
    """Time both on the UK clusters' GEOS triangles; print the medians."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=50)
    args = parser.parse_args(argv)
    steps = compiled_steps()
    if steps is None:
        sys.exit("numba is not installed: pip install numba")

    uk = bench_core.load_groups("uk_clusters")
    ptr = np.zeros(len(uk.labels) + 1, dtype=np.int64)
    np.cumsum(np.bincount(uk.codes), out=ptr[1:])
    local = uk.points - uk.points[ptr[uk.codes]]
    xyz = np.column_stack([local, np.arange(len(local))])
    lines = shapely.from_ragged_array(shapely.GeometryType.LINESTRING, xyz, (ptr,))
    corners = shapely.get_coordinates(shapely.delaunay_triangles(lines), include_z=True)
    tri = corners[:, 2].reshape(-1, 4)[:, :3].astype(np.int64)
    tri_group = uk.codes[tri[:, 0]]
    max_size = int(np.diff(ptr).max())

    t0 = time.perf_counter()
    fast = steps(corners, local)
    compiled = time.perf_counter() - t0
    slow = numpy_steps(corners, local, tri_group, max_size)
    for a, b in zip(slow, fast, strict=True):
        np.testing.assert_array_equal(a, b)

    times = {"numpy (geoalpha today)": [], "one compiled loop (numba)": []}
    for _ in range(args.rounds):
        for name, run in zip(
            times,
            (
                lambda: numpy_steps(corners, local, tri_group, max_size),
                lambda: steps(corners, local),
            ),
            strict=True,
        ):
            t0 = time.perf_counter()
            run()
            times[name].append(time.perf_counter() - t0)
    base = np.array(times["numpy (geoalpha today)"])
    print(
        f"UK clusters: {len(tri):,} GEOS triangles; {args.rounds} rounds, median; "
        f"results equal\n\n| steps after GEOS | median | ratio |\n|---|---:|---:|"
    )
    for name, t in times.items():
        t = np.array(t)
        print(f"| {name} | {np.median(t) * 1e3:.2f} ms | {np.median(t / base):.2f}x |")
    code = "import time; t = time.perf_counter(); import numba\n"
    code += "print(time.perf_counter() - t)"
    imported = float(
        subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, check=True
        ).stdout
    )
    print(
        f"\nnumba's import (a fresh process): {imported:.2f} s; compiling the loop "
        f"(first call): {compiled:.2f} s"
    )


if __name__ == "__main__":
    main()
