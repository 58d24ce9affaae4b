"""Throughput of ``pbrdf batch`` on this machine: renders per minute of one
sweep with 1 and 2 local Dask workers, Dask's overhead per job against a
plain in-process loop over the same jobs, and the peak memory (RSS) of each
worker. Writes ``batch.md`` (default: next to this script) and prints it.

    python benchmarks/batch_throughput.py            # 12 jobs, 96 x 72 px, 32 spp, 3 repeats
    python benchmarks/batch_throughput.py --quick    # 4 tiny jobs, a smoke run

Every configuration first renders the whole sweep once (warm-up: a worker's
first job imports Mitsuba, and each material compiles kernels of its own, from
Dr.Jit's on-disk cache once one configuration has filled it; those seconds are
reported apart), then renders it again into fresh folders, ``--repeats`` times,
interleaved between the configurations (the machine may be shared: medians). Each job renders the gallery
sphere through the same function (:func:`mitsuba_pbrdf.batch.job.run_job`),
so the difference between the loop and 1 worker is what Dask adds: task
submission, scheduling, result transfer, the manifest and the progress.
"""

from __future__ import annotations

import contextlib
import os
import resource
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(ROOT))

from mitsuba_pbrdf.batch.cluster import available_cores, connect  # noqa: E402
from mitsuba_pbrdf.batch.job import JobTask, run_job, set_drjit_threads  # noqa: E402
from mitsuba_pbrdf.batch.runner import run_sweep  # noqa: E402
from mitsuba_pbrdf.batch.sweep import load_sweep  # noqa: E402
from proof.batch_report import bench_parser, busy_seconds, command_line  # noqa: E402
from proof.batch_report import write_batch_md  # noqa: E402

SPHERE = ROOT / "scenes" / "gallery" / "sphere.xml"
MATERIALS = ["Al", "Cu", "Au", "Ag"]


def write_sweep(folder: Path, name: str, jobs: int, spp: int, width: int, out: str) -> Path:
    sigmas = [round(0.05 + 0.05 * i, 2) for i in range(max(1, -(-jobs // len(MATERIALS))))]
    materials = MATERIALS[:min(jobs, len(MATERIALS))]
    path = folder / name
    path.write_text(f'scene = "{SPHERE}"\nspp = {spp}\nout = "{out}"\n[params]\n'
                    f"material = {materials!r}\nsigma = {sigmas!r}\n"
                    f"width = {width}\nheight = {width * 3 // 4}\n".replace("'", '"'))
    return path


def peak_rss_mb() -> float:
    """Peak resident memory of this process (MiB; Linux reports KiB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _task(sweep, job, out):
    return JobTask(name=job.name, scene=sweep.scene, params=dict(job.params), seed=job.seed,
                   spp=sweep.spp, variant=sweep.variant, out=out)


def plain_loop(sweep, out: str, threads: int):
    """The sweep's jobs one after the other in this process: (wall, busy) seconds."""
    t = time.perf_counter()
    busy = 0.0
    for job in sweep.jobs:
        result = run_job(_task(sweep, job, out), threads)
        assert result.status == "done", result.error
        busy += result.seconds
    return time.perf_counter() - t, busy


def on_dask(sweep, address: str, threads: int):
    """The sweep on the cluster at *address*: (wall, busy) seconds."""
    summary = run_sweep(sweep, scheduler=address, drjit_threads=threads, progress=False)
    return summary.seconds, busy_seconds(summary, sweep)


def worker_rss(client) -> list:
    """Peak RSS of each worker process (MiB)."""
    rss = client.run(lambda: resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0)
    return sorted(rss.values())


def main(argv=None) -> int:
    parser = bench_parser(__doc__.split("\n\n")[0], "4 jobs, 32 x 24 px, 4 spp, 1 repeat", HERE)
    args = parser.parse_args(argv)
    if args.quick:
        args.jobs, args.spp, args.width, args.repeats = 4, 4, 32, 1

    folder = Path(tempfile.mkdtemp(prefix="pbrdf-batch-bench-"))
    cores = available_cores()
    threads = max(2, cores)
    set_drjit_threads(threads)
    load = [os.getloadavg()[0]]
    labels = ["plain loop (1 process)", "Dask, 1 worker", "Dask, 2 workers"]
    walls = {label: [] for label in labels}
    idle = {label: [] for label in labels}
    info = {}

    def sweep_for(tag: str):
        return load_sweep(write_sweep(folder, f"{tag}.toml", args.jobs, args.spp, args.width, tag))

    try:
        with contextlib.ExitStack() as stack:
            clusters = {}
            for workers, label in ((1, labels[1]), (2, labels[2])):
                t = time.perf_counter()
                client, thr = stack.enter_context(connect(workers=workers))
                clusters[label] = (client.scheduler.address, thr, client, workers)
                info[label] = {"start": time.perf_counter() - t, "threads": thr}
            info[labels[0]] = {"start": 0.0, "threads": threads}
            # warm-up: every configuration renders the sweep once (imports, kernels)
            for label in labels:
                sweep = sweep_for(f"warm{labels.index(label)}")
                t = time.perf_counter()
                if label == labels[0]:
                    plain_loop(sweep, sweep.out, threads)
                else:
                    on_dask(sweep, *clusters[label][:2])
                info[label]["warm"] = time.perf_counter() - t
            # timed: interleaved repeats, each into a fresh folder
            for repeat in range(args.repeats):
                for label in labels:
                    sweep = sweep_for(f"r{repeat}c{labels.index(label)}")
                    if label == labels[0]:
                        wall, busy = plain_loop(sweep, sweep.out, threads)
                        workers = 1
                    else:
                        address, thr, _, workers = clusters[label]
                        wall, busy = on_dask(sweep, address, thr)
                    walls[label].append(wall)
                    idle[label].append(wall - busy / workers)
            for label in labels[1:]:
                info[label]["rss"] = worker_rss(clusters[label][2])
            info[labels[0]]["rss"] = [peak_rss_mb()]
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    load.append(os.getloadavg()[0])

    n = args.jobs
    loop = statistics.median(walls[labels[0]]) / n
    lines = [
        "# `pbrdf batch` throughput",
        "",
        command_line("batch_throughput.py", args.quick, cores, load) + "): "
        f"{n} jobs of the gallery sphere, {args.width} x {args.width * 3 // 4} px, {args.spp} "
        "spp, variant `llvm_ad_spectral_polarized`. Each configuration first renders the sweep "
        "once (warm-up: imports, kernel compilation or loading from Dr.Jit's on-disk cache), "
        f"then {args.repeats} timed runs of the same sweep into fresh folders, interleaved "
        "between the configurations (loop, 1 worker, 2 workers, loop, ...); medians, with the "
        "range of the runs.",
        "",
        "| configuration | Dr.Jit threads per process | cluster start (s) | warm-up (s) | "
        "sweep wall (s), median [range] | renders / min | s / job | vs loop (s / job) | "
        "not rendering (s / job) | peak RSS per process (MiB) |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for label in labels:
        w = statistics.median(walls[label])
        lines.append(
            f"| {label} | {info[label]['threads']} | {info[label]['start']:.1f} | "
            f"{info[label]['warm']:.1f} | {w:.1f} [{min(walls[label]):.1f}, "
            f"{max(walls[label]):.1f}] | {60.0 * n / w:.1f} | {w / n:.3f} | {w / n - loop:+.3f} "
            f"| {statistics.median(idle[label]) / n:.3f} | "
            f"{', '.join(f'{m:.0f}' for m in info[label]['rss'])} |")
    lines += [
        "",
        "`vs loop`: seconds per job more than the plain loop. `not rendering`: the sweep's "
        "wall-clock time minus the time spent inside jobs (divided by the workers), per job: "
        "with 1 worker, Dask's own overhead per job (submission, scheduling, result transfer, "
        "the manifest), measured directly. Peak RSS: each worker process's maximum resident "
        "memory over the whole run; the plain loop's is the benchmark process's own (it also "
        "holds Dask and both clusters' scheduler).",
        "",
    ]
    write_batch_md(args.out, "\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
