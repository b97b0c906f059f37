"""Answer normalisation: the comparison key of recorded and predicted answers."""

from __future__ import annotations

import json
import re
from typing import Any

_INT = re.compile(r"[+-]?\d+")
_INTEGRAL_FLOAT = re.compile(r"[+-]?\d+\.0*")
_BOOL_WORDS = {"true": "true", "yes": "true", "false": "false", "no": "false"}


def normalise_answer(value: Any) -> str:
    """The comparison key of an answer.

    * strings are stripped and lower-cased (``"Red"`` and ``"red"`` agree, so do ``"Cube"`` and ``"cube"``);
    * booleans: ``True``, ``"True"``, ``"true"`` and ``"yes"`` all become ``"true"``; likewise ``False``,
      ``"False"``, ``"no"`` become ``"false"`` (no CRAFT answer is literally "yes" or "no");
    * numbers: ``2``, ``2.0``, ``"2"``, ``" 02 "`` all become ``"2"``; a non-integral number keeps its text;
    * anything else (``None``, lists) becomes its JSON text, which matches no answer.

    No other synonyms are applied (``"grey"`` does not match ``"gray"``, ``"ball"`` not ``"circle"``).
    """
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return str(int(value)) if value.is_integer() else repr(value)
    if not isinstance(value, str):
        return json.dumps(value, sort_keys=True)
    text = value.strip().lower()
    if text in _BOOL_WORDS:
        return _BOOL_WORDS[text]
    if _INT.fullmatch(text) or _INTEGRAL_FLOAT.fullmatch(text):
        return str(int(float(text)))
    return text


def answers_agree(a: Any, b: Any) -> bool:
    """Whether two answers are the same after :func:`normalise_answer`."""
    return normalise_answer(a) == normalise_answer(b)
