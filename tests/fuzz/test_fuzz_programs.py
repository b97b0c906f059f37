"""Fuzz: program text (valid, near-valid, garbage, deep, huge numbers) and token lists. Whatever the text, the
only exceptions are CraftErrors with a short message; a program that checks prints, re-reads to the same
program and runs on E1 (a run may only fail with a CraftError).

Long run: python -m pytest tests/ -k fuzz --hypothesis-profile=long
"""

from __future__ import annotations

from typing import Any

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from craft_dsl import CraftError, Program, load_simulation
from craft_dsl.errors import ProgramError
from tests.conftest import E1_PATH
from tests.fuzz.hostile import (
    deep_programs,
    expect_only_craft_errors,
    garbage_programs,
    huge_number_programs,
    near_valid_programs,
    program_texts,
    token_lists,
)

E1 = load_simulation(E1_PATH)
SLOW = settings(suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


def _exercise(text: str) -> Program | None:
    """Parse ``text``; if it checks, print, re-read and run it. Returns the program or None."""
    result = expect_only_craft_errors(lambda: Program.parse(text))
    if isinstance(result, CraftError):
        assert isinstance(result, ProgramError)
        if result.line is not None:  # a position inside the text (or just past its end)
            assert 1 <= result.line <= text.count("\n") + 2 and result.column is not None and result.column >= 1
        return None
    program: Program = result
    printed = str(program)
    assert Program.parse(printed).key == program.key
    assert Program.from_tokens(program.to_tokens()).key == program.key
    nodes: Any = expect_only_craft_errors(program.to_nodes)
    if not isinstance(nodes, CraftError):
        assert Program.from_nodes(nodes).key == program.key
    expect_only_craft_errors(lambda: program.run(E1))
    return program


@given(program_texts())
def test_fuzz_valid_programs_check_print_and_run(text: str) -> None:
    assert _exercise(text) is not None, text


@given(near_valid_programs())
def test_fuzz_near_valid_programs(text: str) -> None:
    _exercise(text)


@given(garbage_programs())
def test_fuzz_garbage_programs(text: str) -> None:
    _exercise(text)


@SLOW
@given(deep_programs(max_depth=3000))
def test_fuzz_deep_programs(text: str) -> None:
    _exercise(text)


@SLOW
@given(huge_number_programs())
def test_fuzz_huge_numbers_in_programs(text: str) -> None:
    result = expect_only_craft_errors(lambda: Program.parse(text))
    assert isinstance(result, CraftError)  # every such number is beyond 64 bits or used where none is allowed


@given(token_lists(), st.sampled_from(["prefix", "postfix"]))
def test_fuzz_token_lists(tokens: list[str], order: str) -> None:
    result = expect_only_craft_errors(lambda: Program.from_tokens(tokens, order))  # type: ignore[arg-type]
    if not isinstance(result, CraftError):
        assert Program.from_tokens(result.to_tokens(order), order).key == result.key  # type: ignore[arg-type]
        expect_only_craft_errors(lambda: result.run(E1))
