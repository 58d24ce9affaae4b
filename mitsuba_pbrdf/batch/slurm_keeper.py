"""Keeping a sweep's Slurm worker jobs (``pbrdf batch --slurm``, docs/batch.md):
a worker job that ended (``scancel``, walltime, node failure) is replaced,
but not without end. :class:`ResubmissionCap` counts the replacements of each
worker job since a render was last done; past ``max_resubmissions`` the
:class:`Keeper` submits nothing more and gives up with one line saying why
the last worker job ended. A sweep that renders goes on however long it is
(every render done starts the count again); one whose worker jobs end before
any render is done (a walltime shorter than one render, a broken environment
on the nodes, a failing node) stops instead of submitting jobs for ever.

Imports neither Dask nor Slurm: the cluster (dask-jobqueue's
``SLURMCluster``) and the Slurm look-up come in as arguments, so the unit
tests drive it with stand-ins (tests/test_batch_slurm.py).
"""

from __future__ import annotations

import threading
from dataclasses import dataclass, field
from typing import Callable, Dict, Optional, Set

__all__ = ["ResubmissionCap", "Keeper", "REPLACE_INTERVAL_S", "DEFAULT_MAX_RESUBMISSIONS"]

#: Seconds between two checks that the cluster still has its worker jobs.
REPLACE_INTERVAL_S = 2.0
#: Replacements of one worker job allowed with no render done in between.
DEFAULT_MAX_RESUBMISSIONS = 5


@dataclass
class ResubmissionCap:
    """Replacements of each worker job (by its name in the cluster's spec)
    since the last render done; *limit* of them per worker job at most."""

    limit: int = DEFAULT_MAX_RESUBMISSIONS
    counts: Dict[str, int] = field(default_factory=dict)
    done: int = 0

    def progress(self, done: int) -> None:
        """*done*: renders done so far; a new one starts every count again."""
        if done != self.done:
            self.done = done
            self.counts.clear()

    def allow(self, name: str) -> bool:
        """Count one replacement of worker job *name*: False past the limit."""
        count = self.counts.get(name, 0) + 1
        if count > self.limit:
            return False
        self.counts[name] = count
        return True


class Keeper(threading.Thread):
    """Asks *cluster* for its *jobs* worker jobs again every
    :data:`REPLACE_INTERVAL_S` s, so that one that ended is replaced once
    Dask gives it up, within *cap*. *done* () -> renders done so far;
    *why_ended* (Slurm job id) -> one phrase on how it ended; *on_give_up* ()
    is called once, when the cap is reached (then :attr:`error` holds the line,
    which points at the worker jobs' logs in the folder *logs*)."""

    def __init__(self, cluster, jobs: int, cap: Optional[ResubmissionCap] = None,
                 done: Callable[[], int] = lambda: 0,
                 why_ended: Callable[[str], str] = lambda job: f"Slurm job {job} ended",
                 on_give_up: Callable[[], None] = lambda: None, logs: str = "slurm-logs"):
        super().__init__(daemon=True, name="pbrdf-slurm-keeper")
        self.cluster, self.jobs = cluster, jobs
        self.cap = cap or ResubmissionCap()
        self.done, self.why_ended, self.on_give_up = done, why_ended, on_give_up
        self.logs = logs
        self.stop = threading.Event()
        self.error: Optional[str] = None
        self._job_ids: Dict[str, str] = {}  # worker job name -> its last Slurm job id
        self._counted: Set[str] = set()     # Slurm job ids whose loss was counted

    def run(self):
        while not self.stop.wait(REPLACE_INTERVAL_S):
            try:
                if not self.tick():
                    return
            except Exception:  # pragma: no cover - closing
                return

    def tick(self) -> bool:
        """One check: count the worker jobs lost since the last one, and ask
        for the jobs again; False (after :attr:`on_give_up`) at the cap."""
        self.cap.progress(self.done())
        try:
            running = {name: getattr(job, "job_id", None)
                       for name, job in list(self.cluster.workers.items())}
            names = list(self.cluster.worker_spec)
        except RuntimeError:  # changed while copied (the event loop's thread): next time
            return True
        for name, job_id in running.items():
            if job_id:
                self._job_ids[name] = str(job_id)
        for name in names:
            job_id = self._job_ids.get(name)
            if name in running or job_id is None or job_id in self._counted:
                continue
            self._counted.add(job_id)
            if not self.cap.allow(name):
                self.error = (
                    f"the Slurm worker jobs were lost and replaced {self.cap.limit} times "
                    f"each (max_resubmissions, --max-resubmissions) with no render done in "
                    f"between; the last one: {self.why_ended(job_id)}; submitting no more "
                    f"(the worker jobs' logs are in {self.logs})")
                self.on_give_up()
                return False
        self.cluster.scale(jobs=self.jobs)
        return True
