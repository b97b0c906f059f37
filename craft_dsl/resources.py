"""Locating the data files shipped beside the package (grammar, scene layouts)."""

from __future__ import annotations

from pathlib import Path

_PACKAGE = Path(__file__).resolve().parent


def data_dir(name: str) -> Path:
    """``grammar`` or ``scenes``: the installed copy (wheel) or the repository folder (editable install)."""
    for candidate in (_PACKAGE / "_data" / name, _PACKAGE.parent / name):
        if candidate.is_dir():
            return candidate
    raise FileNotFoundError(f"craft_dsl data folder {name!r} not found next to {_PACKAGE}")
