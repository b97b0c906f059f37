"""benchmarks/oracle_batch.py on a tiny workload: the ratios the targets are about come out as JSON, and
``--hash-seeds`` runs it once per hash seed and summarises them."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "oracle_batch.py"
TINY = ["--sims", "1", "--sampled-sims", "3", "--samples", "30", "--one-sim-batches", "1", "--repeat", "1"]
FIGURES = {"fresh nodes, one batch": 3.0, "fresh prefix, one batch": 2.0, "fresh postfix, one batch": 2.0,
           "fresh text, one batch": 2.0, "one simulation (a), median": None, "one simulation (b), median": 20.0,
           "3 simulations x 8": 8.0, "edited node lists": 8.0, "errors / answers": 1.0,
           "8 copies / one copy": 6.0}


def test_the_ratios_and_their_targets_are_written(tmp_path: Path) -> None:
    out = tmp_path / "ratios.json"
    done = subprocess.run([sys.executable, str(SCRIPT), *TINY, "--json", str(out)], capture_output=True, text=True,
                          check=True, env={**os.environ, "PYTHONHASHSEED": "3"})
    assert "target >= 8x" in done.stdout
    data = json.loads(out.read_text())
    assert data["hash_seed"] == "3"
    assert data["targets"] == FIGURES
    assert all(ratio > 0 for ratio in data["ratios"].values())


def test_each_hash_seed_is_a_run_of_its_own(tmp_path: Path) -> None:
    out = tmp_path / "summary.json"
    done = subprocess.run([sys.executable, str(SCRIPT), *TINY, "--hash-seeds", "2", "--json", str(out)],
                          capture_output=True, text=True, check=True)
    assert "PYTHONHASHSEED=1: " in done.stdout and "PYTHONHASHSEED=2: " in done.stdout
    data = json.loads(out.read_text())
    assert data["hash_seeds"] == 2 and len(data["runs"]) == 2
    for key, row in data["summary"].items():
        values = sorted(run[key] for run in data["runs"])
        assert row["lowest"] == values[0] and row["highest"] == values[-1]
        assert row["median"] == (values[0] + values[1]) / 2
        assert row["target"] == FIGURES[key]
    assert "over 2 hash seeds" in done.stdout
