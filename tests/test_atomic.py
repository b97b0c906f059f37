"""Atomic writes: durable on success, nothing left on failure, leftovers of killed writers removed later."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from craft_dsl import atomic as atomic_module
from craft_dsl.atomic import UNNAMED_STALE_S, atomic_path, remove_stale_temporaries

ROOT = Path(__file__).resolve().parents[1]

#: a writer that enters atomic_path, writes part of the file, says where, and waits to be killed
_WRITER = """
import sys, time
from craft_dsl.atomic import atomic_path
with atomic_path(sys.argv[1]) as tmp:
    tmp.write_bytes(b"half a video")
    print(tmp, flush=True)
    time.sleep(120)
"""

posix_only = pytest.mark.skipif(os.name != "posix", reason="SIGKILL and os.kill(pid, 0) are POSIX")


def _leftovers(folder: Path) -> list[Path]:
    return sorted(p for p in folder.iterdir() if ".tmp" in p.name)


def _killed_writer(target: Path) -> Path:
    """The temporary file a writer of ``target`` SIGKILLed mid-write leaves (its process already reaped)."""
    proc = subprocess.Popen([sys.executable, "-c", _WRITER, str(target)], stdout=subprocess.PIPE, text=True,
                            cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT)})
    try:
        assert proc.stdout is not None
        tmp = Path(proc.stdout.readline().strip())
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)
        if proc.stdout is not None:
            proc.stdout.close()
    assert proc.returncode == -signal.SIGKILL
    return tmp


def test_success_writes_target_with_usual_permissions(tmp_path: Path) -> None:
    target = tmp_path / "sub" / "out.json"
    with atomic_path(target) as tmp:
        assert tmp.parent == target.parent and tmp.suffix == ".json"
        assert tmp.name.startswith(f".out.{os.getpid()}.") and tmp.name.endswith(".tmp.json")
        tmp.write_text("{}")
        assert not target.exists()
    assert target.read_text() == "{}"
    umask = os.umask(0)
    os.umask(umask)
    assert target.stat().st_mode & 0o777 == 0o666 & ~umask
    assert _leftovers(target.parent) == []


def test_failing_block_leaves_neither_target_nor_temporary(tmp_path: Path) -> None:
    target = tmp_path / "out.mp4"
    with pytest.raises(RuntimeError, match="encoder broke"), atomic_path(target) as tmp:
        tmp.write_bytes(b"partial")
        raise RuntimeError("encoder broke")
    assert list(tmp_path.iterdir()) == []


def test_failing_block_keeps_the_old_target(tmp_path: Path) -> None:
    target = tmp_path / "out.json"
    target.write_text("old")
    with pytest.raises(RuntimeError), atomic_path(target) as tmp:
        tmp.write_text("new, half")
        raise RuntimeError
    assert target.read_text() == "old"
    assert _leftovers(tmp_path) == []


@posix_only
def test_data_and_directory_are_flushed(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The file's data is flushed before the rename (through a handle of its own: the block may have written
    it through another process), and the directory after it."""
    target = tmp_path / "out.bin"
    calls: list[tuple[str, bool]] = []
    real_fsync = os.fsync
    fds = Path("/proc/self/fd")

    def recording_fsync(fd: int) -> None:
        calls.append((os.readlink(fds / str(fd)) if fds.is_dir() else "", target.exists()))
        real_fsync(fd)

    monkeypatch.setattr(atomic_module.os, "fsync", recording_fsync)
    with atomic_path(target) as tmp:
        with tmp.open("wb") as fh:  # written through a handle the block closes itself
            fh.write(b"data")
        tmp_name = os.path.realpath(tmp)
    assert [existed for _, existed in calls] == [False, True]  # the data before the rename, the folder after
    if fds.is_dir():
        assert [name for name, _ in calls] == [tmp_name, os.path.realpath(tmp_path)]
    assert target.read_bytes() == b"data"


def test_no_flush_on_failure(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    calls: list[int] = []
    monkeypatch.setattr(atomic_module.os, "fsync", calls.append)
    with pytest.raises(ValueError), atomic_path(tmp_path / "out.json"):
        raise ValueError
    assert calls == []


def test_directory_flush_skipped_where_a_directory_cannot_be_opened(tmp_path: Path,
                                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    """As on Windows: opening a directory fails, the write still succeeds."""
    real_open = os.open

    def no_directories(path: str | os.PathLike[str], flags: int, *args: int) -> int:
        if Path(path).is_dir():
            raise PermissionError(13, "Permission denied", str(path))
        return real_open(path, flags, *args)

    monkeypatch.setattr(atomic_module.os, "open", no_directories)
    target = tmp_path / "out.txt"
    with atomic_path(target) as tmp:
        tmp.write_text("ok")
    assert target.read_text() == "ok"
    assert _leftovers(tmp_path) == []


@posix_only
def test_sigkilled_writer_leftover_removed_by_the_next_write(tmp_path: Path) -> None:
    target = tmp_path / "x.mp4"
    leftover = _killed_writer(target)
    assert leftover.exists() and leftover.parent == tmp_path
    assert leftover.name.startswith(".x.") and leftover.name.endswith(".tmp.mp4")
    assert not target.exists()
    with atomic_path(target) as tmp:
        tmp.write_bytes(b"a whole video")
    assert not leftover.exists()
    assert target.read_bytes() == b"a whole video"
    assert _leftovers(tmp_path) == []


@posix_only
def test_live_writer_and_other_targets_kept(tmp_path: Path) -> None:
    """A running writer's temporary file of the same target stays, and so do other targets' (even a target
    whose stem extends this one's), and a recent leftover without a process id."""
    target = tmp_path / "x.mp4"
    live = tmp_path / f".x.{os.getppid()}.abcd1234.tmp.mp4"  # the parent of this process: running
    other_target = tmp_path / ".x.1.999999.abcd1234.tmp.mp4"  # target x.1.mp4's, by a dead writer
    other_suffix = tmp_path / ".x.999999.abcd1234.tmp.gif"
    unnamed_recent = tmp_path / ".x.abcd1234.tmp.mp4"
    for path in (live, other_target, other_suffix, unnamed_recent):
        path.write_bytes(b"")
    assert remove_stale_temporaries(target) == 0
    with atomic_path(target) as tmp:
        tmp.write_bytes(b"v")
    assert all(p.exists() for p in (live, other_target, other_suffix, unnamed_recent))


@posix_only
def test_old_leftovers_without_process_id_removed(tmp_path: Path) -> None:
    target = tmp_path / "x.mp4"
    old = tmp_path / ".x.k3j2_9zq.tmp.mp4"  # an earlier version's name: no process id
    old.write_bytes(b"")
    stamp = time.time() - UNNAMED_STALE_S - 60
    os.utime(old, (stamp, stamp))
    assert remove_stale_temporaries(target) == 1
    assert not old.exists()


@posix_only
def test_dead_writer_leftover_removed(tmp_path: Path) -> None:
    proc = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True,
                          text=True, check=True)
    dead = int(proc.stdout)  # exited and reaped: no such process (unless the id was reused this instant)
    leftover = tmp_path / f".x.{dead}.abcd1234.tmp.mp4"
    leftover.write_bytes(b"")
    try:
        os.kill(dead, 0)
    except ProcessLookupError:
        pass
    else:  # pragma: no cover - the id went to another process already
        pytest.skip("the dead writer's process id was reused")
    assert remove_stale_temporaries(tmp_path / "x.mp4") == 1
    assert not leftover.exists()


def test_a_folder_is_listed_once_for_many_writes(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Writing N files into a folder lists it once, not N times (a dataset's folders hold a file per video)."""
    listings: list[str] = []
    real_listdir = os.listdir

    def counting_listdir(path: str | os.PathLike[str]) -> list[str]:
        listings.append(os.fspath(path))
        return real_listdir(path)

    monkeypatch.setattr(atomic_module.os, "listdir", counting_listdir)
    for i in range(50):
        with atomic_path(tmp_path / f"qa_{i:06d}.json") as tmp:
            tmp.write_text("{}")
    assert listings == [os.fspath(tmp_path)]


@posix_only
def test_a_leftover_made_after_the_listing_goes_once_it_is_old(tmp_path: Path,
                                                               monkeypatch: pytest.MonkeyPatch) -> None:
    target = tmp_path / "x.mp4"
    with atomic_path(target) as tmp:  # this process has listed the folder
        tmp.write_bytes(b"1")
    leftover = _killed_writer(target)
    with atomic_path(target) as tmp:  # the listing is reused: the leftover is not seen yet
        tmp.write_bytes(b"2")
    assert leftover.exists()
    monkeypatch.setattr(atomic_module, "LOOK_AGAIN_S", 0.0)
    time.sleep(0.01)
    with atomic_path(target) as tmp:
        tmp.write_bytes(b"3")
    assert not leftover.exists() and target.read_bytes() == b"3"
    assert _leftovers(tmp_path) == []
