"""Gradients of a loss on rendered Stokes images with respect to scene
parameters, Jacobian images and the Fisher information (which parameters an
image determines).

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

Passes and their seeds follow :mod:`mitsuba_pbrdf.imaging.passes`.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Callable, Mapping, Sequence

import drjit as dr
import mitsuba as mi
import numpy as np

from ..imaging.passes import derivative_seed, pass_seeds, plan_passes

__all__ = ["render", "reverse_passes", "GradientStats", "loss_and_gradient", "jacobian",
           "fisher_information"]


def _passes(seed, spp, passes):
    """(primal seed, derivative seed, spp) of each pass (:mod:`mitsuba_pbrdf.imaging.passes`)."""
    plan = plan_passes(spp, passes)
    return [(s, derivative_seed(s), n) for s, n in zip(pass_seeds(seed, len(plan)), plan)]


def render(scene, spp=16, seed=0, passes=1):
    """Primal render (no derivatives) of ``scene``'s first sensor as a
    ``mi.TensorXf`` (H, W, C), the samples split into ``passes`` renders
    (:func:`~mitsuba_pbrdf.imaging.passes.plan_passes`, seeds from
    :func:`~mitsuba_pbrdf.imaging.passes.pass_seeds`) whose mean it returns."""
    integrator, sensor = scene.integrator(), scene.sensors()[0]
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
    plan = _passes(seed, spp, passes)
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
    renders = len(plan)
    try:
        if method == "reverse":
            for k in keys:
                dr.enable_grad(params[k])
            params.update()
            for _, grad_seed, n in plan:
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
                        grads[k][j] = _forward_derivative(
                            scene, params, keys, k, type(params[k])(tangent) if width > 1 else 1.0,
                            plan, lambda d: float(dr.sum(d * grad_image, axis=None).array[0]))
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


def _forward_derivative(scene, params, keys, key, tangent, plan, reduce):
    """Sum over the passes ``plan`` of ``(n / spp) * reduce(d image)``, d image
    being the forward-mode derivative render along ``tangent`` of
    ``params[key]``. The caller has enabled the gradients of ``keys`` and
    switched symbolic loops on (tangents propagate inside the kernel: the
    memory of a primal render)."""
    integrator, sensor = scene.integrator(), scene.sensors()[0]
    spp = sum(n for _, _, n in plan)
    total = None
    for _, grad_seed, n in plan:
        for other in keys:  # forward_to clears the input's gradient: set it every pass
            dr.set_grad(params[other], 0.0)
        dr.set_grad(params[key], tangent)
        img = integrator.render(scene, sensor, seed=grad_seed, spp=n, develop=True,
                                evaluate=False)
        dr.forward_to(img)
        part = reduce(dr.grad(img)) * (n / spp)
        total = part if total is None else total + part
        del img
    return total


def jacobian(scene, params, keys: Sequence[str], spp=64, seed=0, passes=1):
    """Derivative images ``{key: d image / d key}`` (NumPy (H, W, C)) of the
    scalar parameters ``keys``, by forward-mode renders with symbolic loops
    (memory of a primal render), ``passes`` renders per key."""
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
                                             lambda d: np.asarray(d, dtype=np.float64))
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
