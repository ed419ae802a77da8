"""The tables of ``explain()`` and ``curve()``: why each group got its radius.

Both read what :func:`~.pipeline.run_all` made (the kernel's
:class:`~geoalpha.kernel.Why`), one row per group or per group and ``k``
(:doc:`/user_guide/why`).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import shapely

from geoalpha import kernel
from geoalpha.errors import OutlierWarning, first_n, setting, spelled, warn_user
from geoalpha.frame.pipeline import Ran

__all__ = ["CURVE_COLUMNS", "EXPLAIN_COLUMNS", "curve_table", "explain_table"]

#: Columns of :func:`geoalpha.explain` after the group keys (then ``geometry``).
EXPLAIN_COLUMNS = (
    "radius",
    "alpha",
    "limited_by",
    "critical_rows",
    "radius_without_1",
    "area_m2_without_1",
    "rows_without_1",
    "suspicious",
)
#: Columns of :func:`geoalpha.curve` after the group keys.
CURVE_COLUMNS = ("k", "radius", "alpha", "area_m2", "n_parts", "left_out")


def _kept(ran: Ran) -> np.ndarray:
    """Return the codes of the groups with a row in the hull table, in its order."""
    keep = ran.hulls.keep
    n = ran.groups.n_groups
    return np.arange(n) if keep is None else np.flatnonzero(keep)


def _keys(ran: Ran, kept: np.ndarray, repeat=None) -> dict:
    columns = (np.asarray(c)[kept] for c in ran.groups.columns)
    if repeat is not None:
        columns = (np.repeat(c, repeat) for c in columns)
    return dict(zip(ran.groups.names, columns, strict=True))


def _labels(ran: Ran, positions) -> list:
    """Index labels of points by position (a list, in the given order)."""
    positions = np.asarray(positions, dtype=np.int64)
    return list(ran.points.labels[positions]) if len(positions) else []


def explain_table(ran: Ran):
    """Build :func:`geoalpha.explain`'s GeoDataFrame from a run with ``explain``."""
    import geopandas as gpd

    hulls, why = ran.hulls, ran.hulls.why
    kept = _kept(ran)
    alt = why.alternatives
    first = {}  # group -> its k = 1 alternative
    for i in np.flatnonzero(alt.k == 1):
        first.setdefault(int(alt.group[i]), i)
    last, last_offsets = why.last
    limited, critical, geometry = [], [], []
    radius_1 = np.full(len(kept), np.nan)
    area_1 = np.full(len(kept), np.nan)
    rows_1 = []
    # area_m2 of a hull is geodesic, the kernel's planar: scale the alternative
    # by the group's ratio of the two (the CRS's areal scale where it is).
    with np.errstate(divide="ignore", invalid="ignore"):
        scale = np.where(ran.planar_area > 0, hulls.area / ran.planar_area, 1.0)
    for j, g in enumerate(kept):
        degenerate = bool(hulls.degenerate[g])
        code = int(why.limited_by[g])
        limited.append("degenerate" if degenerate else kernel.LIMITED_BY[code])
        corners = why.critical[g]
        if degenerate or corners[0] < 0:
            critical.append([])
            geometry.append(None)
        else:
            extra = list(last[last_offsets[g] : last_offsets[g + 1]])
            critical.append(_labels(ran, list(corners) + extra))
            ring = ran.points.coords[corners]
            geometry.append(shapely.Polygon(ring))
        i = first.get(int(g))
        if i is None or degenerate:
            rows_1.append([])
            continue
        radius_1[j] = alt.radius[i]
        area_1[j] = alt.area[i] * scale[g]
        rows_1.append(_labels(ran, alt.left_out(i)))
    table = ran.table
    values = {
        "radius": table["radius"].to_numpy(),
        "alpha": table["alpha"].to_numpy(),
        "limited_by": limited,
        "critical_rows": critical,
        "radius_without_1": radius_1,
        "area_m2_without_1": area_1,
        "rows_without_1": rows_1,
        "suspicious": np.asarray(why.suspicious, dtype=bool)[kept]
        & ~np.asarray(hulls.degenerate, dtype=bool)[kept],
    }
    frame = pd.DataFrame({**_keys(ran, kept), **values})
    return gpd.GeoDataFrame(frame, geometry=geometry, crs=ran.points.crs)


def curve_table(ran: Ran, max_left_out: int, unit: str):
    """Build :func:`geoalpha.curve`'s DataFrame from a run with ``max_left_out``."""
    hulls, alt = ran.hulls, ran.hulls.why.alternatives
    kept = [g for g in _kept(ran) if not hulls.degenerate[g]]
    by_group: dict[int, list[int]] = {}
    for i in range(len(alt.k)):
        by_group.setdefault(int(alt.group[i]), []).append(i)
    table = ran.table.set_index(np.asarray(_kept(ran)))
    columns = {c: [] for c in CURVE_COLUMNS}
    sizes, short = [], []
    for g in kept:
        radius = float(table.at[g, "radius"])
        rows = [(0, radius, float(table.at[g, "alpha"]), ran.planar_area[g])]
        rows[0] += (int(table.at[g, "n_parts"]), [])
        for i in by_group.get(g, []):
            r = float(alt.radius[i])
            left = _labels(ran, alt.left_out(i))
            rows.append(
                (int(alt.k[i]), r, 1.0 / r, alt.area[i], int(alt.n_parts[i]), left)
            )
        if len(rows) - 1 < max_left_out:
            short.append((g, len(rows) - 1))
        for row in rows:
            for name, value in zip(CURVE_COLUMNS, row, strict=True):
                columns[name].append(value)
        sizes.append(len(rows))
    with np.errstate(divide="ignore", invalid="ignore"):
        scale = np.where(ran.planar_area > 0, hulls.area / ran.planar_area, 1.0)
    owner = np.repeat(np.asarray(kept, dtype=np.int64), sizes)
    columns["area_m2"] = np.asarray(columns["area_m2"], dtype=float) * scale[owner]
    if short:
        columns_of = ran.groups.columns
        shown = first_n(
            f"{', '.join(str(c[g]) for c in columns_of) or 'all points'} ({n})"
            for g, n in short
        )
        warn_user(
            f"{spelled('curve()')}: {len(short)} group(s) have fewer {unit} than "
            f"{setting('max_left_out', max_left_out)} leaves a shape for (at least "
            f"3 locations stay); their curves stop earlier (largest k): {shown}",
            OutlierWarning,
        )
    frame = pd.DataFrame(
        {**_keys(ran, np.asarray(kept, dtype=np.int64), sizes), **columns}
    )
    frame["k"] = frame["k"].astype("int64")
    frame["n_parts"] = frame["n_parts"].astype("int64")
    return frame
