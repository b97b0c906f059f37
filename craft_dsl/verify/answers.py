"""Answer normalisation: the comparison key of recorded and predicted answers."""

from __future__ import annotations

import math
import re
from typing import Any

from ..files import describe

_NUMBER = re.compile(r"([+-]?)0*([0-9]+?)(?:\.0*)?")
_NUMERIC = re.compile(r"[+-]?[0-9]+(?:\.[0-9]*)?")
_BOOL_WORDS = {"true": "true", "yes": "true", "false": "false", "no": "false"}
#: Numeric answers are counts: at most this many digits before the decimal point (checked by the readers).
MAX_ANSWER_DIGITS = 18


def answer_problem(value: Any) -> str | None:
    """Why ``value`` cannot be an answer, or None: an answer is a string, a boolean or a finite number whose
    integer part has at most :data:`MAX_ANSWER_DIGITS` digits (a numeric string too)."""
    if isinstance(value, bool):
        return None
    if isinstance(value, int):
        if -(10 ** MAX_ANSWER_DIGITS) < value < 10 ** MAX_ANSWER_DIGITS:
            return None
        return f"the answer is a number out of range ({describe(value)}); numeric answers have at most " \
               f"{MAX_ANSWER_DIGITS} digits"
    if isinstance(value, float):
        if math.isfinite(value) and abs(value) < 10.0 ** MAX_ANSWER_DIGITS:
            return None
        return f"the answer is a number out of range ({value!r}); numeric answers are finite, with at most " \
               f"{MAX_ANSWER_DIGITS} digits"
    if isinstance(value, str):
        text = value.strip()
        if _NUMERIC.fullmatch(text) and len(text.split(".")[0].lstrip("+-").lstrip("0")) > MAX_ANSWER_DIGITS:
            return f"the answer is a number out of range ({describe(value)}); numeric answers have at most " \
                   f"{MAX_ANSWER_DIGITS} digits"
        return None
    return f"the answer must be a string, a number or a boolean, found {describe(value)}"


def normalise_answer(value: Any) -> str:
    """The comparison key of an answer.

    * strings are stripped and lower-cased (``"Red"`` and ``"red"`` agree, so do ``"Cube"`` and ``"cube"``);
    * booleans: ``True``, ``"True"``, ``"true"`` and ``"yes"`` all become ``"true"``; likewise ``False``,
      ``"False"``, ``"no"`` become ``"false"`` (no CRAFT answer is literally "yes" or "no");
    * numbers: ``2``, ``2.0``, ``"2"``, ``" 02 "``, ``"2.00"`` all become ``"2"``; a non-integral number keeps its
      text; numbers are normalised as text, so a number of any size is compared without overflow;
    * anything else (``None``, lists) becomes its JSON text, which matches no answer.

    No other synonyms are applied (``"grey"`` does not match ``"gray"``, ``"ball"`` not ``"circle"``).
    """
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return _integer_text(value)
    if isinstance(value, float):
        return _integer_text(int(value)) if value.is_integer() else repr(value)
    if not isinstance(value, str):
        return describe(value, limit=1 << 20)
    text = value.strip().lower()
    if text in _BOOL_WORDS:
        return _BOOL_WORDS[text]
    m = _NUMBER.fullmatch(text)
    if m:
        sign, digits = m.groups()
        return digits if sign != "-" or digits == "0" else f"-{digits}"
    return text


def _integer_text(value: int) -> str:
    try:
        return str(value)
    except ValueError:  # more digits than Python converts: a key that equals no answer
        return f"int:{value:x}"


def answers_agree(a: Any, b: Any) -> bool:
    """Whether two answers are the same after :func:`normalise_answer`."""
    return normalise_answer(a) == normalise_answer(b)
