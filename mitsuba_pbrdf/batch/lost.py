"""Which of a sweep's jobs lost their worker while running, and why: read
from the Dask scheduler's event log (its ``remove-worker`` events name the
tasks the worker was processing), so that the manifest's ``note`` column
says that a job was run again and what happened to its worker
(docs/batch.md). Works on any scheduler; the reason comes from the cluster
(``explain``: a local worker process died, a Slurm job was cancelled or
reached its walltime, :mod:`mitsuba_pbrdf.batch.slurm`)."""

from __future__ import annotations

from typing import Callable, Dict, Iterable, List

__all__ = ["lost_workers", "notes", "local_explain", "remote_explain"]


def lost_workers(client, keys: Iterable[str]) -> Dict[str, List[str]]:
    """``{task key: [addresses of the workers that left while processing it]}``
    for the tasks *keys* (in the order the workers left)."""
    wanted = set(keys)
    out: Dict[str, List[str]] = {}
    for _, msg in client.get_events("all"):
        if not isinstance(msg, dict) or msg.get("action") != "remove-worker":
            continue
        for key in msg.get("processing-tasks", ()):
            if key in wanted:
                out.setdefault(key, []).append(msg.get("worker", "?"))
    return out


def local_explain(addresses) -> Dict[str, str]:
    return {a: "its worker process died (killed, crashed or out of memory)" for a in addresses}


def remote_explain(addresses) -> Dict[str, str]:
    return {a: f"its worker {a} left the cluster" for a in addresses}


def notes(client, keys: Dict[str, str],
          explain: Callable[[List[str]], Dict[str, str]]) -> Dict[str, str]:
    """``{job name: note}`` for the jobs whose worker left while running them;
    *keys* maps task keys to job names."""
    lost = lost_workers(client, keys)
    if not lost:
        return {}
    why = explain(sorted({a for addresses in lost.values() for a in addresses}))
    return {keys[key]: "run again: " + "; then ".join(why.get(a, f"worker {a} left")
                                                      for a in addresses)
            for key, addresses in lost.items()}
