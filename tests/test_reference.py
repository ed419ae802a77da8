"""The O(m log m) graph reference agrees with the O(m^2) one it replaced.

``reference.graph_optimum`` (one union-find sweep over the spectrum, fill
radii from a second sweep) is what the real-groups test and several property
tests compare geoalpha with; ``reference.graph_optimum_per_value`` builds each
candidate shape anew and counts its pieces with scipy. On small random sets,
grids full of ties and rings with a hole, both give the same alpha for holes
kept and filled and for 1 to 3 pieces.
"""

from __future__ import annotations

import numpy as np
import pytest
import reference
from example_counts import examples
from hypothesis import assume, given
from hypothesis import strategies as st

#: Coordinates on a coarse grid (many cocircular ties) or a fine one.
COARSE = st.integers(0, 6).map(float)
FINE = st.integers(-(10**6), 10**6).map(lambda i: i / 10**4)


def both(p, holes, components):
    try:
        fast = reference.graph_optimum(p, holes=holes, components=components)
    except ValueError:  # collinear within the tolerance: no triangle
        with pytest.raises(ValueError):
            reference.graph_optimum_per_value(p, holes=holes, components=components)
        assume(False)
    return fast, reference.graph_optimum_per_value(
        p, holes=holes, components=components
    )


@pytest.mark.parametrize("components", [1, 2, 3])
@pytest.mark.parametrize("holes", [False, True], ids=["filled", "holes"])
@examples(150)
@given(
    rows=st.one_of(
        st.lists(st.tuples(COARSE, COARSE), min_size=3, max_size=30),
        st.lists(st.tuples(FINE, FINE), min_size=3, max_size=30),
    )
)
def test_sweep_equals_per_value_reference(rows, holes, components):
    p = np.array(rows, dtype=float)
    fast, slow = both(p, holes, components)
    assert fast == slow


def ring_with_hole(k=16):
    """Two rings of k points around an empty middle."""
    theta = 2 * np.pi * np.arange(k) / k
    inner = np.c_[np.cos(theta), np.sin(theta)]
    outer = 1.3 * np.c_[np.cos(theta + np.pi / k), np.sin(theta + np.pi / k)]
    return np.vstack([inner, outer])


#: Seven grid points (found by a search) whose optimal shape with holes kept
#: is a ring with a small hole: filling it gives a larger alpha.
FILL_MATTERS = np.array(
    [[5, 1], [0, 4], [2, 0], [5, 5], [4, 5], [0, 0], [0, 5]], dtype=float
)


@pytest.mark.parametrize("components", [1, 2])
def test_sweep_fills_the_hole_like_the_per_value_reference(components):
    p = FILL_MATTERS
    filled = reference.graph_optimum(p, holes=False, components=components)
    kept = reference.graph_optimum(p, holes=True, components=components)
    assert filled == reference.graph_optimum_per_value(
        p, holes=False, components=components
    )
    assert kept == reference.graph_optimum_per_value(
        p, holes=True, components=components
    )
    assert filled > kept > 0


def test_fill_radius_is_the_widest_path_to_the_outside():
    p = ring_with_hole()
    _, _, neighbors, r = reference.triangulation(p)
    radius = reference.merged(r)
    fill = reference.fill_radii(neighbors, radius)
    # A solid triangle is in the shape, so never above the triangle's own
    # radius; the middle (radius 1) is filled as soon as the ring is solid.
    assert (fill <= radius).all()
    assert fill.max() < 0.3 < radius.max()
    for R in reference.spectrum(r):
        assert ((fill <= R) == reference.shape_mask(neighbors, r, R, False)).all()
