"""Fitting BSDF parameters to target Stokes images with Adam."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Dict, Sequence

import drjit as dr
import mitsuba as mi
import numpy as np

from .gradients import loss_and_gradient
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
    step for all; ``lr_decay`` multiplies it every iteration), a fresh seed
    every iteration.

    ``initial``: {key: starting value} (default: the scene's current values).
    ``bounds``: {key: (low, high)} clamps after each step. ``callback(it,
    loss, values)`` is called every iteration. Leaves the fitted values in the
    scene and returns an :class:`OptimizationResult`.
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
    result = OptimizationResult(keys, dict(values), dict(values))
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
