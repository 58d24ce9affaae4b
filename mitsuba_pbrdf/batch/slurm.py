"""A sweep's workers as Slurm jobs (``pbrdf batch --slurm``, docs/batch.md),
started with dask-jobqueue's ``SLURMCluster``; the scheduler runs in the
``pbrdf batch`` process.

:func:`connect_slurm` checks before it submits anything: Slurm answers
(``scontrol``), the partition exists and is up, and ``sbatch --test-only``
accepts the worker job (cores, memory, walltime, extra directives). Then it
submits ``jobs`` worker jobs, each one Dask worker process of one thread (one
render at a time) whose Dr.Jit pool has as many threads as the job has
cores, and waits until one runs (else a one-line error naming the partition
and ``squeue``'s reason). A worker job that ends (``scancel``, walltime,
node failure) is replaced while the sweep runs; its render runs again on
another worker. The replacements are capped (``max_resubmissions`` per worker
job with no render done in between, :mod:`mitsuba_pbrdf.batch.slurm_keeper`):
at the cap the sweep stops with a :class:`SlurmError`. On exit (end, error,
Ctrl-C) every job it submitted is cancelled: ``SLURMCluster.close`` cancels
those it knows, then whatever is still queued under the sweep's own job name
(``pbrdf-<random>``) is cancelled by id; no other job is touched.
"""

from __future__ import annotations

import contextlib
import logging
import os
import subprocess
import tempfile
import threading
import time
import uuid
from typing import Callable, Dict, List, Optional, Tuple

from .cluster import ALLOWED_FAILURES, WorkerSetup
from .slurm_keeper import REPLACE_INTERVAL_S, Keeper, ResubmissionCap
from .slurm_options import SlurmError, SlurmOptions, format_walltime, parse_memory

__all__ = ["connect_slurm", "slurm_cluster_class", "SlurmWorkerSetup", "WorkerJobEvents",
           "check_partition", "job_states", "job_ended", "REPLACE_INTERVAL_S"]

#: Seconds to wait at exit for the worker jobs to leave Slurm's queue.
LEAVE_TIMEOUT_S = 20.0
#: Worker events (topic of Dask's event log) that map a worker to its Slurm job.
EVENT_TOPIC = "pbrdf-slurm-worker"


def slurm_cluster_class():
    """dask-jobqueue's ``SLURMCluster``; SlurmError naming the ``cluster``
    extra when it is not installed. dask-jobqueue 0.9 replaces the process's
    SIGINT handler when imported (``sys.exit``: Ctrl-C would end the sweep
    with status 0 and no record); the handler is put back."""
    import signal

    main = threading.current_thread() is threading.main_thread()
    previous = signal.getsignal(signal.SIGINT) if main else None
    try:
        from dask_jobqueue import SLURMCluster
    except ImportError:
        raise SlurmError("--slurm needs dask-jobqueue: pip install 'mitsuba-pbrdf[cluster]' "
                         "(the 'cluster' extra)") from None
    finally:
        if main and previous is not None:
            signal.signal(signal.SIGINT, previous)
    return SLURMCluster


def _slurm(*argv: str, timeout: float = 30.0) -> subprocess.CompletedProcess:
    """Run a Slurm client command; SlurmError when it cannot run at all."""
    try:
        return subprocess.run(list(argv), capture_output=True, text=True, timeout=timeout,
                              stdin=subprocess.DEVNULL)
    except FileNotFoundError:
        raise SlurmError(f"Slurm is not reachable: no '{argv[0]}' command here (run on a login "
                         "node of the cluster, or load its Slurm module)") from None
    except subprocess.TimeoutExpired:
        raise SlurmError(f"Slurm is not reachable: '{' '.join(argv)}' did not answer within "
                         f"{timeout:.0f} s") from None


def _first_line(done: subprocess.CompletedProcess) -> str:
    text = (done.stderr or done.stdout or "").strip()
    return text.splitlines()[0].strip() if text else f"exit status {done.returncode}"


def _fields(line: str) -> Dict[str, str]:
    """``Key=Value`` pairs of a one-line ``scontrol show ... -o`` record."""
    out = {}
    for item in line.split():
        key, _, value = item.partition("=")
        out[key] = value
    return out


def check_partition(partition: Optional[str]) -> str:
    """The partition the workers go to (*partition*, or Slurm's default):
    SlurmError when Slurm does not answer, or the partition is unknown or not up."""
    done = _slurm("scontrol", "show", "partition", "-o")
    if done.returncode != 0:
        raise SlurmError(f"Slurm is not reachable: scontrol: {_first_line(done)}")
    partitions = {f.get("PartitionName"): f for f in map(_fields, done.stdout.splitlines())
                  if f.get("PartitionName")}
    if partition is None:
        default = [name for name, f in partitions.items() if f.get("Default") == "YES"]
        if not default:
            raise SlurmError(f"this Slurm has no default partition; choose one with --partition "
                             f"({', '.join(partitions) or 'none defined'})")
        partition = default[0]
    if partition not in partitions:
        raise SlurmError(f"--partition {partition!r}: no such Slurm partition; this cluster has "
                         f"{', '.join(partitions) or 'none'}")
    state = partitions[partition].get("State", "UP")
    if state != "UP":
        raise SlurmError(f"--partition {partition!r} is {state}: it starts no job")
    return partition


def job_states(ids: List[str]) -> Dict[str, Dict[str, str]]:
    """``{job id: scontrol's fields}`` (JobState, Reason, TimeLimit...) of the
    jobs Slurm still knows (finished ones for ``MinJobAge`` seconds)."""
    out = {}
    for job_id in ids:
        done = _slurm("scontrol", "show", "job", "-o", str(job_id))
        if done.returncode == 0 and done.stdout.strip():
            out[str(job_id)] = _fields(done.stdout.splitlines()[0])
    return out


def _queued(job_name: str) -> List[List[str]]:
    """``[id, state, reason]`` of this user's queued jobs named *job_name*."""
    done = _slurm("squeue", "-h", "-u", str(os.getuid()), "-n", job_name, "-o", "%i|%T|%r")
    if done.returncode != 0:
        return []
    return [line.split("|", 2) for line in done.stdout.splitlines() if line.strip()]


def _cancel_leftovers(job_name: str, timeout: float = LEAVE_TIMEOUT_S):
    """Cancel this user's jobs named *job_name* that are still queued, and
    wait (at most *timeout* s) until they have left the queue, completing
    ones included."""
    deadline = time.monotonic() + timeout
    while True:
        queued = _queued(job_name)
        if not queued or time.monotonic() > deadline:
            return
        ids = [job_id for job_id, state, _ in queued if state != "COMPLETING"]
        if ids:
            _slurm("scancel", *ids)
        time.sleep(0.25)


class SlurmWorkerSetup(WorkerSetup):
    """Worker set-up in a Slurm job: Dr.Jit gets the job's cores
    (``SLURM_CPUS_ON_NODE``, else *cores*; at least 2), and the worker reports
    its Slurm job id to the scheduler's event log (:data:`EVENT_TOPIC`)."""

    name = "pbrdf-slurm-worker-setup"

    def __init__(self, cores: int):
        super().__init__(drjit_threads=cores)
        self.cores = cores

    def setup(self, worker):
        try:
            self.drjit_threads = int(os.environ.get("SLURM_CPUS_ON_NODE", self.cores))
        except ValueError:
            self.drjit_threads = self.cores
        super().setup(worker)
        worker.log_event(EVENT_TOPIC, {"worker": worker.address,
                                       "job": os.environ.get("SLURM_JOB_ID", "")})


def _scheduler_plugin_base():
    from distributed.diagnostics.plugin import SchedulerPlugin

    return SchedulerPlugin


class WorkerJobEvents(_scheduler_plugin_base()):
    """A plugin of the scheduler (in the ``pbrdf batch`` process) that tells
    *keeper* each time a worker joins or leaves, by the worker job's name in
    the cluster's spec: every worker, however short its life (a look at the
    cluster every few seconds missed those that joined and left in between)."""

    name = "pbrdf-slurm-worker-jobs"

    def __init__(self, keeper: Keeper):
        self.keeper = keeper
        self._names: Dict[str, str] = {}  # worker address -> worker job name

    def add_worker(self, scheduler=None, worker=None, **kwargs):
        state = scheduler.workers.get(worker)
        if state is not None:
            self._names[worker] = state.name
            self.keeper.worker_joined(state.name)

    def remove_worker(self, scheduler=None, worker=None, **kwargs):
        name = self._names.pop(worker, None)
        if name is not None:
            self.keeper.worker_left(name)


def node_sizes(partition: str) -> Optional[Tuple[int, int]]:
    """The largest CPU count and memory (MB) of the nodes of *partition*
    (``sinfo``), or None where Slurm does not say."""
    done = _slurm("sinfo", "-h", "-p", partition, "-o", "%c %m")
    sizes = []
    for line in done.stdout.splitlines() if done.returncode == 0 else []:
        parts = line.replace("+", "").split()
        if len(parts) == 2 and all(p.isdigit() for p in parts):
            sizes.append((int(parts[0]), int(parts[1])))
    if not sizes:
        return None
    return max(c for c, _ in sizes), max(m for _, m in sizes)


def _test_only(script: str, options: Optional[SlurmOptions] = None,
               partition: Optional[str] = None):
    """``sbatch --test-only`` of the worker job script: SlurmError with sbatch's
    reason; where the job asks more than the partition's nodes have, the
    message names ``--cores`` and ``--memory`` and the nodes' size."""
    with tempfile.NamedTemporaryFile("w", suffix=".sh", delete=False) as f:
        f.write(script)
    try:
        done = _slurm("sbatch", "--test-only", f.name)
    finally:
        os.unlink(f.name)
    if done.returncode == 0:
        return
    reason = f"sbatch refuses the worker job: {_first_line(done)}"
    sizes = node_sizes(partition) if options is not None and partition else None
    if sizes is not None:
        cpus, megabytes = sizes
        asked_mb = parse_memory(options.memory) / 2 ** 20
        if options.cores > cpus or asked_mb > megabytes:
            raise SlurmError(f"{reason}: a worker job asks --cores {options.cores} and --memory "
                             f"{options.memory}, and the nodes of partition {partition!r} have "
                             f"at most {cpus} CPUs and {megabytes} MB; lower --cores or "
                             f"--memory (or cores, memory in the sweep's [slurm] table)")
    raise SlurmError(reason)


def _stop(keeper: Optional[Keeper]):
    """Stop *keeper* and wait for it: no job may be submitted once closing starts."""
    if keeper is not None:
        keeper.stop.set()
        keeper.join()


def _worker_jobs(client) -> Dict[str, str]:
    """``{worker address: Slurm job id}`` from the workers' events."""
    return {msg["worker"]: msg["job"] for _, msg in client.get_events(EVENT_TOPIC)
            if isinstance(msg, dict) and msg.get("job")}


def job_ended(job: str, fields: Dict[str, str]) -> str:
    """How Slurm job *job* ended, from its ``scontrol`` *fields* (empty: unknown)."""
    state = fields.get("JobState", "")
    if state == "CANCELLED":
        return f"Slurm job {job} was cancelled"
    if state == "TIMEOUT":
        return f"Slurm job {job} reached its walltime ({fields.get('TimeLimit', '?')})"
    if state:
        return f"Slurm job {job} ended: {state} (reason {fields.get('Reason', 'None')})"
    return f"Slurm job {job} ended"


def _explainer(client):
    """``explain(addresses) -> {address: why its worker left}`` for Slurm workers."""

    def explain(addresses):
        jobs = _worker_jobs(client)
        states = job_states(sorted({jobs[a] for a in addresses if a in jobs}))
        out = {}
        for address in addresses:
            job = jobs.get(address)
            if not job:
                out[address] = "its Slurm worker was lost before it reported its job id"
            else:
                out[address] = "its worker's " + job_ended(job, states.get(job, {}))
        return out

    return explain


@contextlib.contextmanager
def connect_slurm(options: SlurmOptions, log_directory: str,
                  allowed_failures: int = ALLOWED_FAILURES,
                  done: Callable[[], int] = lambda: 0,
                  on_give_up: Callable[[], None] = lambda: None):
    """A ``dask.distributed.Client`` on Slurm worker jobs (module docstring).
    Yields ``(client, explain)``: *explain* maps addresses of workers that
    left to one line each. Slurm's logs of the jobs go to *log_directory*.
    *done* () -> renders done so far, for the cap on replacements; *on_give_up*
    () is called (from another thread) when the cap is reached, and the
    ``with`` block then ends with a :class:`SlurmError` saying so.
    Raises :class:`SlurmError` (one line) when the workers cannot start."""
    import dask

    cluster_class = slurm_cluster_class()
    partition = check_partition(options.partition)
    os.makedirs(log_directory, exist_ok=True)
    # read by the scheduler (in this process) while the sweep runs, so set throughout
    settings = {"distributed.scheduler.worker-saturation": 1.0,
                "distributed.scheduler.allowed-failures": int(allowed_failures),
                # give up a lost worker's job after 1 s (Dask: 15 s), so it is replaced soon
                "distributed.deploy.lost-worker-timeout": "1s"}
    with dask.config.set(settings):
        yield from _session(cluster_class, options, partition, log_directory, done, on_give_up)


def _why_ended(job: str) -> str:
    return job_ended(job, job_states([job]).get(job, {}))


#: Slurm job states of a job that will not run (again) by itself.
ENDED_STATES = frozenset({"COMPLETED", "FAILED", "CANCELLED", "TIMEOUT", "NODE_FAIL",
                          "OUT_OF_MEMORY", "BOOT_FAIL", "DEADLINE", "PREEMPTED"})


def _ended(jobs: List[str]) -> Dict[str, str]:
    """``{job id: how it ended}`` for those of *jobs* that Slurm says ended."""
    return {job: job_ended(job, fields) for job, fields in job_states(jobs).items()
            if fields.get("JobState") in ENDED_STATES}


def _first_worker_joined(keeper: Keeper, timeout: float) -> bool:
    """Whether a worker joined within *timeout* s, as the scheduler told the
    keeper (:class:`WorkerJobEvents`). A worker that joined and was lost at
    once counts (it started; the keeper replaces it): waiting for one to be
    present, as ``Client.wait_for_workers`` does, can miss every worker that
    lives less than its poll interval and then wait out *timeout* after the
    keeper has given up. Raises :class:`SlurmError` with the keeper's line
    when it gives up first."""
    deadline = time.monotonic() + timeout
    while True:
        if keeper.error:
            raise SlurmError(keeper.error)
        if keeper.any_joined():
            return True
        if time.monotonic() >= deadline:
            return False
        time.sleep(0.1)


def _session(cluster_class, options: SlurmOptions, partition: str, log_directory: str,
             done, on_give_up):
    """The body of :func:`connect_slurm` (a generator it delegates to)."""
    from dask.distributed import Client

    job_name = f"pbrdf-{uuid.uuid4().hex[:8]}"
    cluster = cluster_class(
        cores=1, processes=1, job_cpu=options.cores, memory=options.memory,
        walltime=format_walltime(options.walltime_s), queue=partition, job_name=job_name,
        log_directory=log_directory, job_extra_directives=list(options.sbatch),
        scheduler_options={"dashboard_address": None}, silence_logs=logging.CRITICAL)
    keeper = None
    try:
        _test_only(cluster.job_script(), options, partition)
        client = Client(cluster)
        try:
            client.register_plugin(SlurmWorkerSetup(options.cores))
            keeper = Keeper(cluster, options.jobs, ResubmissionCap(options.max_resubmissions),
                            done=done, why_ended=_why_ended, on_give_up=on_give_up,
                            logs=log_directory, ended=_ended)
            cluster.scheduler.add_plugin(WorkerJobEvents(keeper))
            cluster.scale(jobs=options.jobs)
            keeper.start()
            if not _first_worker_joined(keeper, options.start_timeout):
                queued = _queued(job_name)
                why = ", ".join(sorted({f"{s} ({r})" for _, s, r in queued})) or \
                    "no job in the queue: sbatch failed, see the logs in " + log_directory
                raise SlurmError(f"no worker job started within {options.start_timeout:g} s on "
                                 f"partition {partition!r} (squeue: {why}); the jobs were "
                                 "cancelled") from None
            yield client, _explainer(client)
            if keeper.error:
                raise SlurmError(keeper.error)
        finally:
            _stop(keeper)
            client.close()
    finally:
        _stop(keeper)
        cluster.close()
        _cancel_leftovers(job_name)
