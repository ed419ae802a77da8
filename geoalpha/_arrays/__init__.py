"""The array API: alpha shapes of coordinate arrays (:mod:`~geoalpha._arrays.optimal`).

One module per task; they call the kernel (:mod:`geoalpha._core`), never the frame.
"""
