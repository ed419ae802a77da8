"""The frame layer: the stages of :func:`geoalpha.hull` on a GeoDataFrame.

:mod:`~geoalpha.frame.pipeline` runs the stages (group, read the points,
project, compute, the guarantee, the table); :mod:`~geoalpha.frame.crs` owns
the CRS round trip, :mod:`~geoalpha.frame.schema` the result table,
:mod:`~geoalpha.frame.checks` and :mod:`~geoalpha.frame.distortion` the
warnings about the set-up, :mod:`~geoalpha.frame.progress` the progress bar.
It calls the array API (:mod:`geoalpha.arrays`), never the faces above it.
"""
