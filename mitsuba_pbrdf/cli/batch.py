"""``pbrdf batch``: run a sweep file's renders on Dask (docs/batch.md).

The whole sweep is checked before any worker starts (:func:`~mitsuba_pbrdf.batch.sweep.load_sweep`).
Jobs already finished are skipped; the manifest ``OUT/manifest.csv`` is
written atomically by this process only. Exit status: 0 when every job is
done, 2 when some failed (the first failure on one line; the manifest has
them all), 130 on Ctrl-C (the manifest records what finished; with
``--slurm`` the worker jobs it submitted are cancelled)."""

from __future__ import annotations

import sys

from ..interrupts import release
from .batch_slurm import slurm_arguments, slurm_settings
from .arguments import positive_int, progress_options, require_file, show_progress
from .errors import PROG, CliError


def run(args) -> int:
    """``pbrdf batch``."""
    from ..batch.runner import run_sweep
    from ..batch.sweep import load_sweep

    require_file(args.sweep, "sweep file")
    positive_int("--workers", args.workers)
    if args.drjit_threads is not None and args.drjit_threads < 2:
        raise CliError(f"--drjit-threads must be at least 2 (Mitsuba 3.9.1 hangs loading an "
                       f"envmap with one thread), got {args.drjit_threads}")
    sweep = load_sweep(args.sweep)
    try:
        import distributed  # noqa: F401
    except ImportError:
        raise CliError("pbrdf batch needs Dask, a dependency of the package that is "
                       "missing here: pip install 'dask[distributed]'") from None
    slurm = slurm_settings(args, sweep)
    release()  # checked: Ctrl-C from here on stops the sweep (mitsuba_pbrdf.interrupts)

    summary = run_sweep(sweep, workers=args.workers, scheduler=args.scheduler,
                        drjit_threads=args.drjit_threads, progress=show_progress(args),
                        slurm=slurm)
    print(f"{PROG} batch: {summary.line()}")
    sys.stdout.flush()
    if summary.failed:
        more = f" (and {summary.failed - 1} more)" if summary.failed > 1 else ""
        raise CliError(f"{summary.failed} of {summary.jobs} jobs failed; first: "
                       f"{summary.failures[0]}{more}; see {summary.manifest}")
    return 0


def add_parser(subparsers):
    b = subparsers.add_parser(
        "batch", help="render a sweep file's parameter grid on Dask (local or a cluster)",
        description="Render every combination of a sweep file's [params] on Dask workers: one "
                    "Stokes EXR per job (and optional AOVs) in the sweep's out folder, and "
                    "out/manifest.csv. Finished jobs are skipped on a rerun; failed and "
                    "missing ones run again. See docs/batch.md.")
    b.add_argument("sweep", metavar="SWEEP.toml", help="sweep file (TOML)")
    where = b.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int, default=None, metavar="N",
                       help="worker processes of the local cluster (default: one per 2 cores, "
                            "1 to 4)")
    where.add_argument("--scheduler", default=None, metavar="ADDRESS",
                       help="run on an existing Dask scheduler (e.g. tcp://node:8786) instead "
                            "of a local cluster")
    where.add_argument("--slurm", action="store_true",
                       help="run the workers as Slurm jobs (dask-jobqueue); see the Slurm "
                            "options below and the sweep file's [slurm] table")
    b.add_argument("--drjit-threads", type=int, default=None, metavar="N",
                   help="Dr.Jit threads per worker (default: local cluster: the cores shared "
                        "out between the workers; --scheduler: the workers' own setting; not "
                        "with --slurm, where each job's cores decide)")
    slurm_arguments(b)
    progress_options(b)
    b.set_defaults(func=run)
