"""Shared test configuration: hypothesis profiles.

``default`` (what ``python -m pytest`` uses) runs a tenth of the examples of
``ci``: every property test runs, with few examples, so that the default run
is fast. ``ci`` is reproducible (derandomized, no example database, no
deadline: the machine is shared and the brute-force references are slow) and
runs the counts the tests ask for; CI selects it for its second run,
``HYPOTHESIS_PROFILE=ci python -m pytest -m "exhaustive or hypothesis or notebook"``.
``thorough`` runs ten times as many examples as ``ci``, with fresh
randomness: ``HYPOTHESIS_PROFILE=thorough python -m pytest``.

Tests ask for a count in ``ci`` terms through :func:`example_counts.examples`.
"""

from __future__ import annotations

import os

from hypothesis import HealthCheck, settings

COMMON = {
    "deadline": None,
    "print_blob": True,
    "suppress_health_check": [HealthCheck.too_slow],
}
settings.register_profile(
    "ci", max_examples=100, derandomize=True, database=None, **COMMON
)
settings.register_profile(
    "default", max_examples=10, derandomize=True, database=None, **COMMON
)
settings.register_profile("thorough", max_examples=1000, **COMMON)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "default"))
