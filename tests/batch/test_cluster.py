"""A job whose worker was lost runs again before any job that has not
started (:mod:`mitsuba_pbrdf.batch.runner`), on the sweep's own local
cluster settings (:func:`mitsuba_pbrdf.batch.cluster.connect`: one thread per
worker, ``worker-saturation = 1.0``, so each worker holds only the job it
runs), with plain Python tasks instead of renders so that it takes seconds.

Two workers: job 0 and job 1 start together, one on each; job 0 waits until
job 1 has started, then ends its worker process (the nanny starts a new
one) while job 1 runs on until the scheduler has removed the lost worker. The next job to start, on the new
worker or on job 1's once it is free, is the one Dask chose first among
those waiting: it must be job 0 again, not job 2. Submitted one by one with
``client.submit`` (as before: one priority for all, checked in 3 runs) the
starts were 0 1 4 5 6 7 8 9 3 10 11 2 0 or similar: the 12 jobs reach the
scheduler within Dask's 100 ms ``fifo_timeout`` and share one priority,
among which Dask's queue keeps no order, and the lost job started last.
"""

import os
import time
import uuid

import pytest

from mitsuba_pbrdf.batch.cluster import connect
from mitsuba_pbrdf.batch.runner import submit_in_order

JOBS = 12


def start_and_maybe_die(index: int, folder: str) -> None:
    """Append *index* to ``starts.txt`` in *folder* (this job started). Job 0
    ends its worker process on its first try once job 1 has started, after
    writing the worker's address to ``died``; job 1 runs until the scheduler
    has removed that worker (so job 0 is waiting again when job 1's worker is
    free: a fixed second was too short on a loaded machine, where the starts
    were 0 1 2 0 ...), the others take 50 ms."""
    from distributed import get_client, get_worker

    with open(os.path.join(folder, "starts.txt"), "a") as f:
        f.write(f"{index}\n")
    open(os.path.join(folder, f"started-{index}"), "w").close()
    marker = os.path.join(folder, "died")
    deadline = time.monotonic() + 60
    if index == 0 and not os.path.exists(marker):
        while not os.path.exists(os.path.join(folder, "started-1")):
            assert time.monotonic() < deadline, "job 1 never started"
            time.sleep(0.01)
        with open(marker + ".tmp", "w") as f:
            f.write(get_worker().address)
        os.replace(marker + ".tmp", marker)
        os._exit(1)
    if index == 1:
        while not os.path.exists(marker):
            assert time.monotonic() < deadline, "job 0 never ended its worker"
            time.sleep(0.01)
        lost = open(marker).read()
        client = get_client()
        while lost in client.scheduler_info()["workers"]:
            assert time.monotonic() < deadline, "the scheduler never removed the lost worker"
            time.sleep(0.05)
    time.sleep(0.05)


@pytest.mark.slow
def test_a_lost_job_runs_again_before_the_jobs_not_started(tmp_path):
    with connect(workers=2, drjit_threads=2) as (client, _):
        run = uuid.uuid4().hex[:8]
        futures = submit_in_order(client, start_and_maybe_die,
                                  [(i, str(tmp_path)) for i in range(JOBS)],
                                  [f"order-{i}-{run}" for i in range(JOBS)])
        client.gather(futures)
    starts = [int(line) for line in (tmp_path / "starts.txt").read_text().split()]
    assert (tmp_path / "died").exists()  # job 0's worker died once
    assert sorted(starts[:2]) == [0, 1], starts  # one job on each worker
    assert starts[2] == 0, starts  # the lost job first, before jobs 2..11
    assert sorted(starts[3:]) == list(range(2, JOBS)), starts  # each once


def wait_for_go(index: int, folder: str) -> None:
    """Job *index*: say it started, then (job 0) wait until ``go`` exists."""
    open(os.path.join(folder, f"started-{index}"), "w").close()
    deadline = time.monotonic() + 30
    while index == 0 and not os.path.exists(os.path.join(folder, "go")):
        assert time.monotonic() < deadline, "the test never said go"
        time.sleep(0.01)


def test_a_worker_holds_only_the_job_it_runs_from_the_first_job(tmp_path):
    """One worker, 12 jobs: while job 0 runs, the worker holds no other job (the
    rest wait on the scheduler, where a lost worker cannot take them). Submitted one
    by one, the first jobs reached the scheduler as a group too small to queue and
    were handed to the worker up front (checked: it held jobs 0 and 1, and on Slurm
    a worker cancelled at its first output lost 3 jobs)."""
    with connect(workers=1, drjit_threads=2) as (client, _):
        run = uuid.uuid4().hex[:8]
        keys = [f"hold-{i}-{run}" for i in range(JOBS)]
        futures = submit_in_order(client, wait_for_go, [(i, str(tmp_path)) for i in range(JOBS)],
                                  keys)
        deadline = time.monotonic() + 60
        while not (tmp_path / "started-0").exists():
            assert time.monotonic() < deadline, "job 0 never started"
            time.sleep(0.01)
        held = [list(k) for k in client.processing().values()]
        (tmp_path / "go").touch()
        client.gather(futures)
    assert held == [[keys[0]]], held


def test_keys_and_jobs_must_match():
    with pytest.raises(ValueError, match="2 jobs but 1 keys"):
        submit_in_order(None, print, [(), ()], ["a"])
