"""The outlier budget (``outliers=``): rows each group may leave out."""

from __future__ import annotations

__all__ = ["outlier_budget"]


def outlier_budget(outliers, rows):
    """Return the number ``k`` of rows each group may leave out.

    Parameters
    ----------
    outliers : float or int
        Checked. A float ``q`` in ``[0, 1)``: ``k = floor(q * rows)`` (rounded
        to 9 decimals first: ``0.29 * 100`` gives 29, not 28); an int: ``k``.
    rows : array_like of int, shape (G,)

    Returns
    -------
    ndarray of int, shape (G,)

    Examples
    --------
    >>> outlier_budget(0.02, [13, 50, 586]).tolist()
    [0, 1, 11]
    >>> outlier_budget(0.29, [100]).tolist(), outlier_budget(3, [2, 40]).tolist()
    ([29], [3, 3])
    """
    import numbers

    import numpy as np

    n = np.asarray(rows, dtype=np.int64)
    if isinstance(outliers, numbers.Integral):
        return np.full(n.shape, int(outliers), dtype=np.int64)
    return np.floor(np.round(float(outliers) * n, 9)).astype(np.int64)
