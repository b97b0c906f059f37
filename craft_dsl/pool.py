"""Worker processes for the commands that parallelise (``generate``'s local executor, ``read``).

:func:`run_pool` runs ``fn(*args)`` for keyed tasks in ``spawn``-started processes and hands each result (or
failure) to callbacks in the calling thread as it finishes. The workers are started with Ctrl-C ignored, so a Ctrl-C
reaches only the main process, which stops them (no traceback from any of them); they die with the main process
(:func:`die_with_parent`); a worker that dies has its task reported as failed and is replaced. At most
:data:`QUEUED_PER_WORKER` tasks wait per worker beyond the one it runs, so an interruption drops little work.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
from collections import deque
from collections.abc import Callable, Sequence
from typing import Any

#: Tasks queued per worker process beyond the one it runs.
QUEUED_PER_WORKER = 1

#: One unit of work: a key (a video or instance index) and the arguments of the function run on it.
Task = tuple[int, tuple[Any, ...]]


def describe(err: BaseException) -> str:
    """``ExceptionType: message``: how a task's failure is reported."""
    return f"{type(err).__name__}: {err}"


def die_with_parent(parent: int) -> None:
    """Make this worker process end when ``parent`` does: at once on Linux (``PR_SET_PDEATHSIG``), elsewhere
    within a second (a thread watching the parent's pid). Call it first thing in the worker."""
    if sys.platform.startswith("linux"):
        try:
            import ctypes

            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
        except (OSError, AttributeError):
            pass

    def watch() -> None:
        import time

        while True:
            if os.getppid() != parent:
                os._exit(1)
            time.sleep(1.0)

    if os.getppid() != parent:
        os._exit(1)
    threading.Thread(target=watch, daemon=True).start()


def _worker_main(conn: Any, parent: int, fn: Callable[..., Any]) -> None:
    """A worker process: run the tasks received on ``conn`` until it closes."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    die_with_parent(parent)
    while True:
        try:
            task = conn.recv()
        except (EOFError, OSError):
            return
        if task is None:
            return
        key, args = task
        try:
            message: tuple[Any, ...] = ("ok", key, fn(*args))
        except Exception as err:  # noqa: BLE001 - reported to the main process, which goes on with the others
            message = ("error", key, describe(err))
        try:
            conn.send(message)
        except (EOFError, OSError):
            return
        except Exception as err:  # noqa: BLE001 - a result that cannot be sent (pickled)
            conn.send(("error", key, describe(err)))


class _Worker:
    def __init__(self, ctx: Any, fn: Callable[..., Any], name: str) -> None:
        self.conn, child = ctx.Pipe()
        self.process = ctx.Process(target=_worker_main, args=(child, os.getpid(), fn), daemon=True, name=name)
        self.process.start()
        child.close()
        self.queued: deque[Task] = deque()

    def feed(self, todo: deque[Task]) -> bool:
        """Send tasks from the front of ``todo`` until this worker holds its share; False (the task left in
        ``todo``) when the worker has died, which a worker may do at any moment after its last result arrived."""
        while todo and len(self.queued) <= QUEUED_PER_WORKER:
            try:
                self.conn.send(todo[0])
            except OSError:  # BrokenPipeError: its end of the pipe is gone
                return False
            self.queued.append(todo.popleft())
        return True

    def stop(self) -> None:
        if self.process.is_alive():
            self.process.kill()
        self.process.join(timeout=5)
        self.conn.close()


def _start(ctx: Any, fn: Callable[..., Any], n: int, name: str) -> list[_Worker]:
    # started with Ctrl-C ignored, which the spawned interpreters inherit: a Ctrl-C at any moment (even while they
    # import) reaches only this process, which stops them, and none of them prints a traceback
    main = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN) if main else None
    try:
        return [_Worker(ctx, fn, name) for _ in range(n)]
    finally:
        if main:
            signal.signal(signal.SIGINT, previous)


def run_pool(fn: Callable[..., Any], tasks: Sequence[Task], workers: int, on_result: Callable[[int, Any], None],
             on_failure: Callable[[int, str], None], name: str = "craft-dsl worker") -> None:
    """Run ``fn(*args)`` for each ``(key, args)`` of ``tasks`` in ``workers`` processes (``spawn``: ``fn`` is found
    by its module and name); ``on_result(key, value)``, or ``on_failure(key, "ExceptionType: message")`` where it
    raised or its worker died, is called in this thread as each finishes. A KeyboardInterrupt here stops the
    workers at once."""
    import multiprocessing
    from multiprocessing.connection import wait

    todo = deque(tasks)
    if not todo:
        return
    ctx = multiprocessing.get_context("spawn")
    pool = _start(ctx, fn, min(workers, len(todo)), name)
    try:
        while True:
            for i in range(len(pool)):
                while not pool[i].feed(todo) and not pool[i].queued:  # died holding nothing: only replace it
                    pool[i].stop()
                    pool[i] = _start(ctx, fn, 1, name)[0]
            if not any(w.queued for w in pool):
                break
            by_conn = {w.conn: w for w in pool if w.queued}
            for conn in wait(list(by_conn), timeout=1.0):
                w = by_conn[conn]
                try:
                    message = w.conn.recv()
                except (EOFError, OSError):
                    lost = w.queued.popleft()
                    todo.extendleft(reversed(w.queued))
                    w.queued.clear()
                    w.stop()
                    on_failure(lost[0], f"the worker process died (exit code {w.process.exitcode})")
                    pool[pool.index(w)] = _start(ctx, fn, 1, name)[0]
                    continue
                w.queued.popleft()
                if message[0] == "ok":
                    on_result(message[1], message[2])
                else:
                    on_failure(message[1], message[2])
    finally:
        for w in pool:
            w.stop()


__all__ = ["QUEUED_PER_WORKER", "Task", "describe", "die_with_parent", "run_pool"]
