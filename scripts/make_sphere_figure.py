"""Draw the sphere page's figure: a continent-scale group done both ways.

The airports of the 48 contiguous US states (bundled US airports) as one
group, with ``crs="auto"`` (a local Lambert azimuthal equal-area CRS for the
group) and ``crs="sphere"`` (no projection), drawn in longitude/latitude.

Usage::

    python scripts/make_sphere_figure.py     # writes docs/sphere.png
"""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt

import geoalpha
from geoalpha import datasets

#: Not in the contiguous 48 states.
AWAY = {"AK", "HI", "PR", "GU", "VI", "AS", "MP", "CQ"}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "-o", "--output", default=Path(__file__).parents[1] / "docs/sphere.png"
    )
    args = parser.parse_args()
    points = datasets.load("us_airports").dropna(subset=["state"])
    lower48 = points[~points["state"].isin(AWAY)].assign(country="USA")
    fig, axes = plt.subplots(1, 2, figsize=(11, 3.9), dpi=90, sharey=True)
    for ax, crs in zip(axes, ("auto", "sphere"), strict=True):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            hull = geoalpha.hull(lower48, by="country", crs=crs)
        hull.plot(ax=ax, color="tab:blue", alpha=0.35, edgecolor="tab:blue")
        lower48.plot(ax=ax, color="black", markersize=1)
        row = hull.iloc[0]
        ax.set_title(
            f'crs="{crs}": radius {row["radius"] / 1e3:,.0f} km, '
            f"{row['area_m2'] / 1e6:,.0f} km²",
            fontsize=10,
        )
        ax.set_xlabel("longitude")
    axes[0].set_ylabel("latitude")
    axes[1].set_ylabel("")
    fig.tight_layout()
    fig.savefig(args.output)
    print(f"Wrote {args.output}")


if __name__ == "__main__":
    main()
