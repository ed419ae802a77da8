"""Example counts of property tests, relative to the hypothesis profile.

A test asks for ``n`` examples as the ``ci`` profile runs them (100 per test
by default there); the ``default`` profile of ``python -m pytest`` runs a
tenth of that and ``thorough`` ten times as many (tests/conftest.py).
"""

from __future__ import annotations

from hypothesis import settings


def scaled(n: int) -> int:
    """``n`` examples of the ``ci`` profile, in the loaded profile."""
    return max(1, round(n * settings().max_examples / 100))


def examples(n: int, **kwargs) -> settings:
    """Settings for ``n`` examples of the ``ci`` profile (see :func:`scaled`)."""
    return settings(max_examples=scaled(n), **kwargs)
