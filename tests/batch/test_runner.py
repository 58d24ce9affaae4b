"""``pbrdf batch``: sweep files checked at load time, job names and seeds, and
a sweep on a local Dask cluster of 2 worker processes that loses nothing when
a worker is killed mid-sweep, records a failing job and goes on, stops
cleanly on Ctrl-C, and renders nothing when run again.

The renders are tiny (16 x 16 px, 4 spp of the gallery sphere: one
environment emitter, so a retried job's image equals an in-process render
with the same seed up to the order of float32 additions) and the cluster is shared by the
module's sweep tests (its start and the workers' first kernel compilation
cost ~10-20 s on 2 cores).
"""

import csv
import os
import signal
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from mitsuba_pbrdf.batch.manifest import read_manifest
from mitsuba_pbrdf.batch.sweep import SweepError, job_seed, load_sweep
from mitsuba_pbrdf.cli import main
from mitsuba_pbrdf.stokes.exr import read_stokes_exr
from proof.interrupt import interrupt_once_output_exists

SCENES = Path(__file__).resolve().parents[2] / "scenes"
SPHERE = SCENES / "gallery" / "sphere.xml"

pytest.importorskip("distributed")


def write_sweep(folder: Path, body: str, name: str = "sweep.toml") -> Path:
    path = folder / name
    path.write_text(f'scene = "{SPHERE}"\n' + body)
    return path


TINY = """spp = 4
out = "out"
[params]
width = 16
height = 16
"""


# ---------------------------------------------------------------- load-time checks

@pytest.mark.parametrize("body, words", [
    ('out = "o"\nspp = 4\nbogus = 1\n', ["unknown key 'bogus'"]),
    ('out = "o"\nspp = "many"\n', ["spp must be an integer"]),
    ('out = "o"\nspp = 0\n', ["spp must be an integer >= 1"]),
    ('out = "o"\nseed = -1\n', ["seed must be an integer in"]),
    ('spp = 4\n', ["out is missing"]),
    ('out = "o"\n[params]\nmaterial = []\n', ["params.material is an empty list"]),
    ('out = "o"\n[params]\nmaterial = ["Al", "Al"]\n', ["params.material", "listed twice"]),
    ('out = "o"\n[params]\nmaterial = [["Al"]]\n', ["params.material", "strings, numbers"]),
    ('out = "o"\n[params]\nsigma = [nan]\n', ["params.sigma", "not a finite number"]),
    ('out = "o"\n[params]\nroughness = [0.1]\n', ["params.roughness", "no parameter",
                                                  "sigma"]),
    ('out = "o"\n[params]\nsigmma = [0.1]\n', ["params.sigmma", "no parameter 'sigmma' "
                                              "(did you mean 'sigma'?)"]),
    ('out = "o"\n[params]\nwidth = [0, 8]\n', ["params.width", "positive integer"]),
    ('out = "o"\n[params]\nsigma = ["rough"]\n', ["params.sigma", "must be a number"]),
    ('out = "o"\noutputs = ["stokes", "camera"]\n', ["outputs: unknown output 'camera'",
                                                     "stokes, aov, polcam"]),
    ('out = "o"\n[polcam]\nsensor = "mono"\n', ["[polcam] table needs 'polcam' in outputs"]),
    ('out = "o"\noutputs = ["stokes", "polcam"]\n[polcam]\nsensor = "rgb"\n',
     ["polcam.sensor must be 'mono' or 'colour'"]),
    ('out = "o"\noutputs = ["stokes", "polcam"]\n[polcam]\nfull_well = -5\n',
     ["polcam.full_well must be a finite number > 0"]),
    ('out = "o"\noutputs = ["stokes", "polcam"]\n[polcam]\nread_noise = 2\n',
     ["polcam.read_noise", "needs polcam.full_well"]),
    ('out = "o"\noutputs = ["stokes", "polcam"]\n[polcam]\nexposure = 2.0\n',
     ["polcam.exposure", "needs polcam.full_well or polcam.bits"]),
    ('out = "o"\noutputs = ["stokes", "polcam"]\n[polcam]\nbits = 20\n',
     ["polcam.bits must be an integer in [1, 16]"]),
    ('out = "o"\noutputs = ["stokes", "polcam"]\n[polcam]\ngain = 2\n',
     ["polcam: unknown key 'gain'"]),
    ('out = "o"\noutputs = ["stokes", "polcam"]\n[polcam]\nsensor = "colour"\nband = "R"\n',
     ["polcam.band is for the mono sensor"]),
    ('out = "o"\noutputs = ["aov"]\n', ["outputs must include 'stokes'"]),
    ('out = "o"\nvariant = "llvm_ad_rgb"\n', ["variant:", "polarization"]),
    ('out = "o"\nvariant = "no_such_variant"\n', ["variant: unknown variant"]),
    ('out = "o"\nparams = 3\n', ["params must be a table"]),
    ('out = "o"\n[params]\nseed = [1]\n', ["params.seed", "manifest column"]),
    ('out = "o\n', ["not a valid TOML file"]),
])
def test_bad_sweeps_are_refused_at_load_time_naming_the_key(tmp_path, body, words):
    path = write_sweep(tmp_path, body)
    with pytest.raises(SweepError) as e:
        load_sweep(path)
    message = str(e.value)
    assert "\n" not in message and message.startswith(str(path))
    for word in words:
        assert word in message


def test_missing_scene_and_unwritable_out(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text('scene = "nowhere.xml"\nout = "o"\n')
    with pytest.raises(SweepError, match="scene: no such file: .*nowhere.xml"):
        load_sweep(path)
    (tmp_path / "afile").write_text("x")
    path = write_sweep(tmp_path, 'out = "afile/sub"\n')
    with pytest.raises(SweepError, match="out: cannot write in"):
        load_sweep(path)


def test_scene_path_is_relative_to_the_sweep_file(tmp_path, monkeypatch):
    folder = tmp_path / "sweeps"
    folder.mkdir()
    path = folder / "s.toml"
    path.write_text(f'scene = "{os.path.relpath(SPHERE, folder)}"\nout = "r"\n')
    monkeypatch.chdir(tmp_path.parent)
    sweep = load_sweep(path)
    assert sweep.scene == str(SPHERE) and sweep.out == str(folder / "r")
    assert [j.name for j in sweep.jobs] == ["sphere"]


def test_job_names_are_safe_unique_and_seeds_do_not_depend_on_the_grid(tmp_path):
    body = 'out = "o"\nseed = 7\n[params]\nmaterial = ["Al", "Cu"]\nsigma = [0.05, 0.2]\n'
    sweep = load_sweep(write_sweep(tmp_path, body))
    names = [j.name for j in sweep.jobs]
    assert names == ["material-Al_sigma-0.05", "material-Al_sigma-0.2",
                     "material-Cu_sigma-0.05", "material-Cu_sigma-0.2"]
    seeds = {j.name: j.seed for j in sweep.jobs}
    assert len(set(seeds.values())) == 4
    assert seeds["material-Cu_sigma-0.2"] == job_seed(7, {"material": "Cu", "sigma": "0.2"})
    # adding values keeps every existing job's name and seed
    wider = load_sweep(write_sweep(tmp_path, body.replace('"Cu"]', '"Cu", "Au"]'), "w.toml"))
    assert {j.name: j.seed for j in wider.jobs if j.name in seeds} == seeds
    # values that clean to the same name get distinct names; odd characters go
    odd = load_sweep(write_sweep(tmp_path, 'out = "o"\n[params]\nkdd = ["0.1, 0.2", "0.1 0.2"]\n',
                                 "odd.toml"))
    names = [j.name for j in odd.jobs]
    assert len(set(n.lower() for n in names)) == 2
    assert all(set(n) <= set("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789.+-_~")
               for n in names)


def test_cli_bad_sweep_is_one_line_exit_2(tmp_path, capsys):
    path = write_sweep(tmp_path, 'out = "o"\noutputs = ["stokes", "camera"]\n')
    assert main(["batch", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("pbrdf batch: error: ") and "'camera'" in err and "\n" not in err
    assert main(["batch", str(tmp_path / "none.toml")]) == 2
    assert "sweep file not found" in capsys.readouterr().err
    assert main(["batch", str(path), "--drjit-threads", "1"]) == 2
    assert "--drjit-threads must be at least 2" in capsys.readouterr().err


# ---------------------------------------------------------------- sweeps on a cluster

@pytest.fixture(scope="module")
def cluster():
    """A local cluster of 2 worker processes (1 job each at a time); yields
    (client, scheduler address)."""
    from mitsuba_pbrdf.batch.cluster import connect

    with connect(workers=2, drjit_threads=2) as (client, _):
        yield client, client.scheduler.address


def manifest_rows(sweep):
    with open(sweep.manifest, newline="") as f:
        return list(csv.DictReader(f))


def test_killed_worker_loses_nothing_and_a_rerun_renders_nothing(tmp_path, cluster):
    """Kill (SIGKILL) a worker while it renders a job, after the sweep's
    first output exists: the job runs again on a restarted or the other
    worker, every output appears and reads back, the retried image equals an
    in-process render with the job's seed, and a second run renders nothing."""
    from mitsuba_pbrdf.batch.runner import run_sweep
    from mitsuba_pbrdf.rendering.render import render_scene

    client, address = cluster
    path = write_sweep(tmp_path, TINY.replace("[params]", 'outputs = ["stokes", "aov"]\n[params]')
                       + 'material = ["Al", "Cu", "Au"]\nsigma = [0.05, 0.2]\n')
    sweep = load_sweep(path)
    pids = client.run(os.getpid)
    killed = {}

    def killer():
        deadline = time.time() + 120
        while time.time() < deadline and not killed:
            started = list(Path(sweep.out).glob("*.exr")) if os.path.isdir(sweep.out) else []
            processing = {w: keys for w, keys in client.processing().items() if keys}
            if started and processing:
                worker, keys = next(iter(processing.items()))
                killed.update(worker=worker, key=keys[0], pid=pids[worker])
                os.kill(pids[worker], signal.SIGKILL)
                return
            time.sleep(0.05)

    thread = threading.Thread(target=killer, daemon=True)
    thread.start()
    summary = run_sweep(sweep, scheduler=address, drjit_threads=2, progress=False)
    thread.join(5)
    assert killed, "no job was running to kill"
    assert (summary.done, summary.failed, summary.pending) == (6, 0, 0), summary.failures
    rows = manifest_rows(sweep)
    assert len(rows) == 6 and all(r["status"] == "done" and not r["error"] for r in rows)
    for row in rows:
        image = read_stokes_exr(os.path.join(sweep.out, row["file"]))
        assert image.stokes.shape[:2] == (16, 16) and np.isfinite(image.stokes).all()
        assert os.path.isfile(os.path.join(sweep.out, row["aov"]))
    assert not [p for p in Path(sweep.out).iterdir() if p.name.startswith(".")]  # no temp file
    with pytest.raises(ProcessLookupError):
        os.kill(killed["pid"], 0)

    # the killed job was rendered again with its own seed, and the manifest says why
    job = next(j for j in sweep.jobs if killed["key"].startswith(f"pbrdf-{j.name}-"))
    notes = {r["job"]: r["note"] for r in rows if r["note"]}
    assert notes[job.name] == f"run again: its worker {killed['worker']} left the cluster"
    assert len(notes) <= 2  # at a job boundary also the job just sent to the worker
    retried = read_stokes_exr(os.path.join(sweep.out, f"{job.name}.exr"))
    again = render_scene(SPHERE, spp=4, seed=job.seed, params=job.params).stokes
    other = render_scene(SPHERE, spp=4, seed=job.seed + 1, params=job.params).stokes
    scale = np.abs(again).max()
    # Same seed: equal up to the order of float32 additions (Mitsuba's film
    # accumulates splats with atomic adds from several threads; two renders in
    # one process differ by up to 2 ulp of the image maximum, 2.4e-7 here). A
    # pixel sums at most 4 spp x 9 filter splats = 36 terms, so the reordering
    # error is below 36 * 2^-24 ~ 2.1e-6 of the largest term: 1e-5 of the
    # image maximum. Another seed differs by the Monte Carlo noise, far more.
    assert np.abs(retried.stokes - again).max() <= 1e-5 * scale
    assert np.abs(other - again).max() > 1e-2 * scale

    stamps = {p.name: p.stat().st_mtime_ns for p in Path(sweep.out).glob("*.exr")}
    rerun = run_sweep(sweep, scheduler="tcp://127.0.0.1:9", progress=False)  # never contacted
    assert (rerun.skipped, rerun.done, rerun.failed) == (6, 0, 0)
    assert stamps == {p.name: p.stat().st_mtime_ns for p in Path(sweep.out).glob("*.exr")}

    # a damaged output is found and that job alone is rendered again
    victim = Path(sweep.out) / rows[0]["file"]
    victim.write_bytes(victim.read_bytes()[:200])
    third = run_sweep(sweep, scheduler=address, drjit_threads=2, progress=False)
    assert (third.skipped, third.done) == (5, 1)
    assert read_stokes_exr(victim).stokes.shape[:2] == (16, 16)


def test_failing_job_is_recorded_and_the_others_go_on(tmp_path, cluster):
    from mitsuba_pbrdf.batch.runner import run_sweep

    _, address = cluster
    sweep = load_sweep(write_sweep(tmp_path, TINY + 'material = ["Al", "Unobtainium"]\n'))
    summary = run_sweep(sweep, scheduler=address, drjit_threads=2, progress=False)
    assert (summary.done, summary.failed) == (1, 1)
    rows = {row["material"]: row for row in read_manifest(sweep.manifest).values()}
    bad = rows["Unobtainium"]
    assert bad["status"] == "failed" and "unknown material 'Unobtainium'" in bad["error"]
    assert "\n" not in bad["error"] and not bad["file"]
    assert rows["Al"]["status"] == "done" and (Path(sweep.out) / rows["Al"]["file"]).is_file()
    assert [p.name for p in Path(sweep.out).glob("*.exr")] == [rows["Al"]["file"]]


def test_polcam_outputs_are_pbrdf_polcam_of_the_job_s_stokes_image(tmp_path, cluster):
    """``outputs = ["stokes", "polcam"]``: each job also writes what ``pbrdf
    polcam`` writes of its Stokes EXR, with the sensor noise seeded by the job's
    seed: the files equal a recomputation from the written Stokes EXR (noise
    included, same seed), the manifest lists them, and a rerun checks them
    (one deleted file makes only its job run again)."""
    from mitsuba_pbrdf.batch.runner import run_sweep
    from mitsuba_pbrdf.stokes.exr import read_exr_channels, read_stokes_exr
    from mitsuba_pbrdf.camera.polcam import SensorModel, polcam_outputs

    _, address = cluster
    body = (TINY.replace('out = "out"', 'out = "out"\noutputs = ["stokes", "polcam"]')
            + 'material = ["Al", "Cu"]\n[polcam]\nsensor = "colour"\nfull_well = 5000\n'
              'read_noise = 3.0\nbits = 10\n')
    sweep = load_sweep(write_sweep(tmp_path, body))
    assert sweep.polcam == {"sensor": "colour", "full_well": 5000.0, "read_noise": 3.0,
                            "bits": 10}
    summary = run_sweep(sweep, scheduler=address, drjit_threads=2, progress=False)
    assert (summary.done, summary.failed) == (2, 0)
    out = Path(sweep.out)
    rows = read_manifest(sweep.manifest)
    for job in sweep.jobs:
        row = rows[job.name]
        names = row["polcam"].split(";")
        assert names == [f"{job.name}_{s}" for s in ("I0.exr", "I45.exr", "I90.exr", "I135.exr",
                                                       "mosaic_rgb.exr", "mosaic_rgb.png")]
        image = read_stokes_exr(out / row["file"])
        want = polcam_outputs(image, sensor="colour", model=SensorModel(
            full_well=5000.0, read_noise=3.0, bits=10, seed=job.seed))
        for angle in (0, 45, 90, 135):
            got = read_exr_channels(out / f"{job.name}_I{angle}.exr")
            for band in ("R", "G", "B"):
                np.testing.assert_array_equal(got[band], want[f"I{angle}"][band])
        mosaic = read_exr_channels(out / f"{job.name}_mosaic_rgb.exr")["Y"]
        np.testing.assert_array_equal(mosaic, want["mosaic_rgb"]["Y"])
        assert len(np.unique(mosaic)) <= 2 ** 10  # quantized by the 10-bit ADC
        import cv2

        counts = cv2.imread(str(out / f"{job.name}_mosaic_rgb.png"), cv2.IMREAD_UNCHANGED)
        assert counts.dtype == np.uint16 and counts.max() <= 1023
        np.testing.assert_array_equal(counts, want["mosaic_rgb.png"])
    (out / f"{sweep.jobs[0].name}_I45.exr").unlink()
    again = run_sweep(sweep, scheduler=address, drjit_threads=2, progress=False)
    assert (again.done, again.skipped) == (1, 1)
    assert (out / f"{sweep.jobs[0].name}_I45.exr").is_file()


@pytest.mark.slow
def test_ctrl_c_leaves_a_consistent_manifest(tmp_path):
    """SIGINT to the whole process group (what Ctrl-C does) once the first
    output exists: exit status 130, one line on stderr, and every row the
    manifest marks done names a valid file (the others are pending)."""
    body = TINY.replace("spp = 4", "spp = 64") + 'sigma = [0.05, 0.1, 0.15, 0.2, 0.25, 0.3]\n'
    path = write_sweep(tmp_path, body)
    sweep = load_sweep(path)
    done = interrupt_once_output_exists(["batch", str(path), "--workers", "1", "--no-progress"],
                                        sweep.out)
    assert done.returncode == 130, done.stderr
    assert done.stderr.strip().splitlines()[-1] == "pbrdf batch: interrupted", done.stderr
    rows = manifest_rows(sweep)
    assert len(rows) == 6 and {r["status"] for r in rows} <= {"done", "pending"}
    for row in rows:
        if row["status"] == "done":
            assert read_stokes_exr(os.path.join(sweep.out, row["file"])).stokes.shape[0] == 16


@pytest.mark.slow
def test_benchmark_quick_reports_throughput_overhead_and_memory(tmp_path):
    """Smoke run of benchmarks/batch_throughput.py --quick: every configuration
    renders and reports finite figures (the full run is by hand, docs/batch.md)."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
    import batch_throughput

    assert batch_throughput.main(["--quick", "--out", str(tmp_path)]) == 0
    text = (tmp_path / "batch.md").read_text()
    rows = [line for line in text.splitlines() if line.startswith(("| plain", "| Dask"))]
    assert len(rows) == 3
    for row in rows:
        cells = [c.strip() for c in row.strip("|").split("|")]
        assert float(cells[5]) > 0 and all(float(m) > 50 for m in cells[9].split(","))


def _worker_processes():
    """Pids of this process's Dask worker processes (children started by the
    local cluster's nannies through multiprocessing's spawn)."""
    found = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat") as f:
                parent = int(f.read().rsplit(")", 1)[1].split()[1])
            with open(f"/proc/{entry}/cmdline", "rb") as f:
                command = f.read()
        except OSError:
            continue
        if parent == os.getpid() and b"spawn_main" in command:
            found.append(int(entry))
    return found


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="reads /proc to find the workers")
@pytest.mark.slow
def test_a_job_that_outlives_allowed_failures_is_recorded_failed(tmp_path):
    """With allowed-failures = 0, the job running on a worker that is killed
    is recorded as failed with the one-line reason, the others finish, and a
    rerun renders exactly the failed ones."""
    from mitsuba_pbrdf.batch.runner import run_sweep

    sweep = load_sweep(write_sweep(tmp_path, TINY.replace("spp = 4", "spp = 256")
                                   + "sigma = [0.05, 0.1, 0.15, 0.2]\n"))
    killed = []

    def killer():
        deadline = time.time() + 120
        while time.time() < deadline:
            workers = _worker_processes()
            if len(workers) == 2 and os.path.isdir(sweep.out) \
                    and list(Path(sweep.out).glob("*.exr")):
                os.kill(workers[0], signal.SIGKILL)
                killed.append(workers[0])
                return
            time.sleep(0.05)

    thread = threading.Thread(target=killer, daemon=True)
    thread.start()
    summary = run_sweep(sweep, workers=2, drjit_threads=2, progress=False, allowed_failures=0)
    thread.join(5)
    assert killed
    rows = list(read_manifest(sweep.manifest).values())
    failed = [r for r in rows if r["status"] == "failed"]
    # the job the worker ran fails; at a job boundary also the one just sent to it
    assert summary.failed == len(failed) <= 2 and summary.done + summary.failed == 4
    for row in failed:  # none if the worker died between two jobs
        assert "worker running it died" in row["error"] and "\n" not in row["error"]
    for row in rows:
        if row["status"] == "done":
            assert read_stokes_exr(os.path.join(sweep.out, row["file"])).stokes.shape[0] == 16
    rerun = run_sweep(sweep, workers=1, drjit_threads=2, progress=False)
    assert (rerun.skipped, rerun.done, rerun.failed) == (4 - len(failed), len(failed), 0)
