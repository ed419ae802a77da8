"""The seed paper's ladder and ``alphashape``'s bisection, vectorised (comparison)."""

from __future__ import annotations

import sys
from collections.abc import Callable

import numpy as np

__all__ = ["LADDER", "bisect_alpha", "ladder_alpha"]

#: The seed paper's descending rungs of integer alphas.
LADDER: tuple[int, ...] = (5000, 3000, 1000, 500, 300, 100, 50, 25, 18, 10, 5, 0)
Oracle = Callable[[np.ndarray, np.ndarray], np.ndarray]


def ladder_alpha(
    valid: Oracle, n_groups: int, rungs: tuple[int, ...] = LADDER
) -> tuple[np.ndarray, int]:
    """Largest integer alpha found by the seed paper's ladder search.

    Test the descending ``rungs``; at the first that passes, bisect the integers
    between it and the rung above (valid at the top rung: the top rung).

    Parameters
    ----------
    valid : callable
        ``valid(groups, alphas)`` -> bool array: is the shape of each group valid?
    n_groups : int
    rungs : tuple of int
        Descending alphas ending with 0 (the convex hull, always valid).

    Returns
    -------
    alpha : ndarray of shape (n_groups,)
    tests : int
        Most validity tests of one group.

    Examples
    --------
    >>> ok = lambda g, a: a <= np.array([7.0, 4000.0])[g]
    >>> ladder_alpha(ok, 2)[0].tolist()
    [7.0, 4000.0]
    """
    rungs_arr = np.asarray(rungs, dtype=float)
    groups = np.arange(n_groups)
    passes = valid(
        np.repeat(groups, len(rungs_arr)), np.tile(rungs_arr, n_groups)
    ).reshape(n_groups, len(rungs_arr))
    passes[:, -1] = True  # alpha = 0 is the convex hull
    first = passes.argmax(axis=1)
    lo = rungs_arr[first]
    hi = np.where(first > 0, rungs_arr[np.maximum(first - 1, 0)], lo)
    tests = first + 1
    while True:
        active = np.flatnonzero(hi - lo > 1)
        if len(active) == 0:
            break
        mid = np.floor((lo[active] + hi[active]) / 2)
        ok = valid(groups[active], mid)
        lo[active] = np.where(ok, mid, lo[active])
        hi[active] = np.where(ok, hi[active], mid)
        tests[active] += 1
    return lo, int(tests.max(initial=0))


def bisect_alpha(
    valid: Oracle,
    n_groups: int,
    *,
    max_iterations: int = 10_000,
    lower: float = 0.0,
    upper: float = sys.float_info.max,
) -> tuple[np.ndarray, np.ndarray, int]:
    """``alphashape.optimizealpha``'s float bisection, vectorised over groups.

    Bisects until the bracket is narrower than ``2 * eps`` (absolute: never
    once the optimum is >= 4) or gives up after ``max_iterations`` with 0 (the
    convex hull), as ``alphashape`` does; so does a group valid at ``upper``.

    Parameters
    ----------
    valid, n_groups
        As for :func:`ladder_alpha`.
    max_iterations : int
    lower, upper : float

    Returns
    -------
    alpha, gave_up : ndarray of shape (n_groups,)
        The alphas, and the groups that did not converge (alpha 0).
    tests : int

    Examples
    --------
    >>> ok = lambda g, a: a <= np.array([0.75, 100.0])[g]
    >>> alpha, gave_up, _ = bisect_alpha(ok, 2, max_iterations=2000)
    >>> alpha.round(9).tolist(), gave_up.tolist()
    ([0.75, 0.0], [False, True])
    """
    groups = np.arange(n_groups)
    lo = np.full(n_groups, float(lower))
    hi = np.full(n_groups, float(upper))
    gave_up = np.zeros(n_groups, dtype=bool)
    unbounded = valid(groups, hi)
    active = ~unbounded
    tol = np.finfo(float).eps * 2
    iterations = 0
    while True:
        active &= (hi - lo) > tol
        idx = np.flatnonzero(active)
        if len(idx) == 0:
            break
        mid = (hi[idx] + lo[idx]) * 0.5
        ok = valid(idx, mid)
        lo[idx] = np.where(ok, mid, lo[idx])
        hi[idx] = np.where(ok, hi[idx], mid)
        iterations += 1
        if iterations > max_iterations:  # alphashape's counter > max_iterations
            gave_up[idx] = True
            break
    lo[gave_up | unbounded] = 0.0
    return lo, gave_up, iterations + 1
