"""Render a Mitsuba scene with the ``pbrdf`` plugin into a :class:`StokesImage`.

::

    from mitsuba_pbrdf.render import render_scene
    image = render_scene("scenes/default.xml", spp=16, params={"width": 160})
    print(image.metadata["time_render_s"])

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

from .stokes_io import StokesImage, from_mitsuba

__all__ = [
    "DEFAULT_VARIANT",
    "RenderTimings",
    "UnknownVariantError",
    "SceneLoadError",
    "set_variant",
    "load_scene",
    "render_scene",
    "render_scene_timed",
]

log = logging.getLogger(__name__)

DEFAULT_VARIANT = "llvm_ad_spectral_polarized"


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
        s = f"load {self.load:.2f} s, render {self.render:.2f} s"
        if self.kernels:
            s += (
                f" (JIT compile {self.jit_compile:.2f} s, kernels {self.kernel_run:.2f} s; "
                f"{self.kernels} kernels, {self.kernels_cached} from cache)"
            )
        return s


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
    variant: str = DEFAULT_VARIANT,
    seed: int = 0,
    params: Optional[Mapping[str, object]] = None,
) -> StokesImage:
    """Render the scene file and return its Stokes image; see
    :func:`render_scene_timed`, which also returns the :class:`RenderTimings`."""
    return render_scene_timed(scene_path, spp, variant, seed, params)[0]


def render_scene_timed(
    scene_path,
    spp: Optional[int] = None,
    variant: str = DEFAULT_VARIANT,
    seed: int = 0,
    params: Optional[Mapping[str, object]] = None,
):
    """Render the scene file; return its Stokes image and the timings.

    Parameters
    ----------
    scene_path
        Mitsuba XML scene.
    spp
        Samples per pixel; None keeps the scene's sampler setting.
    variant
        Mitsuba variant; must be polarized for the result to have Stokes channels.
    seed
        Sampler seed passed to ``mi.render``.
    params
        Overrides for the scene's ``$key`` defaults (``mi.load_file(path, **params)``).

    The returned image's ``metadata`` holds the scene, variant, spp, seed,
    parameters and timings (keys ``time_<stage>_s``). Returns
    ``(image, timings)``; the timings are also logged at INFO level.
    """
    import drjit as dr

    mi = set_variant(variant)

    t0 = time.perf_counter()
    scene = load_scene(scene_path, params)
    t1 = time.perf_counter()

    history_was_on = dr.flag(dr.JitFlag.KernelHistory)
    dr.set_flag(dr.JitFlag.KernelHistory, True)
    dr.kernel_history()  # clear what earlier work left there
    try:
        t2 = time.perf_counter()
        tensor = mi.render(scene, spp=spp or 0, seed=seed)
        sensor = scene.sensors()[0]
        image = from_mitsuba(tensor, sensor.film())  # reads the result back: runs the kernels
        t3 = time.perf_counter()
        history = dr.kernel_history()
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
            "spp": str(spp or sensor.sampler().sample_count()),
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
