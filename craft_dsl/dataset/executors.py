"""Where the videos are computed: in this process, in local worker processes, or on a Dask cluster.

Every executor runs :func:`craft_dsl.dataset.instance.run_instance` on tasks and hands each
:class:`~craft_dsl.dataset.instance.InstanceResult` to a callback in the main process, in whatever order they
finish; results are bytes, so the output does not depend on the executor or the number of workers. At most a
few tasks per worker are queued at any time, so an interruption drops little work.

* :class:`LocalExecutor` (the default, no extra): ``workers`` processes started with ``spawn``. They ignore
  Ctrl-C (the main process stops them), die with the main process (Linux ``PR_SET_PDEATHSIG``; elsewhere a
  watchdog thread notices the parent is gone within a second), and a worker that dies is replaced, its video
  reported as failed.
* :class:`DaskExecutor` (the ``dask`` extra): tasks submitted to a ``distributed`` scheduler
  (``tcp://HOST:PORT``) by :mod:`craft_dsl.cluster`, which ``read --executor dask`` shares; the scheduler re-runs
  the tasks of a worker that dies on another worker.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Iterable
from typing import Any, Protocol

from ..cluster import cluster_client, import_distributed, run_on_cluster
from ..errors import CraftError
from ..parallel import usable_cpu_count
from ..pool import describe, run_pool
from .instance import InstanceResult, InstanceTask, run_instance

OnResult = Callable[[InstanceResult], None]
#: (instance id, error message) of a task that raised.
Failure = tuple[int, str]


class Executor(Protocol):
    """Runs tasks, calls ``on_result`` in the calling thread for each finished one, returns the failures."""

    description: str
    #: Whether the machine has cores beyond the workers', so that a worker's media may be rendered in a thread
    #: beside its physics (:attr:`InstanceTask.media_thread`); executors without it are taken to fill every core.
    spare_cores: bool

    def run(self, tasks: Iterable[InstanceTask], on_result: OnResult) -> list[Failure]: ...


def _failure(task_id: int, err: BaseException) -> Failure:
    return (task_id, describe(err))


# -- local ------------------------------------------------------------------------------------------------------


class LocalExecutor:
    """``workers`` local processes; with ``in_process`` (the default for one worker) the tasks run in this process
    instead (no start-up cost, easy to debug). The command line always uses processes: a Ctrl-C that lands while
    pymunk runs a Python collision callback would be printed and swallowed by cffi there, whereas the main process,
    only waiting for results, stops at once."""

    def __init__(self, workers: int = 1, in_process: bool | None = None) -> None:
        if workers < 1:
            raise CraftError(f"--workers {workers}: give at least 1")
        self.workers = workers
        self.in_process = workers == 1 if in_process is None else in_process
        self.spare_cores = workers < usable_cpu_count()
        self.description = "this process" if self.in_process else \
            f"{workers} local worker process{'es' if workers > 1 else ''}"

    def run(self, tasks: Iterable[InstanceTask], on_result: OnResult) -> list[Failure]:
        todo = deque(tasks)
        if not todo:
            return []
        if self.in_process:
            failures: list[Failure] = []
            for task in todo:
                try:
                    result = run_instance(task)
                except Exception as err:  # noqa: BLE001 - reported after the other instances ran
                    failures.append(_failure(task.instance_id, err))
                    continue
                on_result(result)
            return failures
        return self._run_pool(todo, on_result)

    def _run_pool(self, todo: deque[InstanceTask], on_result: OnResult) -> list[Failure]:
        failures: list[Failure] = []
        run_pool(run_instance, [(task.instance_id, (task,)) for task in todo], self.workers,
                 lambda _key, result: on_result(result), lambda key, message: failures.append((key, message)),
                 name="craft-dsl generate worker")
        return sorted(failures)


# -- Dask -------------------------------------------------------------------------------------------------------


class DaskExecutor:
    """Tasks on a Dask distributed cluster: ``scheduler`` is its address (``tcp://HOST:PORT``) or a
    ``distributed.Client`` (:mod:`craft_dsl.cluster`). The workers need craft_dsl installed (same version) and one
    thread each (``dask worker ADDRESS --nthreads 1``: the physics is pure Python and holds the GIL)."""

    def __init__(self, scheduler: Any, timeout: float = 30.0) -> None:
        import_distributed()
        self._scheduler = scheduler
        self._timeout = timeout
        self.description = f"the Dask cluster at {scheduler}"
        self.spare_cores = False  # a cluster's workers are started one per core

    def run(self, tasks: Iterable[InstanceTask], on_result: OnResult) -> list[Failure]:
        by_id = {task.instance_id: task for task in tasks}
        failures: list[Failure] = []

        def key(instance_id: int) -> str:
            task = by_id[instance_id]
            return f"craft-dsl-instance-{task.seed}-{task.instance_id}-{int(task.questions)}{int(task.media)}"

        with cluster_client(self._scheduler, self._timeout) as client:
            run_on_cluster(client, run_instance, [(i, (task,)) for i, task in by_id.items()],
                           lambda _key, result: on_result(result),
                           lambda i, message: failures.append((i, message)), key=key)
        return sorted(failures)


def make_executor(kind: str, workers: int = 1, scheduler: Any = None) -> Executor:
    """The executor named ``kind`` (``local``: always worker processes, or ``dask``), as the command line uses
    it."""
    if kind == "local":
        return LocalExecutor(workers, in_process=False)
    if kind == "dask":
        if not scheduler:
            raise CraftError("--executor dask needs --scheduler tcp://HOST:PORT (the address 'dask scheduler' "
                             "prints)")
        return DaskExecutor(scheduler)
    raise CraftError(f"unknown executor {kind!r}; allowed: local, dask")


__all__ = ["DaskExecutor", "Executor", "Failure", "LocalExecutor", "make_executor"]
