"""The one timing helper of the benchmarks: interleaved rounds, best of N.

Every function runs once as a warm-up, then one call of each per round, so
that load from other processes on a shared machine hits them alike; the best
time of each and the ratios of the bests (or the medians, and the medians of
the per-round ratios) are what the tables report. Peak memory is read in a
fresh process, from its own high-water mark.
"""

from __future__ import annotations

import statistics
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path

Clock = Callable[[], float]


def timed(fn: Callable[..., object], *args, clock: Clock = time.perf_counter):
    """Run ``fn(*args)`` once; return (seconds, its result)."""
    start = clock()
    out = fn(*args)
    return clock() - start, out


def rounds(
    fns: dict, repeat: int, warm_up: bool = True, clock: Clock = time.perf_counter
) -> dict[object, list[float]]:
    """Every round's time of each function over ``repeat`` interleaved rounds.

    ``warm_up=False`` skips the warm-up call (for baselines that take minutes,
    or when the caller made it to keep its results); ``clock`` may be
    ``time.process_time`` (CPU time of this process).
    """
    for fn in fns.values() if warm_up else ():
        fn()
    times: dict[object, list[float]] = {key: [] for key in fns}
    for _ in range(repeat):
        for key, fn in fns.items():
            times[key].append(timed(fn, clock=clock)[0])
    return times


def best_of(
    fns: dict, repeat: int, warm_up: bool = True, clock: Clock = time.perf_counter
) -> dict[object, float]:
    """Best time of each function over ``repeat`` interleaved rounds."""
    return {k: min(t) for k, t in rounds(fns, repeat, warm_up, clock).items()}


def paired_ratio(times: Sequence[float], base: Sequence[float]) -> float:
    """Median of the per-round ratios ``times / base`` (same rounds)."""
    return statistics.median(t / b for t, b in zip(times, base, strict=True))


def fresh_python(code: str, env: dict | None = None, timeout=None) -> str:
    """Run ``code`` in a fresh Python process (this folder on its path).

    Return what it printed; ``subprocess.TimeoutExpired`` past ``timeout``
    seconds.
    """
    path = f"import sys; sys.path.insert(0, {str(Path(__file__).parent)!r})\n"
    out = subprocess.run(
        [sys.executable, "-c", path + code],
        env=env,
        capture_output=True,
        text=True,
        check=True,
        timeout=timeout,
    )
    return out.stdout


def peak_memory_mb(code: str) -> float:
    """Peak RSS (MB) of a fresh Python process running ``code``.

    Read from ``VmHWM``, the high-water mark of that process's own memory
    (``ru_maxrss`` would also count the parent's memory at the fork).
    """
    probe = 'print(open("/proc/self/status").read().split("VmHWM:")[1].split()[0])'
    return int(fresh_python(code + "\n" + probe).split()[-1]) / 1024


def fmt_time(seconds: float) -> str:
    """Seconds as µs below 1 ms, ms below 1 s, else s."""
    if seconds < 1e-3:
        return f"{seconds * 1e6:,.1f} µs"
    return f"{seconds * 1e3:,.1f} ms" if seconds < 1 else f"{seconds:,.2f} s"
