"""Settings of the Slurm jobs that run a sweep's workers (``pbrdf batch
--slurm``, docs/batch.md): read from the ``[slurm]`` table of a sweep file
and the command line (which wins), checked before anything is submitted.
Imports neither Dask nor Slurm.

One Slurm job runs one Dask worker process that renders one job of the sweep
at a time with ``cores`` Dr.Jit threads (at least 2).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, replace
from typing import Optional, Tuple

from .slurm_keeper import DEFAULT_MAX_RESUBMISSIONS

__all__ = ["SlurmOptions", "SlurmError", "SLURM_KEYS", "parse_walltime", "format_walltime",
           "parse_memory", "slurm_options"]

#: Keys of a sweep file's ``[slurm]`` table (the options without ``--``).
SLURM_KEYS = ("jobs", "partition", "cores", "memory", "walltime", "sbatch", "start_timeout",
              "max_resubmissions")
#: Shortest walltime: Slurm counts time limits in whole minutes, and a worker
#: needs seconds to start and import Mitsuba before its first render.
MIN_WALLTIME_S = 60


class SlurmError(ValueError):
    """Slurm settings or a Slurm cluster that cannot run the sweep (one line)."""


@dataclass(frozen=True)
class SlurmOptions:
    """The worker jobs: how many, where, and what each asks for."""

    jobs: int = 2
    partition: Optional[str] = None  # None: the cluster's default partition
    cores: int = 4  # --cpus-per-task; also the worker's Dr.Jit threads (at least 2)
    memory: str = "4GB"  # --mem, and the Dask worker's memory limit
    walltime: str = "01:00:00"  # -t, as [days-]hours:minutes:seconds
    sbatch: Tuple[str, ...] = ()  # extra '#SBATCH' directives, e.g. '--account=lab'
    start_timeout: float = 300.0  # seconds for the first worker job to start
    #: replacements of a lost worker job with no render done in between, at most
    #: (:mod:`mitsuba_pbrdf.batch.slurm_keeper`)
    max_resubmissions: int = DEFAULT_MAX_RESUBMISSIONS

    @property
    def walltime_s(self) -> int:
        return parse_walltime(self.walltime)


def parse_walltime(text: str) -> int:
    """Seconds of a Slurm time limit: ``minutes``, ``minutes:seconds``,
    ``hours:minutes:seconds``, ``days-hours``, ``days-hours:minutes`` or
    ``days-hours:minutes:seconds``. Raises :class:`SlurmError`."""
    text = str(text).strip()
    m = re.fullmatch(r"(?:(\d+)-)?(\d+)(?::(\d+))?(?::(\d+))?", text)
    if not m:
        raise SlurmError(f"walltime {text!r} is not a Slurm time (e.g. 02:00:00, 90, 1-12:00:00)")
    days, a, b, c = m.groups()
    a, b, c = int(a), None if b is None else int(b), None if c is None else int(c)
    if days is not None:  # days-hours[:minutes[:seconds]]
        seconds = int(days) * 86400 + a * 3600 + (b or 0) * 60 + (c or 0)
        fields = [x for x in (b, c) if x is not None]
    elif c is not None:  # hours:minutes:seconds
        seconds, fields = a * 3600 + b * 60 + c, [b, c]
    elif b is not None:  # minutes:seconds
        seconds, fields = a * 60 + b, [b]
    else:  # minutes
        seconds, fields = a * 60, []
    if any(x >= 60 for x in fields):
        raise SlurmError(f"walltime {text!r}: minutes and seconds must be below 60")
    return seconds


def format_walltime(seconds: int) -> str:
    """``HH:MM:SS`` (hours may exceed 24), rounded up to whole minutes as Slurm does."""
    minutes = math.ceil(seconds / 60)
    return f"{minutes // 60:02d}:{minutes % 60:02d}:00"


def parse_memory(text: str) -> int:
    """Bytes of a memory size such as ``4GB`` or ``500MiB``. Raises :class:`SlurmError`."""
    from dask.utils import parse_bytes

    try:
        value = parse_bytes(str(text))
    except (ValueError, TypeError):
        value = None
    if not value or value < 256 * 2**20:
        raise SlurmError(f"memory {text!r} is not a size of at least 256 MiB (e.g. 4GB)")
    return int(value)


def _check(options: SlurmOptions, where: str) -> SlurmOptions:
    def fail(key, message):
        name = key.replace("_", "-") if where == "--" else key
        raise SlurmError(f"{where}{name}: {message}")

    for key in ("jobs", "cores", "max_resubmissions"):
        value = getattr(options, key)
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            fail(key, f"must be a positive integer, got {value!r}")
    if options.partition is not None and (not isinstance(options.partition, str)
                                          or not re.fullmatch(r"[\w.,-]+", options.partition)):
        fail("partition", f"not a partition name: {options.partition!r}")
    if not isinstance(options.memory, str):
        fail("memory", f"must be a size such as '4GB', got {options.memory!r}")
    try:
        parse_memory(options.memory)
        seconds = parse_walltime(options.walltime)
    except SlurmError as e:
        raise SlurmError(f"{where}{e}") from None
    if seconds < MIN_WALLTIME_S:
        fail("walltime", f"{options.walltime!r} is too short: Slurm counts whole minutes and a "
                         "worker needs seconds to start before it renders; give at least "
                         "00:01:00")
    if not all(isinstance(d, str) and d.startswith("-") and "\n" not in d
               for d in options.sbatch):
        fail("sbatch", f"each directive is one sbatch option such as '--account=lab', got "
                       f"{list(options.sbatch)!r}")
    timeout = options.start_timeout
    if isinstance(timeout, bool) or not isinstance(timeout, (int, float)) \
            or not math.isfinite(timeout) or timeout <= 0:
        fail("start_timeout", f"must be a positive number of seconds, got {timeout!r}")
    return options


def slurm_options(table: Optional[dict] = None, where: str = "", **overrides) -> SlurmOptions:
    """Checked :class:`SlurmOptions` from a sweep's ``[slurm]`` *table* and
    the command line's *overrides* (None: not given). *where* prefixes the
    table's errors (the sweep file). Raises :class:`SlurmError`."""
    table = dict(table or {})
    unknown = [k for k in table if k not in SLURM_KEYS]
    if unknown:
        raise SlurmError(f"{where}slurm: unknown key {unknown[0]!r}; [slurm] has "
                         f"{', '.join(SLURM_KEYS)}")
    if "sbatch" in table:
        if not isinstance(table["sbatch"], list):
            raise SlurmError(f"{where}slurm.sbatch must be a list of sbatch options, got "
                             f"{table['sbatch']!r}")
        table["sbatch"] = tuple(table["sbatch"])
    options = _check(replace(SlurmOptions(), **table), f"{where}slurm." if where else "--")
    given = {k: v for k, v in overrides.items() if v is not None and v != ()}
    if "sbatch" in given:
        given["sbatch"] = options.sbatch + tuple(given["sbatch"])
    return _check(replace(options, **given), "--") if given else options
