"""The Dask cluster a sweep runs on: a local cluster of worker processes, or
an existing scheduler (``--scheduler tcp://host:8786``, e.g. one that
dask-jobqueue started on Slurm; docs/batch.md).

Local clusters run one job at a time per worker process (one thread each) and
give each worker's Dr.Jit ``cores // workers`` threads (at least 2: a pool of
one thread hangs Mitsuba 3.9.1 loading an ``envmap``), so the workers share
the machine's cores instead of each starting a pool as large as the machine.
Two scheduler settings make worker deaths cost little and blame the right job:

* ``distributed.scheduler.worker-saturation = 1.0``: a worker holds only the
  job it runs, so a worker that dies takes no queued job down with it (with
  Dask's default 1.1, a one-thread worker also holds the next job, and that
  job is counted as having killed the worker too);
* ``distributed.scheduler.allowed-failures``: how many worker deaths one job
  may cause before it is marked failed (Dask's default, 3: a job is run at
  most 4 times). The nanny restarts a worker that died.

An existing scheduler keeps its own settings (set them where it starts).
"""

from __future__ import annotations

import contextlib
import logging
import os
from typing import Optional

__all__ = ["WorkerSetup", "available_cores", "local_threads", "connect"]

#: Dask's default; a job may kill this many workers before it is failed.
ALLOWED_FAILURES = 3


def available_cores() -> int:
    """Cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1


def local_threads(workers: int) -> int:
    """Dr.Jit threads per worker of a local cluster: the cores shared out, but
    at least :data:`~mitsuba_pbrdf.batch.job.MIN_DRJIT_THREADS` (fewer hang)."""
    from .job import MIN_DRJIT_THREADS

    return max(MIN_DRJIT_THREADS, available_cores() // max(1, int(workers)))


def _plugin_base():
    from distributed.diagnostics.plugin import WorkerPlugin

    return WorkerPlugin


class WorkerSetup(_plugin_base()):
    """A Dask worker plugin run when a worker starts (restarted workers
    included): sets Dr.Jit's thread count and, for local workers, ignores
    SIGINT. Ctrl-C in a terminal reaches the whole process group; the sweep's
    own process handles it (records what finished, closes the cluster), while
    a worker that saw it would stop its render early and the job would write
    a partial image (Mitsuba's integrator winds down on SIGINT)."""

    name = "pbrdf-worker-setup"

    def __init__(self, drjit_threads: Optional[int], ignore_sigint: bool = False):
        self.drjit_threads = drjit_threads
        self.ignore_sigint = ignore_sigint

    def setup(self, worker):
        from .job import set_drjit_threads

        if self.ignore_sigint:
            import signal

            try:
                signal.signal(signal.SIGINT, signal.SIG_IGN)
            except ValueError:  # pragma: no cover - not the main thread
                pass
        set_drjit_threads(self.drjit_threads)


@contextlib.contextmanager
def _workers_ignore_sigint():
    """While the local cluster starts its worker processes, multiprocessing
    starts them through a two-line shell script that ignores SIGINT and runs
    this Python: an ignored signal stays ignored through exec, and Python keeps
    it so, so the workers never see a terminal's Ctrl-C, not even while they
    import (a worker interrupted in its imports printed a traceback, and the
    cluster's close then failed). The sweep's own process handles Ctrl-C;
    WorkerSetup keeps ignoring it in restarted workers."""
    import shlex
    import stat
    import sys
    import tempfile
    from multiprocessing import spawn

    previous = spawn.get_executable()   # bytes or str
    python = os.fsdecode(previous or sys.executable)
    with tempfile.TemporaryDirectory(prefix="pbrdf-worker-") as folder:
        script = os.path.join(folder, "python")
        with open(script, "w") as f:
            f.write(f"#!/bin/sh\ntrap '' INT\nexec {shlex.quote(python)} "
                    '"$@"\n')
        os.chmod(script, stat.S_IRWXU)
        spawn.set_executable(script)
        try:
            yield
        finally:
            spawn.set_executable(previous)


@contextlib.contextmanager
def _closed_if_interrupted():
    """Around a LocalCluster's construction: if it is interrupted (Ctrl-C),
    the half-started cluster, which the caller never got, is closed here
    (quietly: its workers may not have started, and the process is about to
    exit) and taken off Dask's list of clusters to close at exit, whose
    attempt would print a traceback."""
    from distributed.deploy.spec import SpecCluster

    before = set(map(id, SpecCluster._instances))
    try:
        yield
    except BaseException:
        # what the interrupted start-up left (a nanny that failed to start, a task
        # whose result nobody reads) would be logged with tracebacks at exit
        for name in ("distributed", "asyncio", "tornado"):
            logging.getLogger(name).disabled = True
        for cluster in [c for c in list(SpecCluster._instances) if id(c) not in before]:
            with contextlib.suppress(Exception):
                cluster.close(timeout=5)
            SpecCluster._instances.discard(cluster)
        raise


@contextlib.contextmanager
def connect(workers: Optional[int] = None, scheduler: Optional[str] = None,
            drjit_threads: Optional[int] = None,
            allowed_failures: int = ALLOWED_FAILURES):
    """A ``dask.distributed.Client``: on the scheduler at *scheduler*, or on a
    new local cluster of *workers* processes (default: :func:`default_workers`). Yields ``(client, drjit_threads)``,
    the Dr.Jit thread count jobs should set (None: leave the worker's)."""
    import dask
    from dask.distributed import Client, LocalCluster

    if scheduler is not None:
        client = Client(scheduler, timeout="30s")
        try:
            if drjit_threads:
                client.register_plugin(WorkerSetup(drjit_threads))
            yield client, drjit_threads
        finally:
            client.close()
        return

    workers = int(workers or default_workers())
    threads = int(drjit_threads or local_threads(workers))
    settings = {"distributed.scheduler.worker-saturation": 1.0,
                "distributed.scheduler.allowed-failures": int(allowed_failures)}
    with dask.config.set(settings):
        with _workers_ignore_sigint(), _closed_if_interrupted():
            cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                   dashboard_address=":0", silence_logs=logging.CRITICAL)
        try:
            client = Client(cluster)
            try:
                client.register_plugin(WorkerSetup(threads, ignore_sigint=True))
                yield client, threads
            finally:
                client.close()
        finally:
            cluster.close()


def default_workers() -> int:
    """Local workers when ``--workers`` is not given: one per 2 cores, at
    least 1 and at most 4. Each render already runs on its worker's Dr.Jit
    threads; more workers overlap the parts of a job that run on one thread
    (scene loading, the plugin's Python set-up, writing files). On 2 cores, 2
    workers rendered 3 % more per minute than 1 (within the spread of the runs:
    benchmarks/batch.md), hence 1 there; the rule above 2 cores is a guess,
    not a measurement: run benchmarks/batch_throughput.py to choose."""
    return max(1, min(4, available_cores() // 2))
