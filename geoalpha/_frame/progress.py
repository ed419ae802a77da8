"""One progress bar over every phase of a run: read, :data:`HULL_PHASES`, write."""

from __future__ import annotations

import contextlib
import contextvars
import sys
import warnings
from collections.abc import Callable, Iterator, Sequence
from typing import Any

__all__ = [
    "HULL_PHASES",
    "PROGRESS_MIN_GROUPS",
    "TICKS",
    "Phases",
    "current",
    "hull_costs",
    "phases",
]

#: Show a progress bar by default from this many groups on (on a terminal).
PROGRESS_MIN_GROUPS = 2000
#: The phases of :func:`geoalpha.hull`, in order.
HULL_PHASES = ("group", "project", "compute", "check")
#: Steps of a whole bar (it shows a percentage).
TICKS = 1000

_BAR_FORMAT = "{desc} {percentage:3.0f}%|{bar}| [{elapsed}<{remaining}{postfix}]"
_CURRENT: contextvars.ContextVar[Phases | None] = contextvars.ContextVar(
    "geoalpha_phases", default=None
)


def hull_costs(n_rows: int, n_groups: int, *, per_group_crs: bool) -> dict:
    """Estimate the time of each phase of :func:`geoalpha.hull`, in microseconds.

    Measured: 4 us a point to compute; with a metric CRS per group (wide lon/lat
    input), 150 us a group to project and to check. Only the ratios matter.

    Returns
    -------
    dict
        Phase name -> estimated cost (:meth:`Phases.estimate`).

    Examples
    --------
    >>> costs = hull_costs(43_645, 28_694, per_group_crs=True)
    >>> max(costs, key=costs.get)
    'check'
    """
    per_group = 150.0 if per_group_crs else 0.0
    return {
        "group": 0.3 * n_rows + 0.2 * n_groups,
        "project": 0.2 * n_rows + per_group * n_groups,
        "compute": 4.0 * n_rows + 5.0 * n_groups,
        "check": 0.1 * n_rows + (5.0 + per_group) * n_groups,
    }


class Phases:
    """A progress bar over named phases, each with an estimated share.

    Parameters
    ----------
    names : sequence of str
        The phases, in the order they run.
    show : bool or None
        True: show the bar from the start (needs tqdm); False: never; None:
        from :data:`PROGRESS_MIN_GROUPS` groups on a terminal (:meth:`sized`).
    desc, file : str and file-like, optional
        Start of the bar's description, and where it is drawn (``sys.stderr``).
    costs : callable, optional
        ``costs(n_rows, n_groups)`` -> estimated costs of the phases not
        :func:`geoalpha.hull`'s (the command's ``write``).

    Raises
    ------
    ImportError
        For ``show=True`` without tqdm (``pip install "geoalpha[progress]"``).

    Examples
    --------
    >>> import io
    >>> bar = Phases(["read", "compute"], show=True, file=io.StringIO())
    >>> bar.estimate({"read": 1.0, "compute": 3.0})
    >>> bar.start("read")
    >>> bar.start("compute", units=10)
    >>> bar.done  # read took its share (a quarter) of the TICKS
    250
    >>> bar.update(5)  # half of the groups
    >>> bar.done
    625
    >>> bar.close()
    """

    def __init__(
        self,
        names: Sequence[str],
        show: bool | None,
        *,
        desc: str = "geoalpha hull",
        file=None,
        costs: Callable[[int, int], dict] | None = None,
    ) -> None:
        self.names = tuple(names)
        self.done = 0  #: ticks done, of :data:`TICKS`
        self._costs = dict.fromkeys(self.names, 1.0)
        self._show = show
        self._desc = desc
        self._file = sys.stderr if file is None else file
        self._phase = -1
        self._start = self._budget = self._units = self._units_done = 0
        self._groups: int | None = None
        self._extra_costs = costs
        self._bar = self._showwarning = None
        if show:  # the bar appears at the first phase; tqdm is needed now
            self._tqdm()

    @staticmethod
    def _tqdm():
        try:
            from tqdm.auto import tqdm
        except ImportError as err:
            raise ImportError(
                'progress=True needs tqdm: pip install "geoalpha[progress]"'
            ) from err
        return tqdm

    def _open(self) -> None:
        tqdm, file = self._tqdm(), self._file
        self._bar = tqdm(
            total=TICKS,
            initial=self.done,
            desc=self._description(),
            bar_format=_BAR_FORMAT,
            file=file,
        )
        if self._groups is not None:
            self._bar.set_postfix_str(self._postfix(), refresh=False)
        shown = warnings.showwarning

        def above_the_bar(*args, **kwargs):
            with tqdm.external_write_mode(file=file):
                shown(*args, **kwargs)

        self._showwarning = (shown, above_the_bar)
        warnings.showwarning = above_the_bar

    def _description(self) -> str:
        if self._phase >= 0:
            return f"{self._desc}: {self.names[self._phase]}"
        return self._desc

    def _postfix(self) -> str:
        n = self._groups or 0
        return f"{n:,} group{'s' if n != 1 else ''}"

    def _advance(self, target: int) -> None:
        target = min(TICKS, target)
        if target > self.done:
            if self._bar is not None:
                self._bar.update(target - self.done)
            self.done = target

    @property
    def shown(self) -> bool:
        """Whether a bar is on the screen."""
        return self._bar is not None

    def estimate(self, costs: dict) -> None:
        """Set the estimated costs of phases (any unit); started ones keep theirs."""
        for name, cost in costs.items():
            if name in self._costs and self.names.index(name) > self._phase:
                self._costs[name] = max(float(cost), 0.0)

    def sized(self, n_rows: int, n_groups: int, *, per_group_crs: bool) -> None:
        """Estimate the phases to come from the run's size; show the bar if due."""
        costs = hull_costs(n_rows, n_groups, per_group_crs=per_group_crs)
        if self._extra_costs is not None:
            costs.update(self._extra_costs(n_rows, n_groups))
        self.estimate(costs)
        self._groups = int(n_groups)
        if self._bar is not None:
            self._bar.set_postfix_str(self._postfix(), refresh=True)
        elif self._show is None and n_groups >= PROGRESS_MIN_GROUPS:
            if getattr(self._file, "isatty", lambda: False)():
                with contextlib.suppress(ImportError):
                    self._open()

    def start(self, name: str, units: int = 0) -> None:
        """End the current phase and start ``name``, to advance in ``units`` steps."""
        index = self.names.index(name)
        if index <= self._phase:
            raise ValueError(f"phase {name!r} has already started")
        self._advance(self._start + self._budget)
        rest = [self._costs[n] for n in self.names[index:]]
        left, total = TICKS - self.done, sum(rest)
        share = 1.0 if total <= 0 or len(rest) == 1 else rest[0] / total  # last: all
        self._phase = index
        self._start = self.done
        self._budget = min(left, round(left * share))
        self._units = max(int(units), 0)
        self._units_done = 0
        if self._bar is not None:
            self._bar.set_description_str(self._description(), refresh=True)
        elif self._show:
            self._open()

    def update(self, n: int = 1) -> None:
        """Count ``n`` more units of the current phase done (as ``tqdm.update``)."""
        if self._units <= 0:
            return
        self._units_done = min(self._units, self._units_done + int(n))
        self._advance(self._start + self._budget * self._units_done // self._units)

    def close(self, complete: bool = True) -> None:
        """Close the bar, full when ``complete`` (the run ended well)."""
        if complete:
            self._advance(TICKS)
        if self._bar is not None:
            self._bar.close()
            self._bar = None
            shown, ours = self._showwarning
            if warnings.showwarning is ours:
                warnings.showwarning = shown


def current() -> Phases | None:
    """Return the bar of the enclosing :func:`phases` context, if any."""
    return _CURRENT.get()


@contextlib.contextmanager
def phases(names: Sequence[str], show: bool | None, **kwargs: Any) -> Iterator[Phases]:
    r"""Open a :class:`Phases` bar for the ``with`` block and make it :func:`current`.

    The arguments are those of :class:`Phases`; the bar ends full on success.

    Examples
    --------
    >>> import io
    >>> out = io.StringIO()
    >>> with phases(["read", "write"], show=True, file=out) as bar:
    ...     bar.start("read")
    ...     bar.start("write")
    ...     current() is bar
    True
    >>> out.getvalue().split("\r")[-1].split("|")[0], current() is None
    ('geoalpha hull: write 100%', True)
    """
    bar = Phases(names, show, **kwargs)
    token = _CURRENT.set(bar)
    ok = False
    try:
        yield bar
        ok = True
    finally:
        _CURRENT.reset(token)
        bar.close(complete=ok)
