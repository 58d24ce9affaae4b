"""What ``stokes_prb`` writes and where it runs: its film channels, its depth
limit and the variants it needs. Plain Python; no variant needed."""

from __future__ import annotations

__all__ = ["STOKES_CHANNELS", "MAX_DEPTH_LIMIT", "usable_variant"]

#: The Stokes channels ``stokes`` adds after R, G, B (and A).
STOKES_CHANNELS = [f"S{i}.{c}" for i in range(4) for c in "RGB"]
#: Largest ``max_depth``: each vertex costs ~0.5 kB of local memory per lane.
MAX_DEPTH_LIMIT = 64


def usable_variant(variant):
    """Whether ``stokes_prb`` runs in Mitsuba variant *variant* (a polarized
    JIT variant)."""
    variant = variant or ""
    return "polarized" in variant and not variant.startswith("scalar")
