"""Tests of ``n_jobs=``: the kernel's threads (issues #6 and #23).

What a user would notice: a result that differs from ``n_jobs=1`` (values,
geometries, dtypes, group order), a warning lost in a worker or naming the
wrong group, a progress bar that does not reach the end, an unclear error.
"""

from __future__ import annotations

import re
import warnings

import numpy as np
import pytest
import shapely
from compat import requires_tqdm
from geopandas.testing import assert_geodataframe_equal
from progress_output import assert_bar_covers

import geoalpha
from geoalpha import _core as kernel
from geoalpha import datasets
from geoalpha._arrays.optimal import alpha_shapes
from geoalpha.errors import InvalidInputError, SearchWarning

pytestmark = pytest.mark.filterwarnings(
    "ignore::geoalpha.errors.DegenerateGroupWarning",
    "ignore::geoalpha.errors.DroppedRowsWarning",
)


@pytest.fixture(scope="module")
def clusters():
    """The 691 UK accident clusters in EPSG:32630 metres, rows shuffled."""
    gdf = datasets.load("uk_clusters").to_crs(32630)
    gdf = gdf.sample(frac=1.0, random_state=6).reset_index(drop=True)
    xy = shapely.get_coordinates(gdf.geometry.array)
    codes, _ = gdf["Cluster"].factorize(sort=True)
    return xy, codes


def assert_same(a, b):
    """Every field equal, geometries coordinate by coordinate (WKB)."""
    assert a._fields == b._fields
    for name in a._fields:
        x, y = np.asarray(getattr(a, name)), np.asarray(getattr(b, name))
        assert x.dtype == y.dtype, name
        if name == "geometry":
            assert (shapely.to_wkb(x) == shapely.to_wkb(y)).all()
        else:
            np.testing.assert_array_equal(x, y, err_msg=name)


@pytest.mark.parametrize("n_jobs", [0, 1.5, "2", True, -2])
def test_bad_n_jobs_is_an_error(n_jobs):
    with pytest.raises(InvalidInputError, match="n_jobs must be a positive integer"):
        alpha_shapes([[0, 0], [1, 0], [0, 1]], n_jobs=n_jobs)


def test_the_default_is_every_core():
    import os

    cores = len(os.sched_getaffinity(0))
    assert kernel.threads(None) == kernel.threads(-1) == cores
    assert kernel.threads(1) == 1
    # More than the cores is capped to them (issue #37).
    assert kernel.threads(cores + 1) == cores


# --- identical results ---------------------------------------------------------


@pytest.mark.parametrize(
    "kwargs",
    [
        {},
        {"holes": True},
        {"components": 3},
        {"alpha": 0.0},
        {"search": "ladder"},
    ],
)
def test_alpha_shapes_n_jobs_equals_one_job(clusters, kwargs):
    xy, codes = clusters
    one = alpha_shapes(xy, codes, **kwargs)
    assert_same(alpha_shapes(xy, codes, n_jobs=2, **kwargs), one)
    assert_same(alpha_shapes(xy, codes, n_jobs=3, **kwargs), one)


def test_n_jobs_with_per_group_alpha_coords_and_empty_groups(clusters):
    xy, codes = clusters
    # Groups without points (codes 0, 1 and the last two) and per-group alphas.
    codes = codes + 2
    n_groups = int(codes.max()) + 3
    alpha = np.linspace(0.0, 0.02, n_groups)
    coords = xy / 1000.0
    kwargs = {"alpha": alpha, "coords": coords, "n_groups": n_groups}
    one = alpha_shapes(xy, codes, **kwargs)
    many = alpha_shapes(xy, codes, n_jobs=2, **kwargs)
    assert_same(many, one)
    assert many.degenerate[[0, 1, -2, -1]].all()
    assert len(many.alpha) == n_groups


@pytest.mark.parametrize(
    ("name", "by"), [("uk_clusters", "Cluster"), ("us_airports", "state")]
)
def test_hull_n_jobs_equals_one_job(name, by):
    gdf = datasets.load(name)
    one = gdf.alpha.hull(by=by)
    assert_geodataframe_equal(gdf.alpha.hull(by=by, n_jobs=2), one)
    assert_geodataframe_equal(geoalpha.hull(gdf, by, n_jobs=-1), one)


def test_hull_n_jobs_convex():
    gdf = datasets.load("uk_clusters")
    assert_geodataframe_equal(
        gdf.alpha.hull(by="Cluster", method="convex", n_jobs=2),
        gdf.alpha.hull(by="Cluster", method="convex"),
    )


# --- warnings, progress, errors --------------------------------------------------


def test_threads_warn_once_as_a_single_call_does(clusters):
    xy, codes = clusters
    with warnings.catch_warnings(record=True) as one:
        warnings.simplefilter("always")
        alpha_shapes(xy, codes, search="bisect", max_iterations=3)
    with warnings.catch_warnings(record=True) as many:
        warnings.simplefilter("always")
        alpha_shapes(xy, codes, search="bisect", max_iterations=3, n_jobs=2)
    # One SearchWarning for the whole call, naming the same groups by their
    # codes in the whole call (not one per run of groups), at the caller.
    assert len(one) == 1 and one[0].category is SearchWarning
    assert [str(w.message) for w in many] == [str(w.message) for w in one]
    assert all(w.filename == __file__ for w in many)
    assert re.search(r"\(codes 0, 1, 2, [\d, .]+\)", str(one[0].message))


def test_progress_counts_every_group(clusters):
    xy, codes = clusters

    class Bar:
        n = 0

        def update(self, k):
            self.n += k

    bar = Bar()
    alpha_shapes(xy, codes, n_jobs=2, progress=bar)
    assert bar.n == codes.max() + 1


@requires_tqdm
def test_hull_progress_bar_with_threads_covers_every_phase(capsys):
    gdf = datasets.load("uk_clusters")
    geoalpha.hull(gdf, "Cluster", n_jobs=2, progress=True)
    err = capsys.readouterr().err
    assert_bar_covers(err, ["group", "project", "compute", "check"])
    assert "691 groups]" in err


def test_bad_input_is_reported_before_the_kernel_runs():
    xy = np.zeros((50_000, 2))
    xy[123] = np.nan
    with pytest.raises(InvalidInputError, match=r"NaN or inf in 1 row\(s\)"):
        alpha_shapes(xy, np.arange(50_000) // 100, n_jobs=2)


def test_bad_options_are_reported_with_threads(clusters):
    xy, codes = clusters
    n_groups = int(codes.max()) + 1
    with pytest.raises(InvalidInputError, match="alpha must be finite"):
        alpha_shapes(xy, codes, alpha=np.full(n_groups, -1.0), n_jobs=2)


@pytest.mark.skipif(not hasattr(__import__("os"), "fork"), reason="no os.fork")
def test_a_forked_child_gets_its_own_threads(clusters):
    """The kernel keeps its thread pools; a child made by fork has none of the
    parent's threads, so it must build its own rather than wait for ever."""
    import os
    import time

    xy, codes = clusters
    parent = alpha_shapes(xy, codes, n_jobs=2)  # the pools exist now
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # fork with threads
        pid = os.fork()
    if pid == 0:  # the child: same answer on 2 threads, then exit at once
        code = 2
        try:
            child = alpha_shapes(xy, codes, n_jobs=2)
            code = 0 if np.array_equal(child.alpha, parent.alpha, equal_nan=True) else 1
        finally:
            os._exit(code)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            assert os.waitstatus_to_exitcode(status) == 0, "the child's result differs"
            return
        time.sleep(0.05)
    os.kill(pid, 9)
    os.waitpid(pid, 0)
    pytest.fail("the forked child's kernel call hung (the parent's thread pool)")
