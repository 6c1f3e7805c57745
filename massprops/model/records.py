"""Frozen record classes without code generation at import.

``@record`` (and ``@record(eq=False)``) gives a class what
``@dataclass(frozen=True)`` (``eq=False``) gives it: an ``__init__`` taking
the fields in order (defaults and ``field(default_factory=...)`` included),
``__post_init__``, ``__repr__``, ``__eq__`` and ``__hash__`` over the compared
fields, and instances that refuse assignment (``FrozenInstanceError``).  The
fields are dataclasses' own (``dataclasses.fields``, ``replace`` and
``asdict`` work on the class), but the methods are shared functions reading
the field list, not source text that ``dataclass`` writes and compiles for
every class: a dataclass costs about 0.3 ms of ``exec`` per method at import,
and ``massprops props`` imports 15 of them (issue 24).  A method the class
defines itself is kept.
"""

from __future__ import annotations

import dataclasses
import operator
import reprlib
from dataclasses import MISSING, FrozenInstanceError

__all__ = ["record", "replace", "tuple_record"]


def record(cls=None, /, *, eq=True):
    """Make ``cls`` a frozen record (see the module docstring); ``eq=False`` keeps identity comparison."""
    if cls is None:
        return lambda c: _make(c, eq)
    return _make(cls, eq)


def _make(cls, eq):
    if not cls.__doc__:          # else dataclass writes one from inspect.signature (ms, and ast.parse)
        cls.__doc__ = f"{cls.__name__}({', '.join(cls.__dict__.get('__annotations__', ()))})"
    # Fields only: dataclass writes no method when it is asked for none.
    cls = dataclasses.dataclass(cls, init=False, repr=False, eq=False)
    fields = dataclasses.fields(cls)
    names = tuple(f.name for f in fields)
    known = frozenset(names)
    # (name, default, factory) per field, MISSING where there is none
    defaults = tuple((f.name, f.default, f.default_factory) for f in fields)
    shown = tuple(f.name for f in fields if f.repr)
    compared = tuple(f.name for f in fields if f.compare)
    hashed = tuple(f.name for f in fields if (f.compare if f.hash is None else f.hash))
    post_init = getattr(cls, "__post_init__", None)
    qualname = cls.__qualname__

    def refuse(args, kwargs):
        if len(args) > len(names):
            raise TypeError(f"{qualname}() takes {len(names)} positional arguments but {len(args)} were given")
        for key in kwargs:
            if key in names[:len(args)]:
                raise TypeError(f"{qualname}() got multiple values for argument {key!r}")
            if key not in known:
                raise TypeError(f"{qualname}() got an unexpected keyword argument {key!r}")

    def __init__(self, *args, **kwargs):
        # Checked with set operations (a record is made several times per file of a batch); the first
        # wrong argument is named by refuse().
        if not kwargs and len(args) == len(names):
            self.__dict__.update(zip(names, args))          # every field by position: nothing to check
            if post_init is not None:
                self.__post_init__()
            return
        if len(args) > len(names):
            refuse(args, kwargs)
        if not kwargs:
            values = dict(zip(names, args))
        elif not args:
            values = kwargs
            if not known.issuperset(values):
                refuse(args, kwargs)
        else:
            values = dict(zip(names, args))
            if not (known.issuperset(kwargs) and values.keys().isdisjoint(kwargs)):
                refuse(args, kwargs)
            values.update(kwargs)
        if len(values) != len(names):
            for name, default, factory in defaults:
                if name not in values:
                    if default is not MISSING:
                        values[name] = default
                    elif factory is not MISSING:
                        values[name] = factory()
                    else:
                        raise TypeError(f"{qualname}() missing required argument: {name!r}")
        self.__dict__.update(values)
        if post_init is not None:
            self.__post_init__()

    @reprlib.recursive_repr()
    def __repr__(self):
        return f"{type(self).__qualname__}({', '.join(f'{n}={getattr(self, n)!r}' for n in shown)})"

    def __setattr__(self, name, value):
        raise FrozenInstanceError(f"cannot assign to field {name!r}")

    def __delattr__(self, name):
        raise FrozenInstanceError(f"cannot delete field {name!r}")

    def _record_replace(self, changes):
        # replace(): every field's value, the changes over them, and __post_init__, as __init__ would
        if type(self) is not cls or not known.issuperset(changes):
            return dataclasses.replace(self, **changes)         # which names the wrong argument
        values = {name: self.__dict__[name] for name in names}
        values.update(changes)
        made = object.__new__(cls)
        made.__dict__.update(values)
        if post_init is not None:
            made.__post_init__()
        return made

    cls._record_replace = _record_replace
    methods = {"__init__": __init__, "__repr__": __repr__, "__setattr__": __setattr__, "__delattr__": __delattr__}
    if eq:
        def __eq__(self, other):
            if other.__class__ is self.__class__:
                return tuple(getattr(self, n) for n in compared) == tuple(getattr(other, n) for n in compared)
            return NotImplemented

        def __hash__(self):
            return hash(tuple(getattr(self, n) for n in hashed))

        methods.update(__eq__=__eq__, __hash__=__hash__)
    for name, method in methods.items():
        if name not in cls.__dict__:
            method.__qualname__ = f"{qualname}.{name}"
            setattr(cls, name, method)
    return cls


def replace(obj, /, **changes):
    """``dataclasses.replace(obj, **changes)``: a new record with ``changes`` over ``obj``'s fields.

    The same result (``__post_init__`` runs, an unknown field is a TypeError), without
    dataclasses' walk over the field objects at every call: a batch replaces a few records per file.
    Objects that are not records go to ``dataclasses.replace``.
    """
    fast = getattr(type(obj), "_record_replace", None)
    return dataclasses.replace(obj, **changes) if fast is None else fast(obj, changes)


def tuple_record(cls):
    """``cls`` (fields as annotations, as for ``typing.NamedTuple``) as a tuple with named fields.

    What ``NamedTuple`` gives the code that uses it (construction by position
    or keyword, attribute access, unpacking, equality and hashing as tuples,
    ``_fields``, a repr with the names, pickling), without the source text
    ``namedtuple`` writes and evaluates, and the annotations ``typing``
    compiles, for every class at import.  Fields have no defaults.
    """
    names = tuple(cls.__dict__.get("__annotations__", ()))
    qualname = cls.__qualname__

    def __new__(klass, *args, **kwargs):
        if kwargs or len(args) != len(names):
            values = dict(zip(names, args))
            for key, value in kwargs.items():
                if key not in names or key in values:
                    raise TypeError(f"{qualname}() got an unexpected or repeated argument {key!r}")
                values[key] = value
            if len(args) > len(names) or len(values) != len(names):
                raise TypeError(f"{qualname}() takes the {len(names)} arguments {', '.join(names)}")
            args = tuple(values[name] for name in names)
        return tuple.__new__(klass, args)

    def __repr__(self):
        return f"{type(self).__name__}({', '.join(f'{n}={v!r}' for n, v in zip(names, self))})"

    def __getnewargs__(self):
        return tuple(self)

    namespace = {name: value for name, value in cls.__dict__.items()
                 if name not in ("__dict__", "__weakref__", "__annotations__")}
    for name, method in (("__new__", __new__), ("__repr__", __repr__), ("__getnewargs__", __getnewargs__)):
        if name not in namespace:
            method.__qualname__ = f"{qualname}.{name}"
            namespace[name] = method
    namespace.update(__slots__=(), _fields=names)
    for k, name in enumerate(names):
        namespace[name] = property(operator.itemgetter(k), doc=f"Field {k}: {name}.")
    made = type(cls.__name__, (tuple,), namespace)
    made.__qualname__ = qualname
    return made
