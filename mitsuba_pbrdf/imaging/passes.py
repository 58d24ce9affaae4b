"""Splitting a render's samples into passes, and the seeds of the passes.

A pass is one ``mi.render`` (or integrator) call with its own seed; the pass
images are averaged with weights proportional to their samples per pixel, so
each pass is an independent estimate of the same pixel values and so is the
average. Passes bound the memory of a render (Dr.Jit traces a pass's samples
as one wavefront), drive progress bars, and split reverse-mode
differentiation (:mod:`mitsuba_pbrdf.inverse`). One policy serves every
caller:

* :func:`plan_passes`: equal passes (sizes differ by at most one sample);
* :func:`pass_seeds`: the first pass uses the caller's seed, the others steps
  of the 32-bit golden ratio, so one pass is exactly ``mi.render(seed=seed)``;
* :func:`derivative_seed`: the seed ``mi.render`` gives the derivative
  (adjoint) render of a pass, ``sample_tea_32(seed, 1)[0]``, so that the
  gradient of a non-linear loss is unbiased.

A render split into several passes is a different, equally valid, noise
realization of the same seed. Pure Python (no Mitsuba needed).
"""

from __future__ import annotations

from typing import Optional

__all__ = ["SAMPLES_PER_PASS", "MAX_AUTO_PASSES", "plan_passes", "pass_seeds", "derivative_seed"]

#: Automatic passes hold at least this many samples (pixels x spp) each:
#: 2^23, about 2 s of rendering per pass for scenes/default.xml on 2 cores.
SAMPLES_PER_PASS = 1 << 23
#: At most this many automatic passes.
MAX_AUTO_PASSES = 64


def plan_passes(spp: int, passes: Optional[int] = None, pixels: int = 0) -> list:
    """Samples per pixel of each pass, summing to *spp*.

    *passes* None chooses automatically: one pass unless the render has more
    than 2 x :data:`SAMPLES_PER_PASS` samples (``pixels * spp``), else about
    ``pixels * spp / SAMPLES_PER_PASS`` passes (at most :data:`MAX_AUTO_PASSES`),
    preferring a count that divides *spp* so that all passes have the same
    size (one compiled kernel). Given, *passes* is capped at *spp*. Sizes
    differ by at most one sample.
    """
    spp = int(spp)
    if spp < 1:
        raise ValueError(f"spp must be at least 1, got {spp}")
    if passes is None:
        total = int(pixels) * spp
        if total <= 2 * SAMPLES_PER_PASS:
            passes = 1
        else:
            target = min(max(2, round(total / SAMPLES_PER_PASS)), MAX_AUTO_PASSES, spp)
            divisors = [p for p in range(max(2, target // 2), min(spp, 2 * target) + 1)
                        if spp % p == 0]
            passes = min(divisors, key=lambda p: abs(p - target)) if divisors else target
    passes = max(1, min(int(passes), spp))
    base, extra = divmod(spp, passes)
    return [base + 1] * extra + [base] * (passes - extra)


def pass_seeds(seed: int, n: int) -> list:
    """Sampler seeds of *n* passes: *seed* for the first, then steps of the
    32-bit golden ratio (all distinct, and distinct from the seeds of nearby
    base seeds' first passes)."""
    return [(int(seed) + k * 0x9E3779B9) & 0xFFFFFFFF for k in range(n)]


def derivative_seed(seed: int) -> int:
    """The seed of the derivative render that ``mi.render`` pairs with the
    primal seed *seed*: the first output of Mitsuba's 4-round TEA hash
    ``sample_tea_32(seed, 1)``."""
    return _tea(int(seed) & 0xFFFFFFFF, 1)[0]


def _tea(v0: int, v1: int, rounds: int = 4):
    """Tiny Encryption Algorithm as Mitsuba's ``sample_tea_32`` (32-bit words)."""
    mask, total = 0xFFFFFFFF, 0
    for _ in range(rounds):
        total = (total + 0x9E3779B9) & mask
        v0 = (v0 + ((((v1 << 4) & mask) + 0xA341316C) ^ ((v1 + total) & mask)
                    ^ ((v1 >> 5) + 0xC8013EA4))) & mask
        v1 = (v1 + ((((v0 << 4) & mask) + 0xAD90777D) ^ ((v0 + total) & mask)
                    ^ ((v0 >> 5) + 0x7E95761E))) & mask
    return v0, v1
