"""The one Adam loop of :mod:`mitsuba_pbrdf.inverse`: :func:`run_adam`.

:func:`~mitsuba_pbrdf.inverse.optimize.fit_parameters`,
:func:`~mitsuba_pbrdf.inverse.normals.recover_normals` and
:func:`~mitsuba_pbrdf.inverse.svbrdf.recover` each say what one iteration's
loss and gradient are; the loop around them is this one, the same for all:

* **seeds**: the renders of a fit are numbered in order (iteration ``it``'s
  ``k``-th render is render ``it * renders + k``) and seeded as the passes of
  one long render, :func:`~mitsuba_pbrdf.rendering.passes.pass_seeds`
  (:func:`iteration_seeds`), so no two renders of a fit share a seed; the
  derivative render of each gets
  :func:`~mitsuba_pbrdf.rendering.passes.derivative_seed` of its seed (from
  ``mi.render``, or from :func:`~mitsuba_pbrdf.inverse.gradients.loss_and_gradient`).
* **learning rate**: one value per iteration, :func:`learning_rates`:
  constant, ``lr * lr_decay**it``, or a geometric decay from ``lr`` to
  ``lr * lr_end`` at the last iteration.
* **after each step**: ``clamp(optimizer)`` puts the variables back in their
  feasible set (bounds, unit normals), then ``callback(it, loss)`` reports
  progress.
* **Ctrl-C**: nothing is caught. The ``KeyboardInterrupt`` (or the
  ``RuntimeError`` Dr.Jit wraps it in, :func:`mitsuba_pbrdf.interrupts.interrupted`)
  leaves the loop at once: no result, no callback for the interrupted
  iteration. The command line releases SIGINT before the fit starts
  (:mod:`mitsuba_pbrdf.interrupts`) and writes its outputs only after it.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable, List, Mapping, Optional

import numpy as np

from ..rendering.passes import pass_seeds

__all__ = ["LR_END", "learning_rates", "iteration_seeds", "AdamRun", "run_adam"]

#: Learning rate at the last iteration as a fraction of the first (the default decay).
LR_END = 0.1


def learning_rates(lr, iterations, lr_end=LR_END, lr_decay=None) -> np.ndarray:
    """The learning rate of every iteration: ``lr * lr_decay**it`` when
    *lr_decay* is given (1: constant), else a geometric decay from *lr* at the
    first iteration to ``lr * lr_end`` at the last, whatever the number of
    iterations (so a longer fit does not freeze early)."""
    if lr_decay is None:
        lr_decay = lr_end ** (1.0 / max(iterations - 1, 1))
    return lr * lr_decay ** np.arange(iterations, dtype=np.float64)


def iteration_seeds(seed: int, iteration: int, renders: int = 1) -> list:
    """The sampler seeds of iteration *iteration*'s *renders* renders (views,
    or passes): renders ``iteration * renders`` to ``(iteration + 1) * renders
    - 1`` of :func:`~mitsuba_pbrdf.rendering.passes.pass_seeds` (*seed*)."""
    return pass_seeds(seed, renders, first=iteration * renders)


@dataclass
class AdamRun:
    """What :func:`run_adam` returns: the optimizer (its variables hold the
    last iterate, clamped), the loss per iteration and the loop's wall time."""
    optimizer: object
    loss: List[float] = field(default_factory=list)
    seconds: float = 0.0


def run_adam(variables: Mapping, gradient: Callable, rates, *, seed: int = 0, renders: int = 1,
             clamp: Optional[Callable] = None,
             callback: Optional[Callable[[int, float], None]] = None) -> AdamRun:
    """Adam (``mi.ad.Adam``) on *variables* for ``len(rates)`` iterations.

    variables: {name: Dr.Jit array}, the starting point (the optimizer holds
    copies). ``gradient(optimizer, it, seeds) -> loss``: the loss of iteration
    *it* at the optimizer's variables, its gradient left on them
    (``dr.backward`` or ``dr.set_grad``); *seeds* are the iteration's
    *renders* sampler seeds (:func:`iteration_seeds`). rates: the learning
    rate of each iteration (:func:`learning_rates`). ``clamp(optimizer)``
    after each step, then ``callback(it, loss)``. See the module docstring.
    """
    import mitsuba as mi

    rates = [float(rate) for rate in rates]
    optimizer = mi.ad.Adam(lr=rates[0] if rates else 0.0)
    for name, value in variables.items():
        optimizer[name] = value
    run = AdamRun(optimizer)
    t0 = time.perf_counter()
    for it, rate in enumerate(rates):
        optimizer.set_learning_rate(rate)
        value = float(gradient(optimizer, it, iteration_seeds(seed, it, renders)))
        optimizer.step()
        if clamp is not None:
            clamp(optimizer)
        run.loss.append(value)
        if callback is not None:
            callback(it, value)
    run.seconds = time.perf_counter() - t0
    return run
