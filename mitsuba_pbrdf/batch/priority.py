"""Submitting a sweep's jobs so that a job whose worker was lost is rendered
again before any job that has not started (docs/batch.md).

Dask orders the tasks waiting for a worker by their priority tuple
``(-user priority, generation, graph order)``. Tasks submitted one by one
with ``client.submit`` all have graph order 0, and the scheduler starts a new
*generation* only when 100 ms (``fifo_timeout``) have passed since the last
one, so the hundreds of jobs submitted within 100 ms share one priority.
Among equal priorities Dask's queue keeps no particular order, so when a
worker was lost (killed, ``scancel``, Slurm walltime) its job went back
among the waiting jobs of its generation, often behind all of them: on
Slurm one waited more than 60 renders after its worker's walltime
(tests/test_batch_slurm.py), and on a local cluster one ran last of 12
(tests/test_batch_priority.py, with priority 0 for all).

:func:`submit_in_order` gives each job a user priority of its own, higher
for earlier jobs, and Dask starts waiting tasks highest priority first.
With the scheduler's queue (``worker-saturation`` finite, as :mod:`.cluster`
and :mod:`.slurm` set it) jobs leave it in the sweep's order, so every job
that has started (a lost one included) comes before every job still
waiting: a lost job goes back ahead of all the jobs that have not started.
A scheduler that assigns tasks to workers up front (queuing off, e.g. an
existing scheduler with ``worker-saturation: inf``) gives a lost job to
another worker, which runs it before the later jobs in its own queue.
"""

from __future__ import annotations

from typing import Callable, List, Sequence, Tuple

__all__ = ["submit_in_order"]


def submit_in_order(client, function: Callable, arguments: Sequence[Tuple],
                    keys: Sequence[str]) -> List:
    """Futures of ``function(*arguments[i])`` submitted to *client* under the
    task keys *keys* (not pure: run even if a key was seen), with priorities
    ``len(arguments) - i``: the first job highest, all distinct."""
    if len(keys) != len(arguments):
        raise ValueError(f"{len(arguments)} jobs but {len(keys)} keys")
    count = len(arguments)
    return [client.submit(function, *args, key=key, pure=False, priority=count - index)
            for index, (args, key) in enumerate(zip(arguments, keys))]
