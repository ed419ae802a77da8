"""The frame layer: the stages of :func:`geoalpha.hull` on a GeoDataFrame.

Its modules: ``docs/architecture.md``. It calls the array API
(:mod:`geoalpha._arrays`), never the faces above it.
"""
