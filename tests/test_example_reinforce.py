"""examples/reinforce_parser.py end to end on a tiny budget: export-pairs, pretraining, REINFORCE with run_batch
rewards, the figures it prints."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

torch = pytest.importorskip("torch", reason="needs the torch extra: pip install torch==2.13.0 'craft-dsl[torch]'")

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "reinforce_parser.py"
TINY = {"scenes": 3, "pretrain_pairs": 60, "pretrain_epochs": 2, "rl_steps": 3, "questions_per_step": 8,
        "samples": 4, "dim": 32, "hidden": 64, "max_length": 48}


def example() -> ModuleType:
    spec = importlib.util.spec_from_file_location("reinforce_parser", EXAMPLE)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules["reinforce_parser"] = module  # dataclasses look their module up
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def figures() -> tuple[ModuleType, dict[str, Any]]:
    module = example()
    return module, module.run(module.Config(**TINY), verbose=False)


def test_tiny_run_scores_every_sample_with_the_oracle(figures: tuple[ModuleType, dict[str, Any]]) -> None:
    _module, out = figures
    assert out["programs_scored"] == TINY["rl_steps"] * TINY["questions_per_step"] * TINY["samples"]
    assert out["pretrain_pairs"] == TINY["pretrain_pairs"]
    assert out["pairs"] == out["train_questions"] + out["held_out_questions"] > out["pretrain_pairs"]
    for key in ("program_accuracy_before", "answer_accuracy_before", "program_accuracy_after",
                "answer_accuracy_after", "mean_reward"):
        assert 0.0 <= out[key] <= 1.0, key
    assert 0.0 < out["oracle_seconds"] < out["fine_tune_seconds"]
    assert out["oracle_share"] == pytest.approx(out["oracle_seconds"] / out["fine_tune_seconds"])


def test_tiny_run_is_deterministic(figures: tuple[ModuleType, dict[str, Any]]) -> None:
    module, out = figures
    again = module.run(module.Config(**TINY), verbose=False)
    timings = ("oracle_seconds", "fine_tune_seconds", "oracle_share")
    assert {k: v for k, v in again.items() if k not in timings} == {k: v for k, v in out.items() if k not in timings}


def test_command_line_prints_the_figures(capsys: pytest.CaptureFixture[str]) -> None:
    module = example()
    args = [f"--{k.replace('_', '-')}={v}" for k, v in TINY.items()]
    assert module.main([*args, "--rl-steps=1"]) == 0
    out = capsys.readouterr().out
    assert "after pretraining" in out and "after REINFORCE (1 steps" in out
    assert "program accuracy" in out and "answer accuracy" in out and "of the fine-tuning time" in out
