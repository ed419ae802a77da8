"""The array API: optimal alpha shapes of coordinate arrays, no frames.

:mod:`~geoalpha.arrays.optimal` (``optimal_alpha``, ``alpha_shape``,
``alpha_shapes``) and the modules it uses, one per task (the guarantee, the
comparison methods, the searches, areas, longitudes, the sphere). They call
the kernel (:mod:`geoalpha.kernel`), never the frame layer.
"""
