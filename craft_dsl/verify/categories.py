"""The paper's columns, sub-categories and question types of CRAFT templates."""

from __future__ import annotations

from ..errors import CraftError
from ..templates import templates

#: The paper's columns: C (cause, enable, prevent), CF (counterfactual), D (descriptive).
FAMILIES: tuple[str, ...] = ("C", "CF", "D")
#: The paper's sub-categories, in table order (docs/verify.md).
CATEGORIES: tuple[str, ...] = ("D/2Q", "D/N-V", "D/N-T", "D/C", "D/S", "D/C-T", "D/TO", "CF/O", "CF/N", "C/A", "C/N")
#: Question types (the capitalised template file stems of ``question_type``).
QUESTION_TYPES: tuple[str, ...] = ("Descriptive", "Counterfactual", "Cause", "Enable", "Prevent")

_DESCRIPTIVE_RANGES = ((0, 3, "D/2Q"), (4, 15, "D/N-V"), (16, 21, "D/N-T"), (22, 23, "D/C"), (24, 25, "D/S"),
                       (26, 37, "D/C-T"), (38, 39, "D/TO"))


def _split_template_id(template_id: str) -> tuple[str, int]:
    if template_id not in templates():
        raise CraftError(f"{template_id!r} is not a CRAFT template id (e.g. 'descriptive_0' ... 'prevent_5')")
    family, index = template_id.rsplit("_", 1)
    return family, int(index)


def family_of(template_id: str) -> str:
    """The paper's column of a template: ``"D"``, ``"CF"`` or ``"C"`` (cause, enable, prevent)."""
    family, _ = _split_template_id(template_id)
    return {"descriptive": "D", "counterfactual": "CF"}.get(family, "C")


def category_of(template_id: str) -> str:
    """The paper's sub-category of a template (docs/verify.md), e.g. ``category_of("descriptive_22") == "D/C"``."""
    family, i = _split_template_id(template_id)
    if family == "descriptive":
        return next(code for lo, hi, code in _DESCRIPTIVE_RANGES if lo <= i <= hi)
    if family == "counterfactual":
        return "CF/N" if 3 <= i <= 5 else "CF/O"
    return "C/N" if 3 <= i <= 5 else "C/A"


def question_type_of(template_id: str) -> str:
    """``"Descriptive"``, ``"Counterfactual"``, ``"Cause"``, ``"Enable"`` or ``"Prevent"``."""
    return _split_template_id(template_id)[0].capitalize()
