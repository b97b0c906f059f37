"""One reader for the lists and scene references every command takes: ``1,3,5-8``, ``all``, layout files."""

from __future__ import annotations

from pathlib import Path

from .errors import CraftError

SCENE_IDS = range(1, 21)


def parse_ranges(text: str, option: str, low: int, high: int, what: str = "numbers") -> tuple[int, ...]:
    """``"1,3,5-8"`` -> (1, 3, 5, 6, 7, 8), every number within [low, high]; errors name the option and part."""
    out: list[int] = []
    for part in text.split(","):
        part = part.strip()
        if not part:
            continue
        lo, sep, hi = part.partition("-")
        try:
            values = range(int(lo), int(hi) + 1) if sep else range(int(lo), int(lo) + 1)
        except ValueError:
            raise CraftError(f"{option} {text[:60]!r}: {part[:30]!r} is not one of the {what} or a range of them; "
                             f"allowed: {low}-{high}, e.g. {low},{low + 2},{low + 4}-{min(high, low + 7)}") from None
        if not values or values.start < low or values.stop - 1 > high:
            raise CraftError(f"{option} {text[:60]!r}: {part[:30]!r} is outside {low}-{high}")
        out.extend(values)
    if not out:
        raise CraftError(f"{option} {text[:60]!r}: names no {what}")
    return tuple(out)


def parse_scene(text: str, option: str = "--scene") -> int | Path:
    """A built-in scene id (1-20) or a scene layout file."""
    text = str(text).strip()
    if text.isdigit():
        return parse_ranges(text, option, SCENE_IDS.start, SCENE_IDS.stop - 1, "scene ids")[0]
    path = Path(text)
    if not path.is_file():
        raise CraftError(f"{option} {text[:80]!r}: not a scene id (1-20) nor a scene layout file")
    return path


def parse_scenes(text: str | None, option: str = "--scenes") -> list[int | Path]:
    """``all`` (or nothing), ids and ranges of 1-20, and scene layout files, comma-separated."""
    if text is None or text.strip() in ("", "all"):
        return list(SCENE_IDS)
    out: list[int | Path] = []
    for part in text.split(","):
        part = part.strip()
        if part.endswith(".json") or "/" in part:
            out.append(parse_scene(part, option))
        elif part:
            out.extend(parse_ranges(part, option, SCENE_IDS.start, SCENE_IDS.stop - 1, "scene ids"))
    return out
