"""Independent simulations on any :class:`concurrent.futures.Executor`: in this process, a
local pool, a Dask cluster or MPI.

Each evaluation is a *task*: a label that names it in errors (a scenario, a design of a
batch) and plain data for a module-level function, such as
:func:`flextop.simulation.perform` on a :class:`~flextop.simulation.Task` (the scene as
its dict, the design, the run's arguments: what crosses processes is the scene and the
design, never engine state). :func:`run_all` submits the tasks and returns their results
in the tasks' order, the same bits whatever the executor: each result is computed by the
same code from the same inputs, and any sum over them is the caller's, in that order.

Executors, all used as they come:

* ``None``: one after the other, in this process (the default);
* :class:`~concurrent.futures.ThreadPoolExecutor` (what ``--workers N`` makes, see
  :func:`local_executor`: the engine releases the GIL) or
  :class:`~concurrent.futures.ProcessPoolExecutor` (with the spawn or forkserver start
  method: a forked child would inherit the engine's thread pool half-made and hang, so a
  forking pool is refused before any task is sent);
* a ``dask.distributed`` client's ``client.get_executor()`` (what ``--scheduler ADDRESS``
  uses), which retries a task whose worker died when given ``retries``, or the client
  itself (its executor is used);
* ``mpi4py.futures.MPIPoolExecutor``.

Ctrl-C while waiting cancels the tasks not started and stops those running on this
process's threads at their next step (the engine hears Python's signals in the main thread
only); tasks on other processes are the executor's to stop.

A task that fails raises, in the caller, the same :class:`FlextopError` class prefixed with
its label (any other exception it raises, as it would here); a worker that died or a task
that could not be sent is an :class:`ExecutionError` naming the task. The remaining tasks are cancelled: an
evaluation never returns a partial result.
"""

from __future__ import annotations

import math
import multiprocessing
import os
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import (FIRST_EXCEPTION, BrokenExecutor, CancelledError, Executor, Future, ProcessPoolExecutor,
                                ThreadPoolExecutor, wait)
from contextlib import contextmanager
from typing import Any, NamedTuple, TypeVar

from . import _core
from .checks import whole
from .errors import ExecutionError, FlextopError, SettingsError

T = TypeVar("T")
R = TypeVar("R")
S = TypeVar("S")


def run_all(perform: Callable[[T], R], tasks: Sequence[tuple[str, T]], executor: Executor | None = None, *,
            chunksize: int = 1) -> list[R]:
    """``perform(task)`` for each ``(label, task)``, the results in the tasks' order, on
    ``executor`` (``None``: here, one after the other), ``chunksize`` tasks to one
    submission (fewer, larger tasks: what pays on a Dask cluster, whose scheduler spends
    about 2 ms per task). ``perform`` must be a module-level function and ``task``
    picklable for an executor of other processes."""
    chunksize = whole("chunksize", chunksize)
    chunks = [list(tasks[k:k + chunksize]) for k in range(0, len(tasks), chunksize)]
    executor = usable(executor)
    if executor is None:
        return [r for chunk in chunks for r in perform_all(perform, chunk)]
    futures: list[Future] = []
    try:
        for chunk in chunks:
            futures.append(_submit(executor, perform, chunk))
        wait(futures, return_when=FIRST_EXCEPTION)  # the first failure ends the wait
        return [r for chunk, future in zip(chunks, futures) for r in _result(chunk, future)]
    except BaseException as error:
        for future in futures:
            future.cancel()
        if isinstance(error, KeyboardInterrupt):  # the tasks running on this process's threads stop too
            _core.cancel_running()
        raise


def perform_all(perform: Callable[[T], R], chunk: Sequence[tuple[str, T]]) -> list[R]:
    """``perform`` on each task of ``chunk`` in turn (in a worker); a failure is raised with
    its task's label in front."""
    out = []
    for label, task in chunk:
        try:
            out.append(perform(task))
        except FlextopError as error:
            raise _named(error, label) from error
    return out


def side_by_side(here: Callable[[], R], beside: Callable[[], S]) -> tuple[R, S]:
    """``(here(), beside())``, ``beside`` on a thread of its own while ``here`` runs in this
    one where this process may use two cores or more (the engine releases the GIL: two runs
    take the time of the longer), one after the other where it may use one. The same bits
    either way: each run is the same code on the same inputs. A failure is raised once both
    have ended; Ctrl-C stops both."""
    if _cores() < 2:
        return here(), beside()
    with ThreadPoolExecutor(1, thread_name_prefix="flextop-beside") as pool:
        future = pool.submit(beside)
        try:
            return here(), future.result()
        except BaseException as error:
            if isinstance(error, KeyboardInterrupt):  # the run beside stops at its next step too
                _core.cancel_running()
            raise


def _cores() -> int:
    """The cores this process may run on."""
    affinity = getattr(os, "sched_getaffinity", None)
    return len(affinity(0)) if affinity is not None else os.cpu_count() or 1


def usable(executor: Any) -> Executor | None:
    """``executor`` checked before any task is sent: a Dask ``Client`` stands for its
    ``get_executor()`` (a closed one is an :class:`ExecutionError`); a
    :class:`~concurrent.futures.ProcessPoolExecutor` that forks is a
    :class:`SettingsError` (its children would inherit the engine's thread pool half-made
    and hang); anything else that is not an :class:`Executor` is a :class:`SettingsError`."""
    if executor is None or isinstance(executor, ProcessPoolExecutor) and _forks(executor):
        if executor is not None:
            raise SettingsError("executor: a ProcessPoolExecutor must start its workers by spawn (or forkserver), not fork: "
                                "ProcessPoolExecutor(n, mp_context=multiprocessing.get_context('spawn'))")
        return None
    if not isinstance(executor, Executor) and callable(getattr(executor, "get_executor", None)):  # a Dask Client
        if getattr(executor, "status", "running") in ("closing", "closed"):
            raise ExecutionError("executor: the Dask client is closed")
        return executor.get_executor()
    if not isinstance(executor, Executor):
        raise SettingsError(f"executor: expected a concurrent.futures.Executor (or a Dask Client), got {type(executor).__name__}")
    return executor


def _forks(pool: ProcessPoolExecutor) -> bool:
    context = getattr(pool, "_mp_context", None)
    method = context.get_start_method() if context is not None else multiprocessing.get_start_method(allow_none=True)
    return method == "fork"


LOST = ("KilledWorker", "CommClosedError", "FutureCancelledError")
"""Dask's names for a task lost with its worker or connection (matched by name, so that
Dask stays optional)."""


def _submit(executor: Executor, perform: Callable, chunk: list) -> Future:
    try:
        return executor.submit(perform_all, perform, chunk)
    except Exception as error:  # shut down, broken by an earlier task, or a Dask client closed
        if isinstance(error, (RuntimeError, BrokenExecutor)) or type(error).__name__ == "ClosedClientError":
            raise ExecutionError(f"{_labels(chunk)}: the executor does not take tasks ({type(error).__name__}: {error})") from error
        raise


def _result(chunk: Sequence[tuple[str, Any]], future: Future) -> list:
    """The chunk's results; a worker or task lost is an :class:`ExecutionError`, anything
    the task itself raised is raised as it would be in this process."""
    try:
        return future.result()
    except (BrokenExecutor, CancelledError) as error:
        raise ExecutionError(f"{_labels(chunk)}: the task did not complete on its worker ({type(error).__name__}: {error})") from error
    except Exception as error:
        if type(error).__name__ in LOST:
            raise ExecutionError(f"{_labels(chunk)}: the task did not complete on its worker ({type(error).__name__}: {error})") from error
        raise


def _labels(chunk: Sequence[tuple[str, Any]]) -> str:
    return " / ".join(label for label, _ in chunk)


def _named(error: FlextopError, label: str) -> FlextopError:
    """``error``'s class with the task's label in front of its message."""
    try:
        return type(error)(f"{label}: {error}")
    except TypeError:  # a class whose constructor takes other arguments
        return ExecutionError(f"{label}: {type(error).__name__}: {error}")


class Workers(NamedTuple):
    """An executor and how many tasks it runs at once (1 for ``None``)."""

    executor: Executor | None
    slots: int

    def chunksize(self, tasks: int) -> int:
        """Tasks to a submission so that each slot gets one submission."""
        return max(1, math.ceil(tasks / self.slots))


@contextmanager
def local_executor(workers: int | None = None, scheduler: str | None = None) -> Iterator[Workers]:
    """The executor of the command line's ``--workers N`` (``N`` threads; ``N = 1`` or
    ``None``: this process) or ``--scheduler ADDRESS`` (the Dask scheduler there, whose
    client is closed on exit), shut down when the block ends. Threads, because the engine
    releases the GIL and they measured faster than processes on the arm's scenarios
    (BENCHMARKS.md, "Scenarios and batches")."""
    if workers is not None and scheduler is not None:
        raise SettingsError("give --workers (a local pool) or --scheduler (a Dask cluster), not both")
    if scheduler is not None:
        with _dask_client(scheduler) as client:
            yield Workers(client.get_executor(), max(1, sum(client.nthreads().values())))
        return
    if workers is None or workers == 1:
        yield Workers(None, 1)
        return
    if workers < 1:
        raise SettingsError(f"--workers must be at least 1, got {workers}")
    with ThreadPoolExecutor(workers) as pool:
        yield Workers(pool, workers)


@contextmanager
def _dask_client(address: str) -> Iterator[Any]:
    try:
        from distributed import Client
    except ImportError:
        raise SettingsError("--scheduler needs dask.distributed: pip install 'flextop[cluster]'") from None
    try:
        client = Client(address, timeout=10)
    except (OSError, TimeoutError, ValueError) as error:
        raise ExecutionError(f"--scheduler {address}: cannot reach the Dask scheduler ({error})") from None
    try:
        yield client
    finally:
        client.close()
