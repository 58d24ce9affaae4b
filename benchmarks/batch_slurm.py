"""``pbrdf batch --slurm`` against the local cluster: the same 12-job sweep
run whole (cluster start included, as a user runs ``pbrdf batch``) on 2
local worker processes and on 2 Slurm worker jobs of 1 core, interleaved,
medians. Slurm is the single-node Slurm of the tests
(``proof/single_node_slurm.py``, started and stopped here; needs root and
``.ci/install-slurm.sh``), or the one ``SLURM_CONF`` names with ``--running``.
Writes the section ``## On Slurm`` of ``batch.md`` (default: next to this
script; the rest of the file, written by batch_throughput.py, is kept) and
prints it.

    python benchmarks/batch_slurm.py            # 12 jobs, 96 x 72 px, 32 spp, 3 repeats
    python benchmarks/batch_slurm.py --quick    # 2 tiny jobs, 1 repeat, no warm-up: a smoke run

Both configurations give each worker 2 Dr.Jit threads (local: the 2 cores
shared out, at least 2; Slurm: the job's 1 core, at least 2), so the
difference is what Slurm adds: ``sbatch``, the job's start, a worker started
from a job script, the worker jobs' cancellation at the end.
"""

from __future__ import annotations

import os
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path[:0] = [str(ROOT), str(HERE)]

from batch_throughput import write_sweep  # noqa: E402

from mitsuba_pbrdf.batch.runner import run_sweep  # noqa: E402
from mitsuba_pbrdf.batch.slurm_options import SlurmOptions  # noqa: E402
from mitsuba_pbrdf.batch.sweep import load_sweep  # noqa: E402
from proof.batch_report import (SLURM_SECTION, bench_parser, busy_seconds,  # noqa: E402
                                command_line, write_batch_md)

LABELS = ("local cluster, 2 workers", "Slurm, 2 worker jobs of 1 core")


def one_run(label: str, sweep) -> dict:
    """Run the whole sweep (cluster start included): wall and busy seconds."""
    t = time.perf_counter()
    if label == LABELS[0]:
        summary = run_sweep(sweep, workers=2, progress=False)
    else:
        summary = run_sweep(sweep, slurm=SlurmOptions(jobs=2, cores=1, memory="2GB",
                                                      walltime="00:30:00"), progress=False)
    wall = time.perf_counter() - t
    return {"wall": wall, "busy": busy_seconds(summary, sweep)}


def main(argv=None) -> int:
    parser = bench_parser(__doc__.split("\n\n")[0],
                          "2 jobs, 16 x 12 px, 4 spp, 1 repeat, no warm-up", HERE)
    parser.add_argument("--running", action="store_true",
                        help="use the Slurm that SLURM_CONF names instead of starting one")
    args = parser.parse_args(argv)
    warm = not args.quick
    if args.quick:
        args.jobs, args.spp, args.width, args.repeats = 2, 4, 16, 1

    node = None
    if not args.running:
        from proof.single_node_slurm import SingleNodeSlurm, missing

        why = missing()
        if why:
            print(f"batch_slurm.py: {why}", file=sys.stderr)
            return 2
        node = SingleNodeSlurm().start()
        os.environ["SLURM_CONF"] = node.conf
    folder = Path(tempfile.mkdtemp(prefix="pbrdf-slurm-bench-"))
    runs = {label: [] for label in LABELS}
    load = [os.getloadavg()[0]]
    try:
        def sweep_for(tag):
            return load_sweep(write_sweep(folder, f"{tag}.toml", args.jobs, args.spp,
                                          args.width, tag))

        warmup = {label: one_run(label, sweep_for(f"warm{i}"))["wall"] if warm else 0.0
                  for i, label in enumerate(LABELS)}
        for repeat in range(args.repeats):
            for i, label in enumerate(LABELS):
                runs[label].append(one_run(label, sweep_for(f"r{repeat}c{i}")))
    finally:
        shutil.rmtree(folder, ignore_errors=True)
        if node is not None:
            node.stop()
    load.append(os.getloadavg()[0])

    n = args.jobs
    walls = {label: [r["wall"] for r in runs[label]] for label in LABELS}
    local = statistics.median(walls[LABELS[0]])
    lines = [
        SLURM_SECTION, "",
        command_line("batch_slurm.py", args.quick, os.cpu_count(), load) + "; "
        "single-node Slurm 22.05 of the tests): the same sweep of "
        f"{n} jobs ({args.width} x {args.width * 3 // 4} px, {args.spp} spp) run whole, "
        "cluster start included, as `pbrdf batch` runs it: on a local cluster of 2 worker "
        "processes and on 2 Slurm worker jobs of 1 core (2 Dr.Jit threads per worker in "
        f"both). {'After one warm-up run of each, ' if warm else ''}{args.repeats} runs of "
        "each, interleaved; medians [range].",
        "",
        "| configuration | warm-up (s) | sweep wall (s), median [range] | renders / min | "
        "s / job | vs local (s / job) | not rendering (s / job) |",
        "|---|---|---|---|---|---|---|",
    ]
    for label in LABELS:
        w = statistics.median(walls[label])
        idle = statistics.median(r["wall"] - r["busy"] / 2 for r in runs[label]) / n
        lines.append(f"| {label} | {warmup[label]:.1f} | {w:.1f} [{min(walls[label]):.1f}, "
                     f"{max(walls[label]):.1f}] | {60.0 * n / w:.1f} | {w / n:.3f} | "
                     f"{(w - local) / n:+.3f} | {idle:.3f} |")
    lines += [
        "",
        "`vs local`: seconds per job more than the local cluster (the sweep's whole wall "
        "clock, so the cluster start is spread over the jobs). `not rendering`: the wall clock "
        "minus the time spent inside jobs divided by the 2 workers, per job: starting the "
        "cluster and its workers (Slurm: `sbatch`, the job start, the worker's imports), "
        "scheduling, the manifest, the worker jobs' cancellation.",
        "",
    ]
    write_batch_md(args.out, "\n".join(lines), slurm=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
