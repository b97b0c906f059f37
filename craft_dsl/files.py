"""Reading input files: the one place that turns every way a file can be unreadable into a precise error.

Every command and loader reads its files through :func:`read_text` and :func:`read_json` (and in-memory JSON
text through :func:`parse_json`), so that every input gets the same checks and the same messages:

* the path must name a readable file: a missing file, a directory, a file without read permission or one larger
  than the reader's limit is refused by name;
* text must be UTF-8 (a UTF-8 byte order mark is skipped); UTF-16/UTF-32 files and undecodable bytes are refused
  with the line and column of the first bad byte;
* JSON must be standard JSON: no ``NaN``/``Infinity``, no key given twice in one object, no integer longer than
  :data:`MAX_INTEGER_DIGITS` digits, nesting at most :data:`MAX_JSON_DEPTH` levels. Each is reported with its
  line, column and field path.

Errors are :class:`craft_dsl.errors.InputFileError`, or the subclass a caller names (``SimulationFileError``
for simulations, ...). Limits on the *values* (an id, a step, an answer) belong to each format's reader.
"""

from __future__ import annotations

import codecs
import json
import math
import os
import re
from collections.abc import Iterator
from dataclasses import dataclass
from typing import IO, Any

from .errors import InputFileError

#: JSON deeper than this is refused (CRAFT files nest at most 8 levels; node lists and predictions fewer).
MAX_JSON_DEPTH = 100
#: Integers longer than this (Python's limit for converting text to int) are refused.
MAX_INTEGER_DIGITS = 4300
#: Default limit on files read whole into memory (larger predictions files can be JSON Lines, read as a stream).
MAX_FILE_BYTES = 1 << 30
#: The smallest and largest integer a file may give where an integer is an id, a step, an index or a count.
INT64_MIN, INT64_MAX = -(1 << 63), (1 << 63) - 1

_BOMS = (
    (codecs.BOM_UTF32_LE, "UTF-32"), (codecs.BOM_UTF32_BE, "UTF-32"),
    (codecs.BOM_UTF16_LE, "UTF-16"), (codecs.BOM_UTF16_BE, "UTF-16"),
)

ErrorType = type[InputFileError]
PathLike = str | os.PathLike[str]


# -- reading bytes and text --------------------------------------------------------------------------------


def open_binary(path: PathLike, what: str, *, error: ErrorType = InputFileError) -> IO[bytes]:
    """``path`` opened for reading bytes; a missing file, a directory or an unreadable one is ``error`` naming the
    file and its role (``what``)."""
    name = str(path)
    try:
        return open(path, "rb")  # noqa: SIM115 - the caller closes it
    except FileNotFoundError:
        raise error(f"{name}: no such file (expected the {what})", path=name) from None
    except IsADirectoryError:
        raise error(f"{name}: is a directory; expected the {what} (a file)", path=name) from None
    except OSError as err:
        raise error(f"{name}: cannot read the {what}: {err.strerror or err}", path=name) from None


def refuse_utf16_or_32(head: bytes, where: str, what: str, *, error: ErrorType = InputFileError,
                       path: str | None = None) -> None:
    """Refuse text whose first bytes ``head`` are a UTF-16 or UTF-32 byte order mark (say which, and to save it as
    UTF-8)."""
    for bom, encoding in _BOMS:
        if head.startswith(bom):
            raise error(f"{where}: the {what} is {encoding} text (it starts with a {encoding} byte order mark); "
                        "save it as UTF-8", path=path, line=1, column=1)


def read_bytes(path: PathLike, what: str, *, error: ErrorType = InputFileError,
               max_bytes: int = MAX_FILE_BYTES) -> bytes:
    """The bytes of a file; ``what`` names the file's role in messages ("simulation file")."""
    name = str(path)
    try:
        with open_binary(path, what, error=error) as fh:
            size = os.fstat(fh.fileno()).st_size
            too_large = size > max_bytes  # refused below without reading it
            data = b"" if too_large else fh.read() if size else _read_at_most(fh, max_bytes)
    except OSError as err:
        raise error(f"{name}: cannot read the {what}: {err.strerror or err}", path=name) from None
    if too_large or len(data) > max_bytes:
        raise error(f"{name}: the {what} is larger than {max_bytes:,} bytes, the most this reader holds in memory",
                    path=name)
    return data


def _read_at_most(fh: Any, max_bytes: int) -> bytes:
    """The bytes of a file without a size (a pipe, a device), or ``max_bytes + 1`` of them if it is longer."""
    chunks: list[bytes] = []
    total = 0
    while total <= max_bytes:
        chunk = fh.read(min(1 << 20, max_bytes + 1 - total))
        if not chunk:
            break
        chunks.append(chunk)
        total += len(chunk)
    return chunks[0] if len(chunks) == 1 else b"".join(chunks)


def decode_text(data: bytes, where: str, what: str, *, error: ErrorType = InputFileError,
                path: str | None = None) -> str:
    """``data`` decoded as UTF-8 (a byte order mark is skipped); anything else is refused with its position."""
    refuse_utf16_or_32(data, where, what, error=error, path=path)
    if data.startswith(codecs.BOM_UTF8):
        data = data[len(codecs.BOM_UTF8):]
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as err:
        line = data.count(b"\n", 0, err.start) + 1
        line_start = data.rfind(b"\n", 0, err.start) + 1
        column = len(data[line_start:err.start].decode("utf-8", errors="replace")) + 1
        bad = data[err.start:err.start + 1].hex()
        hint = "save it as UTF-8"
        if b"\x00" in data[:64]:
            hint = "it looks like UTF-16: save it as UTF-8"
        elif data[err.start] >= 0x80:
            hint = "Latin-1 or Windows-1252 text? Save it as UTF-8"
        raise error(f"{where}: line {line}, column {column}: the {what} is not UTF-8: byte 0x{bad} cannot be "
                    f"decoded ({err.reason}); {hint}", path=path, line=line, column=column) from None


def read_text(path: PathLike, what: str, *, error: ErrorType = InputFileError,
              max_bytes: int = MAX_FILE_BYTES) -> str:
    """The text of a UTF-8 file (see the module docstring for what is refused)."""
    name = str(path)
    return decode_text(read_bytes(path, what, error=error, max_bytes=max_bytes), name, what, error=error, path=name)


# -- JSON ------------------------------------------------------------------------------------------------------


class _Duplicate(Exception):
    def __init__(self, key: str) -> None:
        self.key = key


class _NonStandard(Exception):
    def __init__(self, name: str) -> None:
        self.name = name


def _no_duplicates(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    out = dict(pairs)
    if len(out) != len(pairs):
        seen: set[str] = set()
        for key, _ in pairs:
            if key in seen:
                raise _Duplicate(key)
            seen.add(key)
    return out


def _no_constants(name: str) -> Any:
    raise _NonStandard(name)


def _finite_float(text: str) -> float:
    value = float(text)
    if value in (math.inf, -math.inf):  # 1e999: beyond the range of a float
        raise _NonStandard(text)
    return value


_DECODER = json.JSONDecoder(object_pairs_hook=_no_duplicates, parse_constant=_no_constants,
                            parse_float=_finite_float)


def read_json(path: PathLike, what: str, *, error: ErrorType = InputFileError,
              max_bytes: int = MAX_FILE_BYTES) -> Any:
    """The parsed JSON of a file, with every check of the module docstring."""
    name = str(path)
    return parse_json(read_text(path, what, error=error, max_bytes=max_bytes), name, what, error=error, path=name)


def parse_json(text: str | bytes, where: str, what: str = "JSON", *, error: ErrorType = InputFileError,
               path: str | None = None) -> Any:
    """Parse JSON text with the checks of :func:`read_json`; ``where`` starts every message."""
    if isinstance(text, bytes):
        text = decode_text(text, where, what, error=error, path=path)
    try:
        value = _DECODER.decode(text)
    except json.JSONDecodeError as err:
        hint = "; the file may be truncated" if err.pos >= len(text.rstrip()) else ""
        raise error(f"{where}: line {err.lineno}, column {err.colno}: not valid JSON: {err.msg}{hint}",
                    path=path, line=err.lineno, column=err.colno) from None
    except (_Duplicate, _NonStandard, RecursionError, ValueError):
        problem = find_problem(text)
        if problem is None:  # pragma: no cover - every failure above has a cause the scanner finds
            raise error(f"{where}: cannot be read as JSON", path=path) from None
        raise problem.error(where, error, path) from None
    if _too_deep(value):
        found = find_problem(text)
        if found is not None:
            raise found.error(where, error, path)
    if "\\ud" in text or "\\uD" in text:
        _check_surrogates(text, where, error, path)
    return value


_SURROGATE_ESCAPE = re.compile(r"(?<!\\)((?:\\\\)*)\\u([dD][89a-fA-F][0-9a-fA-F]{2})"
                               r"(?:\\u([dD][c-fC-F][0-9a-fA-F]{2}))?")


def _check_surrogates(text: str, where: str, error: ErrorType, path: str | None) -> None:
    """Refuse a lone UTF-16 surrogate escape (``"\\ud800"``): the string it makes cannot be written as UTF-8."""
    for m in _SURROGATE_ESCAPE.finditer(text):
        high = m.group(2)[1].lower() in "89ab"  # a high surrogate must be followed by a low one; a low one alone
        if not high or m.group(3) is None:  # (one that follows a high one was matched with it)
            pos = m.start(2) - 2
            line = text.count("\n", 0, pos) + 1
            column = pos - (text.rfind("\n", 0, pos) + 1) + 1
            raise error(f"{where}: line {line}, column {column}: the escape \\u{m.group(2)} is half of a UTF-16 "
                        "surrogate pair; allowed: escapes of whole characters", path=path, line=line, column=column)


def _too_deep(value: Any, limit: int = MAX_JSON_DEPTH) -> bool:
    """Whether ``value`` nests more than ``limit`` containers (an iterative walk that skips scalars)."""
    if not isinstance(value, (dict, list)):
        return False
    stack: list[tuple[Any, int]] = [(value, 1)]
    while stack:
        item, depth = stack.pop()
        if depth > limit:
            return True
        children = item.values() if isinstance(item, dict) else item
        for child in children:
            if isinstance(child, (dict, list)):
                stack.append((child, depth + 1))
    return False


@dataclass(frozen=True)
class JsonProblem:
    """What is wrong with a JSON text that Python's parser refused or that breaks a rule of this module."""

    message: str
    position: int
    line: int
    column: int
    field: str

    def error(self, where: str, error: ErrorType, path: str | None) -> InputFileError:
        at = f" (field {self.field})" if self.field else ""
        return error(f"{where}: line {self.line}, column {self.column}{at}: {self.message}",
                     path=path, line=self.line, column=self.column, field=self.field or None)


_TOKEN = re.compile(
    r'[ \t\n\r]*(?:(?P<s>"[^"\\]*(?:\\.[^"\\]*)*")|(?P<p>[{}\[\]:,])'
    r"|(?P<n>-?[0-9]+(?:\.[0-9]+)?(?:[eE][+-]?[0-9]+)?)|(?P<w>true|false|null|NaN|-?Infinity))",
    re.S,
)


_PLAIN_KEY = re.compile(r"[A-Za-z0-9_\-]{1,60}")


def key_text(key: Any) -> str:
    """A key of a field path as written in messages: plain keys as they are, any other (spaces, newlines, a
    5,000-character key) quoted and shortened, so that a path stays one short line."""
    text = str(key) if isinstance(key, (str, int)) and not isinstance(key, bool) else describe(key, 30)
    return text if _PLAIN_KEY.fullmatch(text) else describe(str(key), 30)


def _field_path(stack: list[list[Any]], shown: int = 4) -> str:
    parts: list[str] = []
    for frame in stack:
        if frame[0] == "{" and frame[2] is not None:
            parts.append(f".{key_text(frame[2])}" if parts else key_text(frame[2]))
        elif frame[0] == "[":
            parts.append(f"[{frame[1]}]")
    if len(parts) > 2 * shown:
        parts = [*parts[:shown], f"...({len(parts) - 2 * shown} more)...", *parts[-shown:]]
    return "".join(parts)


def _iter_tokens(text: str) -> Iterator[tuple[str, str, int]]:
    pos, n = 0, len(text)
    while pos < n:
        m = _TOKEN.match(text, pos)
        if m is None or m.lastgroup is None:
            return
        kind = m.lastgroup
        yield kind, m.group(kind), m.start(kind)
        pos = m.end()


def find_problem(text: str, max_depth: int = MAX_JSON_DEPTH) -> JsonProblem | None:
    """The first breach of this module's JSON rules in ``text`` (depth, repeated key, non-standard constant,
    over-long integer), with its line, column and field path; None if there is none up to the first syntax
    error. A pure-Python scan: only called once something is known to be wrong."""
    stack: list[list[Any]] = []  # [kind, keys seen (object) or item count (array), current key, expect key]

    def problem(message: str, pos: int) -> JsonProblem:
        line = text.count("\n", 0, pos) + 1
        column = pos - (text.rfind("\n", 0, pos) + 1) + 1
        return JsonProblem(message, pos, line, column, _field_path(stack))

    for kind, tok, pos in _iter_tokens(text):
        top = stack[-1] if stack else None
        if kind == "p":
            if tok in "{[":
                if len(stack) >= max_depth:
                    return problem(f"JSON nested deeper than {max_depth} levels; allowed: at most {max_depth}", pos)
                stack.append(["{", set(), None, True] if tok == "{" else ["[", 0, None, False])
            elif tok in "}]":
                if stack:
                    stack.pop()
            elif tok == "," and top is not None:
                if top[0] == "{":
                    top[3] = True
                else:
                    top[1] += 1
            continue
        if top is not None and top[0] == "{" and top[3]:
            if kind != "s":
                return None  # a syntax error: the parser's message says it better
            key = json.loads(tok)
            if key in top[1]:
                top[2] = None
                return problem(f"the key {key!r} appears twice in one object; a key may be given only once", pos)
            top[1].add(key)
            top[2], top[3] = key, False
            continue
        if kind == "w" and tok in ("NaN", "Infinity", "-Infinity"):
            return problem(f"{tok} is not a JSON number; allowed: finite numbers", pos)
        if kind == "n":
            digits = len(tok.lstrip("-").split(".")[0].split("e")[0].split("E")[0])
            if digits > MAX_INTEGER_DIGITS:
                return problem(f"a number with {digits} digits; allowed: at most {MAX_INTEGER_DIGITS} digits", pos)
            if any(c in tok for c in ".eE") and float(tok) in (math.inf, -math.inf):
                return problem(f"the number {describe(tok)[1:-1]} is out of range; allowed: finite numbers (at most "
                               "about 1.8e308)", pos)
    return None


# -- values --------------------------------------------------------------------------------------------------


def describe(value: Any, limit: int = 60) -> str:
    """A short text of ``value`` for messages: a string as Python writes it, anything else as JSON; cut at
    ``limit`` characters; never fails."""
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) >= 10 ** 30:
        return f"an integer of {_digits(value)} digits"
    if isinstance(value, str):
        return repr(value) if len(value) <= limit else f"{value[:limit - 3]!r}... ({len(value):,} characters)"
    try:
        text = json.dumps(value, ensure_ascii=False)
    except (TypeError, ValueError, RecursionError):
        text = f"a {type(value).__name__}"
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _digits(value: int) -> str:
    """The number of decimal digits of a (possibly huge) integer, without converting it to text."""
    bits = abs(value).bit_length()
    estimate = int(bits * math.log10(2)) + 1
    return f"about {estimate:,}" if estimate > MAX_INTEGER_DIGITS else str(len(str(abs(value))))


def int_in_range(value: Any, low: int = INT64_MIN, high: int = INT64_MAX) -> bool:
    """Whether ``value`` is an int (not a bool) with ``low <= value <= high``."""
    return type(value) is int and low <= value <= high


def finite_number(value: Any) -> bool:
    """Whether ``value`` is an int or a finite float (not a bool)."""
    if type(value) is int:
        return True
    return type(value) is float and math.isfinite(value)
