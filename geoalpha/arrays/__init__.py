"""The array API: optimal alpha shapes of coordinate arrays, no frames.

:mod:`~geoalpha.arrays.optimal` (``optimal_alpha``, ``alpha_shape``,
``alpha_shapes``) checks its inputs and makes one kernel call;
:mod:`~geoalpha.arrays.guarantee` enforces the guarantee in the coordinates
the polygons are returned in; :mod:`~geoalpha.arrays.comparison` and
:mod:`~geoalpha.arrays.knn` are the comparison methods,
:mod:`~geoalpha.arrays.area` the areas on the WGS84 ellipsoid,
:mod:`~geoalpha.arrays.search` the seed paper's searches and
:mod:`~geoalpha.arrays.budget` the outlier budget. It calls the kernel
(:mod:`geoalpha.kernel`), never the frame layer.
"""
