"""Bundled real point datasets (provenance, licences: ``geoalpha/data/README.md``)."""

from __future__ import annotations

from pathlib import Path

__all__ = ["DATASETS", "load", "path"]

#: name -> (file, longitude column, latitude column, group column, description)
DATASETS: dict[str, tuple[str, str, str, str, str]] = {
    "stats19": (
        "stats19_2014_subset_razshain.csv",
        "Longitude",
        "Latitude",
        "Local_Authority_(Highway)",
        "1,017 UK road accidents of 2014 (STATS19) by highway local authority; "
        "OGL v3.0",
    ),
    "uk_clusters": (
        "uk_accident_dbscan_clusters_joaofig.csv",
        "Longitude",
        "Latitude",
        "Cluster",
        "15,255 UK road accident locations 2013-2016 in 691 DBSCAN clusters; "
        "MIT (joaofig), data OGL v3.0",
    ),
    "us_airports": (
        "us_airports_vega.csv",
        "longitude",
        "latitude",
        "state",
        "3,376 US airports (FAA, via vega_datasets) by state; US government work",
    ),
}


def path(name: str) -> Path:
    """Return the path of a bundled dataset's CSV file.

    Parameters
    ----------
    name : str
        A key of :data:`DATASETS`: ``"stats19"``, ``"uk_clusters"``, ``"us_airports"``.

    Returns
    -------
    pathlib.Path

    Examples
    --------
    >>> from geoalpha import datasets
    >>> datasets.path("stats19").name
    'stats19_2014_subset_razshain.csv'
    """
    if name not in DATASETS:
        raise KeyError(
            f"unknown dataset {name!r}; expected one of {', '.join(sorted(DATASETS))}"
        )
    from importlib.resources import files  # (here: 13 ms of the command's --help)

    return Path(str(files("geoalpha").joinpath("data", DATASETS[name][0])))


def load(name: str):
    """Load a bundled dataset as a GeoDataFrame of points in EPSG:4326.

    Parameters
    ----------
    name : str
        A key of :data:`DATASETS`, as for :func:`path`.

    Returns
    -------
    geopandas.GeoDataFrame
        Every row, with points from its lon/lat; group by ``DATASETS[name][3]``.

    Examples
    --------
    >>> from geoalpha import datasets
    >>> gdf = datasets.load("uk_clusters")
    >>> len(gdf), gdf["Cluster"].nunique(), gdf.crs.to_epsg()
    (15255, 691, 4326)
    """
    import geopandas as gpd
    import pandas as pd

    frame = pd.read_csv(path(name), low_memory=False)  # KeyError names the datasets
    _, lon, lat, _, _ = DATASETS[name]
    return gpd.GeoDataFrame(
        frame, geometry=gpd.points_from_xy(frame[lon], frame[lat]), crs="EPSG:4326"
    )
