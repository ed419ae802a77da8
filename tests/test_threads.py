"""Tests of ``n_jobs=``: groups spread over worker processes (GitHub issue #6).

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
from geoalpha import datasets, parallel
from geoalpha.errors import InvalidInputError, SearchWarning
from geoalpha.optimal import alpha_shapes

pytestmark = pytest.mark.filterwarnings(
    "ignore::geoalpha.errors.DegenerateGroupWarning",
    "ignore::geoalpha.errors.DroppedRowsWarning",
)


@pytest.fixture(autouse=True)
def _small_jobs(monkeypatch):
    """Start workers even for the small bundled datasets."""
    monkeypatch.setattr(parallel, "MIN_POINTS_PER_JOB", 1)


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


# --- splitting the groups ------------------------------------------------------


@pytest.mark.parametrize(
    ("counts", "n", "expected"),
    [
        ([5, 5, 5, 5], 2, [0, 2, 4]),
        ([5, 5, 5, 5], 4, [0, 1, 2, 3, 4]),
        ([100, 1, 1, 1], 2, [0, 1, 4]),  # one big group is a run of its own
        ([0, 0, 100, 1], 2, [0, 3, 4]),  # leading empty groups join a run
        ([3], 4, [0, 1]),  # fewer groups than runs
        ([1, 1, 1, 0, 0], 3, [0, 1, 2, 5]),  # trailing empty groups join a run
        ([7, 7, 7], 1, [0, 3]),
    ],
)
def test_split_groups(counts, n, expected):
    assert parallel.split_groups(counts, n).tolist() == expected


def test_split_groups_balances_points():
    counts = np.random.default_rng(0).integers(1, 2000, 1000)
    bounds = parallel.split_groups(counts, 4)
    assert bounds[0] == 0 and bounds[-1] == 1000 and len(bounds) == 5
    per_run = np.add.reduceat(counts, bounds[:-1])
    assert per_run.max() - per_run.min() <= 2 * counts.max()


@pytest.mark.parametrize("n_jobs", [0, 1.5, "2", True, None])
def test_bad_n_jobs_is_an_error(n_jobs):
    with pytest.raises(InvalidInputError, match="n_jobs must be a positive integer"):
        alpha_shapes([[0, 0], [1, 0], [0, 1]], n_jobs=n_jobs)


def test_negative_n_jobs_counts_from_all_cores():
    cores = parallel.effective_n_jobs(-1)
    assert cores >= 1
    assert parallel.effective_n_jobs(-2) == max(cores - 1, 1)
    assert parallel.effective_n_jobs(-1000) == 1


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


def test_n_jobs_start_method_spawn(clusters, monkeypatch):
    monkeypatch.setattr(parallel, "START_METHOD", "spawn")
    xy, codes = clusters
    keep = codes < 60  # spawned workers import geoalpha: keep it short
    assert_same(
        alpha_shapes(xy[keep], codes[keep], n_jobs=2),
        alpha_shapes(xy[keep], codes[keep]),
    )


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


def test_small_inputs_run_in_this_process(clusters, monkeypatch):
    monkeypatch.setattr(parallel, "MIN_POINTS_PER_JOB", 10**9)

    def no_pool(*args, **kwargs):
        raise AssertionError("a worker process was started")

    monkeypatch.setattr(parallel, "ProcessPoolExecutor", no_pool)
    xy, codes = clusters
    assert_same(alpha_shapes(xy, codes, n_jobs=2), alpha_shapes(xy, codes))


def test_batches_in_this_process_equal_one_call(clusters, monkeypatch):
    xy, codes = clusters
    one = alpha_shapes(xy, codes, holes=True)
    monkeypatch.setattr(parallel, "BATCH_POINTS", 1000)

    def no_pool(*args, **kwargs):
        raise AssertionError("a worker process was started")

    monkeypatch.setattr(parallel, "ProcessPoolExecutor", no_pool)
    assert_same(alpha_shapes(xy, codes, n_jobs=1, holes=True), one)


# --- warnings, progress, errors --------------------------------------------------


def test_workers_warn_once_as_a_single_call_does(clusters):
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
def test_hull_progress_bar_with_workers_covers_every_phase(capsys, monkeypatch):
    gdf = datasets.load("uk_clusters")
    chunks = []
    real = parallel.split_groups
    monkeypatch.setattr(
        parallel, "split_groups", lambda *a: chunks.append(real(*a)) or chunks[-1]
    )
    geoalpha.hull(gdf, "Cluster", n_jobs=2, progress=True)
    assert len(chunks[0]) > 2  # the groups went to the workers in several chunks
    err = capsys.readouterr().err
    assert_bar_covers(err, ["group", "project", "compute", "check"])
    assert "691 groups]" in err


def test_bad_input_is_reported_before_workers_start():
    xy = np.zeros((50_000, 2))
    xy[123] = np.nan
    with pytest.raises(InvalidInputError, match=r"NaN or inf in 1 row\(s\)"):
        alpha_shapes(xy, np.arange(50_000) // 100, n_jobs=2)


def test_errors_in_workers_reach_the_caller(clusters):
    xy, codes = clusters
    n_groups = int(codes.max()) + 1
    with pytest.raises(InvalidInputError, match="alpha must be finite"):
        alpha_shapes(xy, codes, alpha=np.full(n_groups, -1.0), n_jobs=2)
