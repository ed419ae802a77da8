"""The outlier budget (``outliers=``): rows each group may leave out.

A float ``q`` in ``[0, 1)`` is a fraction of the group's rows,
``k = floor(q * rows)``; an int is ``k`` itself. A location that holds several
rows weighs as many rows, so ``n_outliers <= k`` always holds in rows, as
users read the option.
"""

from __future__ import annotations

from geoalpha.errors import InvalidInputError

__all__ = ["check_outliers", "outlier_budget"]


def check_outliers(outliers) -> None:
    """Raise :class:`InvalidInputError` unless ``outliers`` is a valid budget.

    Parameters
    ----------
    outliers : float or int
        A float in ``[0, 1)`` (a fraction of each group's rows) or an int
        ``>= 0`` (a count of rows per group).

    Examples
    --------
    >>> check_outliers(0.02), check_outliers(3)
    (None, None)
    >>> check_outliers(1.5)
    Traceback (most recent call last):
    ...
    geoalpha.errors.InvalidInputError: outliers must be a fraction in [0, 1) or ...
    """
    import numbers

    if isinstance(outliers, bool) or type(outliers).__name__ == "bool_":
        ok = False
    elif isinstance(outliers, numbers.Integral):
        ok = outliers >= 0
    elif isinstance(outliers, numbers.Real):
        ok = 0 <= outliers < 1
    else:
        ok = False
    if not ok:
        raise InvalidInputError(
            "outliers must be a fraction in [0, 1) or a count >= 0 (an int); "
            f"got {outliers!r}"
        )


def outlier_budget(outliers, rows):
    """Return the number ``k`` of rows each group may leave out.

    Parameters
    ----------
    outliers : float or int
        A float ``q`` in ``[0, 1)``: ``k = floor(q * rows)`` (``q * rows``
        rounded to 9 decimals first, so that ``0.29 * 100`` gives 29, not 28);
        an int: ``k`` itself for every group.
    rows : array_like of int, shape (G,)
        Rows of each group.

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

    check_outliers(outliers)
    n = np.asarray(rows, dtype=np.int64)
    if isinstance(outliers, numbers.Integral):
        return np.full(n.shape, int(outliers), dtype=np.int64)
    return np.floor(np.round(float(outliers) * n, 9)).astype(np.int64)
