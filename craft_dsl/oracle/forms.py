"""The forms a predicted program comes in, and a cache that checks and compiles each distinct program once.

A model emits a program as DSL text (a string), a CLEVR/CRAFT node list (a list of ``{"type", "inputs",
"value_inputs"}`` objects) or a token sequence in prefix or postfix order (a list of strings, or one
space-separated string). :func:`read_program` reads any of them; :class:`ProgramCache` remembers the result
(the program, or the error) by the exact form, so a training loop that re-scores the programs it emitted
before (beams, epochs) pays for reading, checking and compiling once.
"""

from __future__ import annotations

import marshal
from collections.abc import Mapping, Sequence
from typing import Any, Literal

from ..errors import CraftError, ProgramError
from ..program import Program

ProgramForm = Literal["text", "nodes", "prefix", "postfix"]
FORMS: tuple[str, ...] = ("text", "nodes", "prefix", "postfix")


def detect_form(program: Any, token_order: str = "prefix") -> ProgramForm:
    """The form of a predicted program: a string is text, a list of objects a node list, a list of strings
    tokens (in ``token_order``)."""
    if isinstance(program, str):
        return "text"
    if isinstance(program, Sequence) and program and all(isinstance(x, Mapping) for x in program):
        return "nodes"
    if isinstance(program, Sequence) and all(isinstance(x, str) for x in program):
        if token_order not in ("prefix", "postfix"):
            raise CraftError(f"token order must be 'prefix' or 'postfix', not {token_order!r}")
        return "prefix" if token_order == "prefix" else "postfix"
    raise CraftError(
        f"a program must be DSL text (a string), a node list (a list of objects) or tokens (a list of strings); "
        f"found {type(program).__name__}"
    )


def read_program(program: Any, form: ProgramForm | None = None) -> Program:
    """Read a program in any form (detected when ``form`` is None; a string is then DSL text, so give
    ``form="prefix"`` or ``"postfix"`` for a space-separated token string)."""
    form = form or detect_form(program)
    if form == "text":
        if not isinstance(program, str):
            raise CraftError(f"a text program must be a string, found {type(program).__name__}")
        return Program.parse(program)
    if form == "nodes":
        return Program.from_nodes(program)
    if form in ("prefix", "postfix"):
        return Program.from_tokens(program, form)
    raise CraftError(f"unknown program form {form!r}; allowed: {', '.join(FORMS)}")


def _node_key(nodes: Sequence[Mapping[str, Any]]) -> bytes:
    """The exact written form of a node list: marshal's version 2 (no back-references, so equal lists give equal
    bytes), which tells apart what a looser key would merge (``"inputs": null`` from no ``inputs``, ``1`` from
    ``True``, a node's every field); raises ValueError for objects marshal cannot write."""
    return marshal.dumps(nodes, 2)  # type: ignore[arg-type]  # refused with ValueError where not plain


class ProgramCache:
    """Programs (or the errors they raise) by their exact written form; at most ``maxsize`` are kept, the
    oldest entries leaving first."""

    def __init__(self, maxsize: int = 100_000) -> None:
        if maxsize < 1:
            raise ValueError(f"maxsize must be at least 1, not {maxsize}")
        self.maxsize = maxsize
        self._entries: dict[tuple[str, Any], Program | ProgramError] = {}
        self.hits = 0
        self.misses = 0

    def get(self, program: Any, form: ProgramForm | None = None) -> Program:
        """The checked program; raises the same ProgramError as :func:`read_program` would."""
        form = form or detect_form(program)
        try:
            if form == "nodes":
                key: Any = _node_key(program)
            elif isinstance(program, str):
                key = program
            else:
                key = tuple(program)
            entry = self._entries.get((form, key))
        except (TypeError, ValueError):  # not iterable, not hashable, or not a plain node list: read it for the
            return read_program(program, form)  # precise error
        if entry is None:
            self.misses += 1
            try:
                entry = read_program(program, form)
            except ProgramError as err:
                entry = err
            if len(self._entries) >= self.maxsize:
                del self._entries[next(iter(self._entries))]
            self._entries[(form, key)] = entry
        else:
            self.hits += 1
        if isinstance(entry, ProgramError):
            raise entry
        return entry

    def __len__(self) -> int:
        return len(self._entries)
