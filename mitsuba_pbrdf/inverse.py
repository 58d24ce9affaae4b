"""Differentiable inverse rendering with the ``pbrdf`` plugin.

Gradients of a loss on rendered Stokes images with respect to scene
parameters, an Adam fit of BSDF parameters to target Stokes images, and the
sensitivity (Jacobian / Fisher information) analysis that tells which
parameters an image determines::

    import mitsuba as mi
    mi.set_variant("llvm_ad_spectral_polarized")
    from mitsuba_pbrdf import inverse

    scene = mi.load_dict(inverse.sphere_scene(width=128, height=128))
    params = mi.traverse(scene)
    target = inverse.render(scene, spp=256, seed=1)
    loss = inverse.stokes_loss(scene, target, components=(0, 1, 2))
    value, grads, stats = inverse.loss_and_gradient(
        scene, params, ["object.bsdf.sigma.value", "object.bsdf.eta.value"], loss,
        spp=64, passes="auto", max_depth=3)

**Memory and the two methods.** Mitsuba's path-replay integrators (``prb*``)
ignore Mueller frame rotations, so polarized gradients need ``path`` (or
``direct``/``volpath``) differentiated by plain AD. In reverse mode Mitsuba
runs the path loop in *evaluated* mode and records every bounce of every
sample: memory grows as pixels x spp x depth (~2.1 kB per sample at
max_depth 4; 512 x 512 at 64 spp would need ~35 GiB). Two ways around it,
both exact for the same estimator:

* ``method="reverse"`` with ``passes`` (the default method; ``passes="auto"``
  sizes them for a memory budget): reverse-mode AD with the samples split
  into passes whose gradients are accumulated (``Integrator.render_backward``
  once per pass, with the loss gradient of the full image). Memory divides by
  the number of passes; cost about one AD render of all samples, whatever the
  number of parameters K (use it for textures).
* ``method="forward"``: one forward-mode derivative render per scalar
  parameter with Dr.Jit's *symbolic* loops kept on. Tangents are propagated
  inside the megakernel, nothing per bounce or per sample is stored: memory
  is that of a primal render, independent of spp and depth. Cost: K + 1
  renders. (Mitsuba's own ``Integrator.render_forward`` switches symbolic
  loops off, "recorded loops cannot be differentiated", true of reverse mode
  only, and so stores the whole graph: this module calls ``render`` itself.)

Measured (validation/inverse_memory.md; 512 x 512, 64 spp, depth 4, 7
parameters, 2 cores): reverse with 9 passes 4.5 GiB peak, 29 s per gradient
(49 s the first time, compiling); forward 0.27 GiB, 96 s. Reverse with
passes is the default, forward is for tight memory or few parameters.

With ``passes=1`` and the same seed, both give what ``mi.render`` and
``dr.backward`` give (the same paths, the same estimator; tested); with more
passes the samples differ and the gradients agree within Monte Carlo noise.
The seed of the derivative renders differs from the primal one, as in
``mi.render``, so the gradient of a non-linear loss is unbiased.

Stokes channels are found by name (``S0.R`` ... ``S3.B``, see
:mod:`mitsuba_pbrdf.stokes_io`), never by position.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Callable, Dict, Mapping, Sequence

import drjit as dr
import mitsuba as mi
import numpy as np

from .stokes_io import channel_names

__all__ = [
    "mueller_brdf",
    "sphere_scene",
    "render",
    "stokes_indices",
    "stokes_loss",
    "pass_seeds",
    "split_spp",
    "reverse_passes",
    "loss_and_gradient",
    "jacobian",
    "fisher_information",
    "FitResult",
    "fit_parameters",
]


# ---------------------------------------------------------------------------
# The BSDF itself: Mueller matrices in the reference's global frames, with AD
# ---------------------------------------------------------------------------

def _global_basis(d):
    """normalize(z x d); the surface x-axis where d is parallel to z."""
    s = dr.cross(mi.Vector3f(0, 0, 1), d)
    return dr.select(dr.squared_norm(s) == 0, mi.Vector3f(1, 0, 0), dr.normalize(s))


def _vector(v):
    if isinstance(v, mi.Vector3f):
        return v
    v = np.asarray(v, dtype=np.float32).reshape(-1, 3)
    return mi.Vector3f(*(mi.Float(np.ascontiguousarray(v[:, j])) for j in range(3)))


def mueller_brdf(bsdf, wi_hat, wo_hat, wavelengths=(450.0, 520.0, 600.0, 690.0),
                 mode="radiance", uv=None):
    """BRDF Mueller matrices of ``bsdf`` (1/sr, no cosine) in the global s/p
    frames of :mod:`mitsuba_pbrdf.reference`, as a Dr.Jit ``mi.Spectrum`` that
    keeps derivatives (JIT polarized variants).

    ``wo_hat`` points towards the light (the reference's ``wi``), ``wi_hat``
    towards the viewer (its ``wr``): arrays (n, 3) or ``mi.Vector3f``, local
    frame. ``wavelengths``: 4 values (nm) for every lane, or a
    ``mi.UnpolarizedSpectrum`` with one wavelength set per lane. ``uv``:
    texture coordinates (``mi.Point2f``) for textured parameters. Same frames
    and conventions as :func:`mitsuba_pbrdf.frames.eval_global`, which returns
    NumPy arrays without derivatives.
    """
    if not mi.is_polarized:
        raise RuntimeError(f"mueller_brdf needs a polarized variant, not {mi.variant()}")
    wi_hat, wo_hat = _vector(wi_hat), _vector(wo_hat)
    radiance = str(mode).lower().endswith("radiance")
    si = dr.zeros(mi.SurfaceInteraction3f, dr.width(wi_hat))
    si.n = mi.Normal3f(0, 0, 1)
    si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
    si.wi, wo = (wi_hat, wo_hat) if radiance else (wo_hat, wi_hat)
    if uv is not None:
        si.uv = uv
    if mi.is_spectral:
        si.wavelengths = (wavelengths if isinstance(wavelengths, mi.UnpolarizedSpectrum)
                          else mi.UnpolarizedSpectrum(*(float(w) for w in wavelengths)))
    ctx = mi.BSDFContext(mi.TransportMode.Radiance if radiance else mi.TransportMode.Importance)
    value = bsdf.eval(ctx, si, wo)
    value = mi.mueller.rotate_mueller_basis(
        value,
        -wo_hat, mi.mueller.stokes_basis(-wo_hat), _global_basis(-wo_hat),
        wi_hat, mi.mueller.stokes_basis(wi_hat), _global_basis(wi_hat))
    cos = mi.Frame3f.cos_theta(wo)
    return value * dr.select(cos > 0, dr.rcp(cos), 0.0)


# ---------------------------------------------------------------------------
# A scene to invert, rendering, Stokes losses
# ---------------------------------------------------------------------------

def sphere_scene(width=64, height=64, spp=16, max_depth=3, bsdf=None, integrator="path",
                 fov=32.0):
    """Scene dict: a ``pbrdf`` sphere (shape id ``object``) on a grey diffuse
    floor, lit by a soft box above the camera (highlights near normal
    incidence), one behind on the right (highlights at 60-70 degrees, strongly
    s-polarized) and a dim sky, inside Mitsuba's ``stokes`` integrator.

    ``bsdf``: the sphere's BSDF dict (default: a metal with n = 2, k = 4,
    sigma = 0.12 and small diffuse lobes). ``integrator``: ``path`` (or
    ``direct``, which ignores ``max_depth``)."""
    T = mi.ScalarTransform4f
    bsdf = bsdf or {"type": "pbrdf", "eta": 2.0, "k": 4.0, "sigma": 0.12, "ks": 1.0,
                    "kdd": 0.1, "sigma_dd": 0.5, "kid": 0.03}
    inner = {"type": integrator}
    if integrator != "direct":
        inner["max_depth"] = int(max_depth)
    return {
        "type": "scene",
        "integrator": {"type": "stokes", "integrator": inner},
        "sensor": {"type": "perspective", "fov": float(fov),
                   "to_world": T().look_at(origin=[0, 1.6, 5.0], target=[0, 0.9, 0],
                                           up=[0, 1, 0]),
                   "sampler": {"type": "independent", "sample_count": int(spp)},
                   "film": {"type": "hdrfilm", "width": int(width), "height": int(height),
                            "pixel_format": "rgb", "rfilter": {"type": "box"}}},
        "object": {"type": "sphere", "center": [0, 1, 0], "radius": 1.0, "bsdf": bsdf},
        "floor": {"type": "rectangle", "to_world": T().scale(20).rotate([1, 0, 0], -90),
                  "bsdf": {"type": "diffuse", "reflectance": 0.3}},
        "key": {"type": "rectangle",
                "to_world": T().look_at(origin=[-1.5, 4.5, 5.0], target=[0, 1, 0],
                                        up=[0, 1, 0]).scale(0.7),
                "emitter": {"type": "area", "radiance": 25.0}},
        "back": {"type": "rectangle",
                 "to_world": T().look_at(origin=[4.5, 2.5, -3.0], target=[0, 1, 0],
                                         up=[0, 1, 0]).scale(0.8),
                 "emitter": {"type": "area", "radiance": 40.0}},
        "sky": {"type": "constant", "radiance": 0.15},
    }


def render(scene, spp=16, seed=0, passes=1):
    """Primal render (no derivatives) of ``scene``'s first sensor as a
    ``mi.TensorXf`` (H, W, C), the samples split into ``passes`` renders
    (:func:`split_spp`, seeds from :func:`pass_seeds`) whose mean it returns."""
    integrator, sensor = scene.integrator(), scene.sensors()[0]
    image = None
    with dr.suspend_grad():
        for (primal_seed, _), n in zip(pass_seeds(seed, passes), split_spp(spp, passes)):
            part = integrator.render(scene, sensor, seed=primal_seed, spp=n, develop=True,
                                     evaluate=False) * (n / spp)
            image = part if image is None else image + part
            dr.eval(image)
    return image


def _film_channels(scene_or_film):
    if not hasattr(scene_or_film, "sensors"):
        return channel_names(scene_or_film)
    film = scene_or_film.sensors()[0].film()
    try:
        return channel_names(film)
    except RuntimeError:  # nothing rendered yet: allocate the film's storage
        film.prepare(scene_or_film.integrator().aov_names())
        return channel_names(film)


def stokes_indices(scene_or_film, components=(0, 1, 2)):
    """Channel indices of the Stokes components ``components`` (0..3), all
    bands, in the tensor ``mi.render`` returns for this scene or film: a list
    of lists, one per component."""
    names = _film_channels(scene_or_film)
    out = []
    for c in components:
        idx = [i for i, n in enumerate(names) if n.startswith(f"S{int(c)}.")]
        if not idx:
            raise ValueError(f"no S{c}.* channels in {names}: render with the 'stokes' "
                             "integrator in a polarized variant")
        out.append(idx)
    return out


def stokes_loss(scene_or_film, target, components=(0, 1, 2), weights=None):
    """A loss function ``loss(image) -> mi.Float``: the squared error of the
    Stokes components ``components`` against ``target`` (a tensor or array
    (H, W, C) laid out as the scene's film), summed over components and bands,
    averaged over pixels and divided by the mean of the target's S0^2 (so the
    loss does not depend on the image's brightness).

    Equal ``weights`` (default) are what a polarimeter whose S0, S1, S2 carry
    the same absolute noise calls for (maximum likelihood)."""
    groups = stokes_indices(scene_or_film, components)
    weights = [1.0] * len(groups) if weights is None else [float(w) for w in weights]
    target = mi.TensorXf(np.asarray(target, dtype=np.float32))
    s0 = stokes_indices(scene_or_film, (0,))[0]
    norm = float(np.mean(np.asarray(target, dtype=np.float64)[..., s0] ** 2))
    if not norm > 0:
        raise ValueError("the target image is black (mean S0^2 = 0)")

    def loss(image):
        total = mi.Float(0.0)
        for w, idx in zip(weights, groups):
            for i in idx:
                total += w * dr.mean(dr.square(image[..., i] - target[..., i]), axis=None).array
        return total / norm

    return loss


# ---------------------------------------------------------------------------
# Gradients
# ---------------------------------------------------------------------------

def split_spp(spp, passes):
    """Samples per pixel of each of ``passes`` renders (differing by at most 1)."""
    spp, passes = int(spp), int(passes)
    if passes < 1 or spp < passes:
        raise ValueError(f"need 1 <= passes <= spp, got passes={passes}, spp={spp}")
    return [spp // passes + (1 if p < spp % passes else 0) for p in range(passes)]


#: Dr.Jit memory of reverse-mode AD through ``path`` per sample and unit of
#: ``max_depth`` (bytes), measured with validation/inverse_memory.py: 2.06 kB
#: per sample at max_depth 4 on the pbrdf sphere scene, 1.9 kB at depth 3 with
#: ``roughconductor`` (the issue's figure); rounded up.
REVERSE_BYTES_PER_SAMPLE_AND_DEPTH = 560


def reverse_passes(scene, spp, max_depth, memory_budget=4 * 1024**3):
    """Number of passes that keeps reverse-mode AD of ``scene`` (integrator
    ``path`` with this ``max_depth``; 2 for ``direct``) at ``spp`` under
    ``memory_budget`` bytes of Dr.Jit memory. Estimate:
    :data:`REVERSE_BYTES_PER_SAMPLE_AND_DEPTH` x max_depth x pixels x spp."""
    size = scene.sensors()[0].film().crop_size()
    need = (REVERSE_BYTES_PER_SAMPLE_AND_DEPTH * max(int(max_depth), 2)
            * int(size[0]) * int(size[1]) * int(spp))
    return max(1, min(int(spp), math.ceil(need / float(memory_budget))))


def pass_seeds(seed, passes):
    """(primal seed, derivative seed) of each pass. Pass 0 uses ``seed`` and
    the derivative seed ``mi.render`` would use (``sample_tea_32(seed, 1)``),
    so that one pass reproduces ``mi.render``; later passes hash (seed, pass)."""
    out = []
    for p in range(int(passes)):
        primal = int(seed) if p == 0 else int(mi.sample_tea_32(int(seed), 1000 + p)[0])
        out.append((primal, int(mi.sample_tea_32(primal, 1)[0])))
    return out


@dataclass
class GradientStats:
    """What :func:`loss_and_gradient` measured."""
    method: str
    passes: int
    renders: int
    seconds: float
    drjit_peak_bytes: int  # Dr.Jit's allocation watermark during the call (LLVM or CUDA)


def _backend():
    return dr.JitBackend.CUDA if mi.variant().startswith("cuda") else dr.JitBackend.LLVM


def _scalar_grad(value):
    g = dr.grad(value)
    return np.array(g, dtype=np.float64).reshape(-1)


def loss_and_gradient(scene, params, keys: Sequence[str], loss: Callable, spp=16, seed=0,
                      method="reverse", passes=1, return_image=False, max_depth=None,
                      memory_budget=4 * 1024**3):
    """Loss of the rendered image and its gradient with respect to the scene
    parameters ``keys`` (entries of ``params = mi.traverse(scene)``).

    ``loss(image) -> mi.Float`` (e.g. :func:`stokes_loss`). ``method``:
    ``"reverse"`` (``passes`` AD renders; memory divided by ``passes``) or
    ``"forward"`` (memory independent of spp and depth; K + 1 renders for K
    scalar parameters); see the module docstring. ``passes="auto"`` (reverse
    mode) picks the number of passes that keeps Dr.Jit's memory under
    ``memory_budget`` for a ``path`` integrator of depth ``max_depth``
    (:func:`reverse_passes`). The primal image is rendered in ``passes`` parts
    in both methods.

    Returns ``(loss value, {key: gradient as float64 array}, stats)`` and, with
    ``return_image``, the primal image (NumPy) last. Gradients are left neither
    on ``params`` nor enabled afterwards.
    """
    if method not in ("forward", "reverse"):
        raise ValueError(f"method must be 'forward' or 'reverse', not {method!r}")
    keys = list(keys)
    if passes == "auto":
        if method != "reverse":
            passes = 1
        elif max_depth is None:
            raise ValueError("passes='auto' needs the integrator's max_depth")
        else:
            passes = reverse_passes(scene, spp, max_depth, memory_budget)
    integrator, sensor = scene.integrator(), scene.sensors()[0]
    seeds, spps = pass_seeds(seed, passes), split_spp(spp, passes)
    dr.sync_thread()
    dr.flush_malloc_cache()  # so that the watermark counts this call only
    dr.detail.malloc_clear_statistics()
    t0 = time.perf_counter()

    # 1. Primal image and the loss gradient with respect to it.
    for k in keys:
        dr.disable_grad(params[k])
    params.update()
    image = render(scene, spp, seed, passes)
    image = dr.detach(image)
    dr.enable_grad(image)
    value = loss(image)
    dr.backward(value)
    grad_image = dr.grad(image)
    dr.eval(grad_image)
    loss_value = float(np.asarray(dr.detach(value)).reshape(-1)[0])

    grads = {k: np.zeros(dr.width(params[k])) for k in keys}
    renders = passes
    try:
        if method == "reverse":
            for k in keys:
                dr.enable_grad(params[k])
            params.update()
            for (_, grad_seed), n in zip(seeds, spps):
                integrator.render_backward(scene, params, grad_image * (n / spp), sensor,
                                           seed=grad_seed, spp=n)
                renders += 1
            for k in keys:
                grads[k] = _scalar_grad(params[k])
        else:
            # Symbolic loops stay on: tangents are propagated inside the kernel.
            with dr.scoped_set_flag(dr.JitFlag.SymbolicLoops, True):
                for k in keys:
                    dr.enable_grad(params[k])
                params.update()
                for k in keys:
                    width = dr.width(params[k])
                    for j in range(width):
                        tangent = np.zeros(width, dtype=np.float32)
                        tangent[j] = 1.0
                        total = 0.0
                        for (_, grad_seed), n in zip(seeds, spps):
                            # (forward_to clears the input's gradient: set it every pass)
                            for other in keys:
                                dr.set_grad(params[other], 0.0)
                            dr.set_grad(params[k], type(params[k])(tangent) if width > 1 else 1.0)
                            img = integrator.render(scene, sensor, seed=grad_seed, spp=n,
                                                    develop=True, evaluate=False)
                            dr.forward_to(img)
                            d = dr.grad(img)
                            total += (n / spp) * float(dr.sum(d * grad_image, axis=None).array[0])
                            del img, d
                            renders += 1
                        grads[k][j] = total
    finally:
        for k in keys:
            dr.disable_grad(params[k])
        params.update()
    stats = GradientStats(method, int(passes), renders, time.perf_counter() - t0,
                          int(dr.detail.malloc_watermark(_backend())))
    if return_image:
        return loss_value, grads, stats, np.asarray(image)
    return loss_value, grads, stats


def jacobian(scene, params, keys: Sequence[str], spp=64, seed=0, passes=1):
    """Derivative images ``{key: d image / d key}`` (NumPy (H, W, C)) of the
    scalar parameters ``keys``, by forward-mode renders with symbolic loops
    (memory of a primal render), ``passes`` renders per key."""
    integrator, sensor = scene.integrator(), scene.sensors()[0]
    out = {}
    with dr.scoped_set_flag(dr.JitFlag.SymbolicLoops, True):
        try:
            for k in keys:
                if dr.width(params[k]) != 1:
                    raise ValueError(f"jacobian: {k!r} is not a scalar parameter")
                dr.enable_grad(params[k])
            params.update()
            for k in keys:
                total = None
                for (_, grad_seed), n in zip(pass_seeds(seed, passes), split_spp(spp, passes)):
                    for other in keys:  # forward_to clears the input's gradient
                        dr.set_grad(params[other], 0.0)
                    dr.set_grad(params[k], 1.0)
                    img = integrator.render(scene, sensor, seed=grad_seed, spp=n,
                                            develop=True, evaluate=False)
                    dr.forward_to(img)
                    d = np.asarray(dr.grad(img), dtype=np.float64) * (n / spp)
                    total = d if total is None else total + d
                out[k] = total
        finally:
            for k in keys:
                dr.disable_grad(params[k])
            params.update()
    return out


def fisher_information(jac: Mapping[str, np.ndarray], indices, noise):
    """Fisher information matrix (K x K) of the parameters whose derivative
    images ``jac`` holds, for pixels of the channels ``indices`` (e.g.
    ``sum(stokes_indices(scene, (0, 1, 2)), [])``) carrying independent
    Gaussian noise of standard deviation ``noise`` (scalar or per channel).
    Its inverse is the covariance of the maximum-likelihood estimate (the
    Cramer-Rao bound)."""
    keys = list(jac)
    noise = np.broadcast_to(np.asarray(noise, dtype=np.float64), (len(indices),))
    J = np.stack([np.concatenate([(jac[k][..., i] / s).ravel() for i, s in zip(indices, noise)])
                  for k in keys], axis=1)
    return J.T @ J


# ---------------------------------------------------------------------------
# Fitting BSDF parameters to target images with Adam
# ---------------------------------------------------------------------------

@dataclass
class FitResult:
    """History and outcome of :func:`fit_parameters` (parameters in the units
    of the scene's parameters)."""
    keys: list
    initial: Dict[str, float]
    final: Dict[str, float]
    loss: list = field(default_factory=list)          # per iteration
    trajectory: list = field(default_factory=list)    # per iteration: {key: value}
    seconds: float = 0.0
    peak_drjit_bytes: int = 0


def fit_parameters(scene, keys: Sequence[str], target, components=(0, 1, 2), initial=None,
                   iterations=100, lr=0.05, spp=8, seed=0, method="reverse", passes=1,
                   bounds=None, lr_decay=1.0, callback=None, max_depth=None):
    """Fit the positive scalar scene parameters ``keys`` so that the scene
    renders ``target`` (loss :func:`stokes_loss` on ``components``) with
    ``mi.ad.Adam`` on their logarithms (one learning rate ``lr`` = relative
    step for all; ``lr_decay`` multiplies it every iteration), a fresh seed
    every iteration.

    ``initial``: {key: starting value} (default: the scene's current values).
    ``bounds``: {key: (low, high)} clamps after each step. ``callback(it,
    loss, values)`` is called every iteration. Leaves the fitted values in the
    scene and returns a :class:`FitResult`.
    """
    params = mi.traverse(scene)
    keys = list(keys)
    for k in keys:
        if dr.width(params[k]) != 1:
            raise ValueError(f"fit_parameters fits scalar parameters; {k!r} has "
                             f"{dr.width(params[k])} values")
    values = {k: float(np.asarray(params[k]).reshape(-1)[0]) for k in keys}
    if initial:
        values.update({k: float(v) for k, v in initial.items()})
    if any(v <= 0 for v in values.values()):
        raise ValueError(f"fit_parameters fits positive parameters, got {values}")
    bounds = bounds or {}
    loss = stokes_loss(scene, target, components)
    opt = mi.ad.Adam(lr=lr)
    for k in keys:
        opt[k] = mi.Float(math.log(values[k]))
    result = FitResult(keys, dict(values), dict(values))
    t0 = time.perf_counter()
    peak = 0
    for it in range(int(iterations)):
        for k in keys:
            params[k] = mi.Float(values[k])
        params.update()
        value, grads, stats = loss_and_gradient(scene, params, keys, loss, spp=spp,
                                                seed=seed + it * 7919, method=method,
                                                passes=passes, max_depth=max_depth)
        peak = max(peak, stats.drjit_peak_bytes)
        result.loss.append(value)
        result.trajectory.append(dict(values))
        if callback is not None:
            callback(it, value, dict(values))
        for k in keys:  # d loss / d log(x) = x d loss / dx
            dr.set_grad(opt[k], mi.Float(grads[k][0] * values[k]))
        opt.step()
        for k in keys:
            v = math.exp(float(np.asarray(opt[k]).reshape(-1)[0]))
            low, high = bounds.get(k, (1e-4, 1e4))
            v = min(max(v, low), high)
            opt[k] = mi.Float(math.log(v))
            values[k] = v
        if lr_decay != 1.0:
            opt.set_learning_rate(lr * lr_decay ** (it + 1))
    for k in keys:
        params[k] = mi.Float(values[k])
    params.update()
    result.final = dict(values)
    result.seconds = time.perf_counter() - t0
    result.peak_drjit_bytes = peak
    return result
