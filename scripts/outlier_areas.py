"""How much tighter ``outliers=`` makes the hulls of the bundled datasets.

For each dataset: the median over groups of (hull area / convex hull area),
holes filled, with every point kept and with 1 %, 2 % and 5 % of each group's
rows allowed to stay out (``hull(..., outliers=q)``). Groups with
fewer than 4 distinct points or no alpha shape are left out of the medians.

Usage::

    python scripts/outlier_areas.py          # prints a Markdown table
"""

from __future__ import annotations

import warnings

import numpy as np

import geoalpha
from geoalpha import datasets

#: dataset -> (group column, label)
DATASETS = {
    "us_airports": ("state", "US airports by state"),
    "stats19": ("Local_Authority_(Highway)", "STATS19 local authorities"),
    "uk_clusters": ("Cluster", "UK accident clusters"),
}
FRACTIONS = [0, 0.01, 0.02, 0.05]


def ratios(points, by: str, outliers: float):
    """Hull area / convex hull area per group, and the rows left out."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # degenerate groups, dropped rows
        hulls = geoalpha.hull(points, by=by, outliers=outliers)
        convex = geoalpha.hull(points, by=by, method="convex")
    distinct = points.groupby(by).geometry.apply(lambda g: len(set(g.to_wkb())))
    big = hulls[by].map(distinct).to_numpy() >= 4
    ok = big & hulls["alpha"].notna().to_numpy()
    area = hulls["area_m2"].to_numpy()[ok] / convex["area_m2"].to_numpy()[ok]
    return area, int(hulls["n_outliers"].sum()), int(ok.sum())


def main() -> None:
    header = ["data", "all points", "1 % may stay out", "2 %", "5 %"]
    print("| " + " | ".join(header) + " |")
    print("|---|" + "---:|" * (len(header) - 1))
    for name, (by, label) in DATASETS.items():
        points = datasets.load(name)
        cells = []
        for q in FRACTIONS:
            area, left_out, groups = ratios(points, by, q)
            cells.append(f"{np.median(area):.2f} ({left_out} out)")
        print(f"| {label} ({groups} groups) | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
