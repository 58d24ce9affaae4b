"""Splitting a render's samples into passes, and the seeds of the passes.

A pass is one ``mi.render`` (or integrator) call with its own seed; the pass
images are averaged with weights proportional to their samples per pixel, so
each pass is an independent estimate of the same pixel values and so is the
average. Passes bound the time between two progress updates and the time
Ctrl-C waits (Dr.Jit returns to Python only between kernels, so a render
stops at the end of a pass), bound the memory of a render (Dr.Jit traces a
pass's samples as one wavefront), and split reverse-mode differentiation
(:mod:`mitsuba_pbrdf.inverse`). One policy serves every caller:

* :func:`plan_passes`: automatic passes hold at most a budget of samples
  (pixels x spp) sized to about a second of rendering
  (:func:`samples_per_pass`: one budget for the LLVM backend, one for CUDA),
  in passes of a power-of-two spp (which share one compiled kernel with
  single-pass renders of a power-of-two spp) and a last pass with the rest;
  a render within the budget is one pass. Given a count, passes are equal
  (sizes differ by at most one sample);
* :func:`pass_seeds`: the first pass uses the caller's seed, the others steps
  of the 32-bit golden ratio, so one pass is exactly ``mi.render(seed=seed)``;
  the renders of an optimization are numbered as the passes of one long
  render (:mod:`mitsuba_pbrdf.inverse.driver`), so none shares a seed;
* :func:`derivative_seed`: the seed ``mi.render`` gives the derivative
  (adjoint) render of a pass, ``sample_tea_32(seed, 1)[0]``, so that the
  gradient of a non-linear loss is unbiased.

A render split into several passes is a different, equally valid, noise
realization of the same seed: Mitsuba seeds each sample from the seed and the
sample's index within its pass. The automatic plan depends on the image size,
the spp and the backend's budget, never on the machine's number of cores, so
the same seed gives the same image on every machine of the same backend (and
a given pass count, ``passes=N`` or ``--passes N``, everywhere). Splitting
costs one trace of the integrator per pass, a few per cent of a pass on a
small machine (docs/cli.md has the measurement); on machines with many cores a
pass renders faster, so that share grows (``passes=1`` avoids it).
Pure Python (no Mitsuba needed).
"""

from __future__ import annotations

from typing import Optional

__all__ = ["SAMPLES_PER_PASS", "SAMPLES_PER_GPU_PASS", "samples_per_pass", "plan_passes",
           "pass_seeds", "derivative_seed"]

#: Budget of an automatic pass of Dr.Jit's LLVM backend: 2^21 samples, large
#: enough that the fixed cost of a pass stays a few per cent of its render
#: (docs/cli.md has the measurement). The same on every machine, so that a
#: seed gives the same image whatever the number of cores.
SAMPLES_PER_PASS = 1 << 21
#: Budget of an automatic pass on a CUDA GPU (which also bounds its memory).
SAMPLES_PER_GPU_PASS = 1 << 24


def samples_per_pass(backend: str) -> int:
    """The budget of an automatic pass: :data:`SAMPLES_PER_GPU_PASS` for the
    ``cuda`` backend, else :data:`SAMPLES_PER_PASS`."""
    return SAMPLES_PER_GPU_PASS if backend == "cuda" else SAMPLES_PER_PASS


def plan_passes(spp: int, passes: Optional[int] = None, pixels: int = 0,
                budget: int = SAMPLES_PER_PASS) -> list:
    """Samples per pixel of each pass, summing to *spp*.

    *passes* None chooses automatically: one pass if ``pixels * spp`` is
    within *budget* samples, else passes of the largest power-of-two spp
    whose samples fit the budget (at least 1 spp) and a last pass with what
    remains. Given, *passes* is capped at *spp* and the sizes differ by at most
    one sample.
    """
    spp = int(spp)
    if spp < 1:
        raise ValueError(f"spp must be at least 1, got {spp}")
    if passes is None:
        pixels = max(1, int(pixels))
        if pixels * spp <= budget:
            return [spp]
        size = 1 << max(0, (int(budget) // pixels).bit_length() - 1)
        full, rest = divmod(spp, size)
        return [size] * full + ([rest] if rest else [])
    passes = max(1, min(int(passes), spp))
    base, extra = divmod(spp, passes)
    return [base + 1] * extra + [base] * (passes - extra)


def pass_seeds(seed: int, n: int, first: int = 0) -> list:
    """Sampler seeds of *n* passes: *seed* for the first, then steps of the
    32-bit golden ratio (all distinct, and distinct from the seeds of nearby
    base seeds' first passes). *first*: the seeds of passes *first* to
    ``first + n - 1`` of the same sequence (an optimizer's iterations take
    consecutive blocks of it: :func:`mitsuba_pbrdf.inverse.driver.iteration_seeds`)."""
    return [(int(seed) + k * 0x9E3779B9) & 0xFFFFFFFF for k in range(int(first), int(first) + n)]


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
