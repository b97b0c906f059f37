"""The public Program type: parse, print, type, run, trace, node lists."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from .checker import check_tree
from .evaluator import Plan, TraceEntry
from .parser import parse_tree
from .simulation import Event, Simulation
from .syntax import Tree, format_tree
from .types import INVALID, INVALID_JSON, DslType
from .vocabulary import ORIGINAL_EVENT_TYPE


class Program:
    """A type-checked CRAFT program.

    Build one with :func:`parse` (text form) or :meth:`Program.from_nodes` (CLEVR/CRAFT node list).
    ``str(program)`` is the canonical text form, and ``parse(str(p)) == p``.
    """

    def __init__(self, tree: Tree) -> None:
        checked = check_tree(tree)
        self.tree: Tree = checked.tree
        self.type: DslType = checked.type
        self.binding_types = checked.binding_types
        self._plan = Plan(self.tree, checked.call_types)
        self._nodes: tuple[tuple[dict[str, Any], str], ...] | None = None

    # -- construction -------------------------------------------------------------------------------

    @classmethod
    def parse(cls, text: str) -> Program:
        """Parse and type-check the text form (see docs/language.md)."""
        return cls(parse_tree(text))

    @classmethod
    def from_nodes(cls, nodes: Sequence[Mapping[str, Any]], params: Mapping[str, str] | None = None) -> Program:
        """Read a CLEVR/CRAFT node list (original or canonical names; ``_output`` is ignored).

        ``params`` binds template placeholders such as ``{"<Z>": "small", "<C>": "red"}``.
        """
        from .nodes import tree_from_nodes

        return cls(tree_from_nodes(nodes, params))

    def to_nodes(self, outputs: Simulation | None = None) -> list[dict[str, Any]]:
        """The node list for the original tools (original names and argument order).

        With ``outputs=sim``, every node carries the ``_output`` the original engine would cache.
        """
        if self._nodes is None:  # the node list does not depend on the simulation: build it once
            from .nodes import nodes_from_tree

            self._nodes = tuple((node, node.pop("_text")) for node in nodes_from_tree(self.tree))
        values = {e.expression: e.value for e in self.trace(outputs)} if outputs is not None else None
        out = []
        for node, text in self._nodes:
            copy = {**node, "inputs": list(node["inputs"]), "value_inputs": list(node["value_inputs"])}
            if values is not None:
                copy["_output"] = to_json(values.get(text, INVALID), original=True)
            out.append(copy)
        return out

    # -- evaluation -----------------------------------------------------------------------------------

    def run(self, sim: Simulation) -> Any:
        """The answer over ``sim``: bool, int or str for question programs, or INVALID."""
        return self._plan.run(sim)

    def trace(self, sim: Simulation) -> list[TraceEntry]:
        """Every node's value, in evaluation order (shared sub-expressions appear once)."""
        return self._plan.trace(sim)

    # -- identity -------------------------------------------------------------------------------------

    def __str__(self) -> str:
        return format_tree(self.tree)

    def __repr__(self) -> str:
        text = str(self).replace("\n", "; ")
        return f"Program({text!r}) -> {self.type}"

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Program) and self.tree == other.tree

    def __hash__(self) -> int:
        return hash(self.tree)


def parse(text: str) -> Program:
    """Parse and type-check a program in the text form."""
    return Program.parse(text)


def to_json(value: Any, original: bool = False) -> Any:
    """A JSON-ready form of any DSL value (INVALID as the original's ``"__INVALID__"``).

    With ``original=True`` event types use the original simulator's strings (``ContainerEndUp``...).
    """
    if value is INVALID:
        return INVALID_JSON
    if isinstance(value, Event):
        etype = ORIGINAL_EVENT_TYPE[value.type] if original else value.type
        return {"id": value.id, "type": etype, "step": value.step, "objects": list(value.objects)}
    if isinstance(value, tuple):
        return [to_json(v, original) for v in value]
    return value


def format_value(value: Any) -> str:
    """A short human-readable form of a DSL value."""
    if isinstance(value, tuple):
        return "[" + ", ".join(format_value(v) for v in value) + "]"
    return repr(value) if isinstance(value, Event) else str(value)
