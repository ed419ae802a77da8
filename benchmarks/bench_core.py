"""Benchmark geoalpha's exact optimal alpha against its peers on real groups.

Run from the repository root::

    python benchmarks/bench_core.py [--sample N] [--seed S] [--json PATH]

Data: the bundled 2014 STATS19 extract (groups ``Local_Authority_(Highway)``
with >= 4 distinct points, OSGB easting/northing in metres) and the 691 UK
accident DBSCAN clusters (``Cluster``, lon/lat projected to EPSG:27700). Every
group is deduplicated first and every method gets the same distinct points
(alphashape and libpysal fail on duplicates).

The slow peers (alphashape bisection, the paper's ladder, libpysal) run once
on a fixed, seeded sample of ``--sample`` groups per dataset; the fast methods
(the scipy Delaunay floor and geoalpha) run on the same sample and on all
groups, best of ``--repeat``. The ratio column divides each time by geoalpha
exact's time on the same groups. Peer definitions: ``benchmarks/peers.py``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import warnings
from collections.abc import Callable, Sequence
from importlib.metadata import version
from pathlib import Path
from typing import NamedTuple

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))  # peers.py, also when imported from elsewhere
try:
    import geoalpha
except ImportError:  # running from a source tree without installing
    sys.path.insert(0, str(HERE.parent))
    import geoalpha

import peers  # noqa: E402
from timing import fmt_time, rounds, timed  # noqa: E402

DATASETS = {
    # name: (group column, x column, y column); None = project lon/lat
    "stats19": (
        "Local_Authority_(Highway)",
        "Location_Easting_OSGR",
        "Location_Northing_OSGR",
    ),
    "uk_clusters": ("Cluster", None, None),
}
MIN_DISTINCT = 4
DEFAULT_SAMPLE = 150
EXACT = "geoalpha exact (batched)"
GEOS = "shapely.delaunay_triangles (one GEOS call, triangles only)"
HULL = "geoalpha hull(by=...) from lon/lat (frame in and out)"
RTOL = 1e-4  # peers vs exact: equal within this relative tolerance


class Groups(NamedTuple):
    """Distinct points of G groups, sorted by group.

    Attributes
    ----------
    labels : numpy.ndarray
        ``(G,)`` group labels of the dataset.
    points : numpy.ndarray
        ``(n, 2)`` distinct points in metres, grouped.
    codes : numpy.ndarray
        ``(n,)`` group code ``0 .. G-1`` of each point.
    offsets : numpy.ndarray
        ``(G + 1,)``; group ``i`` is ``points[offsets[i]:offsets[i + 1]]``.
    """

    labels: np.ndarray
    points: np.ndarray
    codes: np.ndarray
    offsets: np.ndarray

    def group(self, i: int) -> np.ndarray:
        """Return the ``(n_i, 2)`` distinct points of group ``i``."""
        return self.points[self.offsets[i] : self.offsets[i + 1]]

    def arrays(self) -> list[np.ndarray]:
        """Return one ``(n_i, 2)`` array per group."""
        return [self.group(i) for i in range(len(self.labels))]

    def take(self, idx: Sequence[int]) -> Groups:
        """Return the groups ``idx`` (in that order), recoded ``0 .. k-1``."""
        parts = [self.group(i) for i in idx]
        sizes = np.array([len(p) for p in parts], dtype=np.int64)
        return Groups(
            labels=self.labels[np.asarray(idx, dtype=np.int64)],
            points=np.concatenate(parts) if parts else np.empty((0, 2)),
            codes=np.repeat(np.arange(len(parts)), sizes),
            offsets=np.concatenate([[0], np.cumsum(sizes)]),
        )


def load_groups(name: str) -> Groups:
    """Load a bundled dataset as deduplicated metric groups.

    Parameters
    ----------
    name : {"stats19", "uk_clusters"}
        Dataset; see :data:`DATASETS`.

    Returns
    -------
    Groups
        All groups (``uk_clusters``) or the groups with at least
        :data:`MIN_DISTINCT` distinct points (``stats19``), deduplicated.
    """
    import pandas as pd

    from geoalpha import datasets

    by, xcol, ycol = DATASETS[name]
    frame = datasets.load(name)
    if xcol is None:
        import pyproj

        to_osgb = pyproj.Transformer.from_crs(4326, 27700, always_xy=True)
        x, y = to_osgb.transform(frame["Longitude"].to_numpy(), frame["Latitude"])
    else:
        x, y = frame[xcol].to_numpy(float), frame[ycol].to_numpy(float)
    codes, labels = pd.factorize(frame[by], sort=True)
    table = np.unique(np.column_stack([codes, x, y]), axis=0)  # sorted, distinct
    table = table[table[:, 0] >= 0]  # rows without a group
    sizes = np.bincount(table[:, 0].astype(np.int64), minlength=len(labels))
    full = Groups(
        labels=np.asarray(labels),
        points=table[:, 1:].copy(),
        codes=table[:, 0].astype(np.int64),
        offsets=np.concatenate([[0], np.cumsum(sizes)]),
    )
    if name == "stats19":
        return full.take(np.flatnonzero(sizes >= MIN_DISTINCT))
    return full


def hull_frame(name: str, labels: np.ndarray):
    """The dataset's rows (lon/lat, EPSG:4326) of the groups ``labels``."""
    from geoalpha import datasets

    by = DATASETS[name][0]
    frame = datasets.load(name)
    return frame[frame[by].isin(labels)], by


def geos_triangles(g: Groups):
    """GEOS Delaunay triangles of every group in one shapely call (no indices)."""
    import shapely

    return shapely.delaunay_triangles(shapely.multipoints(g.points, indices=g.codes))


def triangulable(groups: Groups) -> np.ndarray:
    """Return the indices of groups with >= 4 distinct, non-collinear points."""
    from scipy.spatial import Delaunay, QhullError

    keep = []
    for i, xy in enumerate(groups.arrays()):
        if len(xy) < MIN_DISTINCT:
            continue
        try:
            Delaunay(xy)
        except QhullError:
            continue
        keep.append(i)
    return np.asarray(keep, dtype=np.int64)


def run_peer(
    fn: Callable[[np.ndarray], peers.PeerResult], groups: Groups, label: str
) -> tuple[float, list[peers.PeerResult], list[float]]:
    """Run a slow peer once per group; return total time, results, times."""
    results, times = [], []
    n = len(groups.labels)
    for i, xy in enumerate(groups.arrays()):
        seconds, result = timed(fn, xy)
        results.append(result)
        times.append(seconds)
        if sys.stderr.isatty() or (i + 1) % 25 == 0 or i + 1 == n:
            print(f"\r  {label}: {i + 1}/{n}", end="", file=sys.stderr, flush=True)
    print(file=sys.stderr)
    return float(sum(times)), results, times


def compare(
    peer: Sequence[float], exact: np.ndarray, labels: Sequence, rtol: float = RTOL
) -> dict:
    """Count groups where a peer's alpha is below, equal to or above the exact.

    Equal means within ``rtol`` relative: the peers compute circumradii in raw
    OSGB coordinates (~5e5 m), which costs them up to ~1e-5 relative.
    """
    out: dict = {"same": 0, "lower": 0, "higher": 0, "failed": 0, "differ": []}
    for a, e, label in zip(peer, exact, labels, strict=True):
        if not (np.isfinite(a) and np.isfinite(e)):
            key = "failed"
        elif abs(a - e) <= rtol * max(abs(e), 1e-300):
            key = "same"
        else:
            key = "lower" if a < e else "higher"
        out[key] += 1
        if key != "same":
            out["differ"].append(f"{label}: {a:.8g} vs {e:.8g}")
    return out


def geoalpha_api():
    """Return ``(alpha_shapes, optimal_alpha)`` or None if geoalpha lacks them."""
    alpha_shapes = getattr(geoalpha, "alpha_shapes", None)
    optimal_alpha = getattr(geoalpha, "optimal_alpha", None)
    if alpha_shapes is None or optimal_alpha is None:
        try:  # written but not yet exported from the package
            from geoalpha._arrays.optimal import alpha_shapes, optimal_alpha
        except ImportError:
            return None
    return alpha_shapes, optimal_alpha


def valid_shapes(result, groups: Groups) -> str:
    """Count non-degenerate groups whose geometry is one valid covering Polygon.

    Returns
    -------
    str
        ``"k/m"``: k of the m groups geoalpha did not flag as degenerate.
    """
    import shapely

    geoms = np.asarray(result.geometry, dtype=object)
    covered = shapely.covers(geoms[groups.codes], shapely.points(groups.points))
    all_in = np.bincount(groups.codes, weights=~covered, minlength=len(geoms)) == 0
    one = shapely.get_type_id(geoms) == 3  # Polygon
    ok = one & shapely.is_valid(geoms) & all_in
    solid = ~np.asarray(result.degenerate, dtype=bool)
    return f"{int((ok & solid).sum())}/{int(solid.sum())}"


def bench_dataset(name: str, args, api) -> tuple[list[dict], dict, list[dict]]:
    """Benchmark every method on one dataset; return rows, agreement, details."""
    groups = load_groups(name)
    eligible = triangulable(groups)
    rng = np.random.default_rng(args.seed)
    if args.sample is not None and args.sample < len(eligible):
        idx = np.sort(rng.choice(eligible, size=args.sample, replace=False))
    else:
        idx = eligible
    sample = groups.take(idx)
    scopes = {"sample": sample}
    if len(idx) < len(groups.labels):
        scopes["all"] = groups
    print(
        f"{name}: {len(groups.labels)} groups, {len(groups.points)} distinct points; "
        f"{len(eligible)} triangulable with >= {MIN_DISTINCT} points; "
        f"sample of {len(idx)} (seed {args.seed})",
        file=sys.stderr,
    )

    rows: list[dict] = []

    def row(scope, method, g, seconds, builds=None, rounds=None):
        n = len(g.labels)
        rows.append(
            dict(
                dataset=name,
                scope=scope,
                method=method,
                groups=n,
                points=len(g.points),
                seconds=seconds,
                per_group=seconds / n,
                builds_per_group=None if builds is None else builds / n,
                rounds=rounds,
            )
        )

    # Slow peers: once each, on the sample only.
    slow = (
        ("alphashape bisection (patched)", peers.bisection_alpha),
        ("paper ladder (alphashape builds)", peers.ladder_alpha),
        (
            "libpysal alpha_shape_auto"
            + (" (numba)" if peers.LIBPYSAL_HAS_NUMBA else " (no numba)"),
            peers.libpysal_alpha,
        ),
    )
    peer_results, peer_times = {}, {}
    if not args.fast_only:
        peers.libpysal_alpha(np.array([[0.0, 0], [1, 0], [0, 1], [1, 1.1]]))  # warm
        for method, fn in slow:
            seconds, results, times = run_peer(fn, sample, method)
            peer_results[method] = results
            peer_times[method] = times
            row("sample", method, sample, seconds, sum(r.builds for r in results))

    # Fast methods: best of --repeat, on the sample and on all groups.
    exact = {}
    alpha_shapes, optimal_alpha = api if api is not None else (None, None)
    for scope, g in scopes.items():
        arrays = g.arrays()
        fns = {"scipy Delaunay loop (floor)": lambda a=arrays: peers.delaunay_floor(a)}
        fns[GEOS] = lambda g=g: geos_triangles(g)
        if api is not None:
            fns[EXACT] = lambda g=g: alpha_shapes(
                g.points, g.codes, holes=False, components=1
            )
            fns['geoalpha search="ladder" (batched)'] = lambda g=g: alpha_shapes(
                g.points, g.codes, search="ladder"
            )
            fns["geoalpha optimal_alpha (per-group loop)"] = lambda a=arrays: [
                optimal_alpha(xy) for xy in a
            ]
            if scope == "all" or name == "stats19":
                frame, by = hull_frame(name, g.labels)
                fns[HULL] = lambda f=frame, by=by: f.alpha.hull(by=by)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # degenerate groups in "all"
            for method, times in rounds(fns, args.repeat).items():
                row(scope, method, g, min(times), rounds=times)
            if api is not None:
                exact[scope] = fns[EXACT]()

    for r in rows:  # ratio to geoalpha exact on the same groups
        ref = [x for x in rows if x["scope"] == r["scope"] and x["method"] == EXACT]
        r["vs_exact"] = r["seconds"] / ref[0]["seconds"] if ref else None

    agreement: dict = {"groups": len(idx)}
    details: list[dict] = []
    if api is None:
        return rows, agreement, details
    for scope, res in exact.items():
        agreement[f"geoalpha_valid_polygons_{scope}"] = valid_shapes(res, scopes[scope])
    if not peer_results:
        return rows, agreement, details

    # Agreement of the peers with geoalpha on the sample.
    bis_key, lad_key, lib_key = (method for method, _ in slow)
    bis = np.array([r.alpha for r in peer_results[bis_key]])
    lad = np.array([r.alpha for r in peer_results[lad_key]])
    lib = np.array([r.alpha for r in peer_results[lib_key]])
    ex = exact["sample"].alpha
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ex_holes = alpha_shapes(sample.points, sample.codes, holes=True).alpha
        ga_ladder = alpha_shapes(sample.points, sample.codes, search="ladder").alpha
    agreement["peer_errors"] = {
        k: [f"{sample.labels[i]}: {r.error}" for i, r in enumerate(v) if r.error]
        for k, v in peer_results.items()
    }
    agreement["bisection_returned_0"] = int((bis == 0).sum())
    agreement["bisection_not_converged"] = int(
        sum(r.builds > 10000 for r in peer_results[bis_key])
    )
    agreement["bisection_vs_exact"] = compare(bis, ex, sample.labels)
    rel = np.abs(bis - ex) / np.where(ex > 0, ex, np.nan)
    agreement["bisection_max_rel_error_where_same"] = float(
        np.nanmax(np.where(rel <= RTOL, rel, np.nan), initial=0.0)
    )
    agreement["ladder_returned_0"] = int((lad == 0).sum())
    agreement["ladder_ne_exact"] = int((lad != ex).sum())
    agreement["ladder_eq_floor_of_exact"] = int((lad == np.floor(ex)).sum())
    agreement["ladder_eq_geoalpha_ladder"] = int((lad == ga_ladder).sum())
    agreement["libpysal_vs_exact_holes_filled"] = compare(lib, ex, sample.labels)
    agreement["libpysal_vs_exact_holes_kept"] = compare(lib, ex_holes, sample.labels)
    for i, label in enumerate(sample.labels):
        details.append(
            dict(
                label=str(label),
                n=len(sample.group(i)),
                exact=float(ex[i]),
                exact_holes_kept=float(ex_holes[i]),
                geoalpha_ladder=float(ga_ladder[i]),
                **{f"{k} alpha": peer_results[k][i].alpha for k in peer_results},
                **{f"{k} builds": peer_results[k][i].builds for k in peer_results},
                **{f"{k} seconds": peer_times[k][i] for k in peer_times},
            )
        )
    return rows, agreement, details


def fmt_ratio(x: float | None) -> str:
    """Format a time ratio like ``25,000x``."""
    if x is None:
        return "n/a"
    if x >= 100:
        return f"{x:,.0f}x"
    return f"{x:.2g}x" if x < 10 else f"{x:.0f}x"


def markdown(rows: list[dict]) -> str:
    """Render the result rows as a markdown table."""
    head = (
        "| data | groups | method | builds / group | total | per group "
        "| / geoalpha exact |\n|---|---:|---|---:|---:|---:|---:|"
    )
    lines = [head]
    for r in rows:
        builds = (
            "" if r["builds_per_group"] is None else f"{r['builds_per_group']:,.1f}"
        )
        lines.append(
            f"| {r['dataset']} ({r['scope']}) | {r['groups']} | {r['method']} "
            f"| {builds} | {fmt_time(r['seconds'])} | {fmt_time(r['per_group'])} "
            f"| {fmt_ratio(r['vs_exact'])} |"
        )
    return "\n".join(lines)


def goal_ratios(rows: list[dict]) -> list[str]:
    """Issue #12's ratios, each within this run (best / best, median of rounds)."""

    def find(dataset, scope, method):
        for r in rows:
            if (r["dataset"], r["scope"], r["method"]) == (dataset, scope, method):
                return r
        return None

    floor = "scipy Delaunay loop (floor)"
    goals = [
        ("uk_clusters", "all", EXACT, floor, "alpha_shapes / scipy loop", 0.6),
        ("uk_clusters", "all", HULL, floor, "hull(by=...) / scipy loop", 0.75),
        ("uk_clusters", "all", GEOS, floor, "GEOS triangles only / scipy loop", None),
        ("stats19", "sample", HULL, EXACT, "hull(by=...) / alpha_shapes", 1.5),
    ]
    out = []
    for dataset, scope, num, den, label, goal in goals:
        a, b = find(dataset, scope, num), find(dataset, scope, den)
        if a is None or b is None:
            continue
        paired = np.median(np.divide(a["rounds"], b["rounds"]))
        target = "" if goal is None else f" (goal <= {goal}x)"
        out.append(
            f"{dataset} ({scope}, {a['groups']} groups): {label} = "
            f"{a['seconds'] / b['seconds']:.2f}x best/best, {paired:.2f}x median "
            f"of {len(a['rounds'])} paired rounds{target}"
        )
    return out


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    """Parse the command line."""
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "--sample",
        type=int,
        default=DEFAULT_SAMPLE,
        help="groups per dataset for the slow peers (seeded sample; "
        f"default {DEFAULT_SAMPLE}; 0 = all)",
    )
    parser.add_argument("--seed", type=int, default=0, help="sample seed (0)")
    parser.add_argument(
        "--repeat", type=int, default=5, help="best of N for fast methods (5)"
    )
    parser.add_argument(
        "--datasets",
        nargs="+",
        choices=sorted(DATASETS),
        default=list(DATASETS),
        help="datasets to run (both)",
    )
    parser.add_argument(
        "--fast-only",
        action="store_true",
        help="skip the slow peers (bisection, ladder, libpysal)",
    )
    parser.add_argument("--json", type=Path, help="also save the results here")
    args = parser.parse_args(argv)
    if args.sample == 0:
        args.sample = None
    return args


def main(argv: Sequence[str] | None = None) -> int:
    """Run the benchmark, print a markdown table and the agreement checks."""
    args = parse_args(argv)
    api = geoalpha_api()
    rows, agreement, details = [], {}, {}
    for name in args.datasets:
        r, a, d = bench_dataset(name, args, api)
        rows += r
        agreement[name] = a
        details[name] = d

    print(markdown(rows))
    print()
    for r in rows:
        if r["scope"] == "all" and r["method"] == EXACT:
            floor = next(
                x
                for x in rows
                if x["dataset"] == r["dataset"]
                and x["scope"] == "all"
                and x["method"].startswith("scipy Delaunay")
            )
            paired = np.median(np.divide(r["rounds"], floor["rounds"]))
            print(
                f"geoalpha exact / floor on all {r['groups']} {r['dataset']} groups: "
                f"{r['seconds'] / floor['seconds']:.2f}x (best / best), "
                f"{paired:.2f}x (median of {len(r['rounds'])} paired rounds)"
            )
    print()
    for line in goal_ratios(rows):
        print(line)
    if api is None:
        print("geoalpha.alpha_shapes not available: geoalpha rows skipped")
    print(
        "alphashape: optimizealpha unchanged except _testalpha, which iterates "
        "points.geoms (shapely 2 MultiPoint is not iterable); "
        f"libpysal numba: {'yes' if peers.LIBPYSAL_HAS_NUMBA else 'no'}; "
        "all methods get the same deduplicated points (metres, EPSG:27700)"
    )
    print("agreement:", json.dumps(agreement, indent=1))

    if args.json:
        meta = dict(
            command="python benchmarks/bench_core.py " + " ".join(sys.argv[1:]),
            sample=args.sample,
            seed=args.seed,
            repeat=args.repeat,
            python=platform.python_version(),
            cpus=os.cpu_count(),
            libpysal_numba=peers.LIBPYSAL_HAS_NUMBA,
            versions={
                p: version(p)
                for p in ("alphashape", "libpysal", "shapely", "scipy", "numpy")
            },
            geoalpha=getattr(geoalpha, "__version__", "?"),
        )
        args.json.write_text(
            json.dumps(
                dict(meta=meta, rows=rows, agreement=agreement, details=details),
                indent=1,
                default=float,
            )
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
