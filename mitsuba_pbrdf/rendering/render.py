"""Render a Mitsuba scene with the ``pbrdf`` plugin into a :class:`StokesImage`.

::

    from mitsuba_pbrdf.rendering import render_scene
    image = render_scene("scenes/default.xml", spp=16, params={"width": 160})
    print(image.metadata["time_render_s"])

Long renders run in *passes* (:mod:`mitsuba_pbrdf.rendering.passes`) of
about a second each: the samples per pixel are split into passes with
different seeds, and the pass images are averaged with weights proportional
to their sample counts. Between passes a progress bar advances
(:mod:`mitsuba_pbrdf.rendering.progress`) and Ctrl-C can stop the render
(``KeyboardInterrupt``; Dr.Jit returns to Python only between kernels).

Before anything renders, :func:`check_render` checks what needs no scene
loaded, once: the variant must be polarized (:func:`require_polarized`), the
``params`` must suit what the scene does with them, a wavelength band needs a
spectral variant; after loading, the film and sampler must be usable
(:mod:`mitsuba_pbrdf.rendering.scene_params`). Each failure is a one-line
``ValueError`` naming the parameter. A caller that checks early (``pbrdf
render``, before it checks its output files) renders the checked request with
:func:`render_request`.

The default variant is ``cuda_ad_spectral_polarized`` when a CUDA GPU is
usable, else ``llvm_ad_spectral_polarized``
(:func:`mitsuba_pbrdf.variant.default_variant`).

The scene should wrap its integrator in Mitsuba's ``stokes`` integrator (around
``path``, ``direct`` or ``volpath``, not ``prb``, which ignores Mueller frame
rotations) and be rendered in a ``*_polarized`` variant; otherwise the image
has no Stokes channels.
"""

from __future__ import annotations

import logging
import os
import time
from dataclasses import asdict, dataclass
from typing import Mapping, Optional

import numpy as np

from ..errors import ParameterError
from ..interrupts import release as release_interrupts
from ..registry import use_variant
from ..bsdfs import warn_unpolarized_wrappers
from ..variant import default_variant
from .bands import SpectralBands, parse_bands, require_spectral_bands
from ..numbers import MAX_SPP
from .cube import check_cube_spp, cube_image, cube_pass, load_cube_scene
from .scene_loading import SceneLoadError, interrupted, scene_load_errors
from .narrowband import (WavelengthBand, band_image, band_response, load_band_scene,
                         parse_wavelength, require_spectral)
from .passes import pass_seeds, plan_passes, samples_per_pass
from .progress import progress_reporter
from .scene_params import check_loaded_scene, check_parameter_values
from ..stokes.image import StokesImage, from_mitsuba

__all__ = [
    "RenderTimings",
    "SceneLoadError",
    "UnpolarizedVariantError",
    "require_polarized",
    "RenderRequest",
    "check_render",
    "render_request",
    "load_scene",
    "render_scene",
    "render_scene_timed",
]

log = logging.getLogger(__name__)


class UnpolarizedVariantError(ValueError):
    """A Stokes image was asked of a variant that does not track polarization."""


def require_polarized(variant: str):
    """Raise :class:`UnpolarizedVariantError`, naming the polarized variants of
    this Mitsuba build, if *variant* is one of its variants that is not
    polarized (``*_polarized``). Checks the name only: loads no scene."""
    if variant.endswith("_polarized"):
        return
    try:
        import mitsuba as mi

        available = list(mi.variants())
    except ImportError:
        available = []
    if variant not in available:
        return  # use_variant says it is unknown, listing the variants
    choices = [v for v in available if v.endswith("_polarized")]
    raise UnpolarizedVariantError(
        f"variant {variant!r} does not track polarization; Stokes images need a polarized "
        f"variant: {', '.join(choices) or 'none in this Mitsuba build'}")


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
    with scene_load_errors():
        return mi.load_file(scene_path, **kwargs)


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


def render_scene(scene_path, spp: Optional[int] = None, **options) -> StokesImage:
    """Render the scene file and return its Stokes image: :func:`render_scene_timed`
    (same arguments) without the :class:`RenderTimings`."""
    return render_scene_timed(scene_path, spp, **options)[0]


@dataclass(frozen=True)
class RenderRequest:
    """A render whose inputs :func:`check_render` has checked: the scene file,
    the variant (polarized; spectral for a band), the samples per pixel (None:
    the scene's), the number of passes (None: automatic), the ``$key``
    parameters, the wavelength band (None: R, G, B) and the bands of a Stokes
    cube (None: no cube)."""

    scene_path: str
    variant: str
    spp: Optional[int] = None
    passes: Optional[int] = None
    params: Optional[Mapping[str, object]] = None
    band: Optional[WavelengthBand] = None
    bands: Optional[SpectralBands] = None


def check_render(scene_path, spp: Optional[int] = None, variant: Optional[str] = None,
                 params: Optional[Mapping[str, object]] = None, passes: Optional[int] = None,
                 wavelength=None, bands=None) -> RenderRequest:
    """Every check of a render that needs no loaded scene, once: ``spp`` and
    ``passes`` at least 1, the variant polarized (:func:`require_polarized`),
    ``params`` suited to what the scene does with them
    (:func:`~mitsuba_pbrdf.rendering.scene_params.check_parameter_values`),
    ``wavelength`` a band (:func:`~mitsuba_pbrdf.rendering.narrowband.parse_wavelength`)
    and the variant spectral for it, ``bands`` a list of bands
    (:func:`~mitsuba_pbrdf.rendering.bands.parse_bands`, spectral variants
    only, not with ``wavelength``). Raises a ``ValueError`` naming the
    parameter (:class:`~mitsuba_pbrdf.errors.ParameterError` for ``spp``,
    ``passes``, ``wavelength``, ``bands``). Sets no variant and loads nothing."""
    for name, value in (("spp", spp), ("passes", passes)):
        if value is not None and int(value) < 1:
            raise ParameterError(name, f"must be at least 1, got {value}")
        if value is not None and int(value) > MAX_SPP:
            raise ParameterError(name, f"must be at most {MAX_SPP} (2^24), got {value}")
    if variant is None:
        variant = default_variant()
    require_polarized(variant)
    check_parameter_values(scene_path, params)
    band = None
    if wavelength is not None:
        band = wavelength if isinstance(wavelength, WavelengthBand) else \
            parse_wavelength(wavelength)
        require_spectral(variant)
    cube = None
    if bands is not None:
        if band is not None:
            raise ParameterError("bands", "renders a Stokes cube; give wavelength (one band) or "
                                 "bands, not both")
        cube = parse_bands(bands)
        require_spectral_bands(variant)
        if spp is not None:
            check_cube_spp(cube, int(spp))
    return RenderRequest(os.fspath(scene_path), variant, None if spp is None else int(spp),
                         None if passes is None else int(passes), params, band, cube)


def render_scene_timed(
    scene_path,
    spp: Optional[int] = None,
    variant: Optional[str] = None,
    seed: int = 0,
    params: Optional[Mapping[str, object]] = None,
    passes: Optional[int] = None,
    progress=False,
    wavelength=None,
    bands=None,
):
    """Render the scene file; return its Stokes image and the timings:
    :func:`render_request` of :func:`check_render`'s request.

    Parameters
    ----------
    scene_path
        Mitsuba XML scene.
    spp
        Samples per pixel; None keeps the scene's sampler setting.
    variant
        Mitsuba variant; must be polarized for the result to have Stokes
        channels. None: :func:`~mitsuba_pbrdf.variant.default_variant` (CUDA if usable, else LLVM).
    seed
        Sampler seed of the first pass (``mi.render(..., seed=...)``); the
        other passes use :func:`pass_seeds`.
    params
        Overrides for the scene's ``$key`` defaults (``mi.load_file(path, **params)``).
    passes
        Number of sample passes (see the module docstring); None: automatic
        (:func:`plan_passes` with the budget of :func:`samples_per_pass` for
        the variant's backend), 1: a single ``mi.render`` call.
    progress
        Progress over the passes' samples on stderr: False (default), True or
        ``"bar"`` (a ``tqdm`` bar), ``"lines"`` (lines for logs) or ``"auto"``
        (:func:`~mitsuba_pbrdf.rendering.progress.progress_reporter`).
    wavelength
        None (R, G, B Stokes bands), or a narrow band: ``"632.8"``, ``"550:10"``
        (centre and width in nm) or a :class:`~.narrowband.WavelengthBand`; the
        image then has one Stokes band at that wavelength
        (:mod:`mitsuba_pbrdf.rendering.narrowband`; spectral variants only).
    bands
        None, or the bands of a Stokes cube: ``"450:650:20"``,
        ``"450:470,532:533"`` (:mod:`mitsuba_pbrdf.rendering.bands`) or a
        :class:`~.bands.SpectralBands`; the image then has one Stokes band per
        band, named after its centre (``460nm``), each the band average of the
        Stokes vector, from one render (:mod:`mitsuba_pbrdf.rendering.cube`;
        spectral variants only).

    The returned image's ``metadata`` holds the scene, variant, spp, passes,
    seed, parameters and timings (keys ``time_<stage>_s``). Returns
    ``(image, timings)``; the timings are also logged at INFO level.
    """
    request = check_render(scene_path, spp, variant, params, passes, wavelength, bands)
    return render_request(request, seed=seed, progress=progress)


def render_request(request: RenderRequest, seed: int = 0, progress=False):
    """Render a request that :func:`check_render` made (its checks are not run
    again); ``seed`` and ``progress`` as in :func:`render_scene_timed`. Returns
    ``(image, timings)``."""
    import drjit as dr

    import mitsuba as mi

    scene_path, spp, variant, params = (request.scene_path, request.spp, request.variant,
                                        request.params)
    use_variant(variant)
    response = None if request.band is None else band_response(request.band)

    t0 = time.perf_counter()
    if response is None and request.bands is None:
        scene = load_scene(scene_path, params)
    else:
        if not os.path.isfile(os.fspath(scene_path)):
            raise FileNotFoundError(f"{os.fspath(scene_path)}: no such file")
        scene = (load_band_scene(scene_path, params, response) if response is not None
                 else load_cube_scene(scene_path, params))
    t1 = time.perf_counter()
    check_loaded_scene(scene, scene_path, params, spp)
    warn_unpolarized_wrappers(scene)

    sensor = scene.sensors()[0]
    total_spp = int(spp if spp is not None else sensor.sampler().sample_count())
    if request.bands is not None:
        check_cube_spp(request.bands, total_spp)
    size = sensor.film().crop_size()
    backend = "cuda" if variant.startswith("cuda") else "llvm"
    plan = plan_passes(total_spp, request.passes, pixels=int(size[0]) * int(size[1]),
                       budget=samples_per_pass(backend))
    seeds = pass_seeds(seed, len(plan))

    release_interrupts()  # loaded: Ctrl-C from here on stops between passes
    history_was_on = dr.flag(dr.JitFlag.KernelHistory)
    dr.set_flag(dr.JitFlag.KernelHistory, True)
    dr.kernel_history()  # clear what earlier work left there
    name = os.path.basename(os.fspath(scene_path))
    try:
        t2 = time.perf_counter()
        history = []
        accumulated, first = None, 0
        with progress_reporter(total_spp, f"rendering {name} ({len(plan)} passes)", progress,
                               steps=len(plan)) as bar:
            for pass_spp, pass_seed in zip(plan, seeds):
                try:
                    if request.bands is not None:
                        array = cube_pass(scene, request.bands, pass_spp, pass_seed, first,
                                          total_spp)
                    else:
                        tensor = mi.render(scene, spp=pass_spp, seed=pass_seed)
                        # reading the result back runs the kernels
                        array = np.array(tensor, dtype=np.float64) * (pass_spp / total_spp)
                    first += pass_spp
                except RuntimeError as e:
                    if interrupted(e):
                        raise KeyboardInterrupt from e
                    raise
                accumulated = array if accumulated is None else accumulated + array
                history += dr.kernel_history()
                bar.update(pass_spp)
        if request.bands is not None:
            image = cube_image(accumulated, request.bands)
        else:
            image = from_mitsuba(accumulated.astype(np.float32), sensor.film())
        if response is not None:
            image = band_image(image, response)
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
