"""The public Program type: parse, print, type, run, trace, node lists."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

from .checker import CheckedProgram, check_tree
from .evaluator import Plan, TraceEntry
from .ir import Node, node_texts, to_exprs
from .nodes import check_nodes
from .parser import check_text
from .simulation import Event, Simulation
from .syntax import Tree, format_expr, format_tree
from .tokens import check_tokens
from .types import INVALID, INVALID_JSON, DslType
from .vocabulary import ORIGINAL_EVENT_TYPE

if TYPE_CHECKING:
    from .tokens import NameStyle, TokenOrder


class Program:
    """A type-checked CRAFT program.

    Build one with :func:`parse` (text form), :meth:`Program.from_nodes` (CLEVR/CRAFT node list) or
    :meth:`Program.from_tokens` (prefix or postfix token sequence). ``str(program)`` is the canonical text form,
    and ``parse(str(p)) == p``. :attr:`key` identifies what the program computes whatever form it came in
    (``Var`` bindings inlined): two programs with equal keys are the same program.
    """

    __slots__ = ("_checked", "_plan", "type", "_nodes", "_signature")

    def __init__(self, tree: Tree) -> None:
        self._init(check_tree(tree))

    def _init(self, checked: CheckedProgram) -> None:
        self._checked = checked
        self._plan = Plan(checked.raw, checked.root)
        self.type: DslType = checked.type
        self._nodes: tuple[tuple[dict[str, Any], str, int], ...] | None = None
        self._signature: tuple[str, ...] | None = None

    @classmethod
    def _from_checked(cls, checked: CheckedProgram) -> Program:
        program = cls.__new__(cls)
        program._init(checked)
        return program

    # -- construction -------------------------------------------------------------------------------

    @classmethod
    def parse(cls, text: str) -> Program:
        """Parse and type-check the text form (see docs/language.md)."""
        return cls._from_checked(check_text(text))

    @classmethod
    def from_nodes(cls, nodes: Sequence[Mapping[str, Any]], params: Mapping[str, str] | None = None) -> Program:
        """Read a CLEVR/CRAFT node list (original or canonical names; ``_output`` is ignored).

        ``params`` binds template placeholders such as ``{"<Z>": "small", "<C>": "red"}``.
        """
        return cls._from_checked(check_nodes(nodes, params))

    @classmethod
    def from_tokens(cls, tokens: Sequence[str] | str, order: TokenOrder = "prefix") -> Program:
        """Read a prefix or postfix token sequence (a list of tokens, or one space-separated string)."""
        return cls._from_checked(check_tokens(tokens, order))

    # -- forms ----------------------------------------------------------------------------------------

    @property
    def key(self) -> tuple[Node, ...]:
        """The checked nodes: equal for programs that compute the same expression (bindings inlined)."""
        return self._checked.nodes

    @property
    def nodes(self) -> tuple[Node, ...]:
        """The checked nodes in dependency order (see :mod:`craft_dsl.ir`); the last one is the answer."""
        return self._checked.nodes

    @property
    def source_nodes(self) -> tuple[int | None, ...]:
        """For the k-th module call of the form the program was read from (node k of a node list, the k-th
        module token, the k-th call in reading order of text), its index in :attr:`nodes` (None if unused)."""
        return self._checked.source_nodes

    @property
    def tree(self) -> Tree:
        """The checked syntax tree (canonical names and values, explicit Unique)."""
        if self._checked.tree is not None:
            return self._checked.tree
        return Tree((), to_exprs(self._checked.nodes)[-1])

    @property
    def binding_types(self) -> dict[str, DslType]:
        return dict(self._checked.binding_types)

    def to_nodes(self, outputs: Simulation | None = None) -> list[dict[str, Any]]:
        """The node list for the original tools (original names and argument order).

        With ``outputs=sim``, every node carries the ``_output`` the original engine would cache.
        """
        if self._nodes is None:  # the node list does not depend on the simulation: build it once
            from .nodes import nodes_from_checked

            self._nodes = tuple((node, node.pop("_text"), node.pop("_node"))
                                for node in nodes_from_checked(self._checked.nodes))
        values = self.values(outputs) if outputs is not None else None
        out = []
        for node, _text, index in self._nodes:
            copy = {**node, "inputs": list(node["inputs"]), "value_inputs": list(node["value_inputs"])}
            if values is not None:
                copy["_output"] = to_json(values[index], original=True)
            out.append(copy)
        return out

    def to_tokens(self, order: TokenOrder = "prefix", *, names: NameStyle = "canonical",
                  fused: bool = False) -> list[str]:
        """The token sequence (see :mod:`craft_dsl.tokens`); ``from_tokens`` reads it back to an equal program."""
        from .tokens import to_tokens

        return to_tokens(self._checked.nodes, order, names=names, fused=fused)

    # -- evaluation -----------------------------------------------------------------------------------

    def run(self, sim: Simulation) -> Any:
        """The answer over ``sim``: bool, int or str for question programs, or INVALID."""
        return self._plan.run(sim)

    def values(self, sim: Simulation) -> list[Any]:
        """The value of every node of :attr:`nodes` over ``sim`` (literals included)."""
        raw = self._plan.values(sim)
        return [raw[i] for i in self._checked.order]

    def trace(self, sim: Simulation) -> list[TraceEntry]:
        """Every module node's value, in evaluation order (shared sub-expressions appear once)."""
        nodes = self._checked.nodes
        values = self.values(sim)
        texts = node_texts(nodes)
        return [TraceEntry(i, texts[i], node.type, values[i]) for i, node in enumerate(nodes) if node.module]

    # -- identity -------------------------------------------------------------------------------------

    def _binding_signature(self) -> tuple[str, ...]:
        if self._signature is None:
            tree = self._checked.tree
            self._signature = tuple(f"{b.name}={format_expr(b.expr)}" for b in tree.bindings) if tree else ()
        return self._signature

    def __str__(self) -> str:
        if self._checked.tree is not None:
            return format_tree(self._checked.tree)
        return node_texts(self._checked.nodes)[-1]

    def __repr__(self) -> str:
        text = str(self).replace("\n", "; ")
        return f"Program({text!r}) -> {self.type}"

    def __eq__(self, other: object) -> bool:
        return (isinstance(other, Program) and self._checked.nodes == other._checked.nodes
                and self._binding_signature() == other._binding_signature())

    def __hash__(self) -> int:
        return hash(self._checked.nodes)

    def __getstate__(self) -> CheckedProgram:
        return self._checked

    def __setstate__(self, checked: CheckedProgram) -> None:
        self._init(checked)


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
