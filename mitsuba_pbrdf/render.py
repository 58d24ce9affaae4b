"""Render a Mitsuba scene with the ``pbrdf`` plugin into a :class:`StokesImage`.

::

    from mitsuba_pbrdf.render import render_scene
    image = render_scene("scenes/default.xml", spp=16, params={"width": 160})
    print(image.metadata["time_render_s"])

Long renders run in *passes*: the samples per pixel are split into passes of
equal size with different seeds, and the pass images are averaged with weights
proportional to their sample counts (each pass is an independent estimate of
the same pixel values, so the average is one too). This bounds the memory of a
render (Dr.Jit traces all of a pass's samples as one wavefront) and drives the
progress bar. Each pass costs about 0.15 s of tracing on top of its rendering
time, so passes are only used when each holds at least
:data:`SAMPLES_PER_PASS` samples (pixels × spp).

The default variant is ``cuda_ad_spectral_polarized`` when a CUDA GPU is
usable, else ``llvm_ad_spectral_polarized`` (:func:`default_variant`).

The scene should wrap its integrator in Mitsuba's ``stokes`` integrator (around
``path``, ``direct`` or ``volpath``, not ``prb``, which ignores Mueller frame
rotations) and be rendered in a ``*_polarized`` variant; otherwise the image
has no Stokes channels.
"""

from __future__ import annotations

import logging
import os
import re
import time
from dataclasses import asdict, dataclass
from typing import Mapping, Optional

import numpy as np

from .stokes_io import StokesImage, from_mitsuba

__all__ = [
    "DEFAULT_VARIANT",
    "GPU_VARIANT",
    "SAMPLES_PER_PASS",
    "cuda_available",
    "default_variant",
    "plan_passes",
    "pass_seeds",
    "RenderTimings",
    "UnknownVariantError",
    "SceneLoadError",
    "set_variant",
    "load_scene",
    "render_scene",
    "render_scene_timed",
]

log = logging.getLogger(__name__)

#: The CPU variant: the default where no CUDA GPU can be used.
DEFAULT_VARIANT = "llvm_ad_spectral_polarized"
#: The variant chosen when a CUDA GPU is present and usable.
GPU_VARIANT = "cuda_ad_spectral_polarized"
#: Automatic passes hold at least this many samples (pixels x spp) each:
#: 2^23, about 2 s of rendering per pass for scenes/default.xml on 2 cores.
SAMPLES_PER_PASS = 1 << 23
#: At most this many automatic passes.
MAX_AUTO_PASSES = 64


class UnknownVariantError(ValueError):
    """The requested Mitsuba variant is not in this build, or cannot start here
    (e.g. a ``cuda_*`` variant without a GPU)."""


class SceneLoadError(RuntimeError):
    """Mitsuba could not load the scene (its parser's message, on one line)."""


@dataclass
class RenderTimings:
    """Wall-clock seconds of each stage of :func:`render_scene`.

    ``jit_compile`` and ``kernel_run`` come from Dr.Jit's kernel history (LLVM/CUDA
    variants; 0 in scalar ones): time spent generating and compiling kernels
    (small when they come from Dr.Jit's on-disk cache, ``~/.drjit``) and time
    running them. ``render`` is the whole of ``mi.render`` plus reading the
    result back, so it includes tracing, compiling and running.
    """

    load: float = 0.0
    render: float = 0.0
    jit_compile: float = 0.0
    kernel_run: float = 0.0
    kernels: int = 0
    kernels_cached: int = 0

    def summary(self) -> str:
        """One line: load and render seconds, and the JIT compile / kernel split."""
        s = f"load {self.load:.2f} s, render {self.render:.2f} s"
        if self.kernels:
            s += (
                f" (JIT compile {self.jit_compile:.2f} s, kernels {self.kernel_run:.2f} s; "
                f"{self.kernels} kernels, {self.kernels_cached} from cache)"
            )
        return s


def cuda_available() -> bool:
    """True when Mitsuba has :data:`GPU_VARIANT` and it can be set here
    (a CUDA driver and GPU are present).

    Sets :data:`GPU_VARIANT` to find out; puts the previous variant back if
    one was set."""
    import mitsuba as mi

    if GPU_VARIANT not in mi.variants():
        return False
    try:
        import drjit as dr

        if not dr.has_backend(dr.JitBackend.CUDA):
            return False
    except Exception:  # an older Dr.Jit without has_backend: try the variant
        pass
    previous = mi.variant()
    try:
        mi.set_variant(GPU_VARIANT)
    except Exception:
        return False
    if previous is not None and previous != GPU_VARIANT:
        mi.set_variant(previous)
    return True


def default_variant(probe=None) -> str:
    """:data:`GPU_VARIANT` if *probe* (default :func:`cuda_available`) says a
    GPU can be used, else :data:`DEFAULT_VARIANT`. A probe that raises counts
    as no GPU."""
    probe = cuda_available if probe is None else probe
    try:
        return GPU_VARIANT if probe() else DEFAULT_VARIANT
    except Exception:
        return DEFAULT_VARIANT


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


def set_variant(variant: str):
    """``mi.set_variant(variant)`` and register the ``pbrdf`` plugin for it.

    Raises :class:`UnknownVariantError` (listing the available variants) for a
    variant this Mitsuba build lacks. Returns the ``mitsuba`` module.
    """
    import mitsuba as mi

    available = list(mi.variants())
    if variant not in available:
        raise UnknownVariantError(
            f"unknown Mitsuba variant {variant!r}; available: {', '.join(available)}"
        )
    try:
        mi.set_variant(variant)
    except (ImportError, RuntimeError) as e:
        raise UnknownVariantError(
            f"Mitsuba variant {variant!r} cannot be used here: {' '.join(str(e).split())}"
        ) from e
    import mitsuba_pbrdf

    mitsuba_pbrdf.register()
    return mi


def load_scene(scene_path, params: Optional[Mapping[str, object]] = None):
    """``mi.load_file(scene_path, **params)`` (the variant must be set).
    *params* override the scene's ``<default name="key" .../>`` values; Mitsuba
    rejects keys the scene does not use. Raises ``FileNotFoundError`` or
    :class:`SceneLoadError` (with Mitsuba's message, e.g. the XML parse error)."""
    import mitsuba as mi

    scene_path = os.fspath(scene_path)
    if not os.path.isfile(scene_path):
        raise FileNotFoundError(f"{scene_path}: no such file")
    kwargs = {str(k): str(v) for k, v in (params or {}).items()}
    try:
        return mi.load_file(scene_path, **kwargs)
    except RuntimeError as e:
        raise SceneLoadError(_condense(str(e))) from e


def _condense(message: str) -> str:
    """Mitsuba's error message on one line; a Python traceback that a Python
    plugin's constructor raised is reduced to its last line (the exception)."""
    message = re.sub(r"Traceback \(most recent call last\):\n(?:[ \t].*\n)*", "", message)
    return " ".join(message.split())


class _NoBar:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False

    def update(self, n):
        pass


def _progress_bar(total_spp: int, n_passes: int, progress: bool):
    """A tqdm bar over samples per pixel (one update per pass), or a stand-in."""
    if not progress or n_passes < 2:
        return _NoBar()
    from tqdm import tqdm

    return tqdm(total=total_spp, unit="spp", desc=f"rendering ({n_passes} passes)",
                leave=False, dynamic_ncols=True)


def _kernel_stats(history):
    compile_ms = run_ms = 0.0
    kernels = cached = 0
    for k in history:
        run_ms += k.get("execution_time", 0.0)
        if "codegen_time" in k:  # a JIT kernel (not a memset/reduction)
            kernels += 1
            cached += int(bool(k.get("cache_hit", 0)))
            compile_ms += k.get("codegen_time", 0.0) + k.get("backend_time", 0.0)
    return compile_ms / 1000.0, run_ms / 1000.0, kernels, cached


def render_scene(
    scene_path,
    spp: Optional[int] = None,
    variant: Optional[str] = None,
    seed: int = 0,
    params: Optional[Mapping[str, object]] = None,
    passes: Optional[int] = None,
    progress: bool = False,
) -> StokesImage:
    """Render the scene file and return its Stokes image; see
    :func:`render_scene_timed`, which also returns the :class:`RenderTimings`."""
    return render_scene_timed(scene_path, spp, variant, seed, params, passes, progress)[0]


def render_scene_timed(
    scene_path,
    spp: Optional[int] = None,
    variant: Optional[str] = None,
    seed: int = 0,
    params: Optional[Mapping[str, object]] = None,
    passes: Optional[int] = None,
    progress: bool = False,
):
    """Render the scene file; return its Stokes image and the timings.

    Parameters
    ----------
    scene_path
        Mitsuba XML scene.
    spp
        Samples per pixel; None keeps the scene's sampler setting.
    variant
        Mitsuba variant; must be polarized for the result to have Stokes
        channels. None: :func:`default_variant` (CUDA if usable, else LLVM).
    seed
        Sampler seed of the first pass (``mi.render(..., seed=...)``); the
        other passes use :func:`pass_seeds`.
    params
        Overrides for the scene's ``$key`` defaults (``mi.load_file(path, **params)``).
    passes
        Number of sample passes (see the module docstring); None: automatic
        (:func:`plan_passes`), 1: a single ``mi.render`` call.
    progress
        Show a progress bar (``tqdm``, on stderr) over the passes' samples.

    The returned image's ``metadata`` holds the scene, variant, spp, passes,
    seed, parameters and timings (keys ``time_<stage>_s``). Returns
    ``(image, timings)``; the timings are also logged at INFO level.
    """
    import drjit as dr

    if variant is None:
        variant = default_variant()
    mi = set_variant(variant)

    t0 = time.perf_counter()
    scene = load_scene(scene_path, params)
    t1 = time.perf_counter()

    sensor = scene.sensors()[0]
    total_spp = int(spp or sensor.sampler().sample_count())
    size = sensor.film().crop_size()
    plan = plan_passes(total_spp, passes, pixels=int(size[0]) * int(size[1]))
    seeds = pass_seeds(seed, len(plan))

    history_was_on = dr.flag(dr.JitFlag.KernelHistory)
    dr.set_flag(dr.JitFlag.KernelHistory, True)
    dr.kernel_history()  # clear what earlier work left there
    try:
        t2 = time.perf_counter()
        history = []
        accumulated = None
        with _progress_bar(total_spp, len(plan), progress) as bar:
            for pass_spp, pass_seed in zip(plan, seeds):
                tensor = mi.render(scene, spp=pass_spp, seed=pass_seed)
                # reading the result back runs the kernels
                array = np.array(tensor, dtype=np.float64) * (pass_spp / total_spp)
                accumulated = array if accumulated is None else accumulated + array
                history += dr.kernel_history()
                bar.update(pass_spp)
        image = from_mitsuba(accumulated.astype(np.float32), sensor.film())
        t3 = time.perf_counter()
    finally:
        dr.set_flag(dr.JitFlag.KernelHistory, history_was_on)

    compile_s, run_s, kernels, cached = _kernel_stats(history)
    timings = RenderTimings(
        load=t1 - t0, render=t3 - t2, jit_compile=compile_s, kernel_run=run_s,
        kernels=kernels, kernels_cached=cached,
    )
    log.info("%s: %s", scene_path, timings.summary())

    image.metadata.update(
        {
            "scene": os.fspath(scene_path),
            "variant": variant,
            "spp": str(total_spp),
            "passes": str(len(plan)),
            "seed": str(seed),
            "mitsuba_version": mi.__version__,
        }
    )
    if params:
        image.metadata["params"] = " ".join(f"{k}={v}" for k, v in params.items())
    image.metadata.update({f"time_{k}_s": f"{v:.4g}" for k, v in asdict(timings).items()
                           if not k.startswith("kernels")})
    image.metadata.update({"kernels": str(kernels), "kernels_cached": str(cached)})
    return image, timings
