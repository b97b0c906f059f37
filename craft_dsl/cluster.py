"""Tasks on a Dask distributed cluster (the ``dask`` extra), for the commands that run beyond one machine:
``craft-dsl generate --executor dask`` and ``craft-dsl read --executor dask``.

:func:`connect` reaches a scheduler (``tcp://HOST:PORT``) or refuses it in one line; :func:`run_on_cluster` runs
``fn(*args)`` for keyed tasks there, as :func:`craft_dsl.pool.run_pool` does in local processes, and hands each
result (or failure) to callbacks in the calling thread as it finishes. At most
:data:`~craft_dsl.pool.QUEUED_PER_WORKER` tasks wait per worker thread beyond the one it runs (workers that join
during a run get tasks), so an interruption drops little work; the scheduler re-runs the tasks of a worker that
dies on another worker. The workers need craft_dsl installed (the same version) and one thread each
(``dask worker ADDRESS --nthreads 1``: the physics is pure Python and holds the GIL).
"""

from __future__ import annotations

import math
import time
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import CancelledError
from contextlib import contextmanager, suppress
from types import ModuleType
from typing import Any

from .errors import CraftError, MissingExtraError
from .pool import QUEUED_PER_WORKER, Task, describe

#: Seconds to wait for a scheduler to answer.
CONNECT_TIMEOUT_S = 30.0
#: How to start a cluster, for the messages that need one.
HOW_TO_START = "start one with 'dask scheduler' and workers with 'dask worker ADDRESS --nthreads 1'"


def import_distributed(feature: str = "--executor dask") -> ModuleType:
    """Dask's ``distributed``, or a :class:`~craft_dsl.errors.MissingExtraError` naming ``feature`` and the extra."""
    try:
        import distributed
    except ImportError:
        raise MissingExtraError(feature, "dask", "Dask's distributed scheduler") from None
    return distributed


def connect(scheduler: Any, timeout: float | None = None) -> tuple[Any, bool]:
    """A ``distributed.Client`` of ``scheduler`` (an address, or a client, returned as it is) and whether it was made
    here (and is to be closed by the caller); an address that is malformed or where no scheduler answers within
    ``timeout`` seconds (default :data:`CONNECT_TIMEOUT_S`) is a :class:`~craft_dsl.errors.CraftError`."""
    distributed = import_distributed()
    if isinstance(scheduler, distributed.Client):
        return scheduler, False
    try:  # checked first: a Client made of a malformed address complains again when it is collected
        distributed.comm.get_address_host_port(str(scheduler))
    except (ValueError, TypeError) as err:
        raise CraftError(f"--scheduler {scheduler}: not a scheduler address ({err}); expected tcp://HOST:PORT, as "
                         "'dask scheduler' prints it") from None
    try:
        client = distributed.Client(scheduler, timeout=CONNECT_TIMEOUT_S if timeout is None else timeout,
                                    set_as_default=False)
    except (OSError, TimeoutError) as err:
        raise CraftError(f"--scheduler {scheduler}: cannot reach a Dask scheduler there ({err}); {HOW_TO_START}") \
            from None
    except Exception as err:  # noqa: BLE001 - something answered that is not a Dask scheduler
        raise CraftError(f"--scheduler {scheduler}: what answers there is not a Dask scheduler ({describe(err)}); "
                         f"{HOW_TO_START}") from None
    return client, True


@contextmanager
def cluster_client(scheduler: Any, timeout: float | None = None) -> Iterator[Any]:
    """:func:`connect` for the length of the block; a client made here is closed at its end."""
    client, owned = connect(scheduler, timeout)
    try:
        yield client
    finally:
        if owned:
            client.close(timeout=5)


class _Capacity:
    """How many tasks a cluster holds at once (its worker threads', each with its queue), asked of the scheduler at
    most once every ``every_s`` seconds: workers that join during a run get tasks."""

    def __init__(self, client: Any, every_s: float = 1.0) -> None:
        self._client = client
        self._every_s = every_s
        self._asked = -math.inf
        self._slots = 1

    def slots(self) -> int:
        now = time.monotonic()
        if now - self._asked >= self._every_s:
            self._asked = now
            self._slots = max(1, sum(self._client.nthreads().values())) * (1 + QUEUED_PER_WORKER)
        return self._slots


def run_on_cluster(client: Any, fn: Callable[..., Any], tasks: Sequence[Task], on_result: Callable[[int, Any], None],
                   on_failure: Callable[[int, str], None], key: Callable[[int], str] | None = None) -> None:
    """Run ``fn(*args)`` for each ``(key, args)`` of ``tasks`` on ``client``'s cluster (``fn`` is found by its module
    and name); ``on_result(key, value)``, or ``on_failure(key, "ExceptionType: message")`` where it raised (after two
    retries where its worker died), is called in this thread as each finishes. ``key(task_key)`` names the Dask task
    (default: a fresh name). A KeyboardInterrupt here cancels the tasks not finished."""
    distributed = import_distributed()
    todo = deque(tasks)
    if not todo:
        return
    futures: dict[Any, int] = {}
    capacity = _Capacity(client)

    def submit() -> Any:
        task_key, args = todo.popleft()
        fut = client.submit(fn, *args, key=None if key is None else key(task_key), pure=False, retries=2)
        futures[fut] = task_key
        return fut

    def more() -> list[Any]:
        """Tasks to fill the cluster's workers, as many as it has now (one at least while none is queued)."""
        free = capacity.slots() - len(futures)
        return [submit() for _ in range(min(max(free, 0 if futures else 1), len(todo)))]

    try:
        with _scheduler_lost():
            pending = distributed.as_completed(more(), loop=client.loop)
        for fut in pending:
            task_key = futures.pop(fut)
            try:
                value = fut.result()
            except CancelledError as err:  # not the task's doing: the scheduler dropped it
                raise _lost(err) from None
            except Exception as err:  # noqa: BLE001 - reported for this task; the others go on
                on_failure(task_key, describe(err))
            else:
                on_result(task_key, value)
            with _scheduler_lost():
                fut.release()
                pending.update(more())
    finally:
        if futures:
            with suppress(Exception):  # best effort: a scheduler that is gone has dropped them already
                client.cancel(list(futures), force=True)


def _lost(err: BaseException) -> CraftError:
    reason = " ".join(describe(err).split())  # Dask's messages run over lines
    return CraftError(f"the Dask scheduler was lost ({reason}); the finished work is kept: run the same command "
                      "again, once the scheduler is back, to resume")


@contextmanager
def _scheduler_lost() -> Iterator[None]:
    """Calls to the scheduler: losing it is a :class:`~craft_dsl.errors.CraftError` saying how to go on."""
    try:
        yield
    except (OSError, TimeoutError, CancelledError) as err:
        raise _lost(err) from None

__all__ = ["CONNECT_TIMEOUT_S", "cluster_client", "connect", "import_distributed", "run_on_cluster"]
