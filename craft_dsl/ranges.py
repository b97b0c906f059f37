"""One reader for the lists and scene references every command takes: ``1,3,5-8``, ``all``, layout files."""

from __future__ import annotations

from pathlib import Path

from .errors import CraftError

SCENE_IDS = range(1, 21)


def parse_ranges(text: str, option: str, low: int, high: int, what: str = "numbers", *,
                 shown: str | None = None, also: str = "") -> tuple[int, ...]:
    """``"1,3,5-8"`` -> (1, 3, 5, 6, 7, 8), every number within [low, high]; errors name the option and part.

    ``shown``: the whole option value, when ``text`` is a part of it; ``also``: other forms the option allows,
    appended to the message."""
    shown = text if shown is None else shown
    out: list[int] = []
    for part in text.split(","):
        part = part.strip()
        if not part:
            continue
        lo, sep, hi = part.partition("-")
        try:
            values = range(int(lo), int(hi) + 1) if sep else range(int(lo), int(lo) + 1)
        except ValueError:
            raise CraftError(f"{option} {shown[:60]!r}: {part[:30]!r} is not one of the {what} or a range of them; "
                             f"allowed: {low}-{high}, e.g. {low},{low + 2},{low + 4}-{min(high, low + 7)}{also}"
                             ) from None
        if not values or values.start < low or values.stop - 1 > high:
            raise CraftError(f"{option} {shown[:60]!r}: {part[:30]!r} is outside {low}-{high}{also}")
        out.extend(values)
    if not out:
        raise CraftError(f"{option} {shown[:60]!r}: names no {what}")
    return tuple(out)


def parse_scene(text: str, option: str = "--scene", shown: str | None = None) -> int | Path:
    """A built-in scene id (1-20) or a scene layout file (``shown``: the whole option value, when ``text`` is a
    part of it)."""
    text = str(text).strip()
    if text.isdigit():
        return parse_ranges(text, option, SCENE_IDS.start, SCENE_IDS.stop - 1, "scene ids", shown=shown)[0]
    path = Path(text)
    if not path.is_file():
        where = f"{option} {text[:80]!r}" if shown is None else f"{option} {shown[:60]!r}: {text[:80]!r}"
        looks_like_a_path = text.endswith(".json") or "/" in text
        reason = (" (a folder)" if path.is_dir() else " (no such file)") if looks_like_a_path else ""
        raise CraftError(f"{where}: not a scene id (1-20) nor a scene layout file{reason}")
    return path


def parse_scenes(text: str | None, option: str = "--scenes") -> list[int | Path]:
    """``all`` (or nothing), ids and ranges of 1-20, and scene layout files, comma-separated."""
    if text is None or text.strip() in ("", "all"):
        return list(SCENE_IDS)
    out: list[int | Path] = []
    for part in text.split(","):
        part = part.strip()
        if part.endswith(".json") or "/" in part:
            out.append(parse_scene(part, option, shown=text))
        elif part:
            out.extend(parse_ranges(part, option, SCENE_IDS.start, SCENE_IDS.stop - 1, "scene ids", shown=text,
                                    also=", or a scene layout file (a path ending in .json)"))
    return out
