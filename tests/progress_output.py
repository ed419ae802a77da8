"""Read back what a geoalpha progress bar drew: its phases and percentages."""

from __future__ import annotations

import re

_STATE = re.compile(r"geoalpha hull: (\w+)\s+(\d+)%\|")


def bar_states(text: str) -> list[tuple[str, int]]:
    """Every (phase, percent) the bar showed, in order (tqdm redraws with \\r)."""
    return [
        (m[1], int(m[2]))
        for line in re.split(r"[\r\n]", text)
        if (m := _STATE.search(line))
    ]


def phases_seen(states: list[tuple[str, int]]) -> list[str]:
    """The phases in the order they first appeared."""
    return list(dict.fromkeys(phase for phase, _ in states))


def assert_bar_covers(text: str, phases: list[str]) -> list[tuple[str, int]]:
    """Assert the bar went through ``phases`` in order, never back, to 100 %."""
    states = bar_states(text)
    assert phases_seen(states) == phases, text
    percents = [p for _, p in states]
    assert percents == sorted(percents), text  # never backwards
    assert states[-1] == (phases[-1], 100), text
    assert all(c < 100 for p, c in states if p != phases[-1]), text
    return states
