"""The frame layer: the stages of :func:`geoalpha.hull` on a GeoDataFrame.

:mod:`~geoalpha.frame.pipeline` runs them; :mod:`~geoalpha.frame.crs` owns the
CRS round trip, :mod:`~geoalpha.frame.schema` the result table,
:mod:`~geoalpha.frame.checks` the set-up warnings, and
:mod:`~geoalpha.frame.progress` the progress bar. It calls the array API
(:mod:`geoalpha.arrays`), never the faces above it.
"""
