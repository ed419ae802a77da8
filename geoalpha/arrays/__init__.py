"""The array API: alpha shapes of coordinate arrays (:mod:`~geoalpha.arrays.optimal`).

One module per task; they call the kernel (:mod:`geoalpha.kernel`), never the frame.
"""
