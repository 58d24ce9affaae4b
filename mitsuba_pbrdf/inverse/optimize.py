"""Fitting BSDF parameters to target Stokes images with Adam."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Dict, Sequence

import drjit as dr
import mitsuba as mi
import numpy as np

from ..rendering.passes import plan_passes
from .driver import learning_rates, run_adam
from .gradients import gradient_method, loss_and_gradient, resolve_passes
from .losses import stokes_loss

__all__ = ["OptimizationResult", "fit_parameters"]


@dataclass
class OptimizationResult:
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
                   iterations=100, lr=0.05, spp=8, seed=0, method="auto", passes=1,
                   bounds=None, lr_decay=1.0, callback=None, max_depth=None):
    """Fit the positive scalar scene parameters ``keys`` so that the scene
    renders ``target`` (loss :func:`stokes_loss` on ``components``) with
    ``mi.ad.Adam`` on their logarithms (one learning rate ``lr`` = relative
    step for all; ``lr_decay`` multiplies it every iteration), fresh seeds
    every iteration (:mod:`.driver`).

    ``initial``: {key: starting value} (default: the scene's current values).
    ``bounds``: {key: (low, high)} clamps after each step. ``callback(it,
    loss, values)`` is called every iteration, with the values the loss was
    rendered with. Leaves the fitted values in the scene and returns an
    :class:`OptimizationResult`.
    """
    params = mi.traverse(scene)
    keys = list(keys)
    values = _start_values(params, keys, initial)
    bounds = bounds or {}
    loss = stokes_loss(scene, target, components)
    method = gradient_method(scene, method)
    passes = resolve_passes(scene, method, passes, spp, max_depth)
    result = OptimizationResult(keys, dict(values), dict(values))

    def gradient(opt, it, seeds):  # seeds: the passes' of this iteration
        for k in keys:
            params[k] = mi.Float(values[k])
        params.update()
        value, grads, stats = loss_and_gradient(scene, params, keys, loss, spp=spp,
                                                seed=seeds[0], method=method, passes=passes,
                                                max_depth=max_depth)
        result.peak_drjit_bytes = max(result.peak_drjit_bytes, stats.drjit_peak_bytes)
        result.trajectory.append(dict(values))
        for k in keys:  # d loss / d log(x) = x d loss / dx
            dr.set_grad(opt[k], mi.Float(grads[k][0] * values[k]))
        return value

    def clamp(opt):
        for k in keys:
            low, high = bounds.get(k, (1e-4, 1e4))
            values[k] = min(max(math.exp(float(np.asarray(opt[k]).reshape(-1)[0])), low), high)
            opt[k] = mi.Float(math.log(values[k]))

    def progress(it, value):
        if callback is not None:
            callback(it, value, dict(result.trajectory[it]))

    run = run_adam({k: mi.Float(math.log(values[k])) for k in keys}, gradient,
                   learning_rates(lr, int(iterations), lr_decay=lr_decay), seed=seed,
                   renders=len(plan_passes(spp, passes)), clamp=clamp, callback=progress)
    for k in keys:
        params[k] = mi.Float(values[k])
    params.update()
    result.loss, result.final, result.seconds = run.loss, dict(values), run.seconds
    return result


def _start_values(params, keys, initial) -> dict:
    """{key: starting value}: *initial*'s, else the scene's; ValueError unless
    every parameter is a positive scalar."""
    for k in keys:
        if dr.width(params[k]) != 1:
            raise ValueError(f"fit_parameters fits scalar parameters; {k!r} has "
                             f"{dr.width(params[k])} values")
    values = {k: float(np.asarray(params[k]).reshape(-1)[0]) for k in keys}
    if initial:
        values.update({k: float(v) for k, v in initial.items()})
    if any(v <= 0 for v in values.values()):
        raise ValueError(f"fit_parameters fits positive parameters, got {values}")
    return values
