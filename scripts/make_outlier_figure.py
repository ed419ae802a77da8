"""Draw the README's outliers figure: state hulls of US airports, 0 vs 2 % out.

Left: ``airports.alpha.hull(by="state")`` (every airport inside its state's
polygon); right: ``hull(by="state", outliers=0.02)`` with the airports left
out (``geoalpha.outlier_rows``) drawn as red crosses. Contiguous US, in the
CONUS Albers equal-area CRS; drawing helpers from ``make_figure.py``.

Usage::

    python scripts/make_outlier_figure.py          # writes docs/outliers.png
    python scripts/make_outlier_figure.py -o out.png
"""

from __future__ import annotations

import argparse
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
OUTLIERS = 0.02


def panel(ax, points, outliers: float) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", geoalpha.GeoAlphaWarning)
        hulls = points.alpha.hull(by="state", outliers=outliers)
        left_out = geoalpha.outlier_rows(points, by="state", outliers=outliers)
    inside = hulls.within(shapely.box(*CONUS)) & (hulls["n_points"] >= 3)
    hulls = hulls[inside]
    shown = points["state"].isin(hulls["state"])
    kept = points[shown & ~left_out].to_crs(ALBERS)
    out = points[shown & left_out].to_crs(ALBERS)
    hulls = hulls.to_crs(ALBERS)
    ratio = hulls["area_m2"].sum()
    draw(
        ax,
        kept,
        hulls,
        gap=60_000.0,
        point_size=1.5,
        title=(
            f"outliers={outliers}: "
            + ("every airport inside" if not outliers else "up to 2 % per state out")
        ),
        note=(
            f"{len(hulls)} states, total hull area {ratio / 1e12:.2f} million km²"
            + (f"\n{len(out)} airports left out (red)" if len(out) else "")
        ),
    )
    if len(out):
        out.plot(ax=ax, color="#D00000", marker="x", markersize=28, zorder=5)
    room_below(ax, 0.1)
    scale_bar(ax, 500_000.0, "500 km")


def main(argv: list[str] | None = None) -> Path:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "-o", "--out", type=Path, default=ROOT / "docs" / "outliers.png"
    )
    args = parser.parse_args(argv)
    points = datasets.load("us_airports")
    points = points[points["state"].notna()]
    plt.rcParams.update({"font.family": "DejaVu Sans", "figure.dpi": 100})
    fig, axes = plt.subplots(1, 2, figsize=(14, 5.6), gridspec_kw={"wspace": 0.04})
    fig.subplots_adjust(left=0.01, right=0.99, bottom=0.02, top=0.85)
    for ax, outliers in zip(axes, (0, OUTLIERS), strict=True):
        panel(ax, points, outliers)
    fig.suptitle(
        "US airports by state: exact optimal hulls with and without stray points "
        '(gdf.alpha.hull(by="state", outliers=0.02))',
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
