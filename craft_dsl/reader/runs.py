"""Runs of ``craft-dsl read`` that survive interruption: a journal of the finished videos, and worker processes that
stop at once on Ctrl-C (or a Dask cluster's workers, :func:`check_workers`, fed by :mod:`craft_dsl.cluster`).

The journal (``<out>.partial.jsonl``, beside ``--out``) is JSON Lines: a header naming the run's inputs (digests of
the questions and of the resolved video list, and the options that change answers), then one record per finished
video, flushed and fsynced before the next. The same command resumes from it; a journal of other inputs is refused,
never mixed in; a last line cut short by a kill is dropped, and its video read again. While a run holds a journal,
another run on it is refused (a lock on the file, where the system has ``fcntl``).
"""

from __future__ import annotations

import hashlib
import json
import os
import signal
import sys
import threading
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from types import FrameType, TracebackType
from typing import IO, Any

from ..errors import ReaderError
from ..pool import Task, describe, run_pool

#: What the journal's name adds to ``--out``'s.
JOURNAL_SUFFIX = ".partial.jsonl"
JOURNAL_KIND = "craft-dsl read"
JOURNAL_VERSION = 3  # 2: each answer carries its confidence; 3: counterfactual answers are voted (--votes)
#: Packages that call Python from C (pymunk through cffi, Box2D through SWIG): an exception raised in such a
#: callback is printed and swallowed there, so Ctrl-C is not raised while one runs (:func:`ctrl_c_outside_callbacks`).
CALLBACK_PACKAGES = ("pymunk", "Box2D")


def journal_path(out: str | os.PathLike[str]) -> Path:
    """The journal of the run writing ``out``."""
    return Path(f"{os.fspath(out)}{JOURNAL_SUFFIX}")


def _digest(value: Any) -> str:
    return hashlib.sha256(json.dumps(value, sort_keys=True, separators=(",", ":")).encode()).hexdigest()


def text_digest(text: str) -> str:
    """The SHA-256 of ``text`` in UTF-8, in hex."""
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def run_header(questions: Iterable[tuple[int, int, str]], videos: Mapping[int, Path],
               options: Mapping[str, Any]) -> dict[str, Any]:
    """The journal header of a run: digests of its questions ``(video_index, question_index, text)`` and of its
    videos (index, resolved path, size), and the options (``{"samples": 64, ...}``) that change its answers."""
    listed = []
    for index, path in sorted(videos.items()):
        try:
            size = path.stat().st_size
        except OSError:
            size = None
        listed.append([index, str(path.resolve()), size])
    return {"journal": JOURNAL_KIND, "version": JOURNAL_VERSION, "questions": _digest(list(questions)),
            "videos": _digest(listed), "options": dict(options)}


def _differences(found: Mapping[str, Any], expected: Mapping[str, Any]) -> list[str]:
    out = []
    if found.get("questions") != expected["questions"]:
        out.append("other questions")
    if found.get("videos") != expected["videos"]:
        out.append("other videos")
    options = found.get("options")
    theirs: Mapping[str, Any] = options if isinstance(options, dict) else {}
    for name, value in expected["options"].items():
        if theirs.get(name) != value:
            out.append(f"--{name} {theirs.get(name)} there, {value} here")
    return out


def _lock(fh: IO[bytes], path: Path) -> None:
    try:
        import fcntl
    except ImportError:  # pragma: no cover - Windows: no lock
        return
    try:
        fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        fh.close()
        raise ReaderError(f"{path}: another craft-dsl read is writing this journal (a run with the same --out); "
                          "wait for it to end, or give another --out") from None


def _record(line: bytes) -> dict[str, Any] | None:
    """A journal line read as a finished video's record, or None if it is not one."""
    try:
        value = json.loads(line)
    except ValueError:
        return None
    if not isinstance(value, dict) or isinstance(value.get("video"), bool) or not isinstance(value.get("video"), int) \
            or not isinstance(value.get("details"), list):
        return None
    return value


class Journal:
    """The journal of a run, open for appending: :attr:`records` holds the finished videos' records by index (those
    read back from an earlier run, then those added); :attr:`dropped_line` is the number of a last line dropped as cut
    short (None if there was none)."""

    def __init__(self, path: Path, fh: IO[bytes], records: dict[int, dict[str, Any]],
                 dropped_line: int | None) -> None:
        self.path = path
        self._fh = fh
        self.records = records
        self.dropped_line = dropped_line

    @classmethod
    def open(cls, path: str | os.PathLike[str], header: Mapping[str, Any]) -> Journal:
        """Resume the journal at ``path`` if it is one of the run ``header`` describes (refuse it if it is of
        another run), or start it."""
        target = Path(path)
        target.parent.mkdir(parents=True, exist_ok=True)
        try:
            fh = open(target, "a+b")  # noqa: SIM115 - held open for the run; closed by close()
        except OSError as err:
            raise ReaderError(f"{target}: cannot write the run's journal: {err.strerror or err}") from None
        _lock(fh, target)
        try:
            fh.seek(0)
            lines = fh.read().split(b"\n")
            records: dict[int, dict[str, Any]] = {}
            dropped: int | None = None
            keep = 0  # bytes of the file kept
            if len(lines) < 2:  # empty, or the header cut short: nothing was finished
                start = json.dumps({"journal": JOURNAL_KIND}).encode()[:-1]
                if not (start.startswith(lines[0]) or lines[0].startswith(start)):
                    raise ReaderError(f"{target}: not a journal of craft-dsl read; move it away or give another "
                                      "--out")
                fh.truncate(0)
                fh.write((json.dumps(dict(header)) + "\n").encode())
                _sync(fh)
                return cls(target, fh, records, None)
            try:
                found = json.loads(lines[0])
            except ValueError:
                found = None
            if not isinstance(found, dict) or found.get("journal") != JOURNAL_KIND:
                raise ReaderError(f"{target}: not a journal of craft-dsl read (its first line is not one's header); "
                                  "move it away or give another --out")
            if found.get("version") != JOURNAL_VERSION:
                raise ReaderError(f"{target}: a journal of version {found.get('version')!r}, this craft-dsl writes "
                                  f"version {JOURNAL_VERSION}; delete it to start afresh")
            differences = _differences(found, header)
            if differences:
                raise ReaderError(f"{target}: the journal of another run ({'; '.join(differences)}); it is not mixed "
                                  "into this one: run the command that wrote it to finish that run, or delete it to "
                                  "start afresh")
            keep = len(lines[0]) + 1
            complete, tail = lines[1:-1], lines[-1]
            for number, line in enumerate(complete, start=2):
                record = _record(line)
                if record is None:
                    if number == len(complete) + 1 and not tail:  # the last line: cut short by a crash
                        dropped = number
                        break
                    raise ReaderError(f"{target}: line {number} is not the record of a finished video (a JSON object "
                                      "with video and details); the journal is damaged: delete it to start afresh")
                records[record["video"]] = record
                keep += len(line) + 1
            if tail:  # a line without its end: the run was killed while writing it
                dropped = len(complete) + 2
            if dropped is not None:
                fh.truncate(keep)
                _sync(fh)
            return cls(target, fh, records, dropped)
        except BaseException:
            fh.close()
            raise

    def add(self, record: dict[str, Any]) -> None:
        """Append a finished video's record (``video``: its index, ``details``: its answers' records) and make it
        durable before returning."""
        self._fh.write((json.dumps(record, separators=(",", ":")) + "\n").encode())
        _sync(self._fh)
        self.records[record["video"]] = record

    def close(self) -> None:
        self._fh.close()

    def remove(self) -> None:
        """Close and delete the journal (its run's files are written)."""
        self.close()
        self.path.unlink(missing_ok=True)

    def __enter__(self) -> Journal:
        return self

    def __exit__(self, kind: type[BaseException] | None, err: BaseException | None, tb: TracebackType | None) -> None:
        if not self._fh.closed:
            self.close()


def _sync(fh: IO[bytes]) -> None:
    fh.flush()
    os.fsync(fh.fileno())


# -- running the videos ------------------------------------------------------------------------------------------


def _in_callback(frame: FrameType | None) -> bool:
    """Whether Python code is running inside a call from one of :data:`CALLBACK_PACKAGES` (its frames are on the
    stack)."""
    roots = []
    for name in CALLBACK_PACKAGES:
        module = sys.modules.get(name)
        where = getattr(module, "__file__", None)
        if where:
            roots.append(os.path.dirname(where) + os.sep)
    while roots and frame is not None:
        if frame.f_code.co_filename.startswith(tuple(roots)):
            return True
        frame = frame.f_back
    return False


@contextmanager
def ctrl_c_outside_callbacks(retry_s: float = 0.02) -> Iterator[None]:
    """Within the block, Ctrl-C raises KeyboardInterrupt only where it would not be swallowed: one that lands while a
    physics engine runs a Python callback is raised ``retry_s`` later, outside it. Only in the main thread, and only
    where Ctrl-C raises KeyboardInterrupt (not where it is ignored)."""
    if threading.current_thread() is not threading.main_thread() or \
            signal.getsignal(signal.SIGINT) is not signal.default_int_handler:
        yield
        return

    main = threading.main_thread().ident

    def again() -> None:  # to the main thread itself, which a blocking call (a sleep, a wait) then returns from
        if hasattr(signal, "pthread_kill") and main is not None:
            signal.pthread_kill(main, signal.SIGINT)
        else:  # pragma: no cover - Windows
            signal.raise_signal(signal.SIGINT)

    def on_ctrl_c(signum: int, frame: FrameType | None) -> None:
        if _in_callback(frame):
            timer = threading.Timer(retry_s, again)
            timer.daemon = True
            timer.start()
            return
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGINT, on_ctrl_c)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def _worker_view(path: str) -> tuple[bool, str]:
    """On a cluster's worker: whether it sees the file ``path``, and its craft_dsl's version."""
    from .. import __version__

    return os.path.isfile(path), __version__


def check_workers(client: Any, path: str | os.PathLike[str]) -> int:
    """Refuse a Dask cluster (``client``'s) whose workers cannot read the video ``path`` (the workers read the
    videos where this machine finds them: a shared file system, mounted at the same path) or run another version of
    craft_dsl (whose answers may differ); the number of workers checked (0: none has joined yet)."""
    from .. import __version__

    try:
        views: dict[str, tuple[bool, str]] = client.run(_worker_view, os.fspath(path))
    except Exception as err:  # noqa: BLE001 - a worker without craft_dsl cannot unpickle the check
        raise ReaderError(f"the Dask workers cannot run craft_dsl ({describe(err)}); install craft-dsl "
                          f"{__version__} where they run") from None
    blind = sorted(worker for worker, (seen, _version) in views.items() if not seen)
    if blind:
        raise ReaderError(f"{path}: the Dask worker{'s' if len(blind) > 1 else ''} {', '.join(blind)} cannot read "
                          "it; the workers read the videos at the paths this machine finds them at: give --videos "
                          "on a file system the workers mount at the same path")
    other = sorted(f"{worker} ({version})" for worker, (_seen, version) in views.items() if version != __version__)
    if other:
        raise ReaderError(f"the Dask workers {', '.join(other)} run another craft_dsl than this one "
                          f"({__version__}); install the same version on every worker")
    return len(views)


def run_tasks(fn: Callable[..., Any], tasks: Sequence[Task], workers: int, on_result: Callable[[int, Any], None],
              on_failure: Callable[[int, str], None]) -> None:
    """Run ``fn(*args)`` for each ``(key, args)`` of ``tasks``; ``on_result(key, value)``, or ``on_failure(key,
    "ExceptionType: message")`` where it raised, is called in this thread as each finishes. With one worker the tasks
    run in this process, in order; with more, in that many processes (``spawn``; ``fn`` is found by its module and
    name) that ignore Ctrl-C and die with this process: a KeyboardInterrupt here stops them at once."""
    if not tasks:
        return
    if workers <= 1:
        with ctrl_c_outside_callbacks():
            for key, args in tasks:
                try:
                    value = fn(*args)
                except Exception as err:  # noqa: BLE001 - reported for this task; the others go on
                    on_failure(key, describe(err))
                    continue
                on_result(key, value)
        return
    run_pool(fn, tasks, workers, on_result, on_failure, name="craft-dsl read worker")


__all__ = ["JOURNAL_SUFFIX", "Journal", "check_workers", "ctrl_c_outside_callbacks", "journal_path", "run_header",
           "run_tasks", "text_digest"]
