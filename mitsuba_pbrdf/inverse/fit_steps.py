"""The pieces of :func:`~mitsuba_pbrdf.inverse.normals.recover_normals`'s
Adam loop: the learning-rate schedule (:func:`learning_rates`) and the
gradient of a loss summed over views (:func:`summed_gradients`)."""

from __future__ import annotations

import numpy as np

#: Learning rate at the last iteration as a fraction of the first (the default schedule).
LR_END = 0.1


def learning_rates(lr, iterations, lr_end=LR_END, lr_decay=None) -> np.ndarray:
    """The learning rate of every iteration: ``lr * lr_decay**it`` when
    *lr_decay* is given, else a geometric decay from *lr* at the first
    iteration to ``lr * lr_end`` at the last, whatever the number of
    iterations (so a longer fit does not freeze early)."""
    if lr_decay is None:
        lr_decay = lr_end ** (1.0 / max(iterations - 1, 1))
    return lr * lr_decay ** np.arange(iterations, dtype=np.float64)


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
    holding the last view's gradient alone (tests/test_normal_recovery.py
    asserts it): such a fit fitted the last view only. (Where the scene
    parameters are the optimizer's variables themselves, as in
    :mod:`.svbrdf`, the loop's gradients do add up: measured.)"""
    import drjit as dr

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
