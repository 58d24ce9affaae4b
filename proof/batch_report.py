"""What benchmarks/batch_throughput.py and benchmarks/batch_slurm.py share:
their sweep-size options, the seconds spent inside the jobs of a finished
sweep (from its manifest), the line naming the command and the machine, and
writing ``batch.md``, whose ``## On Slurm`` section batch_slurm.py writes and
the rest batch_throughput.py, each keeping the other's part."""

from __future__ import annotations

import argparse
import os
import platform
from pathlib import Path

__all__ = ["SLURM_SECTION", "bench_parser", "busy_seconds", "command_line",
           "write_batch_md"]

#: The heading of batch_slurm.py's section of batch.md.
SLURM_SECTION = "## On Slurm"


def bench_parser(description: str, quick_help: str, out_default) -> argparse.ArgumentParser:
    """The options both benchmarks take: the sweep's size, the repeats,
    ``--quick`` (*quick_help*) and ``--out`` (the folder of batch.md)."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--jobs", type=int, default=12)
    parser.add_argument("--spp", type=int, default=32)
    parser.add_argument("--width", type=int, default=96)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--quick", action="store_true", help=quick_help)
    parser.add_argument("--out", default=str(out_default), help="folder of batch.md")
    return parser


def busy_seconds(summary, sweep) -> float:
    """Seconds spent inside the jobs of *sweep* (the manifest's ``seconds``
    column, summed), once *summary* says that every job was rendered."""
    from mitsuba_pbrdf.batch.manifest import read_manifest

    assert summary.done == len(sweep.jobs), summary.failures
    return sum(float(row["seconds"]) for row in read_manifest(sweep.manifest).values())


def command_line(script: str, quick: bool, cores: int, load) -> str:
    """``\\`python benchmarks/SCRIPT [--quick]\\` on N cores (machine, Python
    version, load average before, after`` (the caller closes the parenthesis)."""
    command = f"python benchmarks/{script}" + (" --quick" if quick else "")
    return (f"`{command}` on {cores} cores ({platform.machine()}, Python "
            f"{platform.python_version()}, load average {load[0]:.1f} before, "
            f"{load[1]:.1f} after")


def write_batch_md(folder, text: str, slurm: bool = False) -> str:
    """Write *text* into ``folder/batch.md`` and print it: as its
    :data:`SLURM_SECTION` (*slurm*; what comes before is kept) or as the rest
    of the file (the Slurm section already there is kept). Returns the file's text."""
    os.makedirs(folder, exist_ok=True)
    path = Path(folder, "batch.md")
    before = path.read_text() if path.exists() else ""
    head, found, section = before.partition(f"\n{SLURM_SECTION}\n")
    if slurm:
        head = head.rstrip("\n")
        whole = (head + "\n\n" if head else "") + text
    else:
        whole = text + (f"\n{SLURM_SECTION}\n{section}" if found else "")
    path.write_text(whole)
    print(text)
    return whole
