"""The 67 CRAFT question templates (original node lists), as data.

``template_programs.txt`` restates the original template files in a compact notation:
``k:type(i,j;P)`` is node k of handler ``type`` with inputs i, j and side-input placeholder P.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
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


@lru_cache(maxsize=1)
def paraphrases() -> dict[str, tuple[str, ...]]:
    """The original paraphrases of every template (with ``*starred*`` words and placeholders)."""
    text = (Path(__file__).parent / "template_texts.txt").read_text(encoding="utf-8")
    out: dict[str, tuple[str, ...]] = {}
    for line in text.splitlines():
        if line.strip() and not line.startswith("#"):
            head, body = line.split(":", 1)
            tid = head.split("[")[0].strip()
            out[tid] = tuple(p.strip() for p in body.split("||"))
    return out


def question_text(template_id: str, params: dict[str, str], paraphrase: int = 0) -> str:
    """A plain rendering of one paraphrase: placeholders bound, starred words unstarred."""
    text = paraphrases()[template_id][paraphrase]
    for key in sorted(params, key=len, reverse=True):
        text = text.replace(key, params[key])
    text = re.sub(r"\*(.+?)\*", r"\1", text)
    return " ".join(text.split())


def instantiate(template: Template, sim: Any) -> tuple[dict[str, str], Any] | None:
    """The first valid binding and its answer, or None (see :func:`first_instance`)."""
    found = first_instance(template, sim)
    return None if found is None else (found[0], found[2])


def first_instances(sim: Any, include_dropped: bool = False) -> Iterator[tuple[Template, dict[str, str], Program, Any]]:
    """``(template, params, program, answer)`` for every template with a valid binding on ``sim``, in file order
    (the 19 dropped templates only with ``include_dropped``)."""
    for template in templates().values():
        if template.dropped and not include_dropped:
            continue
        found = first_instance(template, sim)
        if found is not None:
            yield (template, *found)


def first_instance(template: Template, sim: Any) -> tuple[dict[str, str], Program, Any] | None:
    """The first binding (objects in ascending id order) whose answer is not INVALID, or None.

    Object placeholders (<Z> <C> <S>, <Z2> <C2> <S2>) describe dynamic objects of ``sim``; a lone
    attribute placeholder takes the attribute values of the dynamic objects.
    """
    from .types import INVALID

    dynamic = [o for o in sim.objects if o.dynamic]
    ph = set(template.placeholders)

    def describe(o: Any, suffix: str) -> dict[str, str]:
        return {f"<Z{suffix}>": o.size, f"<C{suffix}>": o.color, f"<S{suffix}>": o.shape}

    candidates: list[dict[str, str]] = []
    if {"<Z2>", "<C2>", "<S2>"} <= ph:
        candidates = [{**describe(a, ""), **describe(b, "2")} for a in dynamic for b in dynamic if a.id != b.id]
    elif {"<Z>", "<C>", "<S>"} <= ph:
        candidates = [describe(a, "") for a in dynamic]
    elif ph:
        (key,) = ph
        attr = {"<Z>": "size", "<C>": "color", "<S>": "shape"}[key]
        candidates = [{key: v} for v in dict.fromkeys(getattr(o, attr) for o in dynamic)]
    else:
        candidates = [{}]
    for params in candidates:
        program = template.program(params)
        answer = program.run(sim)
        if answer is not INVALID:
            return params, program, answer
    return None
