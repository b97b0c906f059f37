"""Streaming JSON: the members of a large top-level object or array, and the lines of a JSON Lines file, one at
a time, with the checks of :mod:`craft_dsl.files`.

A 200 MB predictions file holds about ten million answers; parsed whole, Python holds it several times over
(3 GB). :func:`iter_members` reads it with ijson's C parser (yajl) in 64 KiB blocks and builds one member at a
time, so memory stays constant. ijson was chosen over the byte-offset indexer of
:mod:`craft_dsl.verify.annotations` because it is faster: 5 s against 82 s for the 10.4 million members of a
200 MB file (``benchmarks/predictions_memory.py --compare-readers``).

Within each member the rules of :func:`craft_dsl.files.read_json` hold: nesting at most
:data:`~craft_dsl.files.MAX_JSON_DEPTH` levels (the top level counts), no key twice in one object, standard JSON
numbers; integers outside 64 bits are refused by the parser. Keys of the top-level object are yielded as they
come, a repeated one included: the caller, who knows what makes two keys the same, checks them.
"""

from __future__ import annotations

import codecs
from collections.abc import Iterator
from typing import IO, Any

from .errors import InputFileError
from .files import (
    MAX_JSON_DEPTH,
    ErrorType,
    PathLike,
    decode_text,
    describe,
    open_binary,
    parse_json,
    refuse_utf16_or_32,
)

#: Bytes read at a time.
BLOCK_BYTES = 1 << 16
#: Longest line of a JSON Lines file.
MAX_LINE_BYTES = 64 << 20

_SCALARS = frozenset(("string", "number", "boolean", "null"))


def _open(path: PathLike, what: str, error: ErrorType) -> IO[bytes]:
    name = str(path)
    fh = open_binary(path, what, error=error)  # closed by the caller's generator
    head = fh.read(4)
    try:
        refuse_utf16_or_32(head, name, what, error=error, path=name)
    except InputFileError:
        fh.close()
        raise
    fh.seek(len(codecs.BOM_UTF8) if head.startswith(codecs.BOM_UTF8) else 0)
    return fh


class _Position:
    """Where the stream is, for messages: the member being read (or the last one read)."""

    def __init__(self) -> None:
        self.key: str | int | None = None

    def text(self) -> str:
        if self.key is None:
            return "before the first member"
        if isinstance(self.key, int):
            return f"at or after record {self.key}"
        return f"at or after key {describe(self.key)}"


def _syntax_error(err: Exception, name: str, what: str, at: _Position, error: ErrorType) -> InputFileError:
    raw = err.args[0] if err.args else str(err)
    text = raw.decode("utf-8", "replace") if isinstance(raw, bytes) else str(raw)
    lines = [ln for ln in text.splitlines() if ln.strip()]
    reason = lines[0].strip() if lines else "not valid JSON"
    context = lines[1].strip() if len(lines) > 2 else ""
    if "integer overflow" in reason:
        reason = "an integer out of range; allowed: 64-bit integers"
    elif "floating point) overflow" in reason:
        reason = "a number out of range; allowed: finite numbers"
    elif "invalid bytes in UTF8" in reason:
        reason = "text that is not UTF-8; save the file as UTF-8"
    elif "premature EOF" in reason:
        reason = "the file ends in the middle of a value; it may be truncated"
    near = f" near {describe(context, 80)}" if context else ""
    return error(f"{name}: {at.text()}: not valid JSON: {reason}{near}", path=name)


def iter_members(path: PathLike, what: str, *, error: ErrorType = InputFileError,
                 kinds: tuple[str, ...] = ("object", "array")) -> Iterator[tuple[str | int, Any]]:
    """``(key, value)`` for every member of the top-level value of a JSON file, read as a stream.

    For an object ``key`` is a string (a repeated key is yielded again), for an array the 0-based index (an int).
    A top-level value of another kind than ``kinds`` ("object", "array") is refused.
    """
    import ijson  # loaded on first use, as the package's other heavy libraries

    name = str(path)
    at = _Position()
    fh = _open(path, what, error)
    try:
        events = ijson.basic_parse(fh, use_float=True, buf_size=BLOCK_BYTES)
        try:
            yield from _members(events, name, what, kinds, at, error)
        except ijson.JSONError as err:
            raise _syntax_error(err, name, what, at, error) from None
        except UnicodeDecodeError as err:
            raise error(f"{name}: {at.text()}: the {what} is not UTF-8 ({err.reason})", path=name) from None
    finally:
        fh.close()


def _members(events: Iterator[tuple[str, Any]], name: str, what: str, kinds: tuple[str, ...], at: _Position,
             error: ErrorType) -> Iterator[tuple[str | int, Any]]:
    first = next(events, None)
    expected = " or ".join({"object": "an object", "array": "an array"}[k] for k in kinds)
    if first is None:
        raise error(f"{name}: the {what} is empty; expected {expected}", path=name)
    event, value = first
    kind = {"start_map": "object", "start_array": "array"}.get(event)
    if kind not in kinds:
        found = {"start_map": "an object", "start_array": "an array"}.get(event, f"a {event} ({describe(value)})")
        raise error(f"{name}: expected {expected} at the top level, found {found}", path=name)
    scalars = _SCALARS
    if kind == "object":  # one tight loop per kind: this runs ten million times for a large file
        for event, key in events:
            if event == "end_map":
                break
            at.key = key
            event, value = next(events)
            yield key, (value if event in scalars else _build(event, events, name, at, error))
    else:
        index = 0
        for event, value in events:
            if event == "end_array":
                break
            at.key = index
            yield index, (value if event in scalars else _build(event, events, name, at, error))
            index += 1  # noqa: SIM113 - counts members, not the events the loop reads
    for event, _ in events:  # trailing data makes ijson raise
        raise error(f"{name}: extra data after the top-level value ({event})", path=name)  # pragma: no cover


def _build(event: str, events: Iterator[tuple[str, Any]], name: str, at: _Position, error: ErrorType,
           depth: int = 2) -> Any:
    """One container value at nesting ``depth`` (the top level is 1), with the depth and repeated-key rules.
    Recursive, but never deeper than MAX_JSON_DEPTH calls."""
    if depth > MAX_JSON_DEPTH:
        raise error(f"{name}: {at.text()}: JSON nested deeper than {MAX_JSON_DEPTH} levels; allowed: at most "
                    f"{MAX_JSON_DEPTH}", path=name)
    scalars = _SCALARS
    if event == "start_map":
        obj: dict[str, Any] = {}
        for event, key in events:
            if event == "end_map":
                return obj
            if key in obj:
                raise error(f"{name}: {at.text()}: the key {describe(key)} appears twice in one object; a key may "
                            "be given only once", path=name)
            event, value = next(events)
            obj[key] = value if event in scalars else _build(event, events, name, at, error, depth + 1)
    else:
        items: list[Any] = []
        for event, value in events:
            if event == "end_array":
                return items
            items.append(value if event in scalars else _build(event, events, name, at, error, depth + 1))
    raise error(f"{name}: {at.text()}: the file ends in the middle of a value; it may be truncated", path=name)


def iter_lines(path: PathLike, what: str, *, error: ErrorType = InputFileError) -> Iterator[tuple[int, Any]]:
    """``(line number, value)`` for every non-blank line of a JSON Lines file, each parsed with the rules of
    :func:`craft_dsl.files.parse_json`."""
    name = str(path)
    fh = _open(path, what, error)
    try:
        number = 0
        while True:
            raw = fh.readline(MAX_LINE_BYTES + 1)
            if not raw:
                return
            number += 1
            if len(raw) > MAX_LINE_BYTES:
                raise error(f"{name}: line {number}: longer than {MAX_LINE_BYTES:,} bytes", path=name, line=number)
            if not raw.strip():
                continue
            where = f"{name}: line {number}"
            try:
                value = parse_json(decode_text(raw, where, what, error=error, path=name), where, what, error=error,
                                   path=name)
            except InputFileError as err:  # the message gives "line 1" of the line's own text: say the file's line
                raise error(str(err).replace(f"{where}: line 1, ", f"{where}, ", 1), path=name, line=number,
                            column=err.column, field=err.field) from None
            yield number, value
    finally:
        fh.close()
