"""``out/manifest.csv``: one row per job of a sweep, what a rerun trusts.

Columns: ``job``, one column per sweep parameter (its value as ``-D`` gets
it), ``seed``, ``spp``, ``status`` (``done``, ``failed`` or ``pending``),
``seconds`` (wall clock on the worker), ``file`` (the Stokes EXR, relative to
the output folder), ``aov`` (the AOV EXR, if asked), ``polcam`` (the polarization-camera files,
``;``-separated, if asked), ``error`` (one line, for
failed jobs), ``note`` (one line: why a job was run again, e.g. its worker's
Slurm job was cancelled or reached its walltime).

Only the process that runs the sweep writes the manifest, always whole and
atomically (:func:`mitsuba_pbrdf.outputs.atomic_path`), so a reader or an
interrupted sweep never leaves a half-written table. A job counts as finished
(:func:`is_finished`) only when its row says ``done`` with the job's seed (and
spp, if the sweep sets it) and its files exist and read as valid EXRs.
"""

from __future__ import annotations

import csv
import io
import os
from typing import Dict, Iterable, List, Optional

from .sweep import Job, Sweep

__all__ = ["columns", "read_manifest", "write_manifest", "is_finished", "job_row"]

def columns(sweep: Sweep) -> List[str]:
    """The manifest's header for *sweep*."""
    return ["job", *sweep.param_names, "seed", "spp", "status", "seconds", "file", "aov", "polcam",
            "error", "note"]


def read_manifest(path) -> Dict[str, Dict[str, str]]:
    """``{job name: row}`` from an existing manifest ({} if there is none).
    Raises ``ValueError`` naming the file when it is not a manifest."""
    path = os.fspath(path)
    if not os.path.exists(path):
        return {}
    try:
        with open(path, newline="", encoding="utf-8") as f:
            reader = csv.DictReader(f)
            if reader.fieldnames is None:
                return {}
            if "job" not in reader.fieldnames or "status" not in reader.fieldnames:
                raise ValueError(f"{path}: not a sweep manifest (no 'job' and 'status' columns); "
                                 "move it away or choose another out folder")
            return {row["job"]: row for row in reader if row.get("job")}
    except (UnicodeDecodeError, csv.Error) as e:
        raise ValueError(f"{path}: not a readable manifest ({e})") from None


def job_row(job: Job, status: str = "pending", **fields) -> Dict[str, str]:
    """A manifest row for *job* (parameters and seed filled in)."""
    row = {"job": job.name, **job.params, "seed": str(job.seed), "status": status}
    row.update({k: ("" if v is None else str(v)) for k, v in fields.items()})
    return row


def write_manifest(sweep: Sweep, rows: Dict[str, Dict[str, str]],
                   extra: Iterable[Dict[str, str]] = ()) -> str:
    """Write the manifest of *sweep* (a row per job, in the sweep's order;
    jobs without a row are ``pending``) atomically; *extra* rows (e.g. jobs of
    an earlier version of the sweep) follow. Returns the path."""
    from ..outputs import write_text

    header = columns(sweep)
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=header, extrasaction="ignore", restval="",
                            lineterminator="\n")
    writer.writeheader()
    for job in sweep.jobs:
        writer.writerow(rows.get(job.name) or job_row(job))
    for row in extra:
        writer.writerow(row)
    return write_text(sweep.manifest, buffer.getvalue())


def _valid_exr(path: str, stokes: bool) -> bool:
    if not os.path.isfile(path):
        return False
    try:
        from ..stokes.exr import read_exr_channels, read_stokes_exr

        (read_stokes_exr if stokes else read_exr_channels)(path)  # ValueError if damaged
    except Exception:
        return False
    return True


def is_finished(sweep: Sweep, job: Job, row: Optional[Dict[str, str]]) -> bool:
    """Whether *job* need not run again: its row says ``done`` with the job's
    seed and parameters (and spp, if the sweep sets it), and its files exist
    and read as valid EXRs."""
    if not row or row.get("status") != "done" or row.get("seed") != str(job.seed):
        return False
    if any(row.get(k) != v for k, v in job.params.items()):
        return False
    if sweep.spp is not None and row.get("spp") != str(sweep.spp):
        return False
    if not row.get("file") or not _valid_exr(os.path.join(sweep.out, row["file"]), True):
        return False
    if "aov" in sweep.outputs:
        if not row.get("aov") or not _valid_exr(os.path.join(sweep.out, row["aov"]), False):
            return False
    if "polcam" in sweep.outputs:
        names = [n for n in row.get("polcam", "").split(";") if n]
        if not names or not all(_valid_exr(os.path.join(sweep.out, n), False)
                                if n.endswith(".exr") else os.path.isfile(os.path.join(sweep.out, n))
                                for n in names):
            return False
    return True
