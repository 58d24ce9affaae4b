"""Running a sweep on Dask (local, an existing scheduler, or Slurm worker
jobs) without losing work (docs/batch.md).

::

    from mitsuba_pbrdf.batch import load_sweep, run_sweep
    summary = run_sweep(load_sweep("scenes/sweeps/materials.toml"), workers=2)
    print(summary.line())

What :func:`run_sweep` guarantees:

* jobs already finished (:func:`mitsuba_pbrdf.batch.manifest.is_finished`:
  row ``done``, same seed, files present and valid) are skipped; failed,
  pending and missing ones run again;
* a job that fails (an unknown material, a scene error) is recorded with its
  one-line error and the others go on;
* a job whose worker dies (killed, crashed, out of memory) is run again on a
  worker that the nanny restarted or on another one, with the same seed,
  before any job that has not started (:func:`submit_in_order`, below);
  one that kills ``allowed-failures + 1`` workers is recorded as failed
  (:mod:`mitsuba_pbrdf.batch.cluster`);
* the manifest's ``note`` says why a job ran again (its worker process
  died; its worker's Slurm job was cancelled or reached its walltime:
  :mod:`mitsuba_pbrdf.batch.lost`); on Slurm, lost worker jobs are replaced
  (at most ``max_resubmissions`` times each with no render done in between,
  then the sweep stops with a one-line ``SlurmError`` and its unfinished jobs
  left pending) and every worker job is cancelled at the end
  (:mod:`mitsuba_pbrdf.batch.slurm`);
* temporary files that a worker killed while writing left behind are
  removed at the end;
* only this process writes ``manifest.csv``, whole and atomically, after
  each finished job (at most every ``MANIFEST_INTERVAL_S`` seconds) and at
  the end, also on Ctrl-C (then ``KeyboardInterrupt`` propagates) and on any
  error: the manifest always describes files that exist.

The jobs' order: they start in the sweep's order, each worker holding only
the job it runs, and a job whose worker was lost is rendered again before any
job that has not started.

Dask orders the tasks waiting for a worker by their priority tuple
``(-user priority, generation, graph order)``. Jobs submitted one by one
with ``client.submit`` would all have graph order 0, and the scheduler starts
a new *generation* only when 100 ms (``fifo_timeout``) have passed since the
last one, so the hundreds of jobs submitted within 100 ms would share one
priority, among which Dask's queue keeps no particular order: a job whose
worker was lost (killed, ``scancel``, Slurm walltime) would go back among the
waiting jobs of its generation, often behind all of them
(tests/batch/test_slurm.py, tests/batch/test_cluster.py). Submitted one by
one, the first jobs would also reach the scheduler as a task group too small
to queue (Dask queues only groups larger than twice the cluster's threads)
and be handed to the first worker up front, to be lost with it.

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

import contextlib
import os
import threading
import time
import uuid
from dataclasses import dataclass, field
from typing import Callable, Dict, List, Optional, Sequence, Tuple

from .job import JobTask, run_job
from .manifest import is_finished, job_row, read_manifest, write_manifest
from .sweep import Sweep

__all__ = ["SweepSummary", "run_sweep", "submit_in_order", "MANIFEST_INTERVAL_S"]

#: Folder of ``out`` for Slurm's logs of the worker jobs (``--slurm``).
SLURM_LOGS = "slurm-logs"
#: Least seconds between two manifest rewrites while jobs finish.
MANIFEST_INTERVAL_S = 2.0


@dataclass
class SweepSummary:
    """What a sweep run did: job counts, wall-clock seconds, the manifest."""

    jobs: int
    skipped: int = 0
    done: int = 0
    failed: int = 0
    pending: int = 0
    seconds: float = 0.0
    manifest: str = ""
    failures: List[str] = field(default_factory=list)  # "job: error"
    workers: int = 0

    def line(self) -> str:
        """One line for the user."""
        ran = self.done + self.failed
        rate = f", {60.0 * ran / self.seconds:.1f} jobs/min" if ran and self.seconds > 0 else ""
        return (f"{self.jobs} jobs: {self.done} rendered, {self.skipped} already done, "
                f"{self.failed} failed, {self.pending} pending, in {self.seconds:.1f} s{rate}; "
                f"manifest {self.manifest}")


def _task(sweep: Sweep, job) -> JobTask:
    return JobTask(name=job.name, scene=sweep.scene, params=dict(job.params), seed=job.seed,
                   spp=sweep.spp, variant=sweep.variant, out=sweep.out,
                   outputs=tuple(sweep.outputs), polcam=tuple(sorted(sweep.polcam.items())),
                   bands=sweep.bands)


def _result_row(job, result) -> Dict[str, str]:
    return job_row(job, status=result.status, spp=result.spp, seconds=f"{result.seconds:.3f}",
                   file=result.file, aov=result.aov, polcam=result.polcam,
                   error=result.error)


def _lost_worker_error(error: BaseException) -> str:
    from distributed import KilledWorker

    if isinstance(error, KilledWorker):
        return ("the worker running it died each time it was tried (killed, crashed or out "
                "of memory; Dask's distributed.scheduler.allowed-failures)")
    from ..errors import describe_error

    return f"{type(error).__name__}: {describe_error(error)}"


def _add_notes(sweep: Sweep, rows, client, keys, explain):
    """Set the ``note`` of each job whose worker left while running it. The
    note is a record and never fails the sweep: a scheduler or Slurm that
    no longer answers leaves the notes out."""
    from .lost import notes

    try:
        found = notes(client, keys, explain)
    except Exception:  # noqa: BLE001 - the images and statuses are what matters
        return
    jobs = {job.name: job for job in sweep.jobs}
    for name, note in found.items():
        rows.setdefault(name, job_row(jobs[name]))["note"] = note


def _remove_stale_temporaries(sweep: Sweep):
    """Remove the temporary files of outputs (``.<job>.exr.<random>.tmp.exr``,
    :func:`mitsuba_pbrdf.outputs.atomic_path`) that a worker killed while
    writing left behind; called once the sweep's workers are stopped."""
    import glob

    folder = glob.escape(sweep.out)
    for job in sweep.jobs:
        for path in glob.glob(os.path.join(folder, f".{glob.escape(job.name)}*.tmp.exr")):
            try:
                os.unlink(path)
            except OSError:
                pass


class _Stopper:
    """Cancels the sweep's outstanding futures (once submitted) when the Slurm
    worker jobs reach their cap on replacements
    (:mod:`mitsuba_pbrdf.batch.slurm_keeper`); :meth:`stop` is called from the
    keeper's thread. *futures* is the runner's own dict of outstanding futures
    (not a copy: those already collected are neither kept nor cancelled)."""

    def __init__(self):
        self._lock = threading.Lock()
        self._client, self._futures, self.stopped = None, {}, False

    def arm(self, client, futures: dict):
        with self._lock:
            self._client, self._futures = client, futures
            stopped = self.stopped
        if stopped:
            self._cancel(client, futures)

    def stop(self):
        with self._lock:
            self.stopped = True
            client, futures = self._client, self._futures
        if client is not None:
            self._cancel(client, futures)

    @staticmethod
    def _cancel(client, futures: dict):
        outstanding = list(futures)  # one step under the GIL, while the runner pops
        if outstanding:
            client.cancel(outstanding)


@contextlib.contextmanager
def _connect(sweep: Sweep, workers, scheduler, slurm, drjit_threads, allowed_failures,
             done=lambda: 0, stopper: Optional[_Stopper] = None):
    """``(client, Dr.Jit threads for jobs, explain)`` on the chosen cluster;
    *explain* says why workers left (:mod:`mitsuba_pbrdf.batch.lost`). On
    Slurm, *done* () -> renders done so far and *stopper* serve the cap on
    replacing lost worker jobs."""
    from .cluster import connect
    from .lost import local_explain, remote_explain

    if slurm is not None:
        from .slurm import connect_slurm

        with connect_slurm(slurm, os.path.join(sweep.out, SLURM_LOGS),
                           allowed_failures=allowed_failures, done=done,
                           on_give_up=(stopper or _Stopper()).stop) as (client, explain):
            yield client, None, explain  # the workers set their own threads
        return
    with connect(workers=workers, scheduler=scheduler, drjit_threads=drjit_threads,
                 allowed_failures=allowed_failures) as (client, threads):
        yield client, threads, remote_explain if scheduler else local_explain


def run_sweep(sweep: Sweep, workers: Optional[int] = None, scheduler: Optional[str] = None,
              drjit_threads: Optional[int] = None, progress="auto",
              allowed_failures: Optional[int] = None, slurm=None) -> SweepSummary:
    """Run the jobs of *sweep* that are not finished, on a local Dask cluster
    of *workers* processes, on the scheduler at *scheduler*, or on Slurm
    worker jobs (*slurm*: a :class:`~mitsuba_pbrdf.batch.slurm_options.SlurmOptions`;
    see the module docstring). *drjit_threads*: Dr.Jit threads per worker (local default:
    the cores shared out; Slurm: the job's cores). *progress*: as for
    :func:`~mitsuba_pbrdf.rendering.progress.progress_reporter` (a bar over jobs).
    Returns a :class:`SweepSummary`."""
    from dask.distributed import as_completed

    from ..rendering.progress import progress_reporter
    from .cluster import ALLOWED_FAILURES

    start = time.perf_counter()
    summary = SweepSummary(jobs=len(sweep.jobs), manifest=sweep.manifest)
    previous = read_manifest(sweep.manifest)
    names = {job.name for job in sweep.jobs}
    extra = [row for name, row in previous.items() if name not in names]
    rows = {job.name: previous[job.name] for job in sweep.jobs
            if is_finished(sweep, job, previous.get(job.name))}
    todo = [job for job in sweep.jobs if job.name not in rows]
    summary.skipped = len(rows)

    def save():
        write_manifest(sweep, rows, extra)

    if not todo:
        save()
        summary.seconds = time.perf_counter() - start
        return summary

    last_save = 0.0
    rendered = []  # names of the jobs done in this run (read by the Slurm keeper's thread)
    stopper = _Stopper()
    try:
        with _connect(sweep, workers, scheduler, slurm, drjit_threads,
                      ALLOWED_FAILURES if allowed_failures is None else allowed_failures,
                      done=lambda: len(rendered), stopper=stopper) as (client, threads, explain):
            summary.workers = len(client.scheduler_info().get("workers", {}))
            run = f"{uuid.uuid4().hex[:8]}"
            # one graph in the sweep's order: a job whose worker is lost goes first (submit_in_order)
            submitted = submit_in_order(client, run_job,
                                        [(_task(sweep, job), threads) for job in todo],
                                        [f"pbrdf-{job.name}-{run}" for job in todo])
            futures = dict(zip(submitted, todo))
            keys = {future.key: job.name for future, job in futures.items()}
            stopper.arm(client, futures)
            try:
                with progress_reporter(len(todo), f"batch {os.path.basename(sweep.path)}",
                                       progress, steps=len(todo), unit="jobs") as bar:
                    for future in as_completed(futures):
                        job = futures.pop(future)
                        if future.cancelled():  # the Slurm cap was reached: stays pending
                            continue
                        rows[job.name] = _collect(future, job, rendered)
                        bar.update(1)
                        now = time.perf_counter()
                        if now - last_save >= MANIFEST_INTERVAL_S:
                            save()
                            last_save = now
            finally:
                save()  # before the cluster closes: Ctrl-C there must not lose it
                for future in futures:
                    future.cancel()
                _add_notes(sweep, rows, client, keys, explain)
                save()
    finally:
        save()  # Ctrl-C or any error: what finished is recorded
        _remove_stale_temporaries(sweep)
        _tally(summary, todo, rows)
        summary.seconds = time.perf_counter() - start
    return summary


def _collect(future, job, rendered: List[str]) -> Dict[str, str]:
    """The manifest row of *job* from its finished *future* (released); its
    name joins *rendered* when it rendered."""
    try:
        result = future.result()
        row = _result_row(job, result)
        if result.status == "done":
            rendered.append(job.name)
    except Exception as e:  # the job's workers died, or Dask failed
        row = job_row(job, status="failed", error=_lost_worker_error(e))
    future.release()
    return row


def _tally(summary: SweepSummary, ran, rows: Dict[str, Dict[str, str]]):
    """Count the jobs of this run (*ran*) by their status in *rows*."""
    for job in ran:
        status = rows.get(job.name, {}).get("status", "pending")
        if status == "done":
            summary.done += 1
        elif status == "failed":
            summary.failed += 1
            summary.failures.append(f"{job.name}: {rows[job.name].get('error', '')}")
        else:
            summary.pending += 1


# ------------------------------------------------------- the jobs' order
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
