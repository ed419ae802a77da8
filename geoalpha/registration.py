"""Attach an accessor class to frame classes, as pandas registers its accessors.

Shared by ``accessor`` and ``dask``, so that neither imports the other.
"""

from __future__ import annotations

import warnings

__all__ = ["CachedAccessor", "attach"]


class CachedAccessor:
    """Descriptor: the accessor class on the class, one bound to an instance on it."""

    def __init__(self, name: str, accessor: type):
        self._accessor = accessor  # (``name``: as pandas's CachedAccessor)

    def __get__(self, obj, cls):
        if obj is None:
            return self._accessor
        return self._accessor(obj)


def attach(classes, name: str, accessor: type) -> None:
    """Set ``cls.<name>`` to ``accessor`` on every class of ``classes``.

    Warns (``UserWarning``) when that overrides an attribute not attached here.

    Examples
    --------
    >>> class Frame:
    ...     pass
    >>> class Accessor:
    ...     def __init__(self, obj):
    ...         self.obj = obj
    >>> attach([Frame], "extra", Accessor)
    >>> Frame.extra is Accessor, isinstance(Frame().extra, Accessor)
    (True, True)
    """
    for cls in classes:
        existing = getattr(cls, name, None)
        if existing is not None and not isinstance(
            cls.__dict__.get(name), CachedAccessor
        ):
            warnings.warn(
                f"registering the geoalpha accessor {name!r} overrides an existing "
                f"attribute of {cls.__name__}",
                UserWarning,
                stacklevel=3,
            )
        setattr(cls, name, CachedAccessor(name, accessor))
