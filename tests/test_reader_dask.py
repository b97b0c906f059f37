"""``craft-dsl read --executor dask``: on a local Dask cluster of two worker processes, the same bytes as a local run,
and a run interrupted (locally or on the cluster) resumed from its journal to the same bytes; a missing extra, a
missing or bad scheduler address and workers that cannot see the videos are one error line, with nothing written.

Perception is real: three 200-step videos of the users dataset.
"""

from __future__ import annotations

import socket
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from craft_dsl import cluster
from craft_dsl.cli import main
from craft_dsl.errors import ReaderError
from craft_dsl.reader import cli as read_cli
from craft_dsl.reader.runs import Journal, check_workers, journal_path
from tests.reader_helpers import strip_dataset

VIDEOS = (0, 2, 4)  # one video of each of the users dataset's scenes
OUTPUTS = ("preds.json", "details.jsonl")


@pytest.fixture(scope="module")
def stripped(users_dataset: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Three of the users dataset's videos, flat, and a questions file of their records' texts."""
    return strip_dataset(users_dataset, tmp_path_factory.mktemp("stripped"), VIDEOS)


def _args(stripped: Path, out: Path, *extra: str) -> list[str]:
    return ["read", "--steps", "200", "--videos", str(stripped / "videos"), "--questions",
            str(stripped / "questions.json"), "--out", str(out / "preds.json"), "--details",
            str(out / "details.jsonl"), "--quiet", *extra]


def _files(out: Path) -> dict[str, bytes]:
    return {name: (out / name).read_bytes() for name in OUTPUTS}


@pytest.fixture(scope="module")
def reference(stripped: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, bytes]:
    """The files of an uninterrupted local run (one worker, in this process)."""
    out = tmp_path_factory.mktemp("reference")
    assert main(_args(stripped, out, "--workers", "1")) == 0
    return _files(out)


@pytest.fixture(scope="module")
def scheduler() -> Iterator[str]:
    """The address of a local Dask cluster of two single-threaded worker processes."""
    distributed = pytest.importorskip("distributed", reason="read --executor dask needs the dask extra: "
                                                            "pip install 'craft-dsl[dask]'")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) \
            as local:
        yield local.scheduler_address


def test_a_dask_cluster_reads_the_same_bytes(stripped: Path, reference: dict[str, bytes], scheduler: str,
                                             tmp_path: Path) -> None:
    assert main(_args(stripped, tmp_path, "--executor", "dask", "--scheduler", scheduler)) == 0
    assert _files(tmp_path) == reference
    assert not journal_path(tmp_path / "preds.json").exists()


def _stop_after_first_video(monkeypatch: pytest.MonkeyPatch) -> None:
    """The next run stops as Ctrl-C would once its first video is in the journal."""
    real = Journal.add

    def add(self: Journal, record: dict[str, Any]) -> None:
        real(self, record)
        raise KeyboardInterrupt

    monkeypatch.setattr(Journal, "add", add)


@pytest.mark.parametrize("first", ["local", "dask"])
def test_an_interrupted_run_resumes_on_the_cluster_to_the_same_bytes(
        first: str, stripped: Path, reference: dict[str, bytes], scheduler: str, tmp_path: Path,
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    """The journal is the local run's: a run stopped locally or on the cluster resumes on the cluster."""
    dask = ["--executor", "dask", "--scheduler", scheduler]
    with monkeypatch.context() as patch:
        _stop_after_first_video(patch)
        assert main(_args(stripped, tmp_path, *(dask if first == "dask" else ["--workers", "1"]))) == 130
    journal = journal_path(tmp_path / "preds.json")
    assert journal.read_bytes().count(b"\n") == 2  # the header and one video
    assert not any((tmp_path / name).exists() for name in OUTPUTS)
    args = _args(stripped, tmp_path, *dask)
    args.remove("--quiet")
    assert main(args) == 0
    assert f"resuming {journal}: 1 of {len(VIDEOS)} videos already read" in capsys.readouterr().err
    assert _files(tmp_path) == reference
    assert not journal.exists()


def _closed_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port: int = s.getsockname()[1]
    return port


@pytest.mark.parametrize("address, message", [
    ("nonsense", "not a scheduler address"),
    ("http://127.0.0.1:8786", "not a scheduler address"),
    ("closed", "cannot reach a Dask scheduler there"),
])
def test_a_bad_scheduler_address_is_one_error_and_nothing_is_written(
        address: str, message: str, stripped: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("distributed", reason="the dask extra is not installed")
    monkeypatch.setattr(cluster, "CONNECT_TIMEOUT_S", 1.0)
    if address == "closed":
        address = f"tcp://127.0.0.1:{_closed_port()}"
    assert main(_args(stripped, tmp_path, "--executor", "dask", "--scheduler", address)) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: --scheduler {address}: {message}") and err.count("\n") == 1, err
    assert list(tmp_path.iterdir()) == []


def test_workers_that_cannot_see_the_videos_are_refused(scheduler: str, tmp_path: Path) -> None:
    with cluster.cluster_client(scheduler) as client:
        assert check_workers(client, Path(read_cli.__file__)) == 2
        with pytest.raises(ReaderError, match=r"missing\.mpg: the Dask workers tcp://.* cannot read it"):
            check_workers(client, tmp_path / "missing.mpg")


def test_the_executor_options_are_checked_before_anything_is_read(stripped: Path, tmp_path: Path,
                                                                 monkeypatch: pytest.MonkeyPatch,
                                                                 capsys: pytest.CaptureFixture[str]) -> None:
    assert main(_args(stripped, tmp_path, "--scheduler", "tcp://127.0.0.1:8786")) == 2
    assert "error: --scheduler is for --executor dask" in capsys.readouterr().err
    if "distributed" in sys.modules or _importable("distributed"):
        assert main(_args(stripped, tmp_path, "--executor", "dask")) == 2
        assert "error: --executor dask needs --scheduler tcp://HOST:PORT" in capsys.readouterr().err
    monkeypatch.setitem(sys.modules, "distributed", None)  # as if the dask extra were not installed
    assert main(_args(stripped, tmp_path, "--executor", "dask", "--scheduler", "tcp://127.0.0.1:8786")) == 2
    assert "pip install 'craft-dsl[dask]'" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def _importable(name: str) -> bool:
    import importlib.util

    return importlib.util.find_spec(name) is not None
