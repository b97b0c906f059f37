"""The code base stays ruff-clean and mypy-clean (both are pinned in the dev extra)."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _run(*cmd: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, check=False)


def test_ruff_clean() -> None:
    ruff = shutil.which("ruff")
    cmd = [ruff] if ruff else [sys.executable, "-m", "ruff"]
    res = _run(*cmd, "check", "craft_dsl", "tests", "benchmarks", "examples")
    assert res.returncode == 0, res.stdout + res.stderr


def test_mypy_clean() -> None:
    res = _run(sys.executable, "-m", "mypy", "craft_dsl", "benchmarks")
    assert res.returncode == 0, res.stdout + res.stderr
