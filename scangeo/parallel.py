"""Run independent, picklable tasks: in this process, in local worker processes, or on a Dask cluster.

One helper for every stage that splits its work into tasks (rectification per strip, matching per
overlap, the laser adjustment's patch search per strip pair)::

    from scangeo.parallel import run_tasks
    results = run_tasks(function, tasks, workers=2)                      # 2 local processes
    results = run_tasks(function, tasks, scheduler="tcp://host:8786")    # a Dask scheduler

- ``function(task)`` and every task must be picklable (module-level function, dataclass or tuple of
  plain values, paths as strings): worker processes are started with ``spawn`` and a Dask worker
  may run on another machine, so a task carries what it needs (file paths the workers can read,
  not open files or big arrays), and the function writes its big outputs itself (through
  :mod:`scangeo.atomic`) and returns a small summary;
- results come back in the order of ``tasks``, whichever finished first;
- ``on_done(n, task)`` is called in this process after each finished task (``n`` finished so far):
  progress reporting;
- ``scheduler`` (the address of a running ``dask.distributed`` scheduler, e.g. ``tcp://10.0.0.5:8786``
  or a ``LocalCluster``'s ``scheduler_address``) wins over ``workers``; it needs the optional
  dependency ``dask[distributed]`` (``pip install 'scangeo[cluster]'``). ``key(task, i)`` names a
  task on the scheduler (its dashboard, its logs); the default is ``"{prefix}-{i}"``.

This module is on the ground floor: it imports no domain package.
"""
from __future__ import annotations

import multiprocessing
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from typing import Any, TypeVar

from scangeo.errors import MissingDependencyError

T = TypeVar("T")
R = TypeVar("R")


def run_tasks(function: Callable[[T], R], tasks: Sequence[T], workers: int = 1, scheduler: str | None = None,
              on_done: Callable[[int, T], None] | None = None, key: Callable[[T, int], str] | None = None,
              prefix: str = "task") -> list[R]:
    """``[function(t) for t in tasks]``, in this process (``workers`` 1), in ``workers`` local
    processes, or on the Dask scheduler at ``scheduler``; see the module docstring."""
    if scheduler:
        return _run_dask(function, tasks, scheduler, on_done, key or (lambda t, i: f"{prefix}-{i}"))
    if workers > 1 and len(tasks) > 1:
        return _run_processes(function, tasks, workers, on_done)
    out = []
    for n, t in enumerate(tasks, start=1):
        out.append(function(t))
        if on_done is not None:
            on_done(n, t)
    return out


def _run_processes(function: Callable[[T], R], tasks: Sequence[T], workers: int,
                   on_done: Callable[[int, T], None] | None) -> list[R]:
    out: list[Any] = [None] * len(tasks)
    with ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn")) as pool:
        futures = {pool.submit(function, t): i for i, t in enumerate(tasks)}
        for n, f in enumerate(as_completed(futures), start=1):
            i = futures[f]
            out[i] = f.result()
            if on_done is not None:
                on_done(n, tasks[i])
    return out


def _run_dask(function: Callable[[T], R], tasks: Sequence[T], address: str,
              on_done: Callable[[int, T], None] | None, key: Callable[[T, int], str]) -> list[R]:
    try:  # optional dependency
        from dask.distributed import Client
        from dask.distributed import as_completed as dask_completed
    except ImportError as exc:  # pragma: no cover - depends on the installation
        raise MissingDependencyError("a Dask scheduler needs dask[distributed] "
                                     "(pip install 'scangeo[cluster]')") from exc
    with Client(address) as client:
        futures = [client.submit(function, t, pure=False, key=key(t, i)) for i, t in enumerate(tasks)]
        index = {f.key: i for i, f in enumerate(futures)}
        for n, f in enumerate(dask_completed(futures), start=1):
            f.result()   # raises the task's error here
            if on_done is not None:
                on_done(n, tasks[index[f.key]])
        return [f.result() for f in futures]


__all__ = ["run_tasks"]
