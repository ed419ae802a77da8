"""The kernel at its limits (issue #37): one group never takes the others down,
limits are checked at the edge, no entry point aborts the process, Ctrl-C works.

Each test is made from a reproducer of the issue and failed before its fix.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
import warnings

import geopandas as gpd
import numpy as np
import pytest
import shapely

import geoalpha
from geoalpha import DegenerateGroupWarning
from geoalpha import _core as kernel

GOOD = np.array([[10, 10], [14, 10], [14, 14], [10, 14], [12, 13.5]], float)
TRIANGLE = np.array([[0, 0], [1, 0], [0, 1]], float)
# (1e-60, 0) beside (0, 0): below 2^-142 of the extent, spade set it to 0 and
# merged the two points, and the kernel panicked (repro 01).
TINY = np.r_[TRIANGLE, [[1e-60, 0]]]
SUBNORMAL = np.r_[TRIANGLE, [[5e-324, 5e-324]]]


@pytest.mark.parametrize("bad", [TINY, SUBNORMAL], ids=["1e-60", "5e-324"])
def test_a_tiny_coordinate_beside_zero_is_one_point_with_it(bad):
    res = geoalpha.alpha_shapes(bad)
    assert res.reason.tolist() == [0]
    assert res.n_distinct.tolist() == [3]
    # The optimum of the triangle: its convex hull (radius sqrt(2) / 2).
    assert res.alpha[0] == pytest.approx(np.sqrt(2), rel=1e-12)
    assert shapely.covers(res.geometry[0], shapely.points(bad)).all()
    assert geoalpha.optimal_alpha(bad) == pytest.approx(np.sqrt(2), rel=1e-12)


def test_hull_by_group_returns_every_group_beside_a_tiny_coordinate():
    xy = np.r_[GOOD, TINY]
    frame = gpd.GeoDataFrame(
        {"g": np.repeat(["good", "tiny"], [5, 4])},
        geometry=shapely.points(xy),
        crs="EPSG:32630",
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error", DegenerateGroupWarning)
        out = frame.alpha.hull(by="g")
    assert sorted(out["g"]) == ["good", "tiny"]
    for key, rows in (("good", GOOD), ("tiny", TINY)):
        shape = out.loc[out["g"] == key].geometry.iloc[0]
        assert shape.is_valid and not shape.is_empty
        assert shapely.covers(shape, shapely.points(rows)).all()
    good = out.loc[out["g"] == "good"].geometry.iloc[0]
    assert good.equals(geoalpha.alpha_shape(GOOD))


def _fail_group(monkeypatch, failed: int):
    """Make the kernel fail on group ``failed`` as a caught panic does: reason 7,
    no alpha, no rings, each point its own representative."""
    real = kernel._kernel.alpha_shapes

    def alpha_shapes(xy, offsets, *args, **kwargs):
        res = real(xy, offsets, *args, **kwargs)
        if failed >= len(offsets) - 1:
            return res
        go, po, ro = res["group_offsets"], res["polygon_offsets"], res["ring_offsets"]
        p0, p1 = go[failed], go[failed + 1]
        r0, r1 = po[p0], po[p1]
        v0, v1 = ro[r0], ro[r1]
        out = dict(res)
        out["ring_vertex"] = np.r_[res["ring_vertex"][:v0], res["ring_vertex"][v1:]]
        out["ring_offsets"] = np.r_[ro[: r0 + 1], ro[r1 + 1 :] - (v1 - v0)]
        out["polygon_offsets"] = np.r_[po[: p0 + 1], po[p1 + 1 :] - (r1 - r0)]
        out["group_offsets"] = np.r_[go[: failed + 1], go[failed + 1 :] - (p1 - p0)]
        for key, value in (("reason", 7), ("alpha", np.nan), ("n_parts", 0)):
            out[key] = res[key].copy()
            out[key][failed] = value
        a, b = offsets[failed], offsets[failed + 1]
        out["rep"] = res["rep"].copy()
        out["rep"][a:b] = np.arange(a, b)
        return out

    monkeypatch.setattr(kernel._kernel, "alpha_shapes", alpha_shapes)


def test_a_group_the_kernel_failed_on_warns_with_its_rows_and_spares_the_others(
    monkeypatch,
):
    _fail_group(monkeypatch, 1)
    xy = np.r_[GOOD, GOOD + 100, GOOD + 200]
    with pytest.warns(DegenerateGroupWarning) as caught:
        res = geoalpha.alpha_shapes(xy, np.repeat([0, 1, 2], 5))
    message = str(caught[0].message)
    assert (
        "the kernel failed on 1 group(s) (codes 1; rows at positions 5, 6, 7" in message
    )
    assert res.reason.tolist() == [0, 7, 0]
    assert res.degenerate.tolist() == [False, True, False]
    assert res.geometry[1].is_empty and np.isnan(res.alpha[1])
    for g in (0, 2):
        assert res.geometry[g].equals(geoalpha.alpha_shape(GOOD + 100 * g))
    assert kernel.REASONS[7].startswith("the kernel failed on this group")


def test_hull_names_the_group_the_kernel_failed_on(monkeypatch):
    _fail_group(monkeypatch, 1)
    xy = np.r_[GOOD, GOOD + 100, GOOD + 200]
    frame = gpd.GeoDataFrame(
        {"g": np.repeat(["a", "b", "c"], 5)}, geometry=shapely.points(xy), crs=32630
    )
    with pytest.warns(
        DegenerateGroupWarning, match=r"kernel failed on 1 group.*'b' \(5 rows\)"
    ):
        out = frame.alpha.hull(by="g", degenerate="empty").set_index("g")
    assert np.isnan(out.loc["b", "alpha"]) and out.loc["b", "geometry"].is_empty
    for key, g in (("a", 0), ("c", 2)):
        shape = out.loc[key, "geometry"]
        assert shape.equals(geoalpha.alpha_shape(GOOD + 100 * g))


# --- Limits at the edge (items 6, 7 of the issue) ---------------------------

SQUARE = np.array([[0, 0], [4, 0], [4, 4], [0, 4], [2, 3.5]], float)


def test_n_jobs_above_the_cores_is_capped_to_them():
    # Repro 04: n_jobs=2000 built 2,000 threads (4 s for 5 points) and
    # n_jobs=100000 ran past 40 s.
    assert kernel.threads(100_000) == kernel.cores()
    assert kernel.threads(None) == kernel.threads(-1) == kernel.cores()
    expected = geoalpha.alpha_shapes(SQUARE, n_jobs=1)
    geoalpha.alpha_shapes(SQUARE, n_jobs=kernel.cores() + 1)  # (the pool exists)
    start = time.perf_counter()
    for n_jobs in (2_000, 100_000):
        res = geoalpha.alpha_shapes(SQUARE, n_jobs=n_jobs)
        assert res.alpha.tolist() == expected.alpha.tolist()
    assert time.perf_counter() - start < 1.0


@pytest.mark.parametrize(
    "code",
    [
        np.int64(2**31),
        np.int64(2**40),
        np.int64(np.iinfo(np.int64).max),
        np.uint64(np.iinfo(np.uint64).max),
        np.uint32(2**31),
        np.int32(np.iinfo(np.int32).max),
    ],
    ids=["2^31", "2^40", "int64-max", "uint64-max", "uint32-2^31", "int32-max"],
)
def test_a_group_code_of_any_size_is_refused_clearly(code):
    # Issue #37 item 7: codes >= 2^31 raised MemoryError, ValueError or
    # OverflowError from numpy's bincount.
    groups = np.array([0, code, 1, 0, 0], dtype=np.asarray(code).dtype)
    with pytest.raises(geoalpha.InvalidInputError, match=f"got code {int(code)}"):
        geoalpha.alpha_shapes(SQUARE, groups)


def test_a_huge_n_groups_is_refused_and_empty_groups_within_the_bound_work():
    with pytest.raises(geoalpha.InvalidInputError, match="n_groups must be"):
        geoalpha.alpha_shapes(SQUARE, [0, 0, 0, 0, 0], n_groups=2**40)
    res = geoalpha.alpha_shapes(SQUARE, [0, 0, 0, 0, 2], n_groups=5)
    assert res.n_points.tolist() == [4, 0, 1, 0, 0]
    assert res.degenerate.tolist() == [False, True, True, True, True]


# Every compiled entry point on hostile arguments: each call must raise a
# Python exception or return; the process must not abort (it ran in this
# process before, so a subprocess takes the blow).
_HOSTILE = r"""
import numpy as np
from geoalpha import _kernel as k
from geoalpha._core import DEFAULT_REQUEST, Compiled


def R(**kw):  # the request of the compiled call, with some attributes changed
    request = Compiled(DEFAULT_REQUEST, 0)
    request.__dict__.update(kw)
    return request


xy = np.array([[0, 0], [4, 0], [4, 4], [0, 4], [2, 3.5]], float)
z = np.zeros(5, np.int64)
lon, lat = np.ascontiguousarray(xy[:, 0]), np.ascontiguousarray(xy[:, 1])
calls = [
    lambda: k.sort_groups(xy, z, 2**62),
    lambda: k.sort_groups(xy, z, 2**64 - 1),
    lambda: k.sort_groups(xy, z, 2**70),
    lambda: k.sort_groups(xy, z, -1),
    lambda: k.sort_groups(xy, z[:3], 1),
    lambda: k.sort_groups(xy, z, 1, out_xy=xy[:2]),
    lambda: k.sort_groups(xy, z + 7, 2),
    lambda: k.sort_groups(xy, z - 1, 2),
    lambda: k.sort_groups(xy, z, 1, threads=10**6),
    lambda: k.sort_groups(xy, z, 1, threads=-1),
    lambda: k.sort_groups(np.asfortranarray(xy), z, 1),
    lambda: k.sort_groups(np.zeros((5, 3)), z, 1),
    lambda: k.sort_groups(np.zeros((0, 2)), np.zeros(0, np.int64), 0),
    lambda: k.sort_groups(xy, z.astype(np.int32), 1),
    lambda: k.alpha_shapes(xy, np.array([0, 5]), R(threads=10**6)),
    lambda: k.alpha_shapes(xy, np.array([], np.int64), R()),
    lambda: k.alpha_shapes(xy, np.array([1, 5]), R()),
    lambda: k.alpha_shapes(xy, np.array([0, 6]), R()),
    lambda: k.alpha_shapes(xy, np.array([0, 4, 2, 5]), R()),
    lambda: k.alpha_shapes(xy, np.array([0, -1, 5]), R()),
    lambda: k.alpha_shapes(xy, np.array([0, 2**62, 5]), R()),
    lambda: k.alpha_shapes(xy, np.array([0, 5]), R(), alpha=np.array([1.0, 2.0])),
    lambda: k.alpha_shapes(xy, np.array([0, 5]), R(), alpha=np.array([np.nan])),
    lambda: k.alpha_shapes(xy, np.array([0, 5]), R(count=-1)),
    lambda: k.alpha_shapes(xy, np.array([0, 5]), R(count=2**62)),
    lambda: k.alpha_shapes(xy, np.array([0, 5]), R(components=0)),
    lambda: k.alpha_shapes(xy, np.array([0, 5]), R(components=2**62)),
    lambda: k.alpha_shapes(xy, np.array([0, 5]), R(max_union_nodes=0, components=2,
                                                   count=2)),
    lambda: k.alpha_shapes(xy, np.array([0, 5]), R(), out_xy=xy[:3]),
    lambda: k.alpha_shapes(xy * np.nan, np.array([0, 5]), R()),
    lambda: k.alpha_shapes(xy * 1e300, np.array([0, 5]), R()),
    lambda: k.alpha_shapes(xy * 100, np.array([0, 5]), R(sphere=True)),
    lambda: k.alpha_shapes(np.zeros((0, 2)), np.array([0]), R()),
    lambda: k.alpha_shapes(np.zeros((0, 2)), np.array([0, 0, 0]), R()),
    lambda: k.geodesic_areas(lon, lat[:3], z[:1], z[:1], z[:1]),
    lambda: k.geodesic_areas(lon, lat, z[:0], z[:0], z[:0]),
    lambda: k.geodesic_areas(lon, lat, np.array([0, 9]), np.array([0, 1]),
                             np.array([0, 1])),
    lambda: k.geodesic_areas(lon, lat, np.array([0, 5]), np.array([0, 3]),
                             np.array([0, 1])),
    lambda: k.geodesic_areas(lon, lat * 100, np.array([0, 5]),
                             np.array([0, 1]), np.array([0, 1]), threads=10**6),
]
for i, call in enumerate(calls):
    try:
        call()
    except Exception as err:  # a Python exception is the point
        print(i, type(err).__name__, str(err)[:80], flush=True)
    else:
        print(i, "ok", flush=True)
print("survived", len(calls))
"""


def test_no_kernel_entry_point_aborts_the_process_on_hostile_arguments():
    run = subprocess.run(
        [sys.executable, "-c", _HOSTILE],
        capture_output=True,
        text=True,
        timeout=120,
        env={**os.environ, "RUST_BACKTRACE": "0"},
    )
    assert run.returncode == 0, run.stdout + run.stderr
    lines = run.stdout.splitlines()
    assert lines[-1] == "survived 39", run.stdout + run.stderr
    assert "panicked" not in run.stderr, run.stderr
    outcome = dict(line.split(" ", 1) for line in lines[:-1])
    # Huge group counts are refused clearly, never allocated.
    assert outcome["0"].startswith("ValueError groups must be at most"), outcome["0"]
    assert outcome["1"].startswith("ValueError groups must be at most"), outcome["1"]
    # Only calls with sound arguments return.
    sound = {"8", "12", "14", "24", "26", "27", "32", "33"}
    assert {i for i, o in outcome.items() if o == "ok"} == sound, outcome


# --- Ctrl-C (item 8) ---------------------------------------------------------

_LONG_CALL = r"""
import signal
import time
import numpy as np

# (a shell starts background jobs with SIGINT ignored, and children inherit it)
signal.signal(signal.SIGINT, signal.default_int_handler)
from geoalpha import _kernel
from geoalpha._core import DEFAULT_REQUEST, Compiled

request = Compiled(DEFAULT_REQUEST, 2)
xy = np.random.default_rng(1).uniform(0, 1000, (3_000_000, 2))
print("start", flush=True)
start = time.perf_counter()
try:
    _kernel.alpha_shapes(xy, np.array([0, len(xy)]), request)
    print("finished", flush=True)
except KeyboardInterrupt:
    print("KeyboardInterrupt", flush=True)
"""


@pytest.mark.skipif(not hasattr(signal, "SIGINT") or os.name != "posix", reason="POSIX")
def test_ctrl_c_stops_a_long_kernel_call_within_a_second():
    # Issue #37 item 8: 3M points in one group could not be interrupted for
    # 5 s (signals were honoured only when the kernel returned).
    child = subprocess.Popen(
        [sys.executable, "-c", _LONG_CALL], stdout=subprocess.PIPE, text=True
    )
    try:
        assert child.stdout.readline().strip() == "start"
        time.sleep(2.5)  # inside the triangulation of the one group
        sent = time.perf_counter()
        child.send_signal(signal.SIGINT)
        line = child.stdout.readline().strip()
        waited = time.perf_counter() - sent
        assert child.wait(timeout=30) == 0
    finally:
        child.kill()
    assert line == "KeyboardInterrupt"
    assert waited < 1.0


def test_a_call_after_an_interrupted_one_is_whole():
    # The flag is lowered once the interrupted call is done.
    code = _LONG_CALL.replace('print("start", flush=True)', "")
    code += r"""
import os, signal, threading
threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT)).start()
try:
    _kernel.alpha_shapes(xy, np.array([0, len(xy)]), request)
except KeyboardInterrupt:
    print("again interrupted", flush=True)
square = np.array([[0, 0], [4, 0], [4, 4], [0, 4], [2, 3.5]], float)
res = _kernel.alpha_shapes(np.r_[square, square], np.array([0, 5, 10]), request)
print(res["reason"].tolist(), res["n_parts"].tolist(), flush=True)
"""
    run = subprocess.run(
        [sys.executable, "-c", code.replace("(3_000_000, 2)", "(1_000_000, 2)")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert run.stdout.splitlines()[-2:] == ["again interrupted", "[0, 0] [1, 1]"], (
        run.stdout + run.stderr
    )
