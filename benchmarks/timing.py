"""The one timing helper of the benchmarks: interleaved rounds, best of N.

Every function runs once as a warm-up, then one call of each per round, so
that load from other processes on a shared machine hits them alike; the best
time of each and the ratios of the bests are what the tables report.
"""

from __future__ import annotations

import time
from collections.abc import Callable


def best_of(
    fns: dict[str, Callable[[], object]], repeat: int, warm_up: bool = True
) -> dict[str, float]:
    """Best wall time of each function over ``repeat`` interleaved rounds.

    ``warm_up=False`` skips the warm-up call (for baselines that take
    minutes).
    """
    for fn in fns.values() if warm_up else ():
        fn()
    best = dict.fromkeys(fns, float("inf"))
    for _ in range(repeat):
        for key, fn in fns.items():
            start = time.perf_counter()
            fn()
            best[key] = min(best[key], time.perf_counter() - start)
    return best


def fmt_time(seconds: float) -> str:
    """Seconds as ms below 1 s, else s."""
    return f"{seconds * 1e3:,.1f} ms" if seconds < 1 else f"{seconds:,.2f} s"
