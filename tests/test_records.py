"""``massprops.model.records.record`` behaves as ``dataclass(frozen=True)`` does, without writing code."""

import dataclasses
from dataclasses import FrozenInstanceError, dataclass, field

import pytest

from massprops.model.records import record, replace


def _pair(**options):
    """The same class as a frozen dataclass and as a record."""
    classes = []
    for decorate in (dataclass(frozen=True, **options), record(**options)):
        @decorate
        class Part:
            """A part."""
            name: str
            count: int = 1
            tags: list = field(default_factory=list)
            note: str = field(default="", repr=False, compare=False)
        classes.append(Part)
    return classes


@pytest.mark.parametrize("eq", [True, False])
def test_a_record_is_built_compared_and_printed_as_the_frozen_dataclass(eq):
    reference, ours = _pair(eq=eq)
    for args, kwargs in [(("a",), {}), (("a", 2), {"note": "x"}), ((), {"name": "b", "tags": [1]})]:
        a, b = reference(*args, **kwargs), ours(*args, **kwargs)
        assert repr(a) == repr(b)
        assert dataclasses.asdict(a) == dataclasses.asdict(b)
        assert (b == ours(*args, **kwargs)) is eq
        assert (b == ours(*args, **{**kwargs, "note": "other"})) is eq
        assert b != ours("other")
    assert ours("a").tags is not ours("a").tags            # a fresh default per instance
    if eq:
        assert hash(ours("a", 2, ())) == hash(ours("a", 2, (), note="y")) == hash(reference("a", 2, ()))


def test_a_record_is_frozen_and_replace_makes_a_new_one():
    _, ours = _pair()
    part = ours("a", 3)
    with pytest.raises(FrozenInstanceError):
        part.count = 4
    with pytest.raises(FrozenInstanceError):
        del part.name
    changed = dataclasses.replace(part, count=4)
    assert (changed.name, changed.count, part.count) == ("a", 4, 3)
    assert [f.name for f in dataclasses.fields(ours)] == ["name", "count", "tags", "note"]


@pytest.mark.parametrize("args, kwargs, message", [
    ((), {}, "missing required argument: 'name'"),
    (("a", 1, [], "", 5), {}, "takes 4 positional arguments but 5 were given"),
    (("a",), {"name": "b"}, "multiple values for argument 'name'"),
    (("a",), {"colour": "red"}, "unexpected keyword argument 'colour'"),
])
def test_wrong_arguments_are_refused_as_python_refuses_them(args, kwargs, message):
    _, ours = _pair()
    with pytest.raises(TypeError, match=message):
        ours(*args, **kwargs)


def test_post_init_runs_and_may_set_fields():
    @record
    class Scaled:
        value: float
        double: float = 0.0

        def __post_init__(self):
            object.__setattr__(self, "double", 2 * self.value)

    assert Scaled(1.5).double == 3.0


def test_replace_gives_what_dataclasses_replace_gives():
    """records.replace: the fields over the changes, __post_init__ run on the new record, cached values
    not carried over, an unknown field refused as dataclasses.replace refuses it, other objects passed on."""
    from functools import cached_property

    @record
    class Scaled:
        value: float
        tags: list = dataclasses.field(default_factory=list)
        double: float = 0.0
        calls: list = dataclasses.field(default_factory=list, compare=False)

        def __post_init__(self):
            object.__setattr__(self, "double", 2 * self.value)
            self.calls.append(self.value)

        @cached_property
        def square(self):
            return self.value ** 2

    one = Scaled(1.5, ["a"])
    assert one.square == 2.25
    for changes in ({}, {"value": 4.0}, {"tags": ["b"], "value": -1.0}):
        ours, reference = replace(one, **changes), dataclasses.replace(one, **changes)
        assert ours == reference and ours is not one and type(ours) is Scaled
        assert ours.square == ours.value ** 2 and ours.double == 2 * ours.value
    assert one.calls == [1.5, 1.5, 1.5, 4.0, 4.0, -1.0, -1.0]        # shared list: each new record's post-init
    with pytest.raises(TypeError, match="colour"):
        replace(one, colour="red")

    @dataclass(frozen=True)
    class Plain:
        value: int

    assert replace(Plain(1), value=2) == Plain(2)
