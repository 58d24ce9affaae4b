"""Keeping a sweep's Slurm worker jobs (``pbrdf batch --slurm``, docs/batch.md):
a worker job that ended (``scancel``, walltime, node failure) is replaced,
but not without end. :class:`ResubmissionCap` counts the replacements of each
worker job since a render was last done; past ``max_resubmissions`` the
:class:`Keeper` submits nothing more and gives up with one line saying why
the last worker job ended. A sweep that renders goes on however long it is
(every render done starts the count again); one whose worker jobs end before
any render is done (a walltime shorter than one render, a worker that
crashes on the nodes after it joined, a failing node) stops instead of
submitting jobs for ever.

Imports neither Dask nor Slurm: the cluster (dask-jobqueue's
``SLURMCluster``) and the Slurm look-up come in as arguments, and the
scheduler's worker events as calls (:class:`~mitsuba_pbrdf.batch.slurm.WorkerJobEvents`),
so the unit tests drive it with stand-ins (tests/batch/test_slurm_keeper.py).
"""

from __future__ import annotations

import threading
from dataclasses import dataclass, field
from typing import Callable, Dict, List, Optional, Set

__all__ = ["ResubmissionCap", "Keeper", "log_error_line", "REPLACE_INTERVAL_S",
           "DEFAULT_MAX_RESUBMISSIONS"]

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
    which points at the worker jobs' logs in the folder *logs*). *ended*
    (Slurm job ids) -> ``{job id: how it ended}`` for those that have ended:
    when no worker is in the scheduler and every worker job ended before its
    worker joined (Python missing or broken on the nodes, a prologue that
    failed), nothing will ever render, so the keeper gives up at once, with
    the error line of a job's log.

    Losses come as events, not from looking at the cluster now and then: the
    scheduler calls :meth:`worker_left` (and :meth:`worker_joined`) for every
    worker, however short its life: a worker job that joins and is cancelled
    between two looks would otherwise go uncounted and be replaced beyond the
    cap. Every replacement needs Dask to
    give up a lost job first (``distributed.deploy.lost-worker-timeout``
    after the worker left), and the keeper submits nothing while a loss it
    was told of is not yet counted, so each replacement is counted before it
    is submitted."""

    def __init__(self, cluster, jobs: int, cap: Optional[ResubmissionCap] = None,
                 done: Callable[[], int] = lambda: 0,
                 why_ended: Callable[[str], str] = lambda job: f"Slurm job {job} ended",
                 on_give_up: Callable[[], None] = lambda: None, logs: str = "slurm-logs",
                 ended: Callable[[List[str]], Dict[str, str]] = lambda jobs: {}):
        super().__init__(daemon=True, name="pbrdf-slurm-keeper")
        self.cluster, self.jobs = cluster, jobs
        self.cap = cap or ResubmissionCap()
        self.done, self.why_ended, self.on_give_up = done, why_ended, on_give_up
        self.ended = ended
        self.logs = logs
        self.stop = threading.Event()
        self.error: Optional[str] = None
        self._lock = threading.Lock()
        self._left: Dict[str, Optional[str]] = {}  # worker job name -> Slurm job id of its loss
        self._joined: Set[str] = set()   # Slurm job ids whose worker joined
        self._present: Set[str] = set()  # worker job names whose worker is in the scheduler

    def _job_of(self, name: str) -> Optional[str]:
        job_id = getattr(self.cluster.workers.get(name), "job_id", None)
        return str(job_id) if job_id else None

    def worker_joined(self, name: str) -> None:
        """The worker of worker job *name* joined the scheduler (its thread).
        A worker that left and joined again from the same Slurm job (its
        nanny restarted it) was not lost."""
        job = self._job_of(name)
        with self._lock:
            self._present.add(name)
            if job:
                self._joined.add(job)
            if name in self._left and self._left[name] == job:
                del self._left[name]

    def any_joined(self) -> bool:
        """Whether a worker of this cluster ever joined the scheduler."""
        with self._lock:
            return bool(self._joined or self._present)

    def worker_left(self, name: str) -> None:
        """The worker of worker job *name* left the scheduler (its thread)."""
        job = self._job_of(name)
        with self._lock:
            self._present.discard(name)
            self._left[name] = job

    def run(self):
        while not self.stop.wait(REPLACE_INTERVAL_S):
            try:
                if not self.tick():
                    return
            except Exception:  # pragma: no cover - closing
                return

    def tick(self) -> bool:
        """One check: count the losses Dask has given up since the last one,
        and ask for the missing worker jobs again; False (after
        :attr:`on_give_up`) at the cap."""
        self.cap.progress(self.done())
        try:
            running = {name: self._job_of(name) for name in list(self.cluster.workers)}
            names = list(self.cluster.worker_spec)
        except RuntimeError:  # changed while copied (the event loop's thread): next time
            return True
        lost = None
        with self._lock:  # held briefly: the scheduler's thread takes it too
            for name, job in list(self._left.items()):
                if name in running and running[name] == job:
                    continue  # Dask has not given it up yet: not replaced before it is
                del self._left[name]
                if not self.cap.allow(name):
                    lost = job or ""
                    break
            else:
                if not self._left and any(name not in running for name in names):
                    self.cluster.scale(jobs=self.jobs)
        if lost is not None:
            last = self.why_ended(lost) if lost else "a worker job ended"
            self._give_up(
                f"the Slurm worker jobs were lost and replaced {self.cap.limit} times each "
                f"(max_resubmissions, --max-resubmissions) with no render done in between; the "
                f"last one: {last}; submitting no more (the worker jobs' logs are in {self.logs})")
            return False
        return self._check_unjoined()

    def _check_unjoined(self) -> bool:
        """When no worker is in the scheduler, none is being submitted, and
        the worker job of every spec entry has never had its worker join,
        ask Slurm about them: False (after :attr:`on_give_up`) when all have
        ended, for no worker will come (Dask replaces only workers that left)."""
        try:
            names = list(self.cluster.worker_spec)
            jobs = [self._job_of(name) for name in names]
        except RuntimeError:  # changed while copied: next time
            return True
        with self._lock:
            if self._present or self._left or not jobs or any(
                    not job or job in self._joined for job in jobs):
                return True
        ended = self.ended(sorted(set(jobs)))
        if set(ended) != set(jobs):
            return True
        job = min(ended, key=lambda j: (len(j), j))
        hint = log_error_line(self.logs, job)
        self._give_up(
            f"{ended[job]} before its worker joined the sweep"
            + (f": {hint}" if hint else "")
            + f"; nothing would render, so no more worker jobs are submitted (the worker jobs' "
              f"logs are in {self.logs})")
        return False

    def _give_up(self, line: str) -> None:
        self.error = line
        self.on_give_up()


def log_error_line(logs: str, job: str, tail: int = 50) -> str:
    """The last line that names an error in the last *tail* lines of Slurm
    job *job*'s standard error (``<logs>/<job name>-<job>.err``, as
    dask-jobqueue names it), else its last non-empty line; "" without one."""
    import glob
    import os
    import re

    for path in sorted(glob.glob(os.path.join(glob.escape(logs), f"*-{job}.err"))):
        try:
            with open(path, errors="replace") as f:
                lines = [line.strip() for line in f.read().splitlines()[-tail:] if line.strip()]
        except OSError:
            continue
        for line in reversed(lines):
            if re.search(r"Error\b|error:|Exception\b|Killed|not found|No such file", line):
                return line
        if lines:
            return lines[-1]
    return ""
