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
``params`` must suit what the scene does with them, a passband or a cube needs a
spectral variant, and the scene, read by Mitsuba's parser with its
``<include>`` s, must be able to give Stokes output
(:mod:`mitsuba_pbrdf.rendering.scene_setup`); after loading, the film and
sampler must be usable (:mod:`mitsuba_pbrdf.rendering.scene_params`). Each failure is a one-line
``ValueError`` naming the parameter. A caller that checks early (``pbrdf
render``, before it checks its output files) renders the checked request with
:func:`render_request`. The request carries its render mode
(:mod:`mitsuba_pbrdf.rendering.modes`: the scene's R, G, B, one passband, or a
Stokes cube), which loads the scene, renders each pass and assembles the image.

The default variant is ``cuda_ad_spectral_polarized`` when a CUDA GPU is
usable, else ``llvm_ad_spectral_polarized``
(:func:`mitsuba_pbrdf.variant.default_variant`).

A scene renders as published: where its integrator (``path``, ``direct``,
``volpath``, ``volpathmis``, ``moment`` around one of them, or none: Mitsuba's
default ``path``) is not inside Mitsuba's ``stokes`` integrator, it is wrapped
there for the render, and a warning line says so (``auto_stokes=False`` refuses
instead); an integrator that cannot give Stokes output (``prb``, which ignores
Mueller frame rotations, ``aov``, ...) is refused before loading
(:mod:`mitsuba_pbrdf.rendering.scene_setup`). ``size=(width, height)`` renders
any scene at that resolution, whatever its film's properties are called.
"""

from __future__ import annotations

import logging
import os
import time
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field
from typing import Mapping, Optional

from ..errors import ParameterError
from ..interrupts import release as release_interrupts
from ..registry import use_variant
from ..bsdfs import warn_unpolarized_wrappers
from ..variant import default_variant
from ..numbers import MAX_SPP
from .modes import RenderMode, RgbMode, render_mode
from .scene_loading import SceneLoadError, interrupted, load_scene
from .passes import pass_seeds, plan_passes, samples_per_pass
from .progress import progress_reporter
from .scene_params import check_loaded_scene, check_parameter_values
from .scene_setup import SceneSetup, StokesSceneError, check_scene_setup, parse_size
from ..stokes.image import StokesImage

__all__ = [
    "RenderTimings",
    "SceneLoadError",
    "StokesSceneError",
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
    the variant (polarized; spectral for a passband or a cube), the samples per
    pixel (None: the scene's), the number of passes (None: automatic), the
    ``$key`` parameters, the render mode (:mod:`.modes`: the scene's R, G,
    B; one passband; a Stokes cube), how the scene loads for it
    (:class:`~.scene_setup.SceneSetup`) and the one line saying what that
    changes in the scene's integrator (None: nothing)."""

    scene_path: str
    variant: str
    spp: Optional[int] = None
    passes: Optional[int] = None
    params: Optional[Mapping[str, object]] = None
    mode: RenderMode = field(default_factory=RgbMode)
    setup: SceneSetup = field(default_factory=SceneSetup)
    notice: Optional[str] = None


def check_render(scene_path, spp: Optional[int] = None, variant: Optional[str] = None,
                 params: Optional[Mapping[str, object]] = None, passes: Optional[int] = None,
                 wavelength=None, bands=None, size=None, auto_stokes: bool = True
                 ) -> RenderRequest:
    """Every check of a render that needs no loaded scene, once: ``spp`` and
    ``passes`` at least 1, the variant polarized (:func:`require_polarized`),
    ``params`` suited to what the scene does with them
    (:func:`~mitsuba_pbrdf.rendering.scene_params.check_parameter_values`), and
    the render mode of ``wavelength`` and ``bands``
    (:func:`~mitsuba_pbrdf.rendering.modes.render_mode`: a passband, or a
    list of passbands with enough ``spp``; spectral variants only, not both),
    ``size`` (``"320x240"`` or (width, height)), and the scene as Mitsuba's
    parser reads it (:func:`~.scene_setup.check_scene_setup`: an integrator
    that gives Stokes output, or one that ``stokes`` can wrap when
    ``auto_stokes``; sensors the mode can use). Raises a ``ValueError`` naming
    the parameter (:class:`~mitsuba_pbrdf.errors.ParameterError` for ``spp``,
    ``passes``, ``wavelength``, ``bands``, ``size``;
    :class:`~.scene_setup.StokesSceneError` for the integrator). Sets no
    variant and loads nothing."""
    for name, value in (("spp", spp), ("passes", passes)):
        if value is not None and int(value) < 1:
            raise ParameterError(name, f"must be at least 1, got {value}")
        if value is not None and int(value) > MAX_SPP:
            raise ParameterError(name, f"must be at most {MAX_SPP} (2^24), got {value}")
    if variant is None:
        variant = default_variant()
    require_polarized(variant)
    check_parameter_values(scene_path, params)
    mode = render_mode(variant, wavelength, bands)
    if spp is not None:
        mode.check_spp(int(spp))
    setup = mode.scene_setup(None if size is None else parse_size(size), bool(auto_stokes))
    notice = check_scene_setup(scene_path, variant, params, setup)
    return RenderRequest(os.fspath(scene_path), variant, None if spp is None else int(spp),
                         None if passes is None else int(passes), params, mode, setup, notice)


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
    size=None,
    auto_stokes: bool = True,
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
        None (R, G, B Stokes bands), or a passband: ``"632.8"``, ``"550:10"``
        (centre and width in nm) or a :class:`~.narrowband.Passband`; the
        image then has one Stokes band at that wavelength
        (:mod:`mitsuba_pbrdf.rendering.narrowband`; spectral variants only).
    bands
        None, or the passbands of a Stokes cube: ``"450:650:20"``,
        ``"450:470,532:533"`` (:mod:`mitsuba_pbrdf.rendering.bands`) or a
        :class:`~.bands.PassbandList`; the image then has one Stokes band per
        passband, named after its centre (``460nm``), each the passband average
        of the Stokes vector, from one render (:mod:`mitsuba_pbrdf.rendering.cube`;
        spectral variants only).
    size
        None (the scene's film), or the image size for any scene: ``"320x240"``
        or ``(320, 240)`` pixels, set on the sensors' films wherever the scene
        keeps them.
    auto_stokes
        True (default): a scene whose integrator is not inside ``stokes`` is
        rendered with it wrapped there, and a warning line says so; False:
        such a scene is refused (:class:`~.scene_setup.StokesSceneError`).

    The returned image's ``metadata`` holds the scene, variant, spp, passes,
    seed, parameters and timings (keys ``time_<stage>_s``). Returns
    ``(image, timings)``; the timings are also logged at INFO level.
    """
    request = check_render(scene_path, spp, variant, params, passes, wavelength, bands, size,
                           auto_stokes)
    if request.notice:
        log.warning(request.notice)
    return render_request(request, seed=seed, progress=progress)


def render_request(request: RenderRequest, seed: int = 0, progress=False):
    """Render a request that :func:`check_render` made (its checks are not run
    again); ``seed`` and ``progress`` as in :func:`render_scene_timed`. Returns
    ``(image, timings)``."""
    mode = request.mode
    use_variant(request.variant)
    t0 = time.perf_counter()
    scene = mode.load(request.scene_path, request.params, request.setup)
    t1 = time.perf_counter()
    check_loaded_scene(scene, request.scene_path, request.params, request.spp)
    warn_unpolarized_wrappers(scene)

    sensor = scene.sensors()[0]
    total_spp = request.spp
    if total_spp is None:  # the scene's (check_render checked a given spp)
        total_spp = int(sensor.sampler().sample_count())
        mode.check_spp(total_spp)
    size = sensor.film().crop_size()
    backend = "cuda" if request.variant.startswith("cuda") else "llvm"
    plan = plan_passes(total_spp, request.passes, pixels=int(size[0]) * int(size[1]),
                       budget=samples_per_pass(backend))

    release_interrupts()  # loaded: Ctrl-C from here on stops between passes
    t2 = time.perf_counter()
    label = f"rendering {os.path.basename(request.scene_path)} ({len(plan)} passes)"
    with progress_reporter(total_spp, label, progress, steps=len(plan)) as bar, \
            _kernel_history() as history:
        total = _render_passes(scene, mode, plan, pass_seeds(seed, len(plan)), total_spp,
                               bar, history)
    image = mode.assemble(total, sensor.film())
    t3 = time.perf_counter()

    compile_s, run_s, kernels, cached = _kernel_stats(history)
    timings = RenderTimings(load=t1 - t0, render=t3 - t2, jit_compile=compile_s,
                            kernel_run=run_s, kernels=kernels, kernels_cached=cached)
    log.info("%s: %s", request.scene_path, timings.summary())
    _record(image.metadata, request, total_spp, len(plan), seed, timings)
    return image, timings


@contextmanager
def _kernel_history():
    """Dr.Jit's kernel history on and cleared for the block, which extends the
    yielded list with it; the flag as it was after."""
    import drjit as dr

    was_on = dr.flag(dr.JitFlag.KernelHistory)
    dr.set_flag(dr.JitFlag.KernelHistory, True)
    dr.kernel_history()  # clear what earlier work left there
    try:
        yield []
    finally:
        dr.set_flag(dr.JitFlag.KernelHistory, was_on)


def _render_passes(scene, mode: RenderMode, plan, seeds, total_spp: int, bar, history):
    """The sum of the *mode*'s passes (*plan*: each pass's spp), the kernels of
    each appended to *history*; a Ctrl-C that Mitsuba wrapped is ``KeyboardInterrupt``."""
    import drjit as dr

    total, first = None, 0
    for spp, seed in zip(plan, seeds):
        try:
            array = mode.render_pass(scene, spp, seed, first, total_spp)
        except RuntimeError as e:
            if interrupted(e):
                raise KeyboardInterrupt from e
            raise
        first += spp
        total = array if total is None else total + array
        history += dr.kernel_history()
        bar.update(spp)
    return total


def _record(metadata: dict, request: RenderRequest, total_spp: int, passes: int, seed: int,
            timings: RenderTimings):
    """The render's inputs and timings into the image's *metadata*."""
    import mitsuba as mi

    metadata.update({"scene": request.scene_path, "variant": request.variant,
                     "spp": str(total_spp), "passes": str(passes), "seed": str(seed),
                     "mitsuba_version": mi.__version__})
    if request.params:
        metadata["params"] = " ".join(f"{k}={v}" for k, v in request.params.items())
    metadata.update({f"time_{k}_s": f"{v:.4g}" for k, v in asdict(timings).items()
                     if not k.startswith("kernels")})
    metadata.update({"kernels": str(timings.kernels),
                     "kernels_cached": str(timings.kernels_cached)})
