"""Attach an accessor class to frame classes, as pandas registers its accessors.

Shared by ``accessor`` and ``dask``, so that neither imports the other.
"""

from __future__ import annotations

import warnings

__all__ = ["CachedAccessor", "attach"]  # (ColumnHint: the accessors' base)


class ColumnHint:
    """Base of the accessors: using one as a column says where the column is.

    ``hulls.alpha`` is the accessor, so ``hulls.alpha.mean()`` or
    ``hulls.alpha == 0.5`` on a result of :func:`geoalpha.hull` (which has an
    ``alpha`` column) would otherwise fail obscurely or compare the accessor
    (False): they raise, naming ``hulls["alpha"]``.

    Examples
    --------
    >>> import geoalpha, geopandas as gpd, shapely
    >>> hulls = gpd.GeoDataFrame({"alpha": [0.5]}, geometry=[shapely.Point(0, 0)])
    >>> hulls.alpha == 0.5
    Traceback (most recent call last):
    ...
    TypeError: .alpha is geoalpha's accessor (.alpha.hull()), not the 'alpha' ...
    >>> hulls.alpha.mean()
    Traceback (most recent call last):
    ...
    AttributeError: ... column: write hulls["alpha"].mean(...)
    >>> float(hulls["alpha"].mean())
    0.5
    """

    _obj: object
    _name: str = "alpha"

    def _hint(self, use: str) -> str:
        name = self._name
        if name in getattr(self._obj, "columns", ()):
            column = f'the {name!r} column: write hulls["{name}"]{use}'
        else:
            column = f"a column (this frame has no {name!r} column)"
        return f".{name} is geoalpha's accessor (.{name}.hull()), not {column}"

    def __getattr__(self, attr: str):
        if attr.startswith("__") or attr in ("_obj", "_name"):
            raise AttributeError(attr)
        raise AttributeError(self._hint(f".{attr}(...)"))

    __hash__ = object.__hash__

    def __eq__(self, other):
        raise TypeError(self._hint(" == ..."))

    def __ne__(self, other):
        raise TypeError(self._hint(" != ..."))

    def __lt__(self, other):
        raise TypeError(self._hint(" < ..."))

    def __le__(self, other):
        raise TypeError(self._hint(" <= ..."))

    def __gt__(self, other):
        raise TypeError(self._hint(" > ..."))

    def __ge__(self, other):
        raise TypeError(self._hint(" >= ..."))

    def __getitem__(self, key):
        raise TypeError(self._hint("[...]"))

    def __iter__(self):
        raise TypeError(self._hint(""))

    def __len__(self):
        raise TypeError(self._hint(""))

    def __bool__(self):  # (not __len__'s error: ``if frame.alpha`` stays True)
        return True

    def __array__(self, *args, **kwargs):
        raise TypeError(self._hint(".to_numpy()"))

    def __float__(self):
        raise TypeError(self._hint(""))

    def _arith(symbol: str):
        def arith(self, other):
            raise TypeError(self._hint(f" {symbol} ..."))

        return arith

    __add__ = __radd__ = _arith("+")
    __sub__ = __rsub__ = _arith("-")
    __mul__ = __rmul__ = _arith("*")
    __truediv__ = __rtruediv__ = _arith("/")
    __pow__ = __rpow__ = _arith("**")
    del _arith


class CachedAccessor:
    """Descriptor: the accessor class on the class, one bound to an instance on it."""

    def __init__(self, name: str, accessor: type):
        self._name, self._accessor = name, accessor

    def __get__(self, obj, cls):
        if obj is None:
            return self._accessor
        accessor = self._accessor(obj)
        accessor._name = self._name  # for the messages of ColumnHint
        return accessor


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
