"""The gradient of :func:`~mitsuba_pbrdf.inverse.normals.recover_normals`'s
loss summed over views (:func:`summed_gradients`)."""

from __future__ import annotations

import numpy as np


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
