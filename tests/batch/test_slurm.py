"""``pbrdf batch --slurm`` against a real Slurm: a single-node Slurm
(:mod:`single_node_slurm`: Debian's slurmctld, slurmd and munge, installed by
``.ci/install-slurm.sh``) that the module's fixture starts and stops.

Faults, as on the local cluster (tests/batch/test_runner.py): a worker's Slurm job
cancelled (``scancel``) and another one running out of walltime while they
render lose nothing (the renders run again on other workers, every output
reads back, the manifest's ``note`` names what happened), a rerun renders
nothing, and no Slurm job is left in the queue when the sweep ends, fails or
is interrupted (Ctrl-C), while a job of someone else stays.

Without the packages (or not as root) these tests skip with a one-line
reason saying how to get them; in CI (``CI=true``) they fail instead.
The option checks at the top need no Slurm.
"""

import importlib.util
import os
import re
import signal
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from mitsuba_pbrdf.batch.manifest import read_manifest
from mitsuba_pbrdf.batch.slurm_options import (SlurmError, SlurmOptions, format_walltime,
                                               parse_walltime, slurm_options)
from mitsuba_pbrdf.batch.sweep import SweepError, load_sweep
from mitsuba_pbrdf.cli import main
from mitsuba_pbrdf.stokes.exr import read_stokes_exr
from proof.interrupt import interrupt_once_output_exists
from proof.single_node_slurm import SingleNodeSlurm, missing

ROOT = Path(__file__).resolve().parents[2]
SPHERE = ROOT / "scenes" / "gallery" / "sphere.xml"
IN_CI = os.environ.get("CI", "").lower() == "true"


def write_sweep(folder: Path, body: str, name: str = "sweep.toml") -> Path:
    path = folder / name
    path.write_text(f'scene = "{SPHERE}"\nout = "out"\n' + body)
    return path


def grid(count: int, spp: int) -> str:
    """A sweep body of *count* 16 x 16 px renders of the gallery sphere."""
    sigmas = ", ".join(f"{0.05 + 0.002 * i:.3f}" for i in range(count))
    return f"spp = {spp}\n[params]\nwidth = 16\nheight = 16\nsigma = [{sigmas}]\n"


# ---------------------------------------------------------------- options (no Slurm needed)

@pytest.mark.parametrize("text, seconds", [
    ("90", 5400), ("1:30", 90), ("02:00:00", 7200), ("1-12", 129600), ("1-0:30", 88200),
    ("2-01:02:03", 176523)])
def test_walltime_formats_are_slurm_s(text, seconds):
    assert parse_walltime(text) == seconds


@pytest.mark.parametrize("text", ["", "1h", "01:60:00", "1:2:3:4", "-5", "1.5", "12-"])
def test_malformed_walltimes_are_refused(text):
    with pytest.raises(SlurmError, match="walltime"):
        parse_walltime(text)


def test_walltime_is_rounded_up_to_minutes_as_slurm_does():
    assert format_walltime(61) == "00:02:00" and format_walltime(7200) == "02:00:00"


@pytest.mark.parametrize("table, words", [
    ({"walltime": "0:30"}, ["slurm.walltime", "too short", "00:01:00"]),
    ({"walltime": "soon"}, ["slurm.walltime 'soon' is not a Slurm time"]),
    ({"cores": 0}, ["slurm.cores", "positive integer"]),
    ({"jobs": 1.5}, ["slurm.jobs", "positive integer"]),
    ({"memory": "lots"}, ["slurm.memory 'lots'"]),
    ({"memory": "10MB"}, ["at least 256 MiB"]),
    ({"partition": "a b"}, ["slurm.partition", "not a partition name"]),
    ({"sbatch": "--account=x"}, ["slurm.sbatch must be a list"]),
    ({"sbatch": ["account=x"]}, ["slurm.sbatch", "one sbatch option"]),
    ({"start_timeout": 0}, ["slurm.start_timeout", "positive number"]),
    ({"queue": "x"}, ["slurm: unknown key 'queue'", "partition"]),
])
def test_bad_slurm_tables_are_refused_at_load_time(tmp_path, table, words):
    def toml(value):
        if isinstance(value, str):
            return f'"{value}"'
        if isinstance(value, list):
            return "[" + ", ".join(toml(v) for v in value) + "]"
        return str(value)

    body = "[slurm]\n" + "".join(f"{k} = {toml(v)}\n" for k, v in table.items())
    path = write_sweep(tmp_path, body)
    with pytest.raises(SweepError) as e:
        load_sweep(path)
    message = str(e.value)
    assert message.startswith(str(path)) and "\n" not in message
    for word in words:
        assert word in message


def test_command_line_wins_over_the_table_and_adds_directives():
    options = slurm_options({"jobs": 3, "cores": 8, "sbatch": ["--account=lab"]},
                            where="s.toml: ", cores=2, sbatch=("--qos=short",))
    assert options == SlurmOptions(jobs=3, cores=2, sbatch=("--account=lab", "--qos=short"))
    with pytest.raises(SlurmError, match="^--walltime: '0:59' is too short"):
        slurm_options({}, walltime="0:59")


def test_slurm_options_need_slurm_and_threads_are_the_cores(tmp_path, capsys):
    path = write_sweep(tmp_path, grid(1, 1))
    assert main(["batch", str(path), "--partition", "debug"]) == 2
    assert "--partition is a Slurm option: add --slurm" in capsys.readouterr().err
    assert main(["batch", str(path), "--slurm", "--drjit-threads", "4"]) == 2
    assert "--drjit-threads does not go with --slurm" in capsys.readouterr().err


def test_slurm_without_dask_jobqueue_names_the_extra(tmp_path, capfd, monkeypatch):
    monkeypatch.setitem(sys.modules, "dask_jobqueue", None)  # import fails as if absent
    path = write_sweep(tmp_path, grid(2, 1))
    assert main(["batch", str(path), "--slurm", "--no-progress"]) == 2
    err = capfd.readouterr().err.strip()
    assert err == ("pbrdf batch: error: --slurm needs dask-jobqueue: pip install "
                   "'mitsuba-pbrdf[cluster]' (the 'cluster' extra)")


def test_slurm_without_slurm_is_one_line(tmp_path, capfd, monkeypatch):
    """No Slurm command on PATH (a machine without Slurm): one line, exit 2,
    no output folder content, nothing rendered."""
    if importlib.util.find_spec("dask_jobqueue") is None:
        pytest.skip("dask-jobqueue is not installed: pip install -e '.[test]'")
    monkeypatch.setenv("PATH", str(tmp_path / "empty"))
    path = write_sweep(tmp_path, grid(2, 1))
    assert main(["batch", str(path), "--slurm", "--no-progress"]) == 2
    err = capfd.readouterr().err.strip()
    assert err.count("\n") == 0 and "Traceback" not in err
    assert err.startswith("pbrdf batch: error: Slurm is not reachable: no 'scontrol' command")
    assert not list((tmp_path / "out").glob("*.exr"))


def require_slurm_commands():
    """Skip (fail in CI) without the Slurm packages, dask-jobqueue or root."""
    why = missing()
    if why is None and importlib.util.find_spec("dask_jobqueue") is None:
        why = "dask-jobqueue is not installed: pip install -e '.[test]'"
    if why:
        if IN_CI:
            pytest.fail(f"CI must run the Slurm tests, not skip them: {why}", pytrace=False)
        pytest.skip(why)


def test_slurm_that_does_not_answer_is_one_line(tmp_path, capfd, monkeypatch):
    """Slurm's commands installed but no controller answering (its daemons
    down): one line naming scontrol's reason, exit 2, nothing rendered."""
    require_slurm_commands()
    conf = tmp_path / "slurm.conf"
    conf.write_text("ClusterName=nowhere\nSlurmctldHost=localhost\nSlurmctldPort=6990\n"
                    f"AuthType=auth/munge\nAuthInfo=socket={tmp_path}/munge.socket\n"
                    "NodeName=localhost CPUs=1\nPartitionName=x Nodes=localhost\n")
    monkeypatch.setenv("SLURM_CONF", str(conf))
    path = write_sweep(tmp_path, grid(2, 1))
    assert main(["batch", str(path), "--slurm", "--no-progress"]) == 2
    err = capfd.readouterr().err.strip()
    assert err.count("\n") == 0 and "Traceback" not in err
    assert err.startswith("pbrdf batch: error: Slurm is not reachable: scontrol: ")
    assert "Unable to contact slurm controller" in err
    assert not list((tmp_path / "out").glob("*.exr"))


def test_benchmark_section_replaces_its_own_and_keeps_the_rest(tmp_path, capsys):
    """benchmarks/batch_slurm.py writes the ``## On Slurm`` section of
    batch.md, batch_throughput.py the rest (proof/batch_report.py): each
    keeps the other's part."""
    from proof.batch_report import write_batch_md

    target = tmp_path / "batch.md"
    write_batch_md(tmp_path, "# throughput\n\ntable\n")
    write_batch_md(tmp_path, "## On Slurm\n\nfirst\n", slurm=True)
    write_batch_md(tmp_path, "## On Slurm\n\nsecond\n", slurm=True)
    assert target.read_text() == "# throughput\n\ntable\n\n## On Slurm\n\nsecond\n"
    write_batch_md(tmp_path, "# throughput\n\nnew table\n")
    assert target.read_text() == "# throughput\n\nnew table\n\n## On Slurm\n\nsecond\n"


@pytest.mark.slow
def test_one_run_at_a_time_holds_the_single_node_slurm(tmp_path):
    """Two runs on one machine: the second waits for the first's lock and
    says so in one line if it waits too long; it gets the lock once the
    first gives it back (stop, or its process ends). Needs no Slurm."""
    first = SingleNodeSlurm(str(tmp_path / "slurm")).reserve()
    second = SingleNodeSlurm(str(tmp_path / "slurm"))
    t0 = time.monotonic()
    with pytest.raises(RuntimeError, match=r"another run has held .* \(lock .*slurm\.lock\)"):
        second.reserve(timeout=1.0)
    assert time.monotonic() - t0 >= 1.0  # it waited before giving up
    first.release()
    assert second.reserve(timeout=1.0) is second
    second.release()


# ---------------------------------------------------------------- a real Slurm

@pytest.fixture(scope="module")
def slurm():
    """The single-node Slurm, started for this module and stopped after it
    (also when a previous run left its daemons running); ``SLURM_CONF``
    points the Slurm commands, dask-jobqueue and subprocesses at it."""
    require_slurm_commands()
    node = SingleNodeSlurm()
    before = os.environ.get("SLURM_CONF")
    try:
        node.start()
        os.environ["SLURM_CONF"] = node.conf
        yield node
    finally:
        node.stop()
        if before is None:
            os.environ.pop("SLURM_CONF", None)
        else:
            os.environ["SLURM_CONF"] = before
        node.stop()


def rows_of(sweep):
    return list(read_manifest(sweep.manifest).values())


def running_jobs(node):
    return node.run("squeue", "-h", "-t", "R", "-o", "%i").split()


def timed_out_jobs(node):
    """Ids of the jobs Slurm ended at their walltime (it keeps finished jobs
    for MinJobAge = 600 s)."""
    lines = node.run("scontrol", "show", "job", "-o", check=False).splitlines()
    return [line.split()[0].split("=")[1] for line in lines if "JobState=TIMEOUT" in line]


@pytest.mark.slow
def test_cancelled_and_timed_out_workers_lose_nothing(tmp_path, slurm, python_sigint_handler):
    """Two worker jobs with a walltime of 1 minute render a sweep far longer
    than that. Once the first output exists, one worker's job is cancelled
    (scancel) while it renders; later a worker job runs out of walltime while
    it renders (Slurm ends a job 60 to 90 s after its start: it checks time
    limits every 30 s); 8 renders after that, the sweep is interrupted
    (SIGINT, as Ctrl-C). The jobs of both lost workers ran again first and
    are ``done``, every done job's image reads back, the cancelled job's render
    equals an in-process render with its seed, the notes name the
    cancellation (with the job id) and the walltime, and no job is left in
    the queue. Interrupting keeps the test's length set by the walltime, not
    by the machine's speed."""
    from mitsuba_pbrdf.batch.runner import run_sweep
    from mitsuba_pbrdf.rendering.render import render_scene

    # 2000 renders of 1024 spp at 16 x 16 px, so the walltime (60-90 s) comes first
    # however fast the machine: 400 of them took only about 70 s on 2 otherwise idle
    # cores (the sweep ended before the walltime); the sweep is interrupted 8 renders
    # after the walltime, so its length costs nothing
    sweep = load_sweep(write_sweep(tmp_path, grid(2000, 1024)))
    options = SlurmOptions(jobs=2, cores=1, memory="1GB", walltime="1", start_timeout=120)
    seen = {}

    def monitor():
        out = Path(sweep.out)
        deadline = time.time() + 240
        while time.time() < deadline:
            time.sleep(0.2)
            outputs = len(list(out.glob("*.exr"))) if out.is_dir() else 0
            if "cancelled" not in seen:
                running = running_jobs(slurm) if outputs else []
                if running:
                    slurm.run("scancel", running[0])
                    seen["cancelled"] = running[0]
            elif "timeout" not in seen:
                timed = timed_out_jobs(slurm)
                if timed:
                    seen.update(timeout=timed[0], outputs=outputs)
            elif outputs >= seen["outputs"] + 8:
                os.kill(os.getpid(), signal.SIGINT)  # Ctrl-C
                seen["interrupted"] = outputs
                return

    thread = threading.Thread(target=monitor, daemon=True)
    thread.start()   # Python's own SIGINT handler meanwhile (python_sigint_handler)
    with pytest.raises(KeyboardInterrupt):
        run_sweep(sweep, slurm=options, progress=False)
    thread.join(5)
    assert "interrupted" in seen, f"the sweep ended before its workers were lost: {seen}"
    assert slurm.jobs() == [], slurm.run("squeue")
    rows = rows_of(sweep)
    assert {r["status"] for r in rows} == {"done", "pending"} and not any(r["error"] for r in rows)
    for row in rows:
        if row["status"] == "done":
            image = read_stokes_exr(os.path.join(sweep.out, row["file"]))
            assert image.stokes.shape[:2] == (16, 16) and np.isfinite(image.stokes).all()
    assert not [p for p in Path(sweep.out).iterdir() if p.name.startswith(".")]  # no temp file

    notes = {r["job"]: r for r in rows if r["note"]}
    assert all(r["note"].startswith("run again: ") and "\n" not in r["note"]
               for r in notes.values())
    cancel = [job for job, r in notes.items()
              if f"Slurm job {seen['cancelled']} was cancelled" in r["note"]]
    timeout = [job for job, r in notes.items()
               if f"Slurm job {seen['timeout']} reached its walltime (00:01:00)" in r["note"]]
    # the job each worker rendered; at a job boundary also the one just sent to it (the
    # sweep goes to Dask as one graph, so its jobs wait on the scheduler from the first
    # one; submitted one by one, the first worker was handed jobs 0-3 up front, lost 1-3)
    assert 1 <= len(cancel) <= 2 and 1 <= len(timeout) <= 2, notes
    # every lost job ran again and is done before the interrupt: the runner submits the jobs
    # as one graph in the sweep's order, each with a priority of its own
    # (mitsuba_pbrdf.batch.runner), so a lost job comes before every job that has not
    # started and Dask sends it to the next free worker. 8 new outputs after the walltime leave room for up to 4 lost jobs (2 per
    # worker, and both workers may reach the walltime at one check of Slurm: their renders
    # again are new outputs), a render running on the other worker at the loss, and a
    # result still on its way. (With equal priorities, as before, Dask's queue kept no
    # order among them: a lost job stayed pending 60 renders after its walltime.)
    # The other worker job may reach its walltime too: Slurm checks the time limits of all
    # jobs at once every 30 s, so at the same check (its jobs lost with the first ones,
    # within the room above) or 30 s later, after the interrupt (8 renders take seconds,
    # replacing both workers included): every job with a note is done.
    assert all(r["status"] == "done" for r in notes.values()), \
        {job: (r["status"], r["note"]) for job, r in notes.items()}

    # the cancelled job's render was run again with its own seed: equal to an
    # in-process render up to the order of float32 additions (Mitsuba's film sums
    # a pixel's 1024 spp x 9 filter splats with atomic adds in any order: at most
    # 9216 * 2^-24 = 5.5e-4 of the sum of the terms' magnitudes, which |S1..S3| <= S0
    # keeps below the image maximum; measured here: 2.5e-6). Another seed differs by
    # the Monte Carlo noise, 3e-2 of the maximum here, 50 times the bound.
    job = next(j for j in sweep.jobs if j.name == cancel[0])  # the first lost: it was rendering
    retried = read_stokes_exr(os.path.join(sweep.out, f"{job.name}.exr")).stokes
    again = render_scene(SPHERE, spp=1024, seed=job.seed, params=job.params).stokes
    other = render_scene(SPHERE, spp=1024, seed=job.seed + 1, params=job.params).stokes
    scale = np.abs(again).max()
    assert np.abs(retried - again).max() <= 5.5e-4 * scale
    assert np.abs(other - again).max() > 5e-3 * scale


def one_line_error(capfd):
    err = capfd.readouterr().err.strip()
    assert err.count("\n") == 0 and "Traceback" not in err, err
    assert err.startswith("pbrdf batch: error: "), err
    return err


@pytest.mark.slow
def test_bad_partition_is_one_line_and_submits_nothing(tmp_path, slurm, capfd):
    path = write_sweep(tmp_path, grid(2, 1))
    assert main(["batch", str(path), "--slurm", "--partition", "gpu-huge"]) == 2
    err = one_line_error(capfd)
    assert "--partition 'gpu-huge': no such Slurm partition; this cluster has debug" in err
    assert slurm.jobs() == [] and not (tmp_path / "out" / "slurm-logs").exists()


@pytest.mark.slow
def test_a_job_slurm_refuses_is_one_line(tmp_path, slurm, capfd):
    """More cores than the node has: ``sbatch --test-only`` refuses the
    worker job before any is submitted."""
    path = write_sweep(tmp_path, grid(2, 1))
    assert main(["batch", str(path), "--slurm", "--cores", "4096", "--memory", "1GB"]) == 2
    assert "sbatch refuses the worker job: " in one_line_error(capfd)
    assert slurm.jobs() == []


@pytest.mark.slow
def test_a_job_that_never_starts_names_the_partition_and_the_reason(tmp_path, slurm, capfd):
    """Worker jobs held back (``--begin=now+1hour``) do not start within
    ``--start-timeout``: one line naming the partition and squeue's reason,
    and the jobs are cancelled."""
    path = write_sweep(tmp_path, grid(2, 1))
    t = time.perf_counter()
    assert main(["batch", str(path), "--slurm", "--cores", "1", "--memory", "1GB",
                 "--sbatch=--begin=now+1hour", "--start-timeout", "3"]) == 2
    err = one_line_error(capfd)
    assert "no worker job started within 3 s on partition 'debug'" in err
    assert "(squeue: PENDING (BeginTime))" in err
    assert time.perf_counter() - t < 60
    assert slurm.jobs() == []
    assert all(r["status"] == "pending" for r in rows_of(load_sweep(path)))


@pytest.mark.slow
def test_worker_jobs_lost_before_any_render_stop_at_the_cap(tmp_path, slurm, capfd):
    """Each worker job is cancelled as soon as its worker joins, before it
    renders (its first render imports Mitsuba: seconds; the cancellation
    comes within 50 ms of the log line). With ``--max-resubmissions 2`` the
    one worker job is replaced twice, then nothing more is submitted: one
    line naming the cap and the last job's cancellation, exit 2, the rows
    pending, the queue empty. (Without the cap: a new job every few seconds;
    the test stops cancelling after 6, and the sweep would then end done.)"""
    import re

    path = write_sweep(tmp_path, grid(3, 64))
    logs = tmp_path / "out" / "slurm-logs"
    cancelled, stop = [], threading.Event()

    def cancel_on_join():
        while not stop.wait(0.05):
            for log in logs.glob("*.err") if logs.is_dir() else []:
                job = re.search(r"-(\d+)\.err$", log.name).group(1)
                if (job not in cancelled and len(cancelled) < 6  # then let it render
                        and "Registered to" in log.read_text(errors="replace")):
                    slurm.run("scancel", job, check=False)
                    cancelled.append(job)

    watcher = threading.Thread(target=cancel_on_join, daemon=True)
    watcher.start()
    try:
        assert main(["batch", str(path), "--slurm", "--jobs", "1", "--cores", "1", "--memory",
                     "1GB", "--max-resubmissions", "2", "--start-timeout", "120",
                     "--no-progress"]) == 2
    finally:
        stop.set()
        watcher.join()
    err = one_line_error(capfd)
    assert len(cancelled) == 3, cancelled  # the first job and its 2 replacements
    assert (f"the Slurm worker jobs were lost and replaced 2 times each (max_resubmissions, "
            f"--max-resubmissions) with no render done in between; the last one: Slurm job "
            f"{cancelled[-1]} was cancelled; submitting no more") in err
    assert {r["status"] for r in rows_of(load_sweep(path))} == {"pending"}
    assert slurm.jobs() == []


@pytest.mark.slow
def test_worker_jobs_that_fail_before_joining_stop_the_sweep_with_their_error(tmp_path, slurm,
                                                                              capfd):
    """Python broken on the nodes (here ``PYTHONHOME`` pointing nowhere, passed
    with ``--sbatch=--export=...``): each worker job fails before its worker
    joins. Dask never hears of such a job, so before, the sweep waited out
    ``--start-timeout`` (300 s by default) and then blamed sbatch. Now it
    stops within seconds with Slurm's state of the job and the error line of
    its log; exit 2, rows pending, the queue empty."""
    path = write_sweep(tmp_path, grid(3, 64))
    start = time.monotonic()
    assert main(["batch", str(path), "--slurm", "--jobs", "2", "--cores", "1", "--memory", "1GB",
                 "--sbatch=--export=ALL,PYTHONHOME=/nonexistent", "--no-progress"]) == 2
    took = time.monotonic() - start
    err = one_line_error(capfd)
    assert took < 60, took  # far from the 300 s of --start-timeout
    assert re.search(r"Slurm job \d+ ended: FAILED \(reason NonZeroExitCode\) before its worker "
                     r"joined the sweep: ModuleNotFoundError: No module named 'encodings'; "
                     r"nothing would render, so no more worker jobs are submitted \(the worker "
                     r"jobs' logs are in .*slurm-logs\)$", err), err
    assert {r["status"] for r in rows_of(load_sweep(path))} == {"pending"}
    assert slurm.jobs() == []


@pytest.mark.slow
def test_ctrl_c_cancels_its_worker_jobs_and_nothing_else(tmp_path, slurm, capsys):
    """SIGINT to the process group of ``pbrdf batch --slurm`` once an output
    exists: exit status 130, one line, a manifest whose done rows name valid
    files, none of its worker jobs left, and another job in the queue kept.
    A rerun renders the rest; a third run submits and renders nothing."""
    other = slurm.run("sbatch", "--parsable", "-o", "/dev/null", "--wrap", "sleep 600").strip()
    argv = ["--slurm", "--cores", "1", "--memory", "1GB", "--walltime", "5", "--no-progress"]
    try:
        path = write_sweep(tmp_path, grid(6, 512))
        sweep = load_sweep(path)
        done = interrupt_once_output_exists(["batch", str(path), "--jobs", "1", *argv],
                                            sweep.out, env=slurm.env())
        assert done.returncode == 130, done.stderr
        assert done.stderr.strip().splitlines()[-1] == "pbrdf batch: interrupted", done.stderr
        rows = rows_of(sweep)
        # the first file exists; its row may still be pending (the result was on its way)
        assert len(rows) == 6 and {r["status"] for r in rows} <= {"done", "pending"}
        assert "pending" in {r["status"] for r in rows}
        for row in rows:
            if row["status"] == "done":
                assert read_stokes_exr(os.path.join(sweep.out, row["file"])).stokes.shape[0] == 16
        assert slurm.jobs() == [other]

        assert main(["batch", str(path), "--jobs", "2", *argv]) == 0
        assert " 0 failed, 0 pending" in capsys.readouterr().out
        assert {r["status"] for r in rows_of(sweep)} == {"done"}
        stamps = {p.name: p.stat().st_mtime_ns for p in Path(sweep.out).glob("*.exr")}
        logs = set(os.listdir(Path(sweep.out) / "slurm-logs"))
        assert main(["batch", str(path), "--jobs", "2", *argv]) == 0
        assert "0 rendered, 6 already done" in capsys.readouterr().out
        assert stamps == {p.name: p.stat().st_mtime_ns for p in Path(sweep.out).glob("*.exr")}
        assert set(os.listdir(Path(sweep.out) / "slurm-logs")) == logs  # nothing submitted
        assert slurm.jobs() == [other]
    finally:
        slurm.run("scancel", other, check=False)


@pytest.mark.slow
def test_a_start_stops_the_daemons_a_previous_run_left(slurm):
    """What a test run killed before its teardown leaves (daemons still
    running, their pid files in STATE) is stopped by the next start: the old
    daemons are gone, new ones answer. Runs last: it restarts the fixture's Slurm."""
    from proof.single_node_slurm import DAEMONS, _ours

    def pids():
        return {d: int(Path(slurm.state, f"{d}.pid").read_text().split()[0]) for d in DAEMONS}

    before = pids()
    assert all(_ours(pid, d) for d, pid in before.items())
    slurm.start()
    after = pids()
    assert not any(_ours(pid, d) for d, pid in before.items() if after[d] != pid)
    assert all(after[d] != before[d] and _ours(after[d], d) for d in DAEMONS)
    assert slurm.jobs() == [] and "idle" in slurm.run("sinfo", "-h", "-N", "-o", "%t")
