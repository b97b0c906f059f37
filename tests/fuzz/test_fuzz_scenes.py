"""Fuzz: scene layouts (mutations of scenes/*.json) and the safe expression language of their values. A layout
either loads and samples a world, or fails with a SceneFileError naming the file; an expression evaluates to a
finite real number or fails with an ExpressionError, and never runs code.

Long run: python -m pytest tests/ -k fuzz --hypothesis-profile=long
"""

from __future__ import annotations

import json
import math
import tempfile
from pathlib import Path
from typing import Any

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from craft_dsl import CraftError
from craft_dsl.errors import ExpressionError, SceneFileError
from craft_dsl.scenes import builtin_scene_dir, evaluate_expression, load_layout_file, sample_world
from tests.fuzz.hostile import expect_only_craft_errors, file_bytes, mutated, text_mutations, write

SLOW = settings(suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
LAYOUTS = {p.name: json.loads(p.read_text(encoding="utf-8")) for p in sorted(builtin_scene_dir().glob("scene_*.json"))}

_ATOMS = ["0", "1", "-1", "0.5", "2", "1e308", "1e-308", "pi", "x", "y", "9" * 30, "(-8)", "-0.0", "1e999", "True",
          "__import__", "x.y", "[1]", "'a'", "f'x'"]
_OPS = ["+", "-", "*", "/", "**", "%", "//", "<<", "and", "<", "=="]
_FUNCS = ["sin", "cos", "sqrt", "exp", "eval", "abs", "__import__('os').system"]


@st.composite
def expressions(draw: st.DrawFn, depth: int = 4) -> str:
    """Arithmetic over numbers, names and calls: the allowed subset and its neighbours."""
    if depth <= 0 or draw(st.integers(0, 3)) == 0:
        return draw(st.sampled_from(_ATOMS))
    kind = draw(st.sampled_from(["binary", "binary", "unary", "call", "paren"]))
    if kind == "binary":
        return f"{draw(expressions(depth - 1))} {draw(st.sampled_from(_OPS))} {draw(expressions(depth - 1))}"
    if kind == "unary":
        return f"{draw(st.sampled_from(['-', '+', 'not ', '~']))}{draw(expressions(depth - 1))}"
    if kind == "call":
        return f"{draw(st.sampled_from(_FUNCS))}({draw(expressions(depth - 1))})"
    return f"({draw(expressions(depth - 1))})"


@SLOW
@given(st.one_of(expressions(), expressions().flatmap(text_mutations), st.text(max_size=40)),
       st.dictionaries(st.sampled_from(["x", "y"]), st.floats(allow_nan=False, allow_infinity=False), max_size=2))
def test_fuzz_scene_expressions(source: str, variables: dict[str, float]) -> None:
    result = expect_only_craft_errors(lambda: evaluate_expression(source, variables))
    if isinstance(result, CraftError):
        assert isinstance(result, ExpressionError), result
    else:
        assert type(result) is float and math.isfinite(result), (source, result)


@st.composite
def layout_values(draw: st.DrawFn) -> Any:
    """Values a layout field may be given: numbers, expressions, random draws, and wrong things."""
    return draw(st.one_of(expressions(), st.floats(), st.integers(-(10**30), 10**30),
                          st.builds(lambda a, b: {"uniform": [a, b]}, expressions(2), expressions(2)),
                          st.builds(lambda xs: {"choice": xs}, st.lists(st.floats(), max_size=3)),
                          st.sampled_from([None, [], {}, "random", {"uniform": [1]}, {"normal": [0, 1]}])))


@SLOW
@given(st.sampled_from(sorted(LAYOUTS)).flatmap(lambda name: st.tuples(st.just(name), mutated(LAYOUTS[name]))),
       st.data())
def test_fuzz_scene_layout_mutations(named: tuple[str, Any], data: st.DataObject) -> None:
    name, layout = named
    if isinstance(layout, dict) and data.draw(st.booleans()):  # put an expression or a draw somewhere numeric
        static = layout.get("static")
        if isinstance(static, list) and static and isinstance(static[0], dict):
            static[0][data.draw(st.sampled_from(["angle", "position"]))] = data.draw(layout_values())
    try:
        text = json.dumps(layout)
    except ValueError:  # an integer beyond Python's text conversion
        return
    raw = data.draw(file_bytes(text)) if data.draw(st.integers(0, 4)) == 0 else text.encode("utf-8", "surrogatepass")
    with tempfile.TemporaryDirectory() as tmp:
        path = write(Path(tmp) / name, raw)
        loaded = expect_only_craft_errors(lambda: load_layout_file(path), str(path))
        if isinstance(loaded, CraftError):
            assert isinstance(loaded, SceneFileError), loaded
            return
        world = expect_only_craft_errors(lambda: sample_world(loaded, seed=data.draw(st.integers(0, 2**32))),
                                         str(path))
        if isinstance(world, CraftError):
            assert isinstance(world, SceneFileError), world
        else:
            assert all(math.isfinite(v) for b in world.bodies for v in (*b.position, b.angle, *b.velocity))
