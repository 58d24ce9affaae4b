"""The Slurm options of ``pbrdf batch`` (``--slurm``, docs/batch.md): their
arguments, and the checked settings made of them and the sweep file's
``[slurm]`` table (the command line wins)."""

from __future__ import annotations

from .errors import CliError

__all__ = ["slurm_arguments", "slurm_settings"]

#: (option, key of [slurm] and SlurmOptions)
OPTIONS = (("--jobs", "jobs"), ("--partition", "partition"), ("--cores", "cores"),
           ("--memory", "memory"), ("--walltime", "walltime"), ("--sbatch", "sbatch"),
           ("--start-timeout", "start_timeout"), ("--max-resubmissions", "max_resubmissions"))


def slurm_arguments(parser):
    """Add the Slurm options to the ``pbrdf batch`` *parser*."""
    g = parser.add_argument_group("Slurm (with --slurm; defaults from the sweep's [slurm] table)")
    g.add_argument("--jobs", type=int, default=None, metavar="N",
                   help="worker jobs, each one Dask worker rendering one job at a time "
                        "(default 2)")
    g.add_argument("--partition", default=None, metavar="NAME",
                   help="Slurm partition (default: the cluster's default partition)")
    g.add_argument("--cores", type=int, default=None, metavar="N",
                   help="cores per worker job (--cpus-per-task), used by Dr.Jit (default 4)")
    g.add_argument("--memory", default=None, metavar="SIZE",
                   help="memory per worker job, e.g. 8GB (default 4GB)")
    g.add_argument("--walltime", default=None, metavar="TIME",
                   help="walltime per worker job, e.g. 02:00:00 (default 01:00:00); a job "
                        "that runs out is replaced and its render runs again")
    g.add_argument("--sbatch", action="append", default=None, metavar="OPTION",
                   help="extra sbatch directive for the worker jobs, repeatable, e.g. "
                        "--sbatch=--account=lab --sbatch=--qos=short")
    g.add_argument("--start-timeout", type=float, default=None, metavar="S",
                   help="give up when no worker job runs after S seconds (default 300)")
    g.add_argument("--max-resubmissions", type=int, default=None, metavar="N",
                   help="replace a lost worker job at most N times with no render done in "
                        "between, then stop the sweep with the reason (default 5)")


def slurm_settings(args, sweep):
    """The checked :class:`~mitsuba_pbrdf.batch.slurm_options.SlurmOptions`
    with ``--slurm`` (None without; a Slurm option without ``--slurm`` is an
    error). Raises :class:`CliError` with one line."""
    from ..batch.slurm_options import SlurmError, slurm_options

    given = {key: getattr(args, option[2:].replace("-", "_")) for option, key in OPTIONS}
    if not args.slurm:
        used = [option for option, key in OPTIONS if given[key] is not None]
        if used:
            raise CliError(f"{used[0]} is a Slurm option: add --slurm")
        return None
    if args.drjit_threads is not None:
        raise CliError("--drjit-threads does not go with --slurm: each worker's Dr.Jit "
                       "threads are its job's cores (--cores)")
    from ..batch.slurm import slurm_cluster_class

    if given["sbatch"] is not None:
        given["sbatch"] = tuple(given["sbatch"])
    try:
        options = slurm_options(sweep.slurm, where=f"{sweep.path}: ", **given)
        slurm_cluster_class()  # dask-jobqueue is installed
    except SlurmError as e:
        raise CliError(str(e)) from None
    return options
