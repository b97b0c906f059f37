"""Atomic file writes: write beside the target under a temporary name, rename into place when complete.

An interrupted or failed write therefore never leaves a half-written file (nor, when it fails, the temporary
one). A completed write is durable: the file's data is flushed to disk before the rename and the directory
after it, so a crash of the machine leaves the old file or the new one, never an empty or partial one.

The temporary file is ``.<stem>.<pid>.<random>.tmp<suffix>`` beside the target, ``<pid>`` the writing
process's. A process killed outright (SIGKILL, a lost machine) leaves it behind; a later atomic write of the
same target removes such leftovers once their writer is gone (see :func:`remove_stale_temporaries`). To find them
a process lists a folder at most once every :data:`LOOK_AGAIN_S` seconds (a folder of 10,000 files takes
milliseconds to list, and a dataset writes one file per video into such folders), so a leftover is removed by the
first write of its target in a later process, or in the same process once its listing is that old.
"""

from __future__ import annotations

import errno
import json
import os
import re
import tempfile
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

#: A leftover whose name holds no process id (written before the id was put in the name) is removed once it
#: is this old.
UNNAMED_STALE_S = 6 * 3600
#: A leftover whose process id belongs to a running process is still removed once it is this old: the id was
#: given to another process since (after a reboot, say); no writer keeps a temporary file a week untouched.
REUSED_PID_STALE_S = 7 * 24 * 3600
#: How long a process reuses its listing of a folder's temporary files before it lists the folder again.
LOOK_AGAIN_S = 60.0
#: tempfile.mkstemp's random part: 8 characters of ``[a-z0-9_]``.
_RANDOM = r"[a-z0-9_]{8}"
_MIDDLE = re.compile(rf"(?:(?P<pid>[0-9]+)\.)?{_RANDOM}")
#: Per folder (absolute path): when this process last listed it (time.monotonic()) and the temporary-looking names
#: it held then, less those removed since.
_LOOKS: dict[str, tuple[float, list[str]]] = {}
_LOOKS_LOCK = threading.Lock()
#: Folders whose listing is kept at most (past it, every listing is forgotten and made again when next needed).
_MAX_LOOKS = 1024


def _temp_affixes(target: Path) -> tuple[str, str]:
    """The prefix and suffix of the temporary names of ``target`` (the process id and random part between)."""
    return f".{target.stem}.", f".tmp{target.suffix}"


def _process_alive(pid: int) -> bool:
    """Whether a process ``pid`` runs on this machine (True where that cannot be told)."""
    if pid == os.getpid():
        return True
    if os.name == "nt":  # os.kill(pid, 0) would end the process there, not probe it
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (OverflowError, OSError):  # another user's process (PermissionError), or an id out of range
        return True
    return True


def _is_stale(path: Path, pid: int | None, now: float) -> bool:
    try:
        age = now - path.stat().st_mtime
    except OSError:  # gone already
        return False
    if pid is None:
        return age > UNNAMED_STALE_S
    return not _process_alive(pid) or age > REUSED_PID_STALE_S


def _temporary_names(folder: Path, fresh: bool) -> list[str]:
    """The names in ``folder`` that look like atomic writes' temporary files (``.*.tmp*``): listed now if
    ``fresh`` or this process's last listing is older than :data:`LOOK_AGAIN_S`, else that listing."""
    key = os.path.abspath(folder)
    now = time.monotonic()
    with _LOOKS_LOCK:
        seen = _LOOKS.get(key)
    if not fresh and seen is not None and now - seen[0] <= LOOK_AGAIN_S:
        return list(seen[1])
    try:
        names = [name for name in os.listdir(folder) if name.startswith(".") and ".tmp" in name]
    except OSError:
        return []
    with _LOOKS_LOCK:
        if len(_LOOKS) >= _MAX_LOOKS:
            _LOOKS.clear()
        _LOOKS[key] = (now, names)
    return list(names)


def _forget(folder: Path, name: str) -> None:
    with _LOOKS_LOCK:
        seen = _LOOKS.get(os.path.abspath(folder))
        if seen is not None and name in seen[1]:
            seen[1].remove(name)


def remove_stale_temporaries(path: str | os.PathLike[str], fresh: bool = True) -> int:
    """Remove the temporary files that killed writers of ``path`` left beside it; returns how many.

    A leftover is removed when the process named in it no longer runs (or, where its name holds no process
    id, once it is :data:`UNNAMED_STALE_S` old; where the process id names a running process, once it is
    :data:`REUSED_PID_STALE_S` old): a live writer of the same target keeps its file. ``fresh=False`` (atomic
    writes) reuses this process's listing of the folder while it is at most :data:`LOOK_AGAIN_S` old."""
    target = Path(path)
    prefix, suffix = _temp_affixes(target)
    removed = 0
    now = time.time()
    for name in _temporary_names(target.parent, fresh):
        if not (name.startswith(prefix) and name.endswith(suffix)):
            continue
        match = _MIDDLE.fullmatch(name[len(prefix):len(name) - len(suffix)])
        if match is None:  # another target's temporary file (one whose stem extends this stem)
            continue
        pid = match["pid"]
        leftover = target.parent / name
        if _is_stale(leftover, None if pid is None else int(pid), now):
            try:
                leftover.unlink()
            except FileNotFoundError:  # removed by another writer at the same moment
                _forget(target.parent, name)
                continue
            except OSError:  # not ours to remove (permissions): left alone
                continue
            _forget(target.parent, name)
            removed += 1
    return removed


def _fsync_file(path: Path) -> None:
    """Flush the data of ``path`` to disk, whichever handle wrote it."""
    fd = os.open(path, os.O_RDWR if os.name == "nt" else os.O_RDONLY)  # Windows flushes writable handles only
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _fsync_directory(directory: Path) -> None:
    """Flush ``directory``'s entries (a rename into it) to disk; skipped where a directory cannot be opened
    (Windows) or flushed (some file systems)."""
    try:
        fd = os.open(directory, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError as err:
        if err.errno not in (errno.EINVAL, errno.ENOTSUP, errno.EBADF, errno.EACCES):
            raise
    finally:
        os.close(fd)


@contextmanager
def atomic_path(path: str | os.PathLike[str]) -> Iterator[Path]:
    """A temporary path beside ``path`` (same extension), renamed onto ``path`` if the block succeeds.

    The block may write the path through any handle (another process's included). On success the data is
    flushed to disk, the file renamed onto ``path`` and the directory flushed; on failure the temporary file is
    removed. Stale temporary files of ``path`` that killed writers left are removed first."""
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    remove_stale_temporaries(target, fresh=False)
    prefix, suffix = _temp_affixes(target)
    fd, tmp_name = tempfile.mkstemp(prefix=f"{prefix}{os.getpid()}.", suffix=suffix, dir=target.parent)
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        yield tmp
        # mkstemp creates 0600 files: give the result the usual permissions (0666 less the umask)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        _fsync_file(tmp)
        os.replace(tmp, target)
        _fsync_directory(target.parent)
    finally:
        tmp.unlink(missing_ok=True)


def write_json_atomic(data: Any, path: str | os.PathLike[str], indent: int | None = 2) -> None:
    """Write ``data`` as JSON to ``path`` atomically."""
    with atomic_path(path) as tmp, tmp.open("w", encoding="utf-8") as fh:
        json.dump(data, fh, indent=indent)
        fh.write("\n")
