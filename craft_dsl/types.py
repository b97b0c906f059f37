"""The DSL's value types and the INVALID value."""

from __future__ import annotations

from enum import Enum


class DslType(str, Enum):
    """A type of the CRAFT DSL (names as in the original metadata)."""

    OBJECT = "Object"
    OBJECT_SET = "ObjectSet"
    OBJECT_SET_LIST = "ObjectSetList"
    EVENT = "Event"
    EVENT_SET = "EventSet"
    EVENT_SET_LIST = "EventSetList"
    INTEGER = "Integer"
    BOOL = "Bool"
    BOOL_LIST = "BoolList"
    COLOR = "Color"
    SHAPE = "Shape"
    SIZE = "Size"

    def __str__(self) -> str:
        return self.value


#: Types whose values are written as literals in a program ("Small", "Yellow", 3).
SIDE_INPUT_TYPES = (DslType.COLOR, DslType.SHAPE, DslType.SIZE)


class _Invalid:
    """The single INVALID value: an answer that does not exist (e.g. Unique of a set of size != 1).

    Any module receiving INVALID returns INVALID. It is falsy, equal only to itself, and prints as INVALID.
    """

    _instance: _Invalid | None = None

    def __new__(cls) -> _Invalid:
        if cls._instance is None:
            cls._instance = super().__new__(cls)
        return cls._instance

    def __repr__(self) -> str:
        return "INVALID"

    def __bool__(self) -> bool:
        return False

    def __reduce__(self) -> str:
        return "INVALID"


INVALID = _Invalid()
#: How INVALID is written in JSON (the original engine's string).
INVALID_JSON = "__INVALID__"
