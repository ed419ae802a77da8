"""Pictures of why each hull got its shape: the curve and the map (``[plot]`` extra).

:func:`plot_curve` draws :func:`geoalpha.curve`'s table as small multiples of
area against the number left out, the flagged groups first; :func:`plot_why`
draws the hulls, :func:`geoalpha.explain`'s critical triangles and the flagged
locations on one map (:doc:`/user_guide/why`).
"""

from __future__ import annotations

import math

__all__ = ["plot_curve", "plot_why"]


def _pyplot():
    try:
        import matplotlib.pyplot as plt
    except ImportError as err:
        raise ImportError(
            'geoalpha\'s plots need matplotlib: pip install "geoalpha[plot]"'
        ) from err
    return plt


def _key_columns(table, first: str) -> list[str]:
    """Return the group key columns: those before ``first`` (curve: ``k``)."""
    columns = list(table.columns)
    if first not in columns:
        from geoalpha.errors import InvalidInputError

        raise InvalidInputError(
            f"expected a table of geoalpha.curve() (with a column {first!r}); "
            f"got the columns {', '.join(map(str, columns))}"
        )
    return columns[: columns.index(first)]


def _name(key: tuple) -> str:
    if not key:
        return "all points"
    return ", ".join(map(str, key))


def _flagged_keys(why, keys: list[str]) -> set[tuple]:
    """Return the keys of the groups ``why`` (explain()'s table) flags."""
    if why is None:
        return set()
    missing = [k for k in (*keys, "suspicious") if k not in why.columns]
    if missing:
        from geoalpha.errors import InvalidInputError

        raise InvalidInputError(
            "why= must be geoalpha.explain()'s table of the same groups; it has "
            f"no column {', '.join(map(repr, missing))}"
        )
    flagged = why[why["suspicious"].to_numpy(dtype=bool)]
    return set(flagged[keys].itertuples(index=False, name=None))


def plot_curve(curve, why=None, *, max_groups: int = 24, columns: int = 4):
    """Small multiples of area against the number left out, one per group.

    The flagged groups (``why["suspicious"]``) come first, then the groups
    whose area falls most from ``k = 0`` to the largest ``k``.

    Parameters
    ----------
    curve : pandas.DataFrame
        The result of :func:`geoalpha.curve`.
    why : GeoDataFrame, optional
        The result of :func:`geoalpha.explain` for the same groups: its
        flagged groups are drawn first, titled "(flagged)".
    max_groups : int, default 24
        Draw at most this many groups (the title says how many of how many).
    columns : int, default 4
        Plots per row.

    Returns
    -------
    matplotlib.figure.Figure
        One axes per group drawn, in order, titled with the group's key.

    Raises
    ------
    ImportError
        Without matplotlib (``pip install "geoalpha[plot]"``).
    InvalidInputError
        ``curve`` is not a table of :func:`geoalpha.curve`; ``why`` lacks its
        key columns.

    .. versionadded:: 0.3.0

    Examples
    --------
    >>> import geoalpha
    >>> from geoalpha import datasets
    >>> points = datasets.load("us_airports")
    >>> some = points[points["state"].isin(["CO", "RI", "UT"])]
    >>> table = geoalpha.curve(some, by="state", max_left_out=3)
    >>> fig = geoalpha.plot_curve(table)
    >>> len(fig.axes), sorted(ax.get_title() for ax in fig.axes)
    (3, ['CO', 'RI', 'UT'])
    """
    plt = _pyplot()
    keys = _key_columns(curve, "k")
    flagged = _flagged_keys(why, keys)
    # planar areas not in metres (crs=None): ``area`` in square ``unit``
    column = "area_m2" if "area_m2" in curve.columns else "area"
    groups = []
    for key, rows in curve.groupby(keys, sort=False) if keys else [((), curve)]:
        key = key if isinstance(key, tuple) else (key,)
        rows = rows.sort_values("k")
        area = rows[column].to_numpy(dtype=float)
        drop = 1 - area[-1] / area[0] if area.size and area[0] > 0 else 0.0
        groups.append((key not in flagged, -drop, _name(key), rows))
    groups.sort(key=lambda g: g[:3])
    shown = groups[: max(int(max_groups), 1)]
    n = len(shown)
    ncols = max(1, min(int(columns), n))
    nrows = max(1, math.ceil(n / ncols))
    fig, axes = plt.subplots(
        nrows, ncols, figsize=(3.2 * ncols, 2.6 * nrows), squeeze=False
    )
    big = bool(n) and max(g[3][column].max() for g in shown) >= 1e6
    scale, unit = (1e-6, "km²") if big else (1.0, "m²")
    if column == "area":
        scale, unit = 1.0, f"{curve['unit'].iloc[0] if len(curve) else 'unit'}²"
    for ax, (not_flagged, _, name, rows) in zip(axes.flat, shown, strict=False):
        ax.plot(rows["k"], rows[column] * scale, marker="o", color="C0")
        ax.set_title(name + ("" if not_flagged else " (flagged)"))
        if not not_flagged:
            ax.title.set_color("C3")
        ax.set_xticks(rows["k"].to_numpy())
        ax.set_xlabel("left out (k)")
        ax.set_ylabel(f"area ({unit})")
        ax.set_ylim(bottom=0)
    for ax in axes.flat[n:]:
        fig.delaxes(ax)
    title = f"Area against the number left out, {len(groups)} group(s)"
    if len(groups) > n:
        title += f" ({n} shown)"
    if flagged:
        title += f"; {len(flagged)} flagged, first"
    fig.suptitle(title)
    fig.tight_layout()
    return fig


def plot_why(why, hulls=None, points=None, *, ax=None):
    """Draw the hulls, their critical triangles and the flagged locations.

    Parameters
    ----------
    why : GeoDataFrame
        The result of :func:`geoalpha.explain`: its critical triangles, red.
    hulls : GeoDataFrame, optional
        The result of :func:`geoalpha.hull` with the same options, light blue.
    points : GeoDataFrame, optional
        The input points, grey. The location each flagged group's warning
        names (the first row of its ``rows_without_1``) is drawn as a red
        cross labelled with the group; without ``points`` the title says how
        many were not drawn.
    ax : matplotlib.axes.Axes, optional
        Draw there; by default on a new figure.

    Returns
    -------
    matplotlib.figure.Figure

    Raises
    ------
    ImportError
        Without matplotlib (``pip install "geoalpha[plot]"``).
    InvalidInputError
        ``why`` is not a table of :func:`geoalpha.explain`.

    .. versionadded:: 0.3.0

    Examples
    --------
    >>> import geoalpha
    >>> from geoalpha import datasets
    >>> points = datasets.load("us_airports")
    >>> some = points[points["state"].isin(["CO", "RI", "UT"])]
    >>> hulls = geoalpha.hull(some, by="state")
    >>> why = geoalpha.explain(some, by="state")
    >>> fig = geoalpha.plot_why(why, hulls, some)
    >>> fig.axes[0].get_title()
    '3 hulls, their critical triangles and 0 flagged locations'
    """
    plt = _pyplot()
    keys = _key_columns(why, "radius")
    if ax is None:
        fig, ax = plt.subplots(figsize=(8, 8))
    else:
        fig = ax.figure
    if hulls is not None and len(hulls):
        hulls.plot(ax=ax, color="#9ecae1", edgecolor="#3182bd", linewidth=0.6)
    if points is not None and len(points):
        points.plot(ax=ax, color="0.35", markersize=2)
    triangles = why[~why.geometry.isna()]
    if len(triangles):
        triangles.plot(ax=ax, facecolor="none", edgecolor="C3", linewidth=1.2)
    flagged = why[why["suspicious"].to_numpy(dtype=bool)]
    drawn = 0
    for row in flagged.itertuples(index=False) if points is not None else ():
        values = dict(zip(flagged.columns, row, strict=True))
        labels = [label for label in values["rows_without_1"] if label in points.index]
        if not labels:
            continue
        spot = points.geometry.loc[labels[0]]
        ax.plot(spot.x, spot.y, marker="x", color="C3", markersize=12, mew=2.5)
        ax.annotate(
            f"{_name(tuple(values[k] for k in keys))}: {len(labels)} row(s)",
            (spot.x, spot.y),
            xytext=(6, 6),
            textcoords="offset points",
            color="C3",
        )
        drawn += 1
    n = len(flagged)
    title = (
        f"{len(why)} hulls, their critical triangles and {n} flagged "
        f"location{'s' if n != 1 else ''}"
    )
    if drawn < n:
        title += f" ({n - drawn} not drawn: pass points=)"
    ax.set_title(title)
    return fig
