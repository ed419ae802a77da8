"""Draw the "Why this shape" figure: a flagged UK accident cluster, explained.

Left: cluster 154 of the bundled UK accident clusters, its optimal hull, the
critical triangle (``geoalpha.explain``) and the location whose leaving out
divides the radius by 5; right: ``geoalpha.curve`` of the same cluster, area
against the number of locations left out (k = 0..5).

Usage::

    python scripts/make_why_figure.py          # writes docs/why.png
    python scripts/make_why_figure.py -o out.png
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

ROOT = Path(__file__).resolve().parent.parent
CLUSTER = 154


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-o", "--output", default=str(ROOT / "docs" / "why.png"))
    out = parser.parse_args(argv).output
    points = datasets.load("uk_clusters")
    points = points[points["Cluster"] == CLUSTER]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", geoalpha.GeoAlphaWarning)
        hull = points.alpha.hull(by="Cluster")
        why = points.alpha.explain(by="Cluster")
        curve = points.alpha.curve(
            by="Cluster", max_left_out=5, outlier_unit="locations"
        )
    crs = hull["crs_used"].item()
    metric = points.to_crs(crs)
    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4.6))
    hull.to_crs(crs).plot(ax=left, color="#cfe3f5", edgecolor="#2b6da8")
    why.to_crs(crs).plot(ax=left, color="none", edgecolor="#d62728", linewidth=1.5)
    left.scatter(metric.geometry.x, metric.geometry.y, s=8, color="#333333")
    stray = metric.loc[why["rows_without_1"].item()]
    left.scatter(stray.geometry.x, stray.geometry.y, s=80, marker="x", color="#d62728")
    left.set_title(
        f"cluster {CLUSTER}: radius {why['radius'].item():.1f} m, "
        f"{why['limited_by'].item()}\n"
        f"without the red location: {why['radius_without_1'].item():.1f} m",
        fontsize=10,
    )
    left.set_aspect("equal")
    left.set_xticks([])
    left.set_yticks([])
    right.plot(curve["k"], curve["area_m2"], marker="o", color="#2b6da8")
    right.set_xlabel("locations left out (k)")
    right.set_ylabel("area (m²)")
    right.set_title("geoalpha.curve: the exact optimum for each k", fontsize=10)
    right.set_ylim(bottom=0)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print(f"Wrote {out}")


if __name__ == "__main__":
    main()
