"""Draw the neighbours figure: state hulls of US airports, overlap keep vs split.

Left: ``airports.alpha.hull(by="state")``: states' hulls overlap where states
interleave (the darker areas); right: ``hull(by="state", overlap="split")``:
each overlap given to the state of the nearest airport, so that no hull
overlaps another and every airport stays in its own state's polygon.
Contiguous US, in the CONUS Albers equal-area CRS; drawing helpers from
``make_figure.py``.

Usage::

    python scripts/make_overlap_figure.py          # writes docs/overlap.png
    python scripts/make_overlap_figure.py -o out.png
"""

from __future__ import annotations

import argparse
import itertools
import sys
import warnings
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import shapely

sys.path.insert(0, str(Path(__file__).resolve().parent))
from make_figure import CONUS, ROOT, draw, room_below, scale_bar

import geoalpha
from geoalpha import datasets

ALBERS = "EPSG:5070"  # CONUS Albers equal-area


def counts(hulls, points) -> tuple[int, int]:
    """Pairs of hulls that overlap, and airports strictly inside another's hull."""
    geoms = list(hulls.geometry)
    pairs = sum(a.intersection(b).area > 0 for a, b in itertools.combinations(geoms, 2))
    own = dict(zip(hulls["state"], geoms, strict=True))
    foreign = sum(
        any(
            key != state and shapely.contains_properly(poly, p)
            for key, poly in own.items()
        )
        for state, p in zip(points["state"], points.geometry, strict=True)
    )
    return pairs, foreign


def panel(ax, points, overlap: str) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", geoalpha.GeoAlphaWarning)
        hulls = points.alpha.hull(by="state", overlap=overlap)
    pairs, foreign = counts(hulls, points)
    inside = hulls.within(shapely.box(*CONUS)) & (hulls["n_points"] >= 3)
    hulls = hulls[inside].to_crs(ALBERS)
    shown = points[points["state"].isin(hulls["state"])].to_crs(ALBERS)
    draw(
        ax,
        shown,
        hulls,
        gap=60_000.0,
        point_size=1.5,
        title=f'overlap="{overlap}"',
        note=(
            f"{pairs} pairs of states' hulls overlap; {foreign} airports strictly "
            "inside another state's hull"
        ),
    )
    room_below(ax, 0.1)
    scale_bar(ax, 500_000.0, "500 km")


def main(argv: list[str] | None = None) -> Path:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-o", "--out", type=Path, default=ROOT / "docs" / "overlap.png")
    args = parser.parse_args(argv)
    points = datasets.load("us_airports")
    points = points[points["state"].notna()]
    plt.rcParams.update({"font.family": "DejaVu Sans", "figure.dpi": 100})
    fig, axes = plt.subplots(1, 2, figsize=(14, 5.6), gridspec_kw={"wspace": 0.04})
    fig.subplots_adjust(left=0.01, right=0.99, bottom=0.02, top=0.85)
    for ax, overlap in zip(axes, ("keep", "split"), strict=True):
        panel(ax, points, overlap)
    fig.suptitle(
        "US airports by state: neighbours' hulls kept overlapping or split by the "
        'nearest airport (gdf.alpha.hull(by="state", overlap="split"))',
        fontsize=14,
        x=0.015,
        ha="left",
        y=0.965,
    )
    for ax in axes:
        ax.set_anchor("N")
        fig.text(
            ax.get_position(original=True).x0 + 0.005,
            0.87,
            ax.get_gid(),
            fontsize=13,
            ha="left",
            va="bottom",
        )
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=100, facecolor="white")
    return args.out


if __name__ == "__main__":
    print(main())
