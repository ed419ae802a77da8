"""Spread the groups of :func:`geoalpha.alpha_shapes` over worker processes.

``alpha_shapes(..., n_jobs=k)`` and ``hull(..., n_jobs=k)`` land here. The
groups are cut into contiguous runs of group codes holding about the same
number of points (about :data:`BATCH_POINTS`, at least two runs per worker),
every run is computed by :func:`~geoalpha.alpha_shapes` in a
:class:`concurrent.futures.ProcessPoolExecutor`, and the per-group fields are
concatenated back in group order. Each group is computed as in a single call
(same points in the same order, same code path), so the result equals
``n_jobs=1`` (tie merging, :func:`geoalpha.core.merge_ties`, is per group).

Why processes and not threads: scipy's Qhull call releases the GIL (the bare
Delaunay loop on two threads takes about half the time of one thread in
``benchmarks/bench_scale.py``), but the batched numpy/scipy steps after it
are many calls on arrays of a few hundred thousand items, much of it under
the GIL (fancy indexing, ``ufunc.at``, scipy's spanning trees), so only
processes run the whole pipeline on every core.

Start method: on Linux the workers are forked, so they inherit the (sorted)
input arrays without copying them through a pipe; elsewhere (macOS, Windows)
the default start method of :mod:`multiprocessing` is used and each worker
receives its slice of the arrays. Set :data:`START_METHOD` to force one
(e.g. ``"spawn"`` or ``"forkserver"`` when the calling process runs threads
that must not be forked).
"""

from __future__ import annotations

import itertools
import multiprocessing
import os
import sys
import warnings
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor, as_completed
from contextlib import nullcontext

import numpy as np

from geoalpha import core
from geoalpha.errors import InvalidInputError, user_stacklevel
from geoalpha.options import check, defaults

__all__ = [
    "BATCH_POINTS",
    "CHUNKS_PER_JOB",
    "MIN_POINTS_PER_JOB",
    "START_METHOD",
    "alpha_shapes_parallel",
    "effective_n_jobs",
    "split_groups",
]

#: Fewer points than this per worker are not worth a process (starting a
#: worker and moving its results costs about as much as ~20,000 points).
MIN_POINTS_PER_JOB = 20_000
#: Runs of groups per worker: more than one, so that a worker slowed down by
#: other load on the machine does not hold up the whole call.
CHUNKS_PER_JOB = 2
#: Points per run of groups, about: the batched numpy/scipy steps (sorts,
#: spanning trees, gathers over all triangles) cost about 30 % less CPU in
#: runs of 30,000-150,000 points than in one run of a million, as their
#: arrays then fit the caches (``benchmarks/bench_scale.py``).
BATCH_POINTS = 50_000
#: :mod:`multiprocessing` start method; None: ``"fork"`` on Linux, else the
#: platform default.
START_METHOD: str | None = None

# Inputs of the running parallel calls, by call id. Forked workers inherit
# this dict, so tasks only carry row and group ranges.
_SHARED: dict[int, tuple] = {}
_CALL_IDS = itertools.count()


def effective_n_jobs(n_jobs) -> int:
    """Return the number of worker processes that ``n_jobs`` asks for.

    Parameters
    ----------
    n_jobs : int
        ``1``: no worker process; ``k > 1``: ``k`` workers; ``-1``: one per
        core available to this process; ``-k``: all cores but ``k - 1`` (as
        in joblib and scikit-learn), at least one.

    Returns
    -------
    int

    Raises
    ------
    InvalidInputError
        If ``n_jobs`` is 0 or not an integer.

    Examples
    --------
    >>> effective_n_jobs(1), effective_n_jobs(3)
    (1, 3)
    >>> effective_n_jobs(-1) >= 1
    True
    """
    n_jobs = check(n_jobs=n_jobs)["n_jobs"]  # the check of hull(n_jobs=)
    if n_jobs > 0:
        return n_jobs
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not on Linux
        cores = os.cpu_count() or 1
    return max(cores + 1 + int(n_jobs), 1)


def split_groups(counts, n_chunks: int) -> np.ndarray:
    """Cut groups ``0, ..., G-1`` into contiguous runs of about equal point count.

    Parameters
    ----------
    counts : array_like of int, shape (G,)
        Points per group.
    n_chunks : int
        Number of runs wanted; fewer come back when there are fewer groups
        with points, or when one group outweighs a run.

    Returns
    -------
    ndarray of int
        Group boundaries ``[0, b1, ..., G]``: run ``i`` is groups
        ``bounds[i]:bounds[i + 1]``; every run holds at least one point.

    Examples
    --------
    >>> split_groups([5, 5, 5, 5], 2).tolist()
    [0, 2, 4]
    >>> split_groups([100, 1, 1, 1], 2).tolist()
    [0, 1, 4]
    """
    counts = np.asarray(counts, dtype=np.int64)
    cum = np.cumsum(counts)
    total = int(cum[-1]) if len(cum) else 0
    if total == 0 or n_chunks <= 1:
        return np.array([0, len(counts)], dtype=np.int64)
    targets = total * np.arange(1, n_chunks) / n_chunks
    # Cut after the group whose cumulative count is nearest each target.
    after = np.searchsorted(cum, targets, side="left")
    before = np.maximum(after - 1, 0)
    nearer = np.where(
        np.abs(cum[before] - targets) < np.abs(cum[after] - targets), before, after
    )
    cuts = np.unique(nearer + 1)
    # Keep the cuts that leave at least one point on each side.
    before_cut = np.concatenate([[0], cum])
    out = [0]
    for cut in cuts[cuts < len(counts)].tolist():
        if before_cut[cut] > before_cut[out[-1]]:
            out.append(cut)
    if len(out) > 1 and before_cut[out[-1]] == total:
        out.pop()
    out.append(len(counts))
    return np.asarray(out, dtype=np.int64)


def _start_context():
    method = START_METHOD
    if method is None and sys.platform.startswith("linux"):
        method = "fork"
    return multiprocessing.get_context(method)


def _run(task, in_worker: bool = True):
    """``batch`` of one run of groups; from a worker process, its warnings too.

    In the calling process (``in_worker=False``) warnings take their usual
    way: catching them there would change the process-wide filters under
    other threads (dask's threaded scheduler).
    """
    call, lo, hi, g0, g1, data, batch, kwargs = task
    points, codes, coords, alpha = _SHARED[call] if data is None else data
    if data is None:
        points, codes = points[lo:hi], codes[lo:hi]
        coords = None if coords is None else coords[lo:hi]
    if alpha is not None and np.ndim(alpha) == 1:
        alpha = alpha[:g1]
    record = warnings.catch_warnings(record=True) if in_worker else nullcontext([])
    with record as caught:
        if in_worker:
            warnings.simplefilter("always")
        # Codes stay global (groups before this run are empty, hence skipped),
        # so that results and messages are those of a single call.
        res = batch(
            points,
            codes,
            alpha=alpha,
            coords=coords,
            n_groups=g1,
            progress=None,
            **_with_defaults(kwargs),
        )
    # Per-group fields from this run's first group on; `outlier` is per row.
    res = res._replace(
        **{f: np.asarray(getattr(res, f))[g0:] for f in res._fields if f != "outlier"}
    )
    return res, [(w.category, str(w.message)) for w in caught]


def _with_defaults(kwargs: dict) -> dict:
    """Complete ``kwargs`` with the defaults of the options of ``alpha_shapes``."""
    return {**defaults("holes", "components", "search", "max_iterations"), **kwargs}


def alpha_shapes_parallel(
    points,
    groups=None,
    *,
    batch: Callable,
    n_jobs: int = -1,
    alpha=None,
    coords=None,
    n_groups: int | None = None,
    progress=None,
    **kwargs,
):
    """:func:`~geoalpha.alpha_shapes` with the groups spread over processes.

    Parameters
    ----------
    points, groups, alpha, coords, n_groups
        As in :func:`~geoalpha.alpha_shapes`.
    batch : callable
        Computes one run of groups in one pass: called as
        ``batch(points, codes, alpha=, coords=, n_groups=, progress=None,
        **kwargs)``, it returns a named tuple of per-group arrays
        (:func:`geoalpha.alpha_shapes` passes its own one-pass function). It
        is a module-level function, so that it reaches spawned workers.
    n_jobs : int, default -1
        Worker processes (see :func:`effective_n_jobs`). At most one per
        :data:`MIN_POINTS_PER_JOB` points is started; with one, the runs of
        groups (about :data:`BATCH_POINTS` points each) are computed one
        after the other in this process.
    progress : object with an ``update(n)`` method, optional
        Told the number of groups of each run as the run completes.
    **kwargs
        The other options of :func:`~geoalpha.alpha_shapes` (``holes``,
        ``components``, ``search``, ``max_iterations``, ``outliers``).

    Returns
    -------
    AlphaShapes
        Equal, field by field, to ``alpha_shapes(points, groups, ...)``.

    Examples
    --------
    :func:`geoalpha.alpha_shapes` with ``n_jobs`` lands here:

    >>> import numpy as np
    >>> from geoalpha import alpha_shapes
    >>> pts = np.array([[0, 0], [4, 0], [4, 4], [0, 4], [2, 3.5],
    ...                 [10, 0], [12, 0], [11, 2]])
    >>> res = alpha_shapes(pts, [0, 0, 0, 0, 0, 1, 1, 1], n_jobs=2)
    >>> res.alpha.round(4).tolist()
    [0.4308, 0.8]
    """
    workers = effective_n_jobs(n_jobs)
    try:
        xy = core.check_points(points)
        codes, n_groups = core.group_codes(groups, len(xy), n_groups)
    except ValueError as err:
        raise InvalidInputError(str(err)) from err
    n = len(xy)
    workers = min(workers, max(n // max(MIN_POINTS_PER_JOB, 1), 1), max(n_groups, 1))
    n_chunks = -(-n // max(BATCH_POINTS, 1))
    if workers > 1:
        n_chunks = max(n_chunks, workers * CHUNKS_PER_JOB)
    if n_chunks <= 1:
        return batch(
            xy,
            codes,
            alpha=alpha,
            coords=coords,
            n_groups=n_groups,
            progress=progress,
            **_with_defaults(kwargs),
        )
    if coords is not None:
        coords = np.asarray(coords, dtype=float)
        if coords.shape != (n, 2):
            raise InvalidInputError(
                f"coords must have the shape of points {(n, 2)}; got {coords.shape}"
            )
    if alpha is not None:
        alpha = np.asarray(alpha, dtype=float)
        if alpha.ndim == 1 and alpha.shape != (n_groups,):
            raise InvalidInputError(
                f"alpha must be a number or one per group ({n_groups}); got "
                f"shape {alpha.shape}"
            )

    # Rows sorted by group (stable, a no-op when they already are), so that a
    # run of groups is a slice of rows: a radix sort of the codes, and rows
    # gathered with np.take (several times faster than ``xy[order]``).
    order = None
    if n > 1 and (codes[1:] < codes[:-1]).any():
        order = core.group_order(codes, n_groups)
        xy, codes = np.take(xy, order, axis=0), codes[order]
        coords = None if coords is None else np.take(coords, order, axis=0)
    counts = np.bincount(codes, minlength=n_groups)
    bounds = split_groups(counts, n_chunks)
    rows = np.concatenate([[0], np.cumsum(counts)])[bounds]

    context = _start_context() if workers > 1 else None
    call = next(_CALL_IDS)
    shared = context is None or context.get_start_method() == "fork"
    if shared:
        _SHARED[call] = (xy, codes, coords, alpha)
    tasks = []
    for lo, hi, g0, g1 in zip(
        rows[:-1], rows[1:], bounds[:-1], bounds[1:], strict=True
    ):
        data = None
        if not shared:
            data = (
                xy[lo:hi],
                codes[lo:hi],
                None if coords is None else coords[lo:hi],
                alpha,
            )
        tasks.append((call, int(lo), int(hi), int(g0), int(g1), data, batch, kwargs))
    results: list = [None] * len(tasks)
    try:
        if context is None:  # one process: the runs one after the other
            for i, task in enumerate(tasks):
                results[i] = _run(task, in_worker=False)
                if progress is not None:
                    progress.update(int(bounds[i + 1] - bounds[i]))
        else:
            with ProcessPoolExecutor(
                max_workers=min(workers, len(tasks)), mp_context=context
            ) as pool:
                futures = {pool.submit(_run, task): i for i, task in enumerate(tasks)}
                for future in as_completed(futures):
                    i = futures[future]
                    results[i] = future.result()
                    if progress is not None:
                        progress.update(int(bounds[i + 1] - bounds[i]))
    finally:
        _SHARED.pop(call, None)

    for _, caught in results:
        for category, message in caught:
            warnings.warn(message, category, stacklevel=user_stacklevel())
    fields = zip(*(res for res, _ in results), strict=True)
    out = type(results[0][0])(*(np.concatenate(f) for f in fields))
    if order is not None:  # the per-row field back in input order
        outlier = np.empty_like(out.outlier)
        outlier[order] = out.outlier
        out = out._replace(outlier=outlier)
    return out
