"""The 20 CRAFT scene layouts as data files, and a seeded sampler that turns a layout into a WorldSpec.

A layout (``scenes/scene_NN.json``, format in ``docs/scenes.md``) names random variables, the basket, the
static elements and the dynamic-object slots of one scene, with every position, angle and velocity given
as a number, a small arithmetic expression over the variables, or an inline random draw. Files are
validated on load; :func:`sample_world` draws every random value from one seeded generator and builds the
bodies in the original creation order (walls, ground, basket, statics, dynamics), so uniqueIDs match.
"""

from __future__ import annotations

import ast
import functools
import math
import operator
import re
import warnings
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any, Final, Literal, TypeGuard, Union

import numpy as np
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    PlainSerializer,
    PlainValidator,
    PrivateAttr,
    SerializerFunctionWrapHandler,
    ValidationError,
    field_validator,
    model_serializer,
    model_validator,
)

from .errors import CraftError, ExpressionError, SceneFileError
from .files import describe, key_text, read_json
from .vocabulary import COLORS, SHAPES, SIZES
from .world import BodySpec, WorldSpec, assign_uids, make_dynamic, make_static

__all__ = [
    "LAYOUT_REVISION",
    "LAYOUT_REVISIONS",
    "RANDOM",
    "STATIC_ELEMENT_SHAPES",
    "BasketSpec",
    "Choice",
    "Const",
    "DynamicSlot",
    "Expr",
    "ExpressionError",
    "SceneFileError",
    "SceneLayout",
    "StaticElement",
    "Uniform",
    "builtin_scene_dir",
    "evaluate_expression",
    "list_scenes",
    "layout_from_data",
    "load_layout_file",
    "load_scene",
    "parse_expression",
    "sample_values",
    "sample_world",
]

RANDOM = "random"
#: Static elements a layout may place (walls, ground and basket are implicit).
STATIC_ELEMENT_SHAPES: tuple[str, ...] = ("platform", "ramp", "static_ball")
_SCENE_FILE = re.compile(r"^scene_(\d+)\.json$")


# -- safe expressions --------------------------------------------------------------------------------

_CONSTANTS: dict[str, float] = {"pi": math.pi}
_FUNCTIONS: dict[str, Callable[[float], float]] = {"sin": math.sin, "cos": math.cos, "sqrt": math.sqrt}
RESERVED_NAMES = frozenset(_CONSTANTS) | frozenset(_FUNCTIONS)
_BINOPS: dict[type[ast.operator], Callable[[float, float], float]] = {
    ast.Add: operator.add,
    ast.Sub: operator.sub,
    ast.Mult: operator.mul,
    ast.Div: operator.truediv,
    ast.Pow: operator.pow,
}
_UNARY: dict[type[ast.unaryop], Callable[[float], float]] = {ast.USub: operator.neg, ast.UAdd: operator.pos}
_ALLOWED_TEXT = "numbers, variable names, pi, + - * / **, unary -, sin(), cos(), sqrt()"
_MAX_EXPRESSION_LENGTH = 200
#: Scene layout files larger than this are refused (the built-in ones are about 2 KB).
MAX_SCENE_FILE_BYTES = 1 << 20


@dataclass(frozen=True)
class Expr:
    """A parsed arithmetic expression; ``names`` are the variables it reads (in first-use order)."""

    source: str
    tree: ast.expr = field(compare=False, repr=False)
    names: tuple[str, ...] = ()

    def evaluate(self, variables: Mapping[str, float]) -> float:
        try:
            value = _eval_node(self.tree, variables, self.source)
        except ExpressionError:
            raise
        except (ArithmeticError, ValueError) as exc:  # ZeroDivisionError, OverflowError, math domain error
            raise ExpressionError(f"cannot evaluate {self.source!r}: {exc}") from exc
        if not math.isfinite(value):
            raise ExpressionError(f"{self.source!r} evaluates to {value}, not a finite number")
        return value


def _eval_node(node: ast.expr, variables: Mapping[str, float], source: str) -> float:
    if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)):
        return float(node.value)
    if isinstance(node, ast.Name):
        if node.id in _CONSTANTS:
            return _CONSTANTS[node.id]
        if node.id not in variables:
            defined = ", ".join(variables) or "(none)"
            raise ExpressionError(f"unknown variable {node.id!r} in {source!r}; defined variables: {defined}")
        return float(variables[node.id])
    if isinstance(node, ast.BinOp):
        value = _BINOPS[type(node.op)](_eval_node(node.left, variables, source),
                                       _eval_node(node.right, variables, source))
        if isinstance(value, complex):  # a negative number to a fractional power
            raise ExpressionError(f"{ast.unparse(node)!r} in {source!r} has no real value (a negative number to a "
                                  "fractional power); allowed: expressions with a real value")
        return value
    if isinstance(node, ast.UnaryOp):
        return _UNARY[type(node.op)](_eval_node(node.operand, variables, source))
    if isinstance(node, ast.Call) and isinstance(node.func, ast.Name):
        return _FUNCTIONS[node.func.id](_eval_node(node.args[0], variables, source))
    raise ExpressionError(f"unsupported syntax in {source!r}")  # unreachable after parse_expression


def _check_node(node: ast.AST, source: str, names: list[str]) -> None:
    """Reject every node outside the whitelist; collect variable names."""
    if isinstance(node, ast.Constant):
        if isinstance(node.value, bool) or not isinstance(node.value, (int, float)):
            raise ExpressionError(f"unsupported constant {node.value!r} in {source!r}; "
                                  f"allowed: {_ALLOWED_TEXT}")
        return
    if isinstance(node, ast.Name):
        if node.id in _FUNCTIONS:
            raise ExpressionError(f"{node.id!r} is a function, call it as {node.id}(...) in {source!r}")
        if node.id not in _CONSTANTS and node.id not in names:
            names.append(node.id)
        return
    if isinstance(node, ast.BinOp) and type(node.op) in _BINOPS:
        _check_node(node.left, source, names)
        _check_node(node.right, source, names)
        return
    if isinstance(node, ast.UnaryOp) and type(node.op) in _UNARY:
        _check_node(node.operand, source, names)
        return
    if isinstance(node, ast.Call):
        if not isinstance(node.func, ast.Name) or node.func.id not in _FUNCTIONS:
            callee = node.func.id if isinstance(node.func, ast.Name) else ast.unparse(node.func)
            raise ExpressionError(f"call of {callee!r} is not allowed in {source!r}; "
                                  f"allowed functions: {', '.join(_FUNCTIONS)}")
        if len(node.args) != 1 or node.keywords:
            raise ExpressionError(f"{node.func.id}() takes exactly one argument in {source!r}")
        _check_node(node.args[0], source, names)
        return
    what = type(node.op).__name__ if isinstance(node, (ast.BinOp, ast.UnaryOp)) else type(node).__name__
    raise ExpressionError(f"unsupported syntax ({what}) in {source!r}; allowed: {_ALLOWED_TEXT}")


def parse_expression(source: str) -> Expr:
    """Parse ``source`` into an :class:`Expr`, accepting only the safe arithmetic subset.

    Nothing is ever executed: the text goes through :func:`ast.parse` and a node whitelist.
    """
    if not isinstance(source, str):
        raise ExpressionError(f"an expression must be a string, got {source!r}")
    if len(source) > _MAX_EXPRESSION_LENGTH:
        raise ExpressionError(f"expression longer than {_MAX_EXPRESSION_LENGTH} characters: "
                              f"{source[:40]!r}...")
    try:
        with warnings.catch_warnings():  # "1if x" parses with a warning: refuse it like any other bad expression
            warnings.simplefilter("error", SyntaxWarning)
            tree = ast.parse(source.strip(), mode="eval")
    except SyntaxError as exc:
        raise ExpressionError(f"cannot parse expression {source!r}: {exc.msg}") from None
    names: list[str] = []
    _check_node(tree.body, source, names)
    return Expr(source=source, tree=tree.body, names=tuple(names))


def evaluate_expression(source: str, variables: Mapping[str, float] | None = None) -> float:
    """Evaluate a safe arithmetic expression (see :func:`parse_expression`) with the given variables."""
    return parse_expression(source).evaluate(variables or {})


# -- values: numbers, expressions, inline draws ------------------------------------------------------


@dataclass(frozen=True)
class Const:
    """A fixed number."""

    value: float


@dataclass(frozen=True)
class Uniform:
    """An independent uniform draw on [low, high]; the bounds may be expressions."""

    low: Const | Expr
    high: Const | Expr


@dataclass(frozen=True)
class Choice:
    """An independent draw of one of ``options``, each equally likely."""

    options: tuple[float, ...]


Quantity = Union[Const, Expr, Uniform, Choice]  # noqa: UP007 (runtime alias, py3.10 target)
_VALUE_FORMS = 'a number, an expression string, {"uniform": [min, max]} or {"choice": [n, ...]}'


def _is_number(raw: object) -> TypeGuard[int | float]:
    return isinstance(raw, (int, float)) and not isinstance(raw, bool)


def _float(raw: int | float) -> float:
    try:
        return float(raw)
    except OverflowError:  # an integer beyond the range of a float
        raise ValueError(f"{describe(raw)} is out of range; allowed: finite numbers (at most about 1.8e308)") from None


def _parse_scalar(raw: object) -> Const | Expr:
    if _is_number(raw):
        value = _float(raw)
        if not math.isfinite(value):
            raise ValueError(f"{raw!r} is not a finite number")
        return Const(value)
    if isinstance(raw, str):
        return parse_expression(raw)
    raise ValueError(f"expected a number or an expression string, got {describe(raw)}")


def _constant_value(q: Const | Expr) -> float | None:
    if isinstance(q, Const):
        return q.value
    return q.evaluate({}) if not q.names else None


def _parse_quantity(raw: object) -> Quantity:
    """Pydantic validator for every numeric field (see the module docstring)."""
    if isinstance(raw, (Const, Expr, Uniform, Choice)):
        return raw
    if _is_number(raw) or isinstance(raw, str):
        return _parse_scalar(raw)
    if isinstance(raw, dict):
        if set(raw) == {"uniform"}:
            bounds = raw["uniform"]
            if not isinstance(bounds, list) or len(bounds) != 2:
                raise ValueError(f'"uniform" needs a list [min, max] of two values, got {describe(bounds)}')
            low, high = _parse_scalar(bounds[0]), _parse_scalar(bounds[1])
            lo, hi = _constant_value(low), _constant_value(high)
            if lo is not None and hi is not None and lo > hi:
                raise ValueError(f"uniform range [{bounds[0]}, {bounds[1]}] has min > max ({lo:g} > {hi:g}); "
                                 "write it as [min, max]")
            return Uniform(low, high)
        if set(raw) == {"choice"}:
            options = raw["choice"]
            if not isinstance(options, list) or not options or not all(_is_number(o) for o in options):
                raise ValueError(f'"choice" needs a non-empty list of numbers, got {describe(options)}')
            return Choice(tuple(_float(o) for o in options))
        raise ValueError(f"unknown random draw with keys {sorted(raw)}; expected {_VALUE_FORMS}")
    raise ValueError(f"expected {_VALUE_FORMS}; got {describe(raw)}")


def _quantity_to_raw(q: Quantity) -> float | str | dict[str, list[float | str]] | dict[str, list[float]]:
    """The file form of a value (so that ``model_dump(mode="json")`` round-trips through the loader)."""
    if isinstance(q, Const):
        return q.value
    if isinstance(q, Expr):
        return q.source
    if isinstance(q, Uniform):
        low, high = _quantity_to_raw(q.low), _quantity_to_raw(q.high)
        assert isinstance(low, (float, str)) and isinstance(high, (float, str))
        return {"uniform": [low, high]}
    return {"choice": list(q.options)}


Value = Annotated[Quantity, PlainValidator(_parse_quantity), PlainSerializer(_quantity_to_raw)]
Vec = tuple[Value, Value]


def _names_of(q: Quantity) -> Iterator[tuple[str, Expr]]:
    if isinstance(q, Expr):
        for name in q.names:
            yield name, q
    elif isinstance(q, Uniform):
        yield from _names_of(q.low)
        yield from _names_of(q.high)


# -- the file model ----------------------------------------------------------------------------------


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, arbitrary_types_allowed=True)


def _one_of(value: str, allowed: Sequence[str], extra: str = "") -> str:
    if value not in allowed:
        raise ValueError(f"{value!r} is not one of {', '.join(allowed)}{extra}")
    return value


class BasketSpec(_Model):
    """The basket (always created first after the boundaries, at angle 0)."""

    position: Vec
    note: str = ""


class StaticElement(_Model):
    """A platform (16 x 1 box), ramp (right triangle, legs 3) or static ball (radius 3)."""

    shape: str
    position: Vec
    angle: Value = Const(0.0)
    note: str = ""

    @field_validator("shape")
    @classmethod
    def _shape(cls, v: str) -> str:
        if v in ("basket", "wall_l", "wall_r", "ground"):
            raise ValueError(f"{v!r} is implicit (walls and ground always exist; the basket has its own "
                             f"top-level key); allowed here: {', '.join(STATIC_ELEMENT_SHAPES)}")
        return _one_of(v, STATIC_ELEMENT_SHAPES)


class DynamicSlot(_Model):
    """One dynamic object. Each of shape, size and colour is fixed or ``"random"``. On a (shape, colour, size)
    triple already used in the scene, ``on_duplicate`` decides: ``"redraw"`` (the default) redraws the random parts
    and keeps the fixed ones; ``"drop"`` leaves the object out, as the original does for some slots. Slots sharing
    a ``color_group`` get pairwise distinct colours."""

    shape: str = RANDOM
    size: str = RANDOM
    color: str = RANDOM
    color_group: str | None = None
    on_duplicate: Literal["redraw", "drop"] = "redraw"
    position: Vec
    velocity: Vec = (Const(0.0), Const(0.0))
    note: str = ""

    @model_serializer(mode="wrap")
    def _omit_default_on_duplicate(self, handler: SerializerFunctionWrapHandler) -> dict[str, Any]:
        # the default is left out, so a layout that does not use the field keeps its canonical JSON (and hash)
        data: dict[str, Any] = handler(self)
        if data.get("on_duplicate") == "redraw":
            del data["on_duplicate"]
        return data

    @field_validator("shape")
    @classmethod
    def _shape(cls, v: str) -> str:
        return v if v == RANDOM else _one_of(v, SHAPES, " (or 'random')")

    @field_validator("size")
    @classmethod
    def _size(cls, v: str) -> str:
        return v if v == RANDOM else _one_of(v, SIZES, " (or 'random')")

    @field_validator("color")
    @classmethod
    def _color(cls, v: str) -> str:
        return v if v == RANDOM else _one_of(v, COLORS, " (or 'random')")

    @model_validator(mode="after")
    def _group_needs_random_color(self) -> DynamicSlot:
        if self.color_group is not None and self.color != RANDOM:
            raise ValueError(f"color_group {self.color_group!r} needs color 'random', not {self.color!r}")
        return self


class SceneLayout(_Model):
    """One scene layout file, validated."""

    scene: int = Field(ge=1)
    title: str = ""
    description: str = ""
    variables: dict[str, Value] = Field(default_factory=dict)
    basket: BasketSpec
    static: tuple[StaticElement, ...] = ()
    dynamic: tuple[DynamicSlot, ...] = Field(min_length=1)

    _path: Path | None = PrivateAttr(default=None)

    @field_validator("variables")
    @classmethod
    def _variable_names(cls, v: dict[str, Quantity]) -> dict[str, Quantity]:
        for name in v:
            if not name.isidentifier() or name.startswith("_"):
                raise ValueError(f"variable name {name!r} is not a plain identifier (letters, digits, _)")
            if name in RESERVED_NAMES:
                raise ValueError(f"variable name {name!r} is reserved ({', '.join(sorted(RESERVED_NAMES))})")
        return v

    @property
    def path(self) -> Path | None:
        """The file this layout was loaded from, if any."""
        return self._path

    def fields(self) -> Iterator[tuple[str, Quantity]]:
        """Every numeric field with its path, in draw order (variables first)."""
        for name, q in self.variables.items():
            yield f"variables.{name}", q
        yield "basket.position[0]", self.basket.position[0]
        yield "basket.position[1]", self.basket.position[1]
        for i, s in enumerate(self.static):
            yield f"static[{i}].position[0]", s.position[0]
            yield f"static[{i}].position[1]", s.position[1]
            yield f"static[{i}].angle", s.angle
        for i, d in enumerate(self.dynamic):
            yield f"dynamic[{i}].position[0]", d.position[0]
            yield f"dynamic[{i}].position[1]", d.position[1]
            yield f"dynamic[{i}].velocity[0]", d.velocity[0]
            yield f"dynamic[{i}].velocity[1]", d.velocity[1]


# -- loading -----------------------------------------------------------------------------------------


def builtin_scene_dir() -> Path:
    """The folder of the built-in layouts: inside an installed wheel, else the repository's ``scenes/``."""
    packaged = Path(__file__).parent / "_data" / "scenes"
    return packaged if packaged.is_dir() else Path(__file__).resolve().parents[1] / "scenes"


def list_scenes() -> list[int]:
    """Ids of the built-in layouts (every ``scene_NN.json`` of :func:`builtin_scene_dir`)."""
    folder = builtin_scene_dir()
    if not folder.is_dir():
        return []
    ids = (_SCENE_FILE.match(p.name) for p in folder.iterdir())
    return sorted(int(m.group(1)) for m in ids if m)


_SECTION_MODELS: dict[str, type[BaseModel]] = {"basket": BasketSpec, "static": StaticElement,
                                               "dynamic": DynamicSlot}


def _loc_text(loc: Sequence[int | str]) -> str:
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else (f".{key_text(part)}" if out else key_text(part))
    return out or "(top level)"


def _error_text(err: Mapping[str, Any]) -> str:
    loc = tuple(err["loc"])
    kind = err["type"]
    if kind == "extra_forbidden":
        model: type[BaseModel] = SceneLayout
        if len(loc) > 1 and isinstance(loc[0], str) and loc[0] in _SECTION_MODELS:
            model = _SECTION_MODELS[loc[0]]
        return f"unknown field {loc[-1]!r}; allowed fields: {', '.join(model.model_fields)}"
    if kind == "missing" and len(loc) >= 2 and isinstance(loc[-1], int):
        return f"missing the {'xy'[loc[-1]]} value; expected a pair [x, y]"
    if kind == "missing":
        return "required field is missing"
    if kind in ("too_long", "too_short", "tuple_type") and loc and loc[-1] in ("position", "velocity"):
        return f"expected a pair [x, y] of two values, got {err.get('input')!r}"
    msg = str(err["msg"])
    return msg.removeprefix("Value error, ")


def _check_references(layout: SceneLayout, where: str) -> None:
    """Every expression reads only variables defined before it (variables) or anywhere (fields), and no
    two fully fixed dynamic slots share a (shape, colour, size) triple."""
    defined: list[str] = []
    for path, q in layout.fields():
        for name, expr in _names_of(q):
            if name not in defined:
                in_variables = path.startswith("variables.")
                scope = "variables defined before it" if in_variables else "defined variables"
                raise SceneFileError(f"{where}: {path}: unknown variable {name!r} in {expr.source!r}; "
                                     f"{scope}: {', '.join(defined) or '(none)'}")
        if path.startswith("variables."):
            defined.append(path.removeprefix("variables."))
    fixed: dict[tuple[str, str, str], int] = {}
    for i, d in enumerate(layout.dynamic):
        triple = (d.shape, d.color, d.size)
        if RANDOM in triple:
            continue
        if triple in fixed:
            raise SceneFileError(f"{where}: dynamic[{i}]: the fixed {d.size} {d.color} {d.shape} repeats "
                                 f"dynamic[{fixed[triple]}]; (shape, colour, size) must be unique in a scene")
        fixed[triple] = i


def _parse_layout(data: object, where: str, path: Path | None) -> SceneLayout:
    try:
        layout = SceneLayout.model_validate(data)
    except ValidationError as exc:
        errors = exc.errors()
        locs = [tuple(e["loc"]) for e in errors]
        # a container's length error that only echoes its failed items is noise
        errors = [e for e, loc in zip(errors, locs, strict=True)
                  if not any(len(o) > len(loc) and o[:len(loc)] == loc for o in locs)]
        lines = [f"{where}: {_loc_text(e['loc'])}: {_error_text(e)}" for e in errors]
        raise SceneFileError("\n".join(lines)) from None
    _check_references(layout, where)
    layout._path = path
    return layout


def load_layout_file(path: str | Path) -> SceneLayout:
    """Read and validate one layout file."""
    p = Path(path)
    data = read_json(p, "scene file", error=SceneFileError, max_bytes=MAX_SCENE_FILE_BYTES)
    return _parse_layout(data, str(p), p)


def layout_from_data(data: object, source: str = "scene layout") -> SceneLayout:
    """Validate a layout already read (e.g. a file's JSON); errors name ``source``, as :func:`load_layout_file`'s
    name the file."""
    return _parse_layout(data, source, None)


#: Revisions of the built-in layouts. 1: every dataset made before the original's own sampler was compared with
#: ours. 2 follows the original where that comparison found a difference: scene 15's lower-left platform at
#: x = -8 - 16 cos 30° exactly (revision 1 rounded it to -21.856), and scene 7's 4th object left out on a
#: duplicate triple (revision 1 redrew its colour). ``scenes/revision_1/`` holds revision 1 of the files that
#: changed.
LAYOUT_REVISIONS: Final = (1, 2)
#: The revision new datasets and every function without a ``revision`` argument use.
LAYOUT_REVISION: Final = 2


def _check_revision(revision: int) -> int:
    if isinstance(revision, bool) or revision not in LAYOUT_REVISIONS:
        raise SceneFileError(f"layout revision {revision!r} does not exist; revisions: "
                             f"{', '.join(map(str, LAYOUT_REVISIONS))}")
    return revision


@functools.lru_cache(maxsize=64)
def _load_builtin(scene_id: int, folder: Path, revision: int = LAYOUT_REVISION) -> SceneLayout:
    name = f"scene_{scene_id:02d}.json"
    older = folder / f"revision_{revision}" / name
    path = older if revision != LAYOUT_REVISION and older.is_file() else folder / name
    layout = load_layout_file(path)
    if layout.scene != scene_id:
        raise SceneFileError(f"{path}: scene: the file says {layout.scene}, its name says {scene_id}")
    return layout


def load_scene(scene: int | str | Path, revision: int = LAYOUT_REVISION) -> SceneLayout:
    """Load a layout: an int is a built-in scene id (see :func:`list_scenes`), in ``revision`` of the built-in
    layouts (:data:`LAYOUT_REVISIONS`), a str or Path a file."""
    _check_revision(revision)
    if isinstance(scene, bool):
        raise SceneFileError(f"scene must be an id or a path, got {scene!r}")
    if isinstance(scene, (int, np.integer)):
        ids = list_scenes()
        if int(scene) not in ids:
            raise SceneFileError(f"no built-in scene {int(scene)}; available: "
                                 f"{', '.join(map(str, ids)) or '(none)'} (in {builtin_scene_dir()})")
        return _load_builtin(int(scene), builtin_scene_dir(), revision)
    return load_layout_file(scene)


# -- sampling ----------------------------------------------------------------------------------------


def _generator(scene_id: int, seed: int) -> np.random.Generator:
    """The one generator of a sample: PCG64 seeded by the sequence [seed, scene id]."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise CraftError(f"seed must be a non-negative int, got {seed!r}")
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence([int(seed), scene_id])))


class _Sampler:
    def __init__(self, layout: SceneLayout, rng: np.random.Generator) -> None:
        self.layout = layout
        self.rng = rng
        self.where = str(layout.path) if layout.path is not None else f"scene {layout.scene}"
        self.variables: dict[str, float] = {}
        self.values: dict[str, float] = {}

    def fail(self, path: str, message: str) -> SceneFileError:
        return SceneFileError(f"{self.where}: {path}: {message}")

    def scalar(self, q: Const | Expr, path: str) -> float:
        if isinstance(q, Const):
            return q.value
        try:
            return q.evaluate(self.variables)
        except ExpressionError as exc:
            raise self.fail(path, str(exc)) from None

    def value(self, q: Quantity, path: str) -> float:
        if isinstance(q, Uniform):
            low, high = self.scalar(q.low, path), self.scalar(q.high, path)
            if low > high:
                raise self.fail(path, f"uniform range evaluates to [{low:g}, {high:g}] with min > max")
            out = float(self.rng.uniform(low, high))
        elif isinstance(q, Choice):
            out = q.options[int(self.rng.integers(len(q.options)))]
        else:
            out = self.scalar(q, path)
        self.values[path] = out
        return out

    def vec(self, v: tuple[Quantity, Quantity], path: str) -> tuple[float, float]:
        return (self.value(v[0], f"{path}[0]"), self.value(v[1], f"{path}[1]"))

    def attributes(self, slot: DynamicSlot, path: str, used: set[tuple[str, str, str]],
                   group_colors: dict[str, set[str]]) -> tuple[str, str, str] | None:
        """Draw (shape, colour, size): uniform over the triples that keep the slot's fixed parts, avoid
        the colours already taken in its colour group and are not yet used in the scene. This has the
        same distribution as the original's redraw-until-unique loop. A ``"drop"`` slot draws over every
        triple that keeps its fixed parts and gives None (no object) where the triple is already used."""
        taken = group_colors.get(slot.color_group, set()) if slot.color_group else set()
        drop = slot.on_duplicate == "drop"
        candidates = [
            (shape, color, size)
            for shape in (SHAPES if slot.shape == RANDOM else (slot.shape,))
            for color in (COLORS if slot.color == RANDOM else (slot.color,))
            for size in (SIZES if slot.size == RANDOM else (slot.size,))
            if (drop or (shape, color, size) not in used) and color not in taken
        ]
        if not candidates:
            raise self.fail(path, f"no (shape, colour, size) left for shape={slot.shape}, size={slot.size}, "
                                  f"color={slot.color}: every such triple is already used in the scene"
                                  + (f" or its colour taken in group {slot.color_group!r}"
                                     if slot.color_group else ""))
        triple = candidates[int(self.rng.integers(len(candidates)))]
        if triple in used:
            return None
        used.add(triple)
        if slot.color_group:
            group_colors.setdefault(slot.color_group, set()).add(triple[1])
        return triple

    def run(self) -> list[BodySpec]:
        layout = self.layout
        for name, q in layout.variables.items():
            self.variables[name] = self.value(q, f"variables.{name}")
        bodies = [make_static(0, "wall_l"), make_static(0, "wall_r"), make_static(0, "ground"),
                  make_static(0, "basket", self.vec(layout.basket.position, "basket.position"), 0.0)]
        for i, s in enumerate(layout.static):
            position = self.vec(s.position, f"static[{i}].position")
            bodies.append(make_static(0, s.shape, position, self.value(s.angle, f"static[{i}].angle")))
        used: set[tuple[str, str, str]] = set()
        group_colors: dict[str, set[str]] = {}
        for i, d in enumerate(layout.dynamic):
            position = self.vec(d.position, f"dynamic[{i}].position")
            velocity = self.vec(d.velocity, f"dynamic[{i}].velocity")
            triple = self.attributes(d, f"dynamic[{i}]", used, group_colors)
            if triple is not None:
                shape, color, size = triple
                bodies.append(make_dynamic(0, shape, color, size, position, velocity))
        return bodies


def _as_layout(scene: int | str | Path | SceneLayout, revision: int = LAYOUT_REVISION) -> SceneLayout:
    return scene if isinstance(scene, SceneLayout) else load_scene(scene, revision)


def sample_world(scene: int | str | Path | SceneLayout, seed: int = 0,
                 revision: int = LAYOUT_REVISION) -> WorldSpec:
    """A concrete scene drawn from a layout with one seeded generator (a built-in scene id in ``revision`` of the
    built-in layouts).

    Every random value comes from ``numpy.random.Generator(PCG64(SeedSequence([seed, scene_id])))``,
    drawn in file order (variables, basket, static elements, dynamic slots). Bodies are created as
    wall_l, wall_r, ground, basket, statics, dynamics (initial angle pi) and get uniqueIDs N-1 ... 0.
    """
    layout = _as_layout(scene, revision)
    bodies = _Sampler(layout, _generator(layout.scene, seed)).run()
    return WorldSpec(bodies=assign_uids(bodies), scene_id=layout.scene, seed=int(seed))


def sample_values(scene: int | str | Path | SceneLayout, seed: int = 0,
                  revision: int = LAYOUT_REVISION) -> dict[str, float]:
    """The numbers :func:`sample_world` uses for the same (scene, seed, revision), keyed by field path
    (``"variables.h"``, ``"static[2].angle"``, ``"dynamic[0].velocity[1]"``, ...)."""
    layout = _as_layout(scene, revision)
    sampler = _Sampler(layout, _generator(layout.scene, seed))
    sampler.run()
    return dict(sampler.values)
