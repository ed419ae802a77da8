"""The table :func:`geoalpha.hull` returns, defined once.

One row per group: the key column(s), :data:`RESULT_COLUMNS`, ``geometry``;
:func:`empty_result` (dask's ``meta``) is made by the same code.
"""

from __future__ import annotations

from collections.abc import Mapping
from functools import cache
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import pandas as pd

# numpy and pandas are imported where they are used: the command's --help
# lists RESULT_COLUMNS and stays free of heavy imports.

__all__ = [
    "DTYPES",
    "RESULT_COLUMNS",
    "SPLIT_DTYPES",
    "empty_result",
    "planar_unit",
    "result_columns",
    "result_frame",
    "result_geometry_name",
    "with_area_unit",
]

#: Result columns after the group keys (then ``geometry``), and their dtypes
#: ("text": pandas' default string dtype, ``str`` with pandas 3).
DTYPES: dict[str, str] = {
    "alpha": "float64",
    "radius": "float64",
    "n_points": "int64",
    "n_outliers": "int64",
    "n_parts": "int32",
    "area_m2": "float64",
    "crs_used": "text",
    "method": "text",
}
#: Columns :func:`geoalpha.hull` adds next to the group keys (then ``geometry``).
RESULT_COLUMNS: tuple[str, ...] = tuple(DTYPES)
#: Columns ``overlap="split"`` adds after :data:`RESULT_COLUMNS`: the area each
#: group gave to its neighbours (m², as ``area_m2``) and the number of groups
#: whose polygon shares a boundary line with its own.
SPLIT_DTYPES: dict[str, str] = {"area_ceded_m2": "float64", "neighbours": "int64"}


def result_columns(overlap: str = "keep") -> tuple[str, ...]:
    """Return the result columns after the group keys for an ``overlap`` option.

    Examples
    --------
    >>> result_columns("split")[-3:]
    ('method', 'area_ceded_m2', 'neighbours')
    """
    return RESULT_COLUMNS + (tuple(SPLIT_DTYPES) if overlap == "split" else ())


@cache
def _text_dtype():
    """Return the dtype of "text": ``str`` (pandas 3) or object, as pandas infers."""
    import numpy as np
    import pandas as pd

    return pd.Series(np.array([""], dtype=object)).dtype


def planar_unit(input_crs, crs) -> str | None:
    """Return the unit of a planar computation (``crs=None``) unless it is metres.

    Parameters
    ----------
    input_crs, crs : CRS or None
        The CRS of the input points and the ``crs`` option of :func:`geoalpha.hull`.

    Returns
    -------
    str or None
        ``"coordinate unit"`` without CRS, else the first axis' unit; None for metres.

    Examples
    --------
    >>> planar_unit(None, None), planar_unit("EPSG:4326", None)
    ('coordinate unit', 'degree')
    >>> planar_unit("EPSG:4326", "auto") is None, planar_unit("EPSG:32630", None)
    (True, None)
    """
    if crs is not None:
        return None
    if input_crs is None:
        return "coordinate unit"
    from pyproj import CRS

    info = CRS.from_user_input(input_crs).axis_info
    unit = info[0].unit_name if info else "unit"
    return None if unit == "metre" else unit


def with_area_unit(table, unit: str | None):
    """Write ``area`` and ``unit`` instead of ``area_m2`` when ``unit`` is given.

    (and ``area_ceded`` instead of ``area_ceded_m2``, with ``overlap="split"``).

    Parameters
    ----------
    table : geopandas.GeoDataFrame
        A result of :func:`geoalpha.hull`.
    unit : str or None
        From :func:`planar_unit`; None returns ``table`` as it is.

    Returns
    -------
    geopandas.GeoDataFrame
    """
    if unit is None or "area_m2" not in table.columns:  # (already done)
        return table
    table = table.rename(columns={"area_m2": "area", "area_ceded_m2": "area_ceded"})
    table.insert(list(table.columns).index("area") + 1, "unit", unit)
    return table


def result_geometry_name(frame, keys) -> str:
    """Name the result's geometry column after the input's (``geom`` stays ``geom``).

    ``geometry`` if a group key (``keys``: a table or names) or result column has it.

    Examples
    --------
    >>> import geopandas as gpd, pandas as pd
    >>> frame = gpd.GeoDataFrame(geometry=gpd.GeoSeries([])).rename_geometry("geom")
    >>> result_geometry_name(frame, pd.DataFrame({"g": []}))
    'geom'
    """
    import pandas as pd

    name = frame._geometry_column_name  # frame.geometry.name builds a GeoSeries
    taken = keys.columns if isinstance(keys, pd.DataFrame) else keys
    if not isinstance(name, str) or name in taken or name in RESULT_COLUMNS:
        return "geometry"
    return name


def result_frame(
    keys: pd.DataFrame | Mapping[Any, Any],
    values: dict[str, Any],
    geometry,
    crs,
    geometry_name: str = "geometry",
):
    """Build the result table: ``keys``, then :data:`RESULT_COLUMNS` from ``values``.

    Parameters
    ----------
    keys : pandas.DataFrame or mapping
        One row per group: the key column(s) (none for one group), by name.
    values : dict
        One array per name of :data:`RESULT_COLUMNS`, cast to :data:`DTYPES`;
        with ``overlap="split"`` also those of :data:`SPLIT_DTYPES`.
    geometry, crs : array_like of shapely geometries, CRS or None
        One per group, and their CRS.
    geometry_name : str, default "geometry"
        Name of the geometry column (:func:`result_geometry_name`).

    Returns
    -------
    geopandas.GeoDataFrame
        With a fresh RangeIndex.
    """
    import geopandas as gpd
    import numpy as np
    import pandas as pd

    # One DataFrame from whole columns (one by one costs several times more).
    if isinstance(keys, pd.DataFrame):
        keys = {name: keys.iloc[:, i].array for i, name in enumerate(keys.columns)}
    columns = dict(keys)
    extra = {name: t for name, t in SPLIT_DTYPES.items() if name in values}
    for name, dtype in {**DTYPES, **extra}.items():
        if dtype == "text":
            text = np.asarray(values[name], dtype=object)
            columns[name] = pd.array(text, dtype=_text_dtype())
        else:
            columns[name] = np.asarray(values[name]).astype(dtype, copy=False)
    geoms = np.asarray(geometry, dtype=object).reshape(-1)
    columns[geometry_name] = gpd.array.from_shapely(geoms, crs=crs)
    # GeoDataFrame(columns, geometry=geometry_name) without a second copy:
    frame = pd.DataFrame(columns, copy=False)
    from_mgr = getattr(gpd.GeoDataFrame, "_from_mgr", None)
    if from_mgr is None:  # pragma: no cover - pandas < 2.1 (Debian 12's QGIS)
        return gpd.GeoDataFrame(frame, geometry=geometry_name, copy=False)
    out = from_mgr(frame._mgr, frame._mgr.axes)
    out._geometry_column_name = geometry_name
    return out


def empty_result(
    keys: pd.DataFrame, crs, geometry_name: str = "geometry", overlap: str = "keep"
):
    """Build the result table with no row (dask's ``meta``): same columns and dtypes.

    ``overlap``: that option of :func:`geoalpha.hull` (``"split"`` adds columns).

    Examples
    --------
    >>> import pandas as pd
    >>> meta = empty_result(pd.DataFrame({"g": pd.Series([], dtype=object)}), None)
    >>> len(meta), meta.columns.tolist()[:3], str(meta.dtypes["n_parts"])
    (0, ['g', 'alpha', 'radius'], 'int32')
    """
    values = {name: [] for name in result_columns(overlap)}  # (cast there)
    return result_frame(keys.iloc[:0], values, [], crs, geometry_name)
