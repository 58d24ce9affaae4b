"""Gradients of a loss on rendered Stokes images with respect to scene
parameters, Jacobian images and the Fisher information (which parameters an
image determines).

**Methods.**

* ``method="prb"``: polarized path replay, the package's ``stokes_prb``
  integrator (docs/path-replay.md), built from the scene's ``stokes``/``path``
  (same ``max_depth``, ``rr_depth``, ``hide_emitters``). One primal render and
  one replay of all samples: memory of a primal render, whatever the number
  of samples, the depth or the number of parameters (textures included).
  ``method="auto"`` (the default) uses it wherever the scene allows
  (:func:`mitsuba_pbrdf.integrators.stokes_prb.supports_scene`: ``stokes``
  around ``path`` with a finite depth, an RGB film), else ``"reverse"``.
* ``method="reverse"``: the scene's own integrator (``path``, ``direct``...)
  differentiated by reverse-mode AD, which records every bounce of every
  sample: memory grows as pixels x spp x depth (~2.1 kB per sample at
  max_depth 4; 512 x 512 at 64 spp would need ~35 GiB), so the samples can
  be split into ``passes`` (``passes="auto"`` sizes them for a memory budget)
  whose gradients are accumulated.
* ``method="forward"``: one forward-mode derivative render per scalar
  parameter (``render_forward`` of ``stokes_prb``, or the scene's integrator
  with Dr.Jit's symbolic loops kept on): memory of a primal render, K + 1
  renders for K parameters.

**Mitsuba 3.9's path AD and polarization.** When a sampled BSDF direction
depends on a differentiated parameter (a roughness, or any parameter of
``pbrdf``'s lobe-mixture sampling), Mitsuba's ``path`` re-evaluates the BSDF
weight but leaves it in the BSDF's local Stokes frame: S1 and S2 of those
renders, and their derivatives, are wrong (validation/inverse_memory.md).
``stokes_prb`` rotates every Mueller matrix into the world frames, so
``"prb"``/``"auto"`` are the methods to use for polarized gradients of
``path`` scenes; ``"reverse"`` and ``"forward"`` through ``path`` are exact
where the sampled directions do not depend on the parameters (e.g.
``sampling="cosine"``, ``diffuse``), and with ``direct``.

The memory and time of ``prb`` against reverse mode in passes and forward
mode, with the command that measures them: validation/inverse_memory.md.

With ``passes=1`` and the same seed, the reverse and forward methods give
what ``mi.render`` and ``dr.backward`` give with the scene's integrator (the
same paths, the same estimator; tested), and ``"prb"`` what they give with
``stokes_prb``. The seed of the derivative renders differs from the primal
one, as in ``mi.render``, so the gradient of a non-linear loss is unbiased.

Passes and their seeds follow :mod:`mitsuba_pbrdf.rendering.passes`.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Callable, Mapping, Sequence

import drjit as dr
import mitsuba as mi
import numpy as np

from ..rendering.passes import derivative_seed, pass_seeds, plan_passes

__all__ = ["METHODS", "render", "reverse_passes", "GradientStats", "gradient_method",
           "resolve_passes", "loss_and_gradient", "summed_gradients", "jacobian",
           "fisher_information"]

#: Gradient methods of :func:`loss_and_gradient` (see the module docstring).
METHODS = ("auto", "prb", "reverse", "forward")


def _passes(seed, spp, passes):
    """(primal seed, derivative seed, spp) of each pass (:mod:`mitsuba_pbrdf.rendering.passes`)."""
    plan = plan_passes(spp, passes)
    return [(s, derivative_seed(s), n) for s, n in zip(pass_seeds(seed, len(plan)), plan)]


def render(scene, spp=16, seed=0, passes=1, integrator=None):
    """Primal render (no derivatives) of ``scene``'s first sensor as a
    ``mi.TensorXf`` (H, W, C), the samples split into ``passes`` renders
    (:func:`~mitsuba_pbrdf.rendering.passes.plan_passes`, seeds from
    :func:`~mitsuba_pbrdf.rendering.passes.pass_seeds`) whose mean it returns.
    ``integrator``: another integrator than the scene's (default)."""
    integrator = integrator or scene.integrator()
    sensor = scene.sensors()[0]
    image = None
    with dr.suspend_grad():
        for primal_seed, _, n in _passes(seed, spp, passes):
            part = integrator.render(scene, sensor, seed=primal_seed, spp=n, develop=True,
                                     evaluate=False) * (n / spp)
            image = part if image is None else image + part
            dr.eval(image)
    return image


#: Dr.Jit memory of reverse-mode AD through ``path`` per sample and unit of
#: ``max_depth`` (bytes), measured with validation/inverse_memory.py: 2.06 kB
#: per sample at max_depth 4 on the pbrdf sphere scene, 1.9 kB at depth 3 with
#: ``roughconductor``; rounded up.
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


def gradient_method(scene, method="auto"):
    """The method :func:`loss_and_gradient` uses for ``method`` on ``scene``:
    ``"auto"`` becomes ``"prb"`` where ``stokes_prb`` can replay the scene's
    integrator, else ``"reverse"``. Raises ``ValueError`` for an unknown
    method or ``"prb"`` on a scene it cannot replay (saying why)."""
    from ..integrators import supports_scene

    if method not in METHODS:
        raise ValueError(f"method must be one of {', '.join(METHODS)}, not {method!r}")
    if method in ("auto", "prb"):
        ok, why = supports_scene(scene)
        if method == "prb" and not ok:
            raise ValueError(f"method='prb' needs stokes around path: {why}")
        return "prb" if ok else "reverse"
    return method


def resolve_passes(scene, method, passes, spp, max_depth=None, memory_budget=4 * 1024**3):
    """What ``passes`` means for :func:`loss_and_gradient` with *method* (as
    :func:`gradient_method` returns it): ``"auto"`` is :func:`reverse_passes`
    in reverse mode (which needs *max_depth*), else 1; a count or None as given
    (:func:`~mitsuba_pbrdf.rendering.passes.plan_passes` reads it)."""
    if passes != "auto":
        return passes
    if method != "reverse":
        return 1
    if max_depth is None:
        raise ValueError("passes='auto' needs the integrator's max_depth")
    return reverse_passes(scene, spp, max_depth, memory_budget)


def _is_replay(integrator):
    from ..integrators import integrator_class

    return isinstance(integrator, integrator_class())


def _replay_integrator(scene):
    from ..integrators import from_path

    return from_path(scene)


def loss_and_gradient(scene, params, keys: Sequence[str], loss: Callable, spp=16, seed=0,
                      method="auto", passes=1, return_image=False, max_depth=None,
                      memory_budget=4 * 1024**3):
    """Loss of the rendered image and its gradient with respect to the scene
    parameters ``keys`` (entries of ``params = mi.traverse(scene)``).

    ``loss(image) -> mi.Float`` (e.g. :func:`stokes_loss`). ``method``:
    ``"auto"`` (``"prb"`` where the scene allows it, else ``"reverse"``),
    ``"prb"`` (polarized path replay: memory of a primal render), ``"reverse"``
    (``passes`` AD renders; memory divided by ``passes``) or ``"forward"``
    (memory independent of spp and depth; K + 1 renders for K scalar
    parameters); see the module docstring. ``passes="auto"`` (reverse mode)
    picks the number of passes that keeps Dr.Jit's memory under
    ``memory_budget`` for a ``path`` integrator of depth ``max_depth``
    (:func:`reverse_passes`); other methods then use 1. The primal image is
    rendered in ``passes`` parts in all methods.

    Returns ``(loss value, {key: gradient as float64 array}, stats)`` and, with
    ``return_image``, the primal image (NumPy) last. Gradients are left neither
    on ``params`` nor enabled afterwards.
    """
    method = gradient_method(scene, method)
    keys = list(keys)
    passes = resolve_passes(scene, method, passes, spp, max_depth, memory_budget)
    integrator, sensor = scene.integrator(), scene.sensors()[0]
    plan = _passes(seed, spp, passes)
    dr.sync_thread()
    dr.flush_malloc_cache()  # so that the watermark counts this call only
    dr.detail.malloc_clear_statistics()
    t0 = time.perf_counter()

    # 1. Primal image and the loss gradient with respect to it.
    for k in keys:
        dr.disable_grad(params[k])
    params.update()
    # With path replay, stokes_prb renders the primal image too: the same
    # paths as the scene's stokes + path (same random numbers) in 0.90 to 0.95
    # of its time (validation/prb_profile.md).
    image = render(scene, spp, seed, passes,
                   integrator=_replay_integrator(scene) if method == "prb" else None)
    image = dr.detach(image)
    dr.enable_grad(image)
    value = loss(image)
    dr.backward(value)
    grad_image = dr.grad(image)
    dr.eval(grad_image)
    loss_value = float(np.asarray(dr.detach(value)).reshape(-1)[0])

    grads = {k: np.zeros(dr.width(params[k])) for k in keys}
    renders = len(plan)
    try:
        if method in ("reverse", "prb"):
            backward = integrator if method == "reverse" else _replay_integrator(scene)
            for k in keys:
                dr.enable_grad(params[k])
            params.update()
            for _, grad_seed, n in plan:
                backward.render_backward(scene, params, grad_image * (n / spp), sensor,
                                         seed=grad_seed, spp=n)
                renders += 1
            for k in keys:
                grads[k] = _scalar_grad(params[k])
        else:
            # Symbolic loops stay on: tangents are propagated inside the kernel.
            own_replay = integrator if _is_replay(integrator) else None
            with dr.scoped_set_flag(dr.JitFlag.SymbolicLoops, True):
                for k in keys:
                    dr.enable_grad(params[k])
                params.update()
                for k in keys:
                    width = dr.width(params[k])
                    for j in range(width):
                        tangent = np.zeros(width, dtype=np.float32)
                        tangent[j] = 1.0
                        grads[k][j] = _forward_derivative(
                            scene, params, keys, k, type(params[k])(tangent) if width > 1 else 1.0,
                            plan, lambda d: float(dr.sum(d * grad_image, axis=None).array[0]),
                            integrator=own_replay)
                        renders += len(plan)
    finally:
        for k in keys:
            dr.disable_grad(params[k])
        params.update()
    stats = GradientStats(method, len(plan), renders, time.perf_counter() - t0,
                          int(dr.detail.malloc_watermark(_backend())))
    if return_image:
        return loss_value, grads, stats, np.asarray(image)
    return loss_value, grads, stats


def _forward_derivative(scene, params, keys, key, tangent, plan, reduce, integrator=None):
    """Sum over the passes ``plan`` of ``(n / spp) * reduce(d image)``, d image
    being the forward-mode derivative render along ``tangent`` of
    ``params[key]``. The caller has enabled the gradients of ``keys`` and
    switched symbolic loops on (tangents propagate inside the kernel: the
    memory of a primal render). ``integrator``: a ``stokes_prb`` integrator
    (its ``render_forward``), else the scene's (a render differentiated
    forward)."""
    sensor = scene.sensors()[0]
    spp = sum(n for _, _, n in plan)
    total = None
    for _, grad_seed, n in plan:
        for other in keys:  # forward_to clears the input's gradient: set it every pass
            dr.set_grad(params[other], 0.0)
        dr.set_grad(params[key], tangent)
        if integrator is not None:
            d_image = integrator.render_forward(scene, params, sensor, seed=grad_seed, spp=n)
        else:
            d_image = _forward_render(scene, sensor, grad_seed, n)
        part = reduce(d_image) * (n / spp)
        total = part if total is None else total + part
    return total


#: Dr.Jit's refusal that forward mode through the scene's own integrator can
#: meet (docs/inverse-rendering.md, "Forward mode and Dr.Jit's isolation scopes").
ISOLATION_REFUSAL = "isolate_grad() scope"


def _forward_render(scene, sensor, seed, spp):
    """The forward-mode derivative image of one render by the scene's own
    integrator (the tangents already set on the parameters). Dr.Jit 1.x can
    refuse to propagate tangents into the symbolic loop and call that hold a
    Python BSDF, depending on what the process did before (seen with
    ``pbrdf``, never with Mitsuba's ``roughconductor``); that refusal becomes a
    one-line RuntimeError naming the methods that work."""
    img = scene.integrator().render(scene, sensor, seed=seed, spp=spp, develop=True,
                                    evaluate=False)
    try:
        dr.forward_to(img)
    except RuntimeError as error:
        if ISOLATION_REFUSAL not in str(error):
            raise
        raise RuntimeError(
            "forward mode through the scene's own integrator: Dr.Jit refused to propagate "
            "the tangents into its symbolic loop and calls (a known limitation, "
            "docs/inverse-rendering.md); render with a stokes integrator around path "
            "(method='prb'), or use method='reverse' for the gradient of a loss") from None
    return dr.grad(img)


def jacobian(scene, params, keys: Sequence[str], spp=64, seed=0, passes=1, method="auto"):
    """Derivative images ``{key: d image / d key}`` (NumPy (H, W, C)) of the
    scalar parameters ``keys``, by forward-mode renders (memory of a primal
    render), ``passes`` renders per key: ``stokes_prb``'s ``render_forward``
    where the scene allows it (``method="auto"`` or ``"prb"``), else the
    scene's integrator with symbolic loops (``"forward"``)."""
    method = gradient_method(scene, method)
    replay = _replay_integrator(scene) if method == "prb" else None
    out = {}
    with dr.scoped_set_flag(dr.JitFlag.SymbolicLoops, True):
        try:
            for k in keys:
                if dr.width(params[k]) != 1:
                    raise ValueError(f"jacobian: {k!r} is not a scalar parameter")
                dr.enable_grad(params[k])
            params.update()
            plan = _passes(seed, spp, passes)
            for k in keys:
                out[k] = _forward_derivative(scene, params, keys, k, 1.0, plan,
                                             lambda d: np.asarray(d, dtype=np.float64),
                                             integrator=replay)
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


def summed_gradients(view_losses, variables):
    """Back-propagate every view's loss on its own and leave the sum of the
    views' gradients on *variables* (Dr.Jit arrays with gradients enabled).

    view_losses: callables, each building its view's loss (an ``mi.Float``
    of one entry) on a fresh graph from *variables*. Returns the losses'
    values and the norm of each view's gradient of ``variables[0]``. The
    gradients are read after each view and summed here because, with the
    normal map's texels set from the variable (``params[key] = f(x)``,
    ``params.update()``) before each view's ``mi.render`` with
    ``stokes_prb``, a plain loop of ``dr.backward`` calls leaves the variable
    holding the last view's gradient alone (tests/inverse/test_normals.py
    asserts it): such a fit fitted the last view only. (Where the scene
    parameters are the optimizer's variables themselves, as in
    :mod:`.svbrdf`, the loop's gradients do add up.)"""
    sums, values, norms = [None] * len(variables), [], []
    for view_loss in view_losses:
        for var in variables:
            dr.clear_grad(var)
        value = view_loss()
        dr.backward(value)
        values.append(float(value[0]))
        grads = [dr.grad(var) for var in variables]
        dr.eval(grads)
        norms.append(float(np.linalg.norm(np.array(grads[0], np.float64))))
        sums = [g if total is None else total + g for total, g in zip(sums, grads)]
        dr.eval(sums)
    for var, total in zip(variables, sums):
        dr.set_grad(var, total)
    return values, norms
