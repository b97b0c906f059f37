"""Whole generation runs: the same bytes on every executor (local processes, a real Dask cluster), and runs
interrupted at random moments (SIGKILL, Ctrl-C) then resumed by the same command.

Timeouts are generous (a loaded 2-core machine) but bounded; the 2-second Ctrl-C figure of docs/dataset.md is
measured by benchmarks/generate_speed.py, not asserted here.
"""

from __future__ import annotations

import hashlib
import json
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from craft_dsl.dataset import pipeline as P
from craft_dsl.dataset.merge import WORK_FOLDER
from tests.foreground import popen_foreground

CONFIG = {"size": 6, "seed": 3, "scenes": (1, 2, 3), "steps": 200, "perturbations": 1}
ARGS = ["--size", "6", "--seed", "3", "--scenes", "1-3", "--steps", "200", "--perturbations", "1"]


def hashes(folder: Path) -> dict[str, str]:
    """Every file's hash, the log (which holds times) left out."""
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file() and p.name != P.LOG_FILE}


@pytest.fixture(scope="module")
def reference(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("reference")
    P.generate_dataset(P.GenerationConfig.make(**CONFIG), out)
    return out


def _start(out: Path, workers: int, *extra: str) -> subprocess.Popen[str]:
    """``craft-dsl generate`` in a new process group (as a shell runs a foreground command)."""
    cmd = [sys.executable, "-m", "craft_dsl", "generate", *ARGS, *extra, "--out", str(out), "--workers", str(workers),
           "--quiet"]
    return popen_foreground(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)


def _children(pid: int) -> list[int]:
    """Processes whose parent is ``pid`` (Linux /proc)."""
    out = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
            except OSError:
                continue
            if int(stat.rpartition(")")[2].split()[1]) == pid:
                out.append(int(entry.name))
    return out


def _alive(pid: int) -> bool:
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rpartition(")")[2].split()[0] != "Z"


def _assert_gone(pids: list[int], timeout: float = 10.0) -> None:
    """The processes end soon after the main process (the workers at once; multiprocessing's resource tracker
    when it reads the end of its pipe)."""
    deadline = time.monotonic() + timeout
    while any(_alive(p) for p in pids) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not [p for p in pids if _alive(p)], "a child process outlived the main process"


def _log_size(out: Path) -> int:
    log = out / P.LOG_FILE
    return log.stat().st_size if log.is_file() else 0


def _wait_for_log(out: Path, text: str, since: int = 0, timeout: float = 120.0) -> bool:
    """Whether ``text`` appears in the log after its first ``since`` bytes (what earlier runs wrote) in time."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        log = out / P.LOG_FILE
        if log.is_file() and text in log.read_bytes()[since:].decode("utf-8", "replace"):
            return True
        time.sleep(0.05)
    return False


def _finished_work(out: Path) -> tuple[int, int]:
    """(videos done, scene blocks merged) as a killed run left them."""
    from craft_dsl.dataset.instance import shard_is_complete

    work = out / WORK_FOLDER
    if not work.exists():
        return (CONFIG["size"], 3) if (out / "generation_report.json").is_file() else (0, 0)
    state_path = work / "state.json"
    merged = int(json.loads(state_path.read_text())["blocks_merged"]) if state_path.is_file() else 0
    shards = sum(shard_is_complete(p) for p in (work / "shards").glob("*.shard"))
    return 2 * merged + shards, merged


def _run_lines(out: Path) -> list[str]:
    """The log lines of the last run."""
    lines = (out / P.LOG_FILE).read_text().splitlines()
    starts = [k for k, line in enumerate(lines) if " start: " in line]
    return lines[starts[-1]:]


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc to find the worker processes")
def test_sigkill_at_random_moments_then_resume(reference: Path, tmp_path: Path) -> None:
    out = tmp_path / "run"
    rng = random.Random(12)
    for attempt in range(3):
        before = _finished_work(out) if out.exists() else (0, 0)
        since = _log_size(out)
        proc = _start(out, workers=2 if attempt != 1 else 1)
        assert _wait_for_log(out, f"start: 6 videos, {before[0]} already done", since), proc.communicate()
        if attempt:
            run = _run_lines(out)
            assert not any(f"merged scene {s} " in line for line in run for s in (1, 2, 3)[:before[1]]), run
        time.sleep(rng.uniform(0.2, 2.5))
        workers = _children(proc.pid)
        proc.kill()
        proc.wait(timeout=30)
        _assert_gone(workers)
    before = _finished_work(out)
    proc = _start(out, workers=2)
    _stdout, stderr = proc.communicate(timeout=600)
    assert proc.returncode == 0, stderr
    run = _run_lines(out)
    # no finished video is simulated again, no merged scene merged again
    assert f"start: 6 videos, {before[0]} already done, {6 - before[0]} tasks" in run[0], (before, run)
    assert not any(f"merged scene {s} " in line for line in run for s in (1, 2, 3)[:before[1]]), run
    assert hashes(out) == hashes(reference)
    assert not (out / WORK_FOLDER).exists() and not [p for p in out.rglob("*") if ".tmp" in p.name]


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc to find the worker processes")
def test_sigkill_with_videos_then_resume(tmp_path: Path) -> None:
    """With --videos the media are encoded in the workers and written by the main process: killed runs resume
    to the bytes of an uninterrupted run, videos included, with no temporary file left."""
    reference = tmp_path / "reference"
    P.generate_dataset(P.GenerationConfig.make(**CONFIG, videos=True), reference)
    out = tmp_path / "run"
    # killed while the first videos are encoded, then (resumed with one worker) as soon as scene 1 is merged
    for attempt, (workers, mark, wait) in enumerate([(2, "start: 6 videos", 0.3), (1, "merged scene 1 ", 0.0)]):
        since = _log_size(out)
        proc = _start(out, workers, "--videos")
        assert _wait_for_log(out, mark, since), proc.communicate()
        time.sleep(wait)
        children = _children(proc.pid)
        proc.kill()
        proc.wait(timeout=30)
        _assert_gone(children)
        if attempt == 0:
            assert _finished_work(out)[0] < 6, "the run ended before it was killed"
    proc = _start(out, 2, "--videos")
    _stdout, stderr = proc.communicate(timeout=600)
    assert proc.returncode == 0, stderr
    assert hashes(out) == hashes(reference)
    assert any(name.endswith(".mpg") for name in hashes(out))
    assert not (out / WORK_FOLDER).exists() and not [p for p in out.rglob("*") if ".tmp" in p.name]


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc to find the worker processes")
@pytest.mark.parametrize("workers", [1, 2])
def test_ctrl_c_exits_130_without_traceback_and_resumes(reference: Path, tmp_path: Path, workers: int) -> None:
    out = tmp_path / "run"
    proc = _start(out, workers=workers)
    assert _wait_for_log(out, "start: "), proc.communicate()
    time.sleep(0.5)
    workers = _children(proc.pid)
    sent = time.monotonic()
    os.killpg(proc.pid, signal.SIGINT)  # what a terminal's Ctrl-C does: the whole foreground process group
    _stdout, stderr = proc.communicate(timeout=60)
    stopped = time.monotonic() - sent
    if proc.returncode == 0:  # the run had already finished: nothing to interrupt
        assert hashes(out) == hashes(reference)
        return
    assert proc.returncode == 130, stderr
    assert stopped < 10, stopped
    assert "Traceback" not in stderr and "interrupted" in stderr, stderr
    _assert_gone(workers)
    proc = _start(out, workers=1)
    _stdout, stderr = proc.communicate(timeout=600)
    assert proc.returncode == 0, stderr
    assert hashes(out) == hashes(reference)


def test_dask_cluster_gives_the_same_bytes(reference: Path, tmp_path: Path) -> None:
    distributed = pytest.importorskip("distributed", reason="the Dask executor needs the dask extra: "
                                                            "pip install 'craft-dsl[dask]'")
    from craft_dsl.dataset.executors import DaskExecutor

    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) \
            as cluster:
        config = P.GenerationConfig.make(**CONFIG)
        report = P.generate_dataset(config, tmp_path / "dask", executor=DaskExecutor(cluster.scheduler_address))
        assert report["videos"]["total"] == 6
        # the command line, on the same cluster
        from craft_dsl.cli import main

        assert main(["generate", *ARGS, "--out", str(tmp_path / "cli"), "--executor", "dask", "--scheduler",
                     cluster.scheduler_address, "--quiet"]) == 0
    assert hashes(tmp_path / "dask") == hashes(reference)
    assert hashes(tmp_path / "cli") == hashes(reference)
    assert "the Dask cluster at tcp://" in (tmp_path / "dask" / P.LOG_FILE).read_text()


def test_executor_errors() -> None:
    from craft_dsl.cli import main

    assert main(["generate", *ARGS, "--out", "/nonexistent/x", "--executor", "dask"]) == 2
    assert main(["generate", *ARGS, "--out", "/nonexistent/x", "--scheduler", "tcp://127.0.0.1:1"]) == 2
