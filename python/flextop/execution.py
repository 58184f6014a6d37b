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
* :class:`~concurrent.futures.ProcessPoolExecutor` (what ``--workers N`` makes, see
  :func:`local_executor`) or :class:`~concurrent.futures.ThreadPoolExecutor` (the engine
  releases the GIL, but two runs in one process share its memory bandwidth: processes are
  faster, BENCHMARKS.md "Scenarios and batches");
* a ``dask.distributed`` client's ``client.get_executor()`` (what ``--scheduler ADDRESS``
  uses), which retries a task whose worker died when given ``retries``;
* ``mpi4py.futures.MPIPoolExecutor``.

A task that fails raises, in the caller, the same :class:`FlextopError` class prefixed with
its label; anything else that stops it (a worker that died, a task that could not be sent)
is an :class:`ExecutionError` naming the task. The remaining tasks are cancelled: an
evaluation never returns a partial result.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Executor, Future, ProcessPoolExecutor
from contextlib import contextmanager
from multiprocessing import get_context
from typing import Any, TypeVar

from .errors import ExecutionError, FlextopError, SettingsError

T = TypeVar("T")
R = TypeVar("R")


def run_all(perform: Callable[[T], R], tasks: Sequence[tuple[str, T]], executor: Executor | None = None) -> list[R]:
    """``perform(task)`` for each ``(label, task)``, the results in the tasks' order, on
    ``executor`` (``None``: here, one after the other). ``perform`` must be a module-level
    function and ``task`` picklable for an executor of other processes."""
    if executor is None:
        return [_here(perform, label, task) for label, task in tasks]
    futures: list[Future] = []
    try:
        for _, task in tasks:
            futures.append(executor.submit(perform, task))
        return [_result(label, future) for (label, _), future in zip(tasks, futures)]
    except BaseException:
        for future in futures:
            future.cancel()
        raise


def _here(perform: Callable[[T], R], label: str, task: T) -> R:
    try:
        return perform(task)
    except FlextopError as error:
        raise _named(error, label) from error


def _result(label: str, future: Future) -> Any:
    try:
        return future.result()
    except FlextopError as error:
        raise _named(error, label) from error
    except (KeyboardInterrupt, SystemExit):
        raise
    except BaseException as error:  # a worker that died, a task that could not be sent or was lost
        raise ExecutionError(f"{label}: the task did not complete on its worker ({type(error).__name__}: {error})") from error


def _named(error: FlextopError, label: str) -> FlextopError:
    """``error``'s class with the task's label in front of its message."""
    try:
        return type(error)(f"{label}: {error}")
    except TypeError:  # a class whose constructor takes other arguments
        return ExecutionError(f"{label}: {type(error).__name__}: {error}")


@contextmanager
def local_executor(workers: int | None = None, scheduler: str | None = None) -> Iterator[Executor | None]:
    """The executor of the command line's ``--workers N`` (a pool of ``N`` processes;
    ``N = 1`` or ``None``: this process) or ``--scheduler ADDRESS`` (the Dask scheduler
    there, whose client is closed on exit), shut down when the block ends."""
    if workers is not None and scheduler is not None:
        raise SettingsError("give --workers (a local pool) or --scheduler (a Dask cluster), not both")
    if scheduler is not None:
        with _dask_client(scheduler) as client:
            yield client.get_executor()
        return
    if workers is None or workers == 1:
        yield None
        return
    if workers < 1:
        raise SettingsError(f"--workers must be at least 1, got {workers}")
    # spawn, not fork: a forked child would inherit the engine's thread pool half-made
    with ProcessPoolExecutor(workers, mp_context=get_context("spawn")) as pool:
        yield pool


@contextmanager
def _dask_client(address: str) -> Iterator[Any]:
    try:
        from distributed import Client
    except ImportError:
        raise SettingsError("--scheduler needs dask.distributed: pip install 'flextop[cluster]'") from None
    try:
        client = Client(address, timeout=30)
    except (OSError, TimeoutError, ValueError) as error:
        raise ExecutionError(f"--scheduler {address}: cannot reach the Dask scheduler ({error})") from None
    try:
        yield client
    finally:
        client.close()
