"""Simulations by video id: a streaming index of annotations.json, loaded on demand."""

from __future__ import annotations

import codecs
import json
import re
from collections import OrderedDict
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import IO, Any

from ..errors import CraftError, DatasetFileError, SimulationFileError
from ..files import MAX_JSON_DEPTH, parse_json
from ..simulation import Simulation
from .formats import PathLike, _read_json

_WS = re.compile(r"[ \t\n\r]*")


class _Stream:
    """Incremental reader of one JSON document, keeping byte offsets of what it decodes."""

    def __init__(self, fh: IO[bytes], where: str, chunk_size: int) -> None:
        self.fh = fh
        self.where = where
        self.chunk_size = chunk_size
        self.decoder = codecs.getincrementaldecoder("utf-8")()
        self.json = json.JSONDecoder()
        self.text = ""
        self.base = 0  # byte offset of text[0]
        self.ascii = True
        self.i = 0
        self.eof = False

    def more(self) -> bool:
        if self.eof:
            return False
        data = self.fh.read(self.chunk_size)
        try:
            new = self.decoder.decode(data, final=not data)
        except UnicodeDecodeError as err:
            raise DatasetFileError(f"{self.where}: not UTF-8 text near byte {self.base + len(self.text)}: "
                                   f"{err.reason}") from None
        if not data:
            self.eof = True
        consumed = self.text[: self.i]
        self.base += len(consumed) if self.ascii else len(consumed.encode("utf-8"))
        self.text = self.text[self.i:] + new
        self.i = 0
        self.ascii = self.text.isascii()
        return True

    def offset(self, i: int) -> int:
        return self.base + (i if self.ascii else len(self.text[:i].encode("utf-8")))

    def peek(self) -> str:
        while True:
            self.i = _WS.match(self.text, self.i).end()  # type: ignore[union-attr]
            if self.i < len(self.text):
                return self.text[self.i]
            if not self.more():
                return ""

    def expect(self, chars: str, what: str) -> str:
        c = self.peek()
        if not c or c not in chars:
            found = repr(c) if c else "the end of the file (truncated?)"
            raise DatasetFileError(f"{self.where}: expected {what} at byte {self.offset(self.i)}, found {found}")
        self.i += 1
        return c

    def value(self) -> tuple[Any, int, int]:
        """Decode the next value; return it with its byte span."""
        self.peek()
        while True:
            try:
                value, end = self.json.raw_decode(self.text, self.i)
            except json.JSONDecodeError as err:
                if self.more():
                    continue
                raise DatasetFileError(f"{self.where}: not valid JSON at byte {self.offset(err.pos)}: {err.msg} "
                                       "(the file may be truncated)", path=self.where) from None
            except RecursionError:
                raise DatasetFileError(f"{self.where}: the value at byte {self.offset(self.i)} is nested deeper than "
                                       f"{MAX_JSON_DEPTH} levels; allowed: at most {MAX_JSON_DEPTH}",
                                       path=self.where) from None
            if end == len(self.text) and self.more():
                continue  # a number may go on in the next chunk
            start = self.offset(self.i)
            self.i = end
            return value, start, self.offset(end)


def index_json_object(path: PathLike, chunk_size: int = 1 << 24) -> dict[str, tuple[int, int]]:
    """Byte spans ``{key: (start, end)}`` of the values of a top-level JSON object, in one streaming pass.

    Memory stays at about ``chunk_size`` plus one value, whatever the file size.
    """
    where = str(path)
    spans: dict[str, tuple[int, int]] = {}
    with open(path, "rb") as fh:
        s = _Stream(fh, where, chunk_size)
        s.expect("{", "a JSON object mapping video ids to simulations ('{')")
        if s.peek() == "}":
            return spans
        while True:
            if s.peek() != '"':
                s.expect('"', "a key string")
            key, _, _ = s.value()
            s.expect(":", "':'")
            _, start, end = s.value()
            if key in spans:
                raise DatasetFileError(f"{where}: key {key!r} appears twice")
            spans[key] = (start, end)
            if s.expect(",}", "',' or '}'") == "}":
                break
        if s.peek():
            raise DatasetFileError(f"{where}: extra data after the top-level object at byte {s.offset(s.i)}")
    return spans


class Annotations:
    """Simulations by video id (``"000042"``), loaded on demand.

    Build with :meth:`open` (``annotations.json``, or a directory of ``<id6>.json`` files) or
    :meth:`from_mapping` (an in-memory dict, e.g. from :func:`build_dataset`). A few recently used
    simulations are cached.
    """

    def __init__(self, name: str, loader: Callable[[str], Any], ids: Iterable[str], cache: int = 4) -> None:
        self.name = name
        self._loader = loader
        self._ids = list(ids)
        self._set = set(self._ids)
        self._cache: OrderedDict[str, Simulation] = OrderedDict()
        self._cache_size = cache

    @classmethod
    def from_mapping(cls, data: Mapping[str, Any], name: str = "annotations") -> Annotations:
        if not isinstance(data, Mapping):
            raise DatasetFileError(f"{name}: expected an object mapping video ids to simulations, "
                                   f"found {type(data).__name__}")
        keys = {str(k): k for k in data}
        return cls(name, lambda key: data[keys[key]], keys)

    @classmethod
    def open(cls, path: PathLike, chunk_size: int = 1 << 24) -> Annotations:
        p = Path(path)
        if p.is_dir():
            files = {f.stem: f for f in sorted(p.rglob("*.json")) if f.stem.isdigit()}
            if not files:
                raise DatasetFileError(f"{p}: directory holds no <id6>.json simulation files")
            return cls(str(p), lambda key: _read_json(files[key], "simulation"), files)
        if not p.exists():
            raise DatasetFileError(f"{p}: no such file (annotations)")
        try:
            spans = index_json_object(p, chunk_size)
        except OSError as err:
            raise DatasetFileError(f"{p}: cannot read ({err.strerror})") from None

        def load(key: str) -> Any:
            start, end = spans[key]
            with open(p, "rb") as fh:
                fh.seek(start)
                return parse_json(fh.read(end - start), f"{p}: simulation {key!r} (bytes {start}-{end})",
                                  "simulation", error=DatasetFileError, path=str(p))

        return cls(str(p), load, spans)

    def ids(self) -> list[str]:
        """Every video id, in file order."""
        return list(self._ids)

    def __len__(self) -> int:
        return len(self._ids)

    def __contains__(self, key: object) -> bool:
        return key in self._set

    def resolve(self, video: str, video_index: int) -> str | None:
        """The key of a video: its id6 name, or its index written plainly; None if absent."""
        for key in (video, f"{video_index:06d}", str(video_index)):
            if key in self._set:
                return key
        return None

    def raw(self, key: str) -> Any:
        """The parsed JSON of one simulation."""
        if key not in self._set:
            raise DatasetFileError(f"{self.name}: no simulation for video {key!r}")
        return self._loader(key)

    def simulation(self, key: str) -> Simulation:
        """One simulation, validated by :func:`craft_dsl.load_simulation`."""
        from ..recorded import load_simulation

        if key in self._cache:
            self._cache.move_to_end(key)
            return self._cache[key]
        data = self.raw(key)
        if not isinstance(data, Mapping):
            raise SimulationFileError(f"{self.name}[{key!r}]: expected a simulation object, found "
                                      f"{type(data).__name__}")
        try:
            sim = load_simulation(data)
        except CraftError as err:
            raise SimulationFileError(f"{self.name}[{key!r}]: {str(err).removeprefix('<dict>: ')}",
                                      path=None if self.name == "annotations" else self.name) from None
        self._cache[key] = sim
        if len(self._cache) > self._cache_size:
            self._cache.popitem(last=False)
        return sim


def open_annotations(source: PathLike | Mapping[str, Any] | Annotations) -> Annotations:
    """An :class:`Annotations` from a path (file or directory), a mapping, or an existing one."""
    if isinstance(source, Annotations):
        return source
    if isinstance(source, Mapping):
        return Annotations.from_mapping(source)
    return Annotations.open(source)
