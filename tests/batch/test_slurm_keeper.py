"""The cap on replacing lost Slurm worker jobs (``pbrdf batch --slurm
--max-resubmissions N``; mitsuba_pbrdf/batch/slurm_keeper.py), without Slurm:
the keeper runs against a stand-in for dask-jobqueue's cluster (its
``worker_spec``, ``workers`` of jobs with a ``job_id`` and ``scale``), and
the sweep's side (futures cancelled, rows left pending, one line, exit 2)
against a local Dask cluster standing in for the Slurm one. The real-Slurm
tests are in tests/batch/test_slurm.py."""

import contextlib
import threading
import time

import pytest

from mitsuba_pbrdf.batch.slurm_keeper import Keeper, ResubmissionCap
from mitsuba_pbrdf.batch.slurm_options import SlurmError


class Job:
    def __init__(self, job_id):
        self.job_id = job_id


class FakeCluster:
    """What the keeper reads of a SLURMCluster: the spec of *jobs* worker
    jobs, the submitted ones, and ``scale``, which submits a job for each
    spec entry without one (as SpecCluster's ``_correct_state`` does). The
    keeper hears of each loss as the scheduler's plugin tells it
    (:class:`~mitsuba_pbrdf.batch.slurm.WorkerJobEvents`)."""

    def __init__(self, jobs):
        self.worker_spec = {f"SLURMCluster-{i}": {} for i in range(jobs)}
        self.workers = {}
        self.submitted = []
        self.keeper = None
        self.scale()

    def scale(self, jobs=None):
        for name in self.worker_spec:
            if name not in self.workers:
                self.submitted.append(str(100 + len(self.submitted)))
                self.workers[name] = Job(self.submitted[-1])

    def leave(self, name):
        """The worker of worker job *name* left the scheduler (Dask still holds the job)."""
        self.keeper.worker_left(name)

    def give_up(self, name):
        """Dask gave up the worker job *name* (lost-worker-timeout after it left)."""
        del self.workers[name]

    def lose(self, name):
        """The worker job *name* ended and Dask gave it up."""
        self.leave(name)
        self.give_up(name)


W0, W1 = "SLURMCluster-0", "SLURMCluster-1"


def keeper_for(cluster, limit, done=lambda: 0):
    given_up = []
    keeper = Keeper(cluster, len(cluster.worker_spec), ResubmissionCap(limit), done=done,
                    why_ended=lambda job: f"Slurm job {job} reached its walltime (00:01:00)",
                    on_give_up=lambda: given_up.append(True), logs="out/slurm-logs")
    cluster.keeper = keeper
    return keeper, given_up


def test_lost_jobs_are_replaced_up_to_the_cap_then_nothing_more_is_submitted():
    cluster = FakeCluster(jobs=2)
    keeper, given_up = keeper_for(cluster, limit=3)
    assert keeper.tick() and cluster.submitted == ["100", "101"]  # nothing lost yet
    for i in range(3):  # job 0 ends again and again: replaced 3 times
        cluster.lose(W0)
        assert keeper.tick()
        assert keeper.tick()  # the same loss is counted once
    assert len(cluster.submitted) == 5 and not given_up
    last = cluster.workers[W0].job_id
    cluster.lose(W0)
    assert not keeper.tick()
    assert len(cluster.submitted) == 5, "a job was submitted past the cap"
    assert given_up == [True]
    assert keeper.error == (
        "the Slurm worker jobs were lost and replaced 3 times each (max_resubmissions, "
        "--max-resubmissions) with no render done in between; the last one: Slurm job "
        f"{last} reached its walltime (00:01:00); submitting no more (the worker jobs' logs "
        "are in out/slurm-logs)")


def test_a_render_done_starts_the_count_again():
    """A sweep many walltimes long: each worker job renders, then ends; it is
    replaced each time, well past the cap."""
    cluster = FakeCluster(jobs=1)
    done = [0]
    keeper, given_up = keeper_for(cluster, limit=2, done=lambda: done[0])
    for i in range(20):
        done[0] += 1  # the worker job rendered before it ended
        cluster.lose(W0)
        assert keeper.tick()
    assert len(cluster.submitted) == 21 and not given_up and keeper.error is None


def test_the_cap_counts_each_worker_job_on_its_own():
    """Two worker jobs lost twice each with a cap of 2: still within it."""
    cluster = FakeCluster(jobs=2)
    keeper, given_up = keeper_for(cluster, limit=2)
    for _ in range(2):
        cluster.lose(W0)
        cluster.lose(W1)
        assert keeper.tick()
    assert len(cluster.submitted) == 6 and not given_up


def test_jobs_not_yet_submitted_are_not_counted_as_lost():
    cluster = FakeCluster(jobs=2)
    cluster.workers.clear()  # the first submissions still under way
    keeper, given_up = keeper_for(cluster, limit=1)
    assert keeper.tick() and not given_up


def test_a_job_lost_before_the_keeper_looked_is_counted_before_it_is_replaced():
    """CI's failure: each worker job was cancelled as soon as its worker
    joined, and with a cap of 2 five jobs were submitted. The keeper counted a
    loss only when a look at the cluster found a job it had seen before
    missing; a job submitted after one look and given up before the next was
    never seen, so its loss went uncounted and it was replaced anyway. Losses
    now come from the scheduler's events: each replaced job is counted."""
    cluster = FakeCluster(jobs=1)
    keeper, given_up = keeper_for(cluster, limit=2)
    for _ in range(2):
        cluster.lose(W0)  # the job lost, as every replacement, before any look saw it
        assert keeper.tick()
    assert cluster.submitted == ["100", "101", "102"] and not given_up
    cluster.lose(W0)
    assert not keeper.tick() and given_up == [True]
    assert cluster.submitted == ["100", "101", "102"], "a job was submitted past the cap"
    assert "the last one: Slurm job 102 reached its walltime" in keeper.error


def test_a_lost_job_is_replaced_only_once_dask_gives_it_up():
    """Between the worker leaving and Dask giving up its job (1 s,
    lost-worker-timeout) nothing is submitted and nothing counted; then one
    replacement, counted once."""
    cluster = FakeCluster(jobs=2)
    keeper, given_up = keeper_for(cluster, limit=1)
    cluster.leave(W0)
    assert keeper.tick() and keeper.tick()
    assert cluster.submitted == ["100", "101"] and keeper.cap.counts == {}
    cluster.give_up(W0)
    assert keeper.tick() and keeper.tick()
    assert cluster.submitted == ["100", "101", "102"] and keeper.cap.counts == {W0: 1}
    assert not given_up


def test_a_worker_restarted_in_its_own_job_is_not_a_lost_job():
    """A worker process that died and was restarted by its nanny leaves and
    joins again from the same Slurm job: no job was lost, none is submitted,
    and the cap's count stays at zero."""
    cluster = FakeCluster(jobs=1)
    keeper, given_up = keeper_for(cluster, limit=1)
    for _ in range(3):
        cluster.leave(W0)
        keeper.worker_joined(W0)
        assert keeper.tick()
    assert cluster.submitted == ["100"] and keeper.cap.counts == {} and not given_up
    cluster.lose(W0)  # a real loss is still the first one
    assert keeper.tick() and cluster.submitted == ["100", "101"]


def test_the_scheduler_plugin_names_each_worker_that_joins_and_leaves():
    """:class:`WorkerJobEvents` on a real Dask scheduler: a worker's join and
    its leaving reach the keeper under the worker's name (the name the
    cluster's spec and ``workers`` use)."""
    distributed = pytest.importorskip("distributed")
    from mitsuba_pbrdf.batch.slurm import WorkerJobEvents

    class Recorder:
        def __init__(self):
            self.calls = []

        def worker_joined(self, name):
            self.calls.append(("joined", name))

        def worker_left(self, name):
            self.calls.append(("left", name))

    recorder = Recorder()
    with distributed.LocalCluster(n_workers=0, processes=False, threads_per_worker=1,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        cluster.scheduler.add_plugin(WorkerJobEvents(recorder))
        cluster.scale(1)
        client.wait_for_workers(1, timeout=30)
        (name,) = list(cluster.workers)
        cluster.scale(0)
        deadline = time.monotonic() + 30
        while ("left", name) not in recorder.calls and time.monotonic() < deadline:
            time.sleep(0.05)
    assert recorder.calls == [("joined", name), ("left", name)]


PYTHON_BROKEN_LOG = """\
Python path configuration:
  PYTHONHOME = '/nonexistent'
Fatal Python error: init_fs_encoding: failed to get the Python codec of the filesystem encoding
Python runtime state: core initialized
ModuleNotFoundError: No module named 'encodings'

Current thread 0x00007f6365e45b80 (most recent call first):
  <no Python frame>
"""


def test_a_job_that_ended_before_its_worker_joined_stops_the_sweep_at_once(tmp_path):
    """Python broken on the nodes: the worker job fails before its worker
    joins. Dask never hears of it (nothing to replace), and waiting would last
    until --start-timeout (or for ever, mid-sweep); with no worker in the
    scheduler the keeper asks Slurm, and gives up with Slurm's answer and the
    error line of the job's log."""
    from mitsuba_pbrdf.batch.slurm import _first_worker_joined

    logs = tmp_path / "slurm-logs"
    logs.mkdir()
    (logs / "pbrdf-0a1b2c3d-100.err").write_text(PYTHON_BROKEN_LOG)
    cluster = FakeCluster(jobs=1)
    asked = []

    def ended(jobs):
        asked.append(list(jobs))
        return {"100": "Slurm job 100 ended: FAILED (reason NonZeroExitCode)"}

    given_up = []
    keeper = Keeper(cluster, 1, ResubmissionCap(2), ended=ended, logs=str(logs),
                    on_give_up=lambda: given_up.append(True))
    cluster.keeper = keeper
    assert not keeper.tick() and given_up == [True] and asked == [["100"]]
    assert keeper.error == (
        "Slurm job 100 ended: FAILED (reason NonZeroExitCode) before its worker joined the "
        "sweep: ModuleNotFoundError: No module named 'encodings'; nothing would render, so no "
        f"more worker jobs are submitted (the worker jobs' logs are in {logs})")
    assert cluster.submitted == ["100"]
    with pytest.raises(SlurmError, match="^Slurm job 100 ended: FAILED .* 'encodings'"):
        _first_worker_joined(keeper, 60.0)


def test_a_job_that_may_still_bring_a_worker_keeps_the_sweep_going():
    """The keeper gives up only when no worker job can bring a worker: not
    while one is still queued (Slurm: not ended), nor while a worker is in the
    scheduler (Slurm is not even asked), nor while a replacement is on its
    way, nor for a worker job whose worker had joined."""
    cluster = FakeCluster(jobs=2)
    states = {}
    asked = []

    def ended(jobs):
        asked.append(list(jobs))
        return {job: f"Slurm job {job} ended: FAILED" for job in jobs if states.get(job)}

    keeper = Keeper(cluster, 2, ResubmissionCap(2), ended=ended)
    cluster.keeper = keeper
    states["101"] = "FAILED"  # one of the two failed before joining, the other is queued
    assert keeper.tick() and asked == [["100", "101"]] and keeper.error is None
    keeper.worker_joined(W0)  # 100 joined: Slurm is not asked while it is there
    asked.clear()
    assert keeper.tick() and asked == [] and keeper.error is None
    cluster.lose(W0)  # 100 lost: its replacement 102 is submitted and queued
    assert keeper.tick() and cluster.submitted == ["100", "101", "102"]
    assert keeper.tick() and keeper.error is None
    states["102"] = "FAILED"  # now no worker job can bring a worker
    assert not keeper.tick()
    assert keeper.error.startswith("Slurm job 101 ended: FAILED before its worker joined")


def test_the_log_line_shown_is_the_error_not_the_trailing_noise(tmp_path):
    from mitsuba_pbrdf.batch.slurm_keeper import log_error_line

    (tmp_path / "pbrdf-x-7.err").write_text(PYTHON_BROKEN_LOG)
    (tmp_path / "pbrdf-x-8.err").write_text("starting\n\nslurmstepd: step 8.0 done\n")
    (tmp_path / "pbrdf-x-9.err").write_text("")
    assert log_error_line(str(tmp_path), "7") == "ModuleNotFoundError: No module named 'encodings'"
    assert log_error_line(str(tmp_path), "8") == "slurmstepd: step 8.0 done"
    assert log_error_line(str(tmp_path), "9") == ""
    assert log_error_line(str(tmp_path), "10") == ""


@pytest.mark.parametrize("value", [0, -1, 1.5, True])
def test_max_resubmissions_must_be_a_positive_integer(value):
    from mitsuba_pbrdf.batch.slurm_options import slurm_options

    with pytest.raises(SlurmError, match="^--max-resubmissions: must be a positive integer"):
        slurm_options({}, max_resubmissions=value)
    with pytest.raises(SlurmError, match="^s.toml: slurm.max_resubmissions: must be a positive"):
        slurm_options({"max_resubmissions": value}, where="s.toml: ")


def test_at_the_cap_the_sweep_stops_with_one_line_and_pending_rows(tmp_path, capfd,
                                                                   monkeypatch):
    """The runner's side, on a local Dask cluster standing in for Slurm's: the
    cap is reached (on_give_up) as the sweep starts; its futures are
    cancelled, no row is marked failed, ``pbrdf batch --slurm`` ends with
    the keeper's line and exit status 2, and the manifest keeps the rest
    pending for a rerun."""
    pytest.importorskip("distributed")
    import mitsuba_pbrdf.batch.slurm as slurm_module
    from mitsuba_pbrdf.batch.cluster import connect
    from mitsuba_pbrdf.batch.lost import local_explain
    from mitsuba_pbrdf.batch.manifest import read_manifest
    from mitsuba_pbrdf.batch.sweep import load_sweep
    from mitsuba_pbrdf.cli import main
    from tests.batch.test_slurm import grid, write_sweep

    line = "the Slurm worker jobs were lost and replaced 5 times each (stand-in)"

    @contextlib.contextmanager
    def connect_slurm(options, log_directory, allowed_failures=3, done=lambda: 0,
                      on_give_up=lambda: None):
        with connect(workers=1) as (client, _):
            threading.Thread(target=on_give_up).start()  # the keeper's thread
            yield client, local_explain
        raise SlurmError(line)

    monkeypatch.setattr(slurm_module, "connect_slurm", connect_slurm)
    path = write_sweep(tmp_path, grid(4, 256))
    assert main(["batch", str(path), "--slurm", "--no-progress"]) == 2
    err = capfd.readouterr().err.strip().splitlines()
    assert err == [f"pbrdf batch: error: {line}"]
    rows = list(read_manifest(load_sweep(path).manifest).values())
    # cancelled before their worker imported Mitsuba: none rendered, none failed
    assert len(rows) == 4 and {r["status"] for r in rows} == {"pending"}


def test_a_request_larger_than_the_nodes_names_cores_memory_and_the_node_size(monkeypatch):
    """sbatch's 'Requested node configuration is not available' for the
    default 4 cores on 2-CPU nodes (issue 28) names --cores, --memory and
    the nodes' size (Slurm's answers stubbed: sbatch --test-only, sinfo)."""
    import subprocess

    from mitsuba_pbrdf.batch import slurm
    from mitsuba_pbrdf.batch.slurm_options import slurm_options

    def fake(*argv, timeout=30.0):
        if argv[0] == "sbatch":
            return subprocess.CompletedProcess(argv, 1, "", "sbatch: error: Batch job "
                                               "submission failed: Requested node "
                                               "configuration is not available\n")
        assert argv[:2] == ("sinfo", "-h")
        return subprocess.CompletedProcess(argv, 0, "2 1998\n2 1998+\n", "")

    monkeypatch.setattr(slurm, "_slurm", fake)
    with pytest.raises(SlurmError) as info:
        slurm._test_only("#!/bin/sh\n", slurm_options(), "debug")
    message = str(info.value)
    assert "\n" not in message
    for words in ("Requested node configuration is not available", "--cores 4",
                  "--memory 4GB", "partition 'debug' have at most 2 CPUs and 1998 MB"):
        assert words in message, message
    # within the nodes' size, sbatch's own reason alone
    with pytest.raises(SlurmError) as info:
        slurm._test_only("#!/bin/sh\n", slurm_options(cores=2, memory="1GB"), "debug")
    assert "--cores" not in str(info.value)


def test_a_worker_that_joined_and_left_counts_as_started():
    """Slurm workers cancelled within milliseconds of joining (CI: three in
    a row, each gone before a poll) were never seen by
    ``Client.wait_for_workers``, which then waited out --start-timeout and
    reported that no worker job started, after the keeper had given up. The
    wait now asks the keeper, which the scheduler told of every join."""
    from mitsuba_pbrdf.batch.slurm import _first_worker_joined

    cluster = FakeCluster(1)
    keeper, _ = keeper_for(cluster, limit=2)
    assert not _first_worker_joined(keeper, 0.2)
    keeper.worker_joined(W0)
    cluster.leave(W0)  # joined and left before the wait looked
    assert _first_worker_joined(keeper, 5.0)


def test_the_keepers_give_up_ends_the_wait_for_the_first_worker_with_its_line():
    from mitsuba_pbrdf.batch.slurm import _first_worker_joined

    cluster = FakeCluster(1)
    keeper, given_up = keeper_for(cluster, limit=1)
    assert keeper.tick()
    cluster.lose(W0)
    assert keeper.tick() and keeper.tick()  # replaced once, the new job seen
    cluster.lose(W0)
    assert not keeper.tick() and given_up
    start = time.monotonic()
    with pytest.raises(SlurmError, match="replaced 1 times each .* submitting no more"):
        _first_worker_joined(keeper, 60.0)
    assert time.monotonic() - start < 1.0
