"""The steps after the triangulation, this checkout against a git revision.

Times ``core.fill_radius``, ``core.Spectrum.build`` (filled), ``core.piece_labels``,
``core.boundary_rings`` and ``shapes.assemble`` of this checkout against the same
functions of ``--ref`` (default ``main``, loaded from ``git show``), on the
same triangulations, interleaved in one process (CPU time, median of
``--rounds`` rounds; the machine may be shared). Two workloads:

* ``uk``: the 691 bundled UK clusters in one batch (~9k points), where every
  numpy call's fixed cost counts;
* ``1m``: 1M points in 1,000 groups (``bench_scale.py``'s generator), cut into
  the runs of about ``parallel.BATCH_POINTS`` points that ``alpha_shapes``
  computes one after the other.

Both versions must give equal results (checked). Run from the repository root::

    python benchmarks/bench_steps.py [--ref main] [--rounds 15] [--only uk]
"""

from __future__ import annotations

import argparse
import importlib.util
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

from geoalpha import core, delaunay, optimal, parallel, shapes  # noqa: E402


def load_revision(ref: str, tmp: Path):
    """``(core, shapes, parallel)`` of git revision ``ref``, under other names."""
    out = []
    for name in ("core", "shapes", "parallel"):
        text = subprocess.run(
            ["git", "show", f"{ref}:geoalpha/{name}.py"],
            cwd=HERE.parent,
            check=True,
            capture_output=True,
            text=True,
        ).stdout
        path = tmp / f"old_{name}.py"
        path.write_text(
            text.replace("from geoalpha.core import", "from old_core import")
        )
        spec = importlib.util.spec_from_file_location(f"old_{name}", path)
        module = importlib.util.module_from_spec(spec)
        sys.modules[f"old_{name}"] = module
        spec.loader.exec_module(module)
        out.append(module)
    return out


def workloads(which: str) -> dict[str, list]:
    out = {}
    if which in ("all", "uk"):
        import bench_core as bc

        g = bc.load_groups("uk_clusters")
        out["uk"] = [
            core.triangulate(g.points, g.codes, backend=delaunay.triangulate_groups)
        ]
    if which in ("all", "1m"):
        import bench_scale as bs

        x, y, c = bs.make_points(bs.make_groups(1000), 1_000_000)
        order = np.argsort(c, kind="stable")
        xy, c = np.column_stack([x, y])[order], c[order]
        counts = np.bincount(c, minlength=1000)
        bounds = parallel.split_groups(counts, -(-len(xy) // parallel.BATCH_POINTS))
        rows = np.concatenate([[0], np.cumsum(counts)])[bounds]
        out["1m"] = [
            core.triangulate(
                xy[lo:hi],
                c[lo:hi],
                n_groups=int(g1),
                backend=delaunay.triangulate_groups,
            )
            for lo, hi, g1 in zip(rows[:-1], rows[1:], bounds[1:], strict=True)
        ]
    return out


def steps(mod_core, mod_shapes, tri):
    """The post-triangulation steps of ``alpha_shapes(holes=False)``, timed."""
    tri.__dict__.pop("_dual_edges", None)
    times = {}
    t0 = time.process_time()
    weight = mod_core.fill_radius(tri)
    t1 = time.process_time()
    spectrum = mod_core.Spectrum.build(tri, weight, filled=True)
    top = spectrum.optimum(1)
    n_pieces = spectrum.pieces_at_rank(np.arange(tri.n_groups), top)
    t2 = time.process_time()
    inside = weight <= top[tri.tri_group]
    piece = mod_core.piece_labels(tri, inside, n_pieces)
    t3 = time.process_time()
    rings = mod_core.boundary_rings(tri, inside, piece)
    t4 = time.process_time()
    geoms = mod_shapes.assemble(tri.xy, rings, tri.n_groups)
    t5 = time.process_time()
    times = {
        "fill_radius": t1 - t0,
        "Spectrum.build+optimum": t2 - t1,
        "piece_labels": t3 - t2,
        "boundary_rings": t4 - t3,
        "assemble": t5 - t4,
        "all steps": t5 - t0,
    }
    return times, (weight, spectrum.pieces, spectrum.cover, rings, geoms)


def no_op_batch(points, codes, *, n_groups, **kwargs):
    """A batch that computes nothing: what is left is the split's own cost."""
    zeros = np.zeros(n_groups)
    return optimal.AlphaShapes(*[zeros] * 8, outlier=np.zeros(len(points), bool))


def split_overhead(old_parallel, rounds: int) -> None:
    """``alpha_shapes_parallel``'s own cost on 1M rows in 1,000 groups (lon/lat)."""
    import bench_scale as bs

    x, y, c = bs.make_points(bs.make_groups(1000), 1_000_000)
    xy = np.column_stack([x, y])
    lonlat = xy * 1e-5
    times: dict[str, list[float]] = {"old": [], "new": []}
    for _ in range(rounds):
        for label, mod in (("old", old_parallel), ("new", parallel)):
            t0 = time.process_time()
            mod.alpha_shapes_parallel(xy, c, batch=no_op_batch, n_jobs=1, coords=lonlat)
            times[label].append(time.process_time() - t0)
    o, n = (np.median(times[k]) * 1e3 for k in ("old", "new"))
    print(f"\n1m: alpha_shapes_parallel with a no-op batch, median of {rounds}, CPU ms")
    print(f"{'split, sort, gather':<24}{o:>10.2f}{n:>10.2f}{n / o:>8.2f}")


def same(a, b) -> bool:
    import shapely

    wa, pa, ca, ra, ga = a
    wb, pb, cb, rb, gb = b
    return (
        np.array_equal(wa, wb)
        and np.array_equal(pa, pb)
        and np.array_equal(ca, cb)
        and all(
            np.array_equal(getattr(ra, f), getattr(rb, f))
            for f in ("vertex", "ring", "ring_piece", "piece_group", "failed")
        )
        and bool(shapely.equals_exact(ga, gb, 0.0).all())
    )


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--ref", default="main")
    parser.add_argument("--rounds", type=int, default=15)
    parser.add_argument("--only", choices=["all", "uk", "1m"], default="all")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        old_core, old_shapes, old_parallel = load_revision(args.ref, Path(tmp))
        for name, tris in workloads(args.only).items():
            for tri in tris:
                if not same(
                    steps(old_core, old_shapes, tri)[1], steps(core, shapes, tri)[1]
                ):
                    raise SystemExit(f"{name}: results differ from {args.ref}")
            old_t, new_t = [], []
            for _ in range(args.rounds):  # interleaved: old, new, old, new, ...
                for label, mods in (
                    ("old", (old_core, old_shapes)),
                    ("new", (core, shapes)),
                ):
                    total: dict[str, float] = {}
                    for tri in tris:
                        for k, v in steps(*mods, tri)[0].items():
                            total[k] = total.get(k, 0.0) + v
                    (old_t if label == "old" else new_t).append(total)
            print(
                f"\n{name}: {len(tris)} batch(es), "
                f"{sum(len(t.triangles) for t in tris)}"
                f" triangles; median of {args.rounds} rounds, CPU ms"
            )
            print(f"{'step':<24}{args.ref:>10}{'this':>10}{'ratio':>8}")
            for k in old_t[0]:
                o = np.median([r[k] for r in old_t]) * 1e3
                n = np.median([r[k] for r in new_t]) * 1e3
                print(f"{k:<24}{o:>10.2f}{n:>10.2f}{n / o:>8.2f}")
        if args.only in ("all", "1m"):
            split_overhead(old_parallel, args.rounds)


if __name__ == "__main__":
    main()
