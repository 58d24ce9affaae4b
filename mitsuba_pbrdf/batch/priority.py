"""Submitting a sweep's jobs so that they start in the sweep's order, each
worker holding only the job it runs, and a job whose worker was lost is
rendered again before any job that has not started (docs/batch.md).

Dask orders the tasks waiting for a worker by their priority tuple
``(-user priority, generation, graph order)``. Jobs submitted one by one
with ``client.submit`` all had graph order 0, and the scheduler starts a new
*generation* only when 100 ms (``fifo_timeout``) have passed since the last
one, so the hundreds of jobs submitted within 100 ms shared one priority,
among which Dask's queue keeps no particular order. A job whose worker was
lost (killed, ``scancel``, Slurm walltime) went back among the waiting jobs
of its generation, often behind all of them: on Slurm one waited more than
60 renders after its worker's walltime (tests/test_batch_slurm.py), on a
local cluster one ran last of 12 (tests/test_batch_priority.py). Submitted
one by one, the first jobs also reached the scheduler as a task group too
small to queue (Dask queues only groups larger than twice the cluster's
threads), so they were handed to the first worker up front: a worker lost
early took 3 jobs with it.

:func:`submit_in_order` submits all jobs as one graph (``client.map``): one
generation, graph order = the sweep's order (all priorities distinct), and
one task group as large as the sweep. With the scheduler's queue
(``worker-saturation`` finite, as :mod:`.cluster` and :mod:`.slurm` set
it) and a sweep larger than twice the workers' threads, every job waits in
that queue and leaves it highest priority first: jobs start in the sweep's
order, so every job that has started (a lost one included) comes before
every job still waiting, and a lost job goes to the next free worker. A
scheduler that assigns tasks to workers up front (queuing off, e.g. an
existing scheduler with ``worker-saturation: inf``, or a sweep of at most
twice the threads) gives a lost job to another worker, which runs it
before the later jobs it holds (workers run their ready tasks by priority).
"""

from __future__ import annotations

from typing import Callable, List, Sequence, Tuple

__all__ = ["submit_in_order"]


def submit_in_order(client, function: Callable, arguments: Sequence[Tuple],
                    keys: Sequence[str]) -> List:
    """Futures of ``function(*arguments[i])`` under the task keys *keys*,
    submitted to *client* as one graph whose order is that of *arguments*
    (not pure: run even if a key was seen)."""
    if len(keys) != len(arguments):
        raise ValueError(f"{len(arguments)} jobs but {len(keys)} keys")
    if not arguments:
        return []
    columns = [list(column) for column in zip(*arguments)]
    return client.map(function, *columns, key=list(keys), pure=False)
