"""Peer implementations of the optimal alpha search, for benchmarking geoalpha.

Every peer takes the *distinct* points of one group as an ``(n, 2)`` float
array in a metric CRS (metres) and returns a :class:`PeerResult` with the
alpha it found (in 1/metre, the ``alphashape`` convention: alpha = 1/radius)
and the number of alpha shapes it built to get there.

The peers
---------
``bisection_alpha``
    ``alphashape.optimizealpha`` (alphashape 1.3.1), unchanged, except for the
    smallest patch that lets it run on shapely 2: its helper ``_testalpha``
    iterates ``points.geoms`` instead of ``points`` (a shapely 2
    ``MultiPoint`` is not iterable; unpatched, every call raises
    ``TypeError: 'MultiPoint' object is not iterable``). See
    :func:`patched_alphashape`.
``ladder_alpha``
    The seed paper's coarse search: the descending integer ladder
    :data:`LADDER`, then integer bisection between the first rung that passes
    and the rung above it. It uses the same alphashape builds and the same
    (patched) validity test as the bisection.
``libpysal_alpha``
    ``libpysal.cg.alpha_shape_auto``: walks the Delaunay triangles from the
    largest circumradius down, builds the shape at every step and stops at the
    first invalid one. It returns a *radius*; we report ``alpha = 1 / radius``.
    Without numba, libpysal's ``@jit`` helpers run as plain Python
    (:data:`LIBPYSAL_HAS_NUMBA` says which).
``delaunay_floor``
    A bare Python loop of ``scipy.spatial.Delaunay`` over the groups: the
    least any per-group method that triangulates must spend.

alphashape and libpysal both fail on duplicate points (degenerate Delaunay
triangles, zero-length edges), so callers must deduplicate each group first.
"""

from __future__ import annotations

import contextlib
import importlib
import warnings
from collections.abc import Callable, Iterator, Sequence
from typing import NamedTuple

import numpy as np

__all__ = [
    "LADDER",
    "LIBPYSAL_HAS_NUMBA",
    "PeerResult",
    "bisection_alpha",
    "delaunay_floor",
    "ladder_alpha",
    "libpysal_alpha",
    "patched_alphashape",
    "testalpha_shapely2",
]

#: The seed paper's descending integer ladder of alpha values (1/unit).
LADDER: tuple[int, ...] = (5000, 3000, 1000, 500, 300, 100, 50, 25, 18, 10, 5, 0)


def _libpysal_has_numba() -> bool:
    """Return whether libpysal found numba (its ``HAS_JIT`` flag)."""
    try:
        from libpysal.common import HAS_JIT
    except ImportError:  # pragma: no cover - libpysal missing
        return False
    return bool(HAS_JIT)


#: True when libpysal's alpha-shape helpers are numba-compiled.
LIBPYSAL_HAS_NUMBA: bool = _libpysal_has_numba()


class PeerResult(NamedTuple):
    """What a peer found for one group.

    Attributes
    ----------
    alpha : float
        The alpha the peer returned, in 1/metre (alpha = 1/radius).
    builds : int
        How many alpha shapes (shape + validity test) it built.
    error : str
        Empty, or the exception the peer raised (``alpha`` is then NaN).
    """

    alpha: float
    builds: int
    error: str = ""


class _Counter:
    """A mutable call counter shared by a patch and its caller."""

    def __init__(self) -> None:
        self.n = 0


_COUNTER = _Counter()


def testalpha_shapely2(points, alpha: float) -> bool:
    """alphashape 1.3.1 ``optimizealpha._testalpha`` with one line patched.

    The original (``alphashape/optimizealpha.py``) ends its Polygon branch
    with ``all([polygon.intersects(point) for point in points])``; a shapely 2
    ``MultiPoint`` is not iterable, so that raises ``TypeError``. This copy
    iterates ``points.geoms``; every other line is alphashape's own. Each call
    builds one alpha shape, counted in a module-level counter.

    Parameters
    ----------
    points : array-like or shapely.MultiPoint
        The group's points.
    alpha : float
        Alpha to test, in 1/unit of the coordinates.

    Returns
    -------
    bool
        True when the alpha shape is a single Polygon that intersects every
        input point.
    """
    import shapely
    import trimesh
    from alphashape import alphashape
    from shapely.geometry import MultiPoint

    _COUNTER.n += 1
    polygon = alphashape(points, alpha)
    if isinstance(polygon, shapely.geometry.polygon.Polygon):
        if not isinstance(points, MultiPoint):
            points = MultiPoint(list(points))
        # the patch: ``points.geoms`` instead of ``points``
        return all([polygon.intersects(point) for point in points.geoms])
    elif isinstance(polygon, trimesh.base.Trimesh):
        return len(polygon.faces) > 0 and all(
            trimesh.proximity.signed_distance(polygon, list(points)) >= 0
        )
    else:
        return False


@contextlib.contextmanager
def patched_alphashape() -> Iterator[Callable[..., float]]:
    """Install :func:`testalpha_shapely2` as alphashape's ``_testalpha``.

    Only the module attribute ``alphashape.optimizealpha._testalpha`` is
    replaced (and restored on exit); ``optimizealpha`` itself, its bounds,
    its stopping rule and ``alphashape.alphashape`` stay alphashape's code.

    Yields
    ------
    callable
        ``alphashape.optimizealpha.optimizealpha``.
    """
    module = importlib.import_module("alphashape.optimizealpha")
    original = module._testalpha
    module._testalpha = testalpha_shapely2
    try:
        yield module.optimizealpha
    finally:
        module._testalpha = original


def bisection_alpha(points: np.ndarray, max_iterations: int = 10000) -> PeerResult:
    """Run ``alphashape.optimizealpha`` (patched for shapely 2) on one group.

    Float bisection between 0 and ``sys.float_info.max`` until the bracket is
    narrower than ``2 * eps`` (absolute); about 1,075 builds when the optimum
    is below 4, and no convergence (it returns 0, the convex hull, after
    ``max_iterations``) when the optimum is 4 or more.

    Parameters
    ----------
    points : numpy.ndarray
        ``(n, 2)`` distinct points of the group.
    max_iterations : int, default 10000
        alphashape's own default.

    Returns
    -------
    PeerResult
        The returned alpha and the number of shape builds.
    """
    with patched_alphashape() as optimizealpha:
        _COUNTER.n = 0
        try:
            alpha = optimizealpha(points, max_iterations=max_iterations, silent=True)
        except Exception as err:  # a peer failing is a result, not a crash
            return PeerResult(float("nan"), _COUNTER.n, f"{type(err).__name__}: {err}")
        return PeerResult(float(alpha), _COUNTER.n)


def ladder_alpha(points: np.ndarray, ladder: Sequence[int] = LADDER) -> PeerResult:
    """Run the seed paper's integer ladder search on one group.

    Test the rungs of ``ladder`` from the top; at the first rung that passes
    (``lo``), bisect on integers between it and the rung above (``hi``, which
    failed): ``while hi - lo > 1: mid = (lo + hi) // 2``. Each test is an
    alphashape build with the patched validity test of
    :func:`testalpha_shapely2` (one Polygon intersecting every point).

    Parameters
    ----------
    points : numpy.ndarray
        ``(n, 2)`` distinct points of the group.
    ladder : sequence of int, default :data:`LADDER`
        Descending alphas; the last one should be 0 (convex hull).

    Returns
    -------
    PeerResult
        The integer alpha found (0 if no rung passes) and the build count.
    """
    _COUNTER.n = 0
    try:
        for i, rung in enumerate(ladder):
            if not testalpha_shapely2(points, rung):
                continue
            if i == 0:  # the top rung passes: nothing above it to bisect
                return PeerResult(float(rung), _COUNTER.n)
            lo, hi = int(rung), int(ladder[i - 1])
            while hi - lo > 1:
                mid = (lo + hi) // 2
                if testalpha_shapely2(points, mid):
                    lo = mid
                else:
                    hi = mid
            return PeerResult(float(lo), _COUNTER.n)
    except Exception as err:
        return PeerResult(float("nan"), _COUNTER.n, f"{type(err).__name__}: {err}")
    return PeerResult(0.0, _COUNTER.n)


def libpysal_alpha(points: np.ndarray) -> PeerResult:
    """Run ``libpysal.cg.alpha_shape_auto`` on one group.

    libpysal returns the circumradius ``r`` (metres) of the last triangle it
    could drop; its shape keeps the triangles with radius ``< 1/alpha`` where
    ``alpha = 1/r - eps``, i.e. radius ``<= r``. So ``1/r`` is on the same
    1/metre scale as alphashape's and geoalpha's alpha. Its validity test
    (``polygonize`` of the boundary edges gives exactly one polygon covering
    every point) rejects shapes with holes, since a hole ring polygonizes to a
    second polygon. Builds are counted by wrapping libpysal's private
    ``_alpha_geoms`` (one Python call per build, negligible next to a build).

    Parameters
    ----------
    points : numpy.ndarray
        ``(n, 2)`` distinct points of the group.

    Returns
    -------
    PeerResult
        ``alpha = 1 / radius`` and the number of shape builds.
    """
    from libpysal.cg import alpha_shapes as module

    original = module._alpha_geoms
    counter = _Counter()

    def counted(*args, **kwargs):
        counter.n += 1
        return original(*args, **kwargs)

    module._alpha_geoms = counted
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # "Numba not imported ..."
            _, radius = module.alpha_shape_auto(
                np.asarray(points, dtype=float), return_radius=True
            )
    except Exception as err:
        return PeerResult(float("nan"), counter.n, f"{type(err).__name__}: {err}")
    finally:
        module._alpha_geoms = original
    alpha = 1.0 / radius if radius > 0 else float("inf")
    return PeerResult(float(alpha), counter.n)


def delaunay_floor(groups: Sequence[np.ndarray]) -> int:
    """Triangulate every group with ``scipy.spatial.Delaunay`` in a Python loop.

    Groups that cannot be triangulated (fewer than 3 points, or collinear)
    are skipped, as any per-group method would have to.

    Parameters
    ----------
    groups : sequence of numpy.ndarray
        One ``(n_i, 2)`` array of distinct points per group.

    Returns
    -------
    int
        The total number of triangles (so the work cannot be optimised away).
    """
    from scipy.spatial import Delaunay, QhullError

    triangles = 0
    for xy in groups:
        if len(xy) < 3:
            continue
        try:
            triangles += len(Delaunay(xy).simplices)
        except QhullError:
            continue
    return triangles
