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

    # Enum's own __hash__ is a Python function; types are hashed in every checker lookup, and a str-valued
    # member equals its string, so the string's hash is the consistent (and C-speed) one.
    __hash__ = str.__hash__


#: Types whose values are written as literals in a program ("Small", "Yellow", 3).
SIDE_INPUT_TYPES = (DslType.COLOR, DslType.SHAPE, DslType.SIZE)

#: Integer literals of a program are 64-bit signed integers.
INTEGER_MIN, INTEGER_MAX = -(1 << 63), (1 << 63) - 1


def integer_literal(text: str) -> int:
    """The value of an integer literal (``-?[0-9]+``); ValueError naming the allowed range if it is outside
    64 bits (checked on the text first, so that a literal of any length costs nothing to refuse)."""
    digits = len(text) - text.startswith("-")
    value = int(text) if digits <= 19 else None
    if value is None or not INTEGER_MIN <= value <= INTEGER_MAX:
        shown = text if len(text) <= 24 else f"{text[:20]}... ({digits:,} digits)"
        raise ValueError(f"the integer {shown} is out of range; integers are between {INTEGER_MIN} and "
                         f"{INTEGER_MAX}")
    return value


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
