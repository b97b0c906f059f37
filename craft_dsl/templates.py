"""The 67 CRAFT question templates (original node lists), as data.

``template_programs.txt`` restates the original template files in a compact notation:
``k:type(i,j;P)`` is node k of handler ``type`` with inputs i, j and side-input placeholder P.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

from .program import Program

_NODE = re.compile(r"(\d+):(\w+)\(([^;)]*)(?:;([^)]*))?\)")

#: The 19 basket-collision templates the original pipeline drops (the paper's 48 tasks are the rest).
DROPPED: frozenset[str] = frozenset(
    [f"descriptive_{i}" for i in (12, 13, 14, 15, 20, 21, 30, 31, 36, 37)]
    + ["counterfactual_2", "counterfactual_5", "counterfactual_8"]
    + [f"{c}_{i}" for c in ("cause", "enable", "prevent") for i in (2, 5)]
)


@dataclass(frozen=True)
class Template:
    """One template: id (``file_index``), family, index, node list with placeholders, placeholders."""

    id: str
    family: str
    index: int
    nodes: tuple[dict[str, Any], ...]
    placeholders: tuple[str, ...]

    @property
    def dropped(self) -> bool:
        return self.id in DROPPED

    def program(self, params: dict[str, str]) -> Program:
        """The template's program with placeholders bound, e.g. ``{"<Z>": "small", ...}``."""
        return Program.from_nodes([dict(n) for n in self.nodes], params)


def _parse_line(line: str) -> Template:
    tid, body = line.split(":", 1)
    nodes: list[dict[str, Any]] = []
    placeholders: list[str] = []
    for k, (idx, name, inputs, side) in enumerate(_NODE.findall(body)):
        if int(idx) != k:
            raise ValueError(f"template {tid}: node {idx} out of order")
        node: dict[str, Any] = {"type": name, "inputs": [int(i) for i in inputs.split(",") if i]}
        if side:
            node["side_inputs"] = [side]
            if side not in placeholders:
                placeholders.append(side)
        nodes.append(node)
    family, index = tid.rsplit("_", 1)
    return Template(tid, family, int(index), tuple(nodes), tuple(placeholders))


@lru_cache(maxsize=1)
def templates() -> dict[str, Template]:
    """All 67 templates by id, in file order (descriptive, counterfactual, cause, enable, prevent)."""
    text = (Path(__file__).parent / "template_programs.txt").read_text(encoding="utf-8")
    out: dict[str, Template] = {}
    for line in text.splitlines():
        if line.strip() and not line.startswith("#"):
            t = _parse_line(line.strip())
            out[t.id] = t
    return out
