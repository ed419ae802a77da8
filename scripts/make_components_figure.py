"""Draw the README figure on islands: one polygon, or one per island.

Hawaii's 16 airports (bundled US airports) with ``components=1`` (the default:
one polygon, so it bridges the sea between islands) and ``components=4`` (up
to four pieces: the islands apart). Same command line: ``geoalpha hull ...
--by state --components 4``.

Usage::

    python scripts/make_components_figure.py     # writes docs/components.png
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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "-o", "--output", default=Path(__file__).parents[1] / "docs/components.png"
    )
    args = parser.parse_args()
    points = datasets.load("us_airports")
    hawaii = points[points["state"] == "HI"]
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.2), dpi=100, sharey=True)
    for ax, components in zip(axes, (1, 4), strict=True):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            hull = geoalpha.hull(hawaii, by="state", components=components)
        hull.plot(ax=ax, color="tab:blue", alpha=0.35, edgecolor="tab:blue")
        hawaii.plot(ax=ax, color="black", markersize=6)
        row = hull.iloc[0]
        ax.set_title(
            f"components={components}: {row['n_parts']} part(s), "
            f"{row['area_m2'] / 1e6:,.0f} km²"
        )
        ax.set_xlabel("longitude")
    axes[0].set_ylabel("latitude")
    fig.suptitle(
        "Hawaii's airports: one polygon bridges the sea; --components 4 does not"
    )
    fig.tight_layout()
    fig.savefig(args.output, bbox_inches="tight")
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
