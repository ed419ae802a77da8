"""The compiled kernel against the per-group scipy loop, side by side in one run.

Issue #23's goals, each a ratio measured in this one run (interleaved rounds,
best of ``--repeat``; see ``timing.py``):

- the 691 bundled UK clusters: ``alpha_shapes`` on one thread, and ``hull()``
  from lon/lat, against a per-group ``scipy.spatial.Delaunay`` loop that also
  computes every triangle's circumradius (the floor any per-group method
  pays);
- 1M points in 1,000 groups (seed 0): ``hull(n_jobs=1)`` against that loop,
  and ``hull(n_jobs=2)`` against ``hull(n_jobs=1)``;
- 1M points in one group: ``alpha_shapes`` against ``scipy.spatial.Delaunay``
  of that group alone;
- nearly collinear chains (y = 0.3 x rounded to 3 decimals, x every 1 cm, one
  point 1 m off the line) of 16,001 and 64,001 points against scipy (one
  call each in a fresh process, at most ``BASELINE_LIMIT`` seconds: Qhull
  takes minutes on them), and the growth from one to the other;
- peak memory (max RSS of a fresh process) of ``alpha_shapes`` on 1M points
  in one group; the time of ``import geoalpha`` and ``geoalpha --help``.

With ``--before DIR`` (a checkout of an earlier geoalpha that runs from its
source tree, such as the last pure-Python one), its ``hull()`` and imports are
timed too, in fresh processes, on the same data.

    python benchmarks/bench_kernel.py [--repeat 5] [--before DIR] [--quick]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import textwrap
import warnings
from functools import partial
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from timing import best_of, fmt_time, fresh_python, peak_memory_mb  # noqa: E402

import geoalpha  # noqa: E402
from geoalpha import datasets  # noqa: E402


def scipy_loop(groups: list[np.ndarray]) -> int:
    """Delaunay and every circumradius of each group, in a Python loop."""
    from scipy.spatial import Delaunay

    total = 0
    for xy in groups:
        s = Delaunay(xy).simplices
        a, b, c = xy[s[:, 0]], xy[s[:, 1]], xy[s[:, 2]]
        ab = np.hypot(*(b - a).T)
        bc = np.hypot(*(c - b).T)
        ca = np.hypot(*(a - c).T)
        cross = np.abs((b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0])
        with np.errstate(divide="ignore"):
            total += int(np.isfinite(ab * bc * ca / (2 * cross)).sum())
    return total


def split(xy: np.ndarray, codes: np.ndarray) -> list[np.ndarray]:
    """The distinct points of each group with at least 3 of them."""
    order = np.argsort(codes, kind="stable")
    cuts = np.flatnonzero(np.diff(codes[order])) + 1
    groups = [np.unique(g, axis=0) for g in np.split(xy[order], cuts)]
    return [g for g in groups if len(g) >= 3]


def many_groups(n: int, k: int, seed: int = 0):
    """``n`` points in ``k`` normal clusters (EPSG:32630 metres), as a frame."""
    import geopandas as gpd

    rng = np.random.default_rng(seed)
    codes = rng.integers(0, k, n)
    centre = np.c_[
        400_000 + (np.arange(k) % 40) * 5_000, 5_500_000 + (np.arange(k) // 40) * 5_000
    ]
    xy = centre[codes] + rng.normal(size=(n, 2)) * 500.0
    frame = gpd.GeoDataFrame(
        {"g": codes}, geometry=gpd.points_from_xy(xy[:, 0], xy[:, 1]), crs=32630
    )
    return frame, xy, codes


def chain(n: int) -> np.ndarray:
    """The nearly collinear chain of issue #23 (x every 1 cm)."""
    x = np.arange(n) * 0.01
    xy = np.c_[x, np.round(0.3 * x, 3)]
    return np.r_[xy, [[x[n // 2], 0.3 * x[n // 2] + 1.0]]]


def peak_memory(n: int) -> float:
    """Peak RSS (MB) of a fresh process that runs alpha_shapes on n points."""
    return peak_memory_mb(
        "import numpy as np, geoalpha\n"
        f"geoalpha.alpha_shapes(np.random.default_rng(1).random(({n}, 2)) * 10_000)"
    )


def command_times(commands: dict, repeat: int) -> dict:
    """Best wall time of a fresh process for each ``name: (argv, env)``."""
    runs = {
        name: partial(subprocess.run, argv, env=env, check=True, capture_output=True)
        for name, (argv, env) in commands.items()
    }
    return best_of(runs, repeat, warm_up=False)


def before_hull(before: Path, repeat: int) -> float:
    """Best time of ``hull()`` on the UK clusters with the code in ``before``."""
    code = textwrap.dedent(
        f"""
        import warnings
        warnings.simplefilter("ignore")
        import geoalpha
        from geoalpha import datasets
        from timing import best_of
        gdf = datasets.load("uk_clusters")
        print(best_of({{"h": lambda: gdf.alpha.hull(by="Cluster")}}, {repeat})["h"])
        """
    )
    out = fresh_python(code, dict(os.environ, PYTHONPATH=str(before)))
    return float(out.split()[-1])


#: Longest a baseline may take (Qhull on the nearly collinear chains takes
#: minutes): past it the baseline is reported as "> limit" and the ratio as an
#: upper bound.
BASELINE_LIMIT = 300.0


def scipy_delaunay_seconds(n: int) -> float | None:
    """Seconds of ``scipy.spatial.Delaunay`` on the chain, in a fresh process.

    None past :data:`BASELINE_LIMIT`.
    """
    code = textwrap.dedent(
        f"""
        from bench_kernel import chain
        from scipy.spatial import Delaunay
        from timing import timed
        print(timed(Delaunay, chain({n}))[0])
        """
    )
    try:
        return float(fresh_python(code, timeout=BASELINE_LIMIT).split()[-1])
    except subprocess.TimeoutExpired:
        return None


def row(rows: list, what: str, t: float, base: float, goal: str) -> None:
    rows.append((what, fmt_time(t), f"{t / base:.2f}x", goal))


def main(argv=None) -> int:
    """Print the table of issue #23's goals, measured in this run."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--before", type=Path, default=None)
    parser.add_argument("--quick", action="store_true", help="100k instead of 1M")
    args = parser.parse_args(argv)
    warnings.simplefilter("ignore")
    r = args.repeat
    big = 100_000 if args.quick else 1_000_000
    rows: list[tuple[str, str, str, str]] = []

    # 691 UK clusters
    uk = datasets.load("uk_clusters")
    metres = uk.to_crs(uk.estimate_utm_crs())
    xy = np.c_[metres.geometry.x, metres.geometry.y]
    codes, _ = uk["Cluster"].factorize()
    groups = split(xy, codes)
    t = best_of(
        {
            "loop": lambda: scipy_loop(groups),
            "one": lambda: geoalpha.alpha_shapes(xy, codes, n_jobs=1),
            "hull": lambda: uk.alpha.hull(by="Cluster", n_jobs=1),
        },
        r,
    )
    base = t["loop"]
    rows.append(("**691 UK clusters** (15,255 points)", "", "", ""))
    rows.append(
        ("per-group scipy loop (Delaunay + radii)", fmt_time(base), "1.00x", "")
    )
    row(rows, "`alpha_shapes(n_jobs=1)`", t["one"], base, "<= 0.25x")
    row(rows, "`hull()` from lon/lat, one thread", t["hull"], base, "<= 0.5x")
    if args.before is not None:
        old = before_hull(args.before, r)
        row(rows, f"`hull()` of {args.before.name} (before)", old, base, "")

    # 1M points in 1,000 groups
    frame, bxy, bcodes = many_groups(big, 1000)
    bgroups = split(bxy, bcodes)
    t = best_of(
        {
            "loop": lambda: scipy_loop(bgroups),
            "one": lambda: frame.alpha.hull(by="g", n_jobs=1),
            "two": lambda: frame.alpha.hull(by="g", n_jobs=2),
        },
        max(1, r // 2),
    )
    base = t["loop"]
    rows.append((f"**{big:,} points in 1,000 groups**", "", "", ""))
    rows.append(("per-group scipy loop", fmt_time(base), "1.00x", ""))
    row(rows, "`hull(n_jobs=1)`", t["one"], base, "<= 0.5x")
    rows.append(
        (
            "`hull(n_jobs=2)`",
            fmt_time(t["two"]),
            f"{t['one'] / t['two']:.2f}x faster than 1 thread",
            ">= 1.7x",
        )
    )

    # 1M points in one group
    one = np.random.default_rng(1).random((big, 2)) * 10_000
    from scipy.spatial import Delaunay

    t = best_of(
        {
            "scipy": lambda: Delaunay(one),
            "ours": lambda: geoalpha.alpha_shapes(one),
        },
        max(1, r // 2),
    )
    rows.append((f"**{big:,} points in one group**", "", "", ""))
    rows.append(
        ("`scipy.spatial.Delaunay` of the group", fmt_time(t["scipy"]), "1.00x", "")
    )
    row(rows, "`alpha_shapes` (every core)", t["ours"], t["scipy"], "<= 0.15x")

    # Nearly collinear chains
    rows.append(("**nearly collinear chains**", "", "", ""))
    times = {}
    for n in (16_001, 64_001):
        c = chain(n)
        ours = best_of({"ours": lambda c=c: geoalpha.alpha_shapes(c)}, r)["ours"]
        times[n] = ours
        scipy = scipy_delaunay_seconds(n)  # one call: Qhull takes minutes
        if scipy is None:
            rows.append(
                (f"{n:,} points: scipy", f"> {BASELINE_LIMIT:.0f} s", "1.00x", "")
            )
            rows.append(
                (
                    f"{n:,} points: `alpha_shapes`",
                    fmt_time(ours),
                    f"< {ours / BASELINE_LIMIT:.4f}x",
                    "<= 0.35x",
                )
            )
        else:
            rows.append((f"{n:,} points: scipy", fmt_time(scipy), "1.00x", ""))
            row(rows, f"{n:,} points: `alpha_shapes`", ours, scipy, "<= 0.35x")
    rows.append(
        ("growth 16k -> 64k", "", f"{times[64_001] / times[16_001]:.2f}x", "<= 5x")
    )

    # Memory and start-up
    rows.append(("**memory and start-up**", "", "", ""))
    rows.append(
        (
            f"peak RSS, `alpha_shapes` of {big:,} points",
            f"{peak_memory(big):,.0f} MB",
            "",
            "<= 500 MB",
        )
    )
    env = dict(os.environ)
    starts = {
        "imp": ([sys.executable, "-c", "import geoalpha"], env),
        "help": ([sys.executable, "-m", "geoalpha", "--help"], env),
    }
    if args.before is not None:
        old_env = dict(os.environ, PYTHONPATH=str(args.before))
        starts["old_imp"] = ([sys.executable, "-c", "import geoalpha"], old_env)
        starts["old_help"] = ([sys.executable, "-m", "geoalpha", "--help"], old_env)
    # Fresh processes, interleaved (one of each per round), best of 10 or more.
    t = command_times(starts, max(r, 10))
    imp, helptime = t["imp"], t["help"]
    if args.before is not None:
        row(rows, "`import geoalpha`", imp, t["old_imp"], "no slower than before")
        row(rows, "`geoalpha --help`", helptime, t["old_help"], "no slower than before")
    else:
        rows.append(("`import geoalpha`", fmt_time(imp), "", ""))
        rows.append(("`geoalpha --help`", fmt_time(helptime), "", ""))

    print(f"geoalpha {geoalpha.__version__}, {os.cpu_count()} cores, best of {r}\n")
    print("| case | time | ratio | goal |")
    print("|---|---:|---:|---|")
    for what, tm, ratio, goal in rows:
        print(f"| {what} | {tm} | {ratio} | {goal} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
