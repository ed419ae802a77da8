"""Draw the README figure: optimal alpha-shape hulls over their points.

Two panels from the bundled data: STATS19 road accidents in London by highway
authority (with their convex hulls for comparison) and US airports by state
(contiguous US). Every hull is ``gdf.alpha.hull(by=...)``
with the defaults (exact optimal alpha, holes filled, one polygon per group).

Usage::

    python scripts/make_figure.py            # writes docs/hulls.png
    python scripts/make_figure.py -o out.png
"""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import geopandas as gpd
import matplotlib.pyplot as plt
import numpy as np
import shapely
from matplotlib.patches import Patch

import geoalpha
from geoalpha import datasets

ROOT = Path(__file__).resolve().parents[1]
#: Inner London, British National Grid metres.
LONDON = (522_700.0, 176_400.0, 534_300.0, 183_100.0)
#: Contiguous US, lon/lat.
CONUS = (-125.0, 24.0, -66.5, 49.5)
#: Colourblind-friendly qualitative palette (Okabe-Ito, without black/yellow).
PALETTE = ["#0072B2", "#E69F00", "#009E73", "#CC79A7", "#D55E00", "#56B4E9"]
POINT_COLOUR = "#1a1a1a"
#: Names of the highway authorities (ONS codes) in the London panel.
LONDON_NAMES = {
    "E09000001": "City of London",
    "E09000007": "Camden",
    "E09000013": "Hammersmith and Fulham",
    "E09000020": "Kensington and Chelsea",
    "E09000030": "Tower Hamlets",
    "E09000033": "Westminster",
}


def colours(hulls: gpd.GeoDataFrame, gap: float) -> list[str]:
    """Greedy colouring: hulls closer than ``gap`` get different colours."""
    near = shapely.STRtree(hulls.geometry.to_numpy()).query(
        hulls.geometry.to_numpy(), predicate="dwithin", distance=gap
    )
    neighbours: dict[int, set[int]] = {i: set() for i in range(len(hulls))}
    for i, j in near.T:
        if i != j:
            neighbours[int(i)].add(int(j))
    chosen: dict[int, int] = {}
    count = [0] * len(PALETTE)
    for i in sorted(neighbours, key=lambda k: -len(neighbours[k])):
        used = {chosen[j] for j in neighbours[i] if j in chosen}
        free = [c for c in range(len(PALETTE)) if c not in used] or list(
            range(len(PALETTE))
        )
        chosen[i] = min(free, key=lambda c: count[c])  # balance the colours
        count[chosen[i]] += 1
    return [PALETTE[chosen[i]] for i in range(len(hulls))]


def draw(ax, points, hulls, *, gap, point_size, title, note) -> list[str]:
    """Hulls (filled, outlined), points on top, title and a note; the colours."""
    fill = colours(hulls, gap)
    hulls.plot(
        ax=ax,
        color=fill,
        alpha=0.45,
        edgecolor="none",
        zorder=1,
    )
    hulls.boundary.plot(ax=ax, color=fill, linewidth=1.0, zorder=2)
    points.plot(ax=ax, color=POINT_COLOUR, markersize=point_size, zorder=3)
    ax.set_gid(title)  # the figure writes the panel titles (aligned)
    ax.text(
        0.01,
        0.01,
        note,
        transform=ax.transAxes,
        fontsize=9.5,
        color="#333333",
        va="bottom",
        bbox={"facecolor": "white", "edgecolor": "none", "alpha": 0.8, "pad": 3},
        zorder=4,
    )
    ax.set_axis_off()
    ax.set_aspect("equal")
    return fill


def room_below(ax, share: float) -> None:
    """Extend the y range downwards so that the note does not hide data."""
    y0, y1 = ax.get_ylim()
    ax.set_ylim(y0 - share * (y1 - y0), y1)


def scale_bar(ax, length_m: float, label: str) -> None:
    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    x = x1 - (x1 - x0) * 0.04 - length_m
    y = y0 + (y1 - y0) * 0.04
    ax.plot([x, x + length_m], [y, y], color="#333333", linewidth=2.5, zorder=5)
    ax.text(
        x + length_m / 2,
        y + (y1 - y0) * 0.012,
        label,
        ha="center",
        va="bottom",
        fontsize=9.5,
        zorder=5,
    )


def london_panel(ax) -> None:
    points = datasets.load("stats19")
    by = "Local_Authority_(Highway)"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", geoalpha.DegenerateGroupWarning)
        hulls = points.alpha.hull(by=by, degenerate="drop")
    # Draw in the British National Grid so that metres look like metres.
    bng = "EPSG:27700"
    hulls, points = hulls.to_crs(bng), points.to_crs(bng)
    hulls = hulls[hulls.intersects(shapely.box(*LONDON))]
    points = points[points[by].isin(hulls[by])]
    convex = points.dissolve(by=by).convex_hull
    convex.boundary.plot(
        ax=ax, color="#777777", linewidth=0.9, linestyle=(0, (4, 3)), zorder=0
    )
    fill = draw(
        ax,
        points,
        hulls,
        gap=200.0,
        point_size=3.0,
        title="Road accidents in London by highway authority",
        note=(
            f"{len(points):,} STATS19 accidents (2014) in {len(hulls)} local "
            "authorities\n"
            "filled: optimal alpha shape;  dashed: convex hull"
        ),
    )
    order = np.argsort(-hulls["n_points"].to_numpy())
    handles = [
        Patch(
            facecolor=fill[i],
            edgecolor=fill[i],
            alpha=0.6,
            label=f"{LONDON_NAMES.get(hulls[by].iloc[i], hulls[by].iloc[i])} "
            f"({hulls['n_points'].iloc[i]})",
        )
        for i in order
    ]
    ax.legend(
        handles=handles,
        loc="lower right",
        bbox_to_anchor=(1.0, 0.12),
        fontsize=9.5,
        frameon=False,
        title="highway authority (accidents)",
        title_fontsize=9.5,
    )
    ax.set_xlim(LONDON[0], LONDON[2])
    ax.set_ylim(LONDON[1], LONDON[3])
    room_below(ax, 0.12)
    scale_bar(ax, 1000.0, "1 km")


def airports_panel(ax) -> None:
    points = datasets.load("us_airports")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", geoalpha.GeoAlphaWarning)
        hulls = points.alpha.hull(by="state")
    inside = hulls.within(shapely.box(*CONUS)) & (hulls["n_points"] >= 3)
    hulls = hulls[inside]
    points = points[points["state"].isin(hulls["state"])]
    albers = "EPSG:5070"  # CONUS Albers equal-area
    hulls, points = hulls.to_crs(albers), points.to_crs(albers)
    draw(
        ax,
        points,
        hulls,
        gap=60_000.0,
        point_size=1.5,
        title="US airports by state, contiguous US",
        note=(
            f"{len(points):,} FAA airports; one hull per state "
            f"({len(hulls)} states)\n"
            "alpha computed in metres (local UTM zone or equal-area CRS)"
        ),
    )
    room_below(ax, 0.1)
    scale_bar(ax, 500_000.0, "500 km")


def main(argv: list[str] | None = None) -> Path:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-o", "--out", type=Path, default=ROOT / "docs" / "hulls.png")
    args = parser.parse_args(argv)

    plt.rcParams.update({"font.family": "DejaVu Sans", "figure.dpi": 100})
    fig, (left, right) = plt.subplots(
        1,
        2,
        figsize=(14, 6.0),
        gridspec_kw={"width_ratios": [1.0, 1.0], "wspace": 0.04},
    )
    fig.subplots_adjust(left=0.01, right=0.99, bottom=0.02, top=0.865)
    london_panel(left)
    airports_panel(right)
    fig.suptitle(
        "geoalpha: one tight polygon per group of points "
        "(exact optimal alpha shape, gdf.alpha.hull(by=...))",
        fontsize=15,
        x=0.015,
        ha="left",
        y=0.965,
    )
    for ax in (left, right):
        ax.set_anchor("N")  # both maps hang from the same line, under their title
        fig.text(
            ax.get_position(original=True).x0 + 0.005,
            0.88,
            ax.get_gid(),
            fontsize=13,
            ha="left",
            va="bottom",
        )
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=100, facecolor="white")
    plt.close(fig)
    size = args.out.stat().st_size
    print(f"wrote {args.out} ({size / 1024:.0f} KB)")
    return args.out


if __name__ == "__main__":
    main()
