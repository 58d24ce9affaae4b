"""Derivatives of a fixed linear functional of a rendered image with respect to
scene parameters, in reverse or forward mode: what tests/integrators/test_stokes_prb.py and
validation/path_replay_gradients.py compare between integrators (``stokes_prb``
against Mitsuba's ``path`` in AD mode), entry by entry.

The functional is ``sum(image * weights)`` over every pixel and channel (a
Stokes image has 15: R, G, B and S0..S3 per band), so with random weights its
gradient checks every Stokes component at once. A Mitsuba variant must be set.
"""

import drjit as dr
import mitsuba as mi
import numpy as np

__all__ = ["random_functional", "functional_gradient"]


def random_functional(height: int, width: int, channels: int = 15, seed: int = 0):
    """Standard normal weights, shape (height, width, channels), as ``mi.TensorXf``."""
    rng = np.random.default_rng(seed)
    return mi.TensorXf(rng.normal(size=(height, width, channels)).astype(np.float32))


def functional_gradient(scene, keys, weights, *, spp: int, seed: int, seed_grad: int,
                        integrator=None, mode: str = "reverse") -> np.ndarray:
    """d/dp of ``sum(render * weights)`` for every entry p of the parameters
    *keys* (``mi.traverse`` names), in their order, as float64. ``reverse``: one
    ``dr.backward``; ``forward``: one ``dr.forward_to`` render per entry. The
    renders use *seed* (primal) and *seed_grad* (derivative); *integrator*
    None is the scene's own. The parameters' gradients are disabled again."""
    if mode not in ("reverse", "forward"):
        raise ValueError(f"mode must be 'reverse' or 'forward', got {mode!r}")
    params = mi.traverse(scene)
    for k in keys:
        dr.enable_grad(params[k])
    params.update()

    def render():
        return mi.render(scene, params, integrator=integrator, spp=spp, seed=seed,
                         seed_grad=seed_grad)

    out = []
    if mode == "reverse":
        dr.backward(dr.sum(render() * weights, axis=None))
        out = np.concatenate([np.array(dr.grad(params[k]), dtype=np.float64).ravel()
                              for k in keys])
    else:
        for key in keys:
            for j in range(dr.width(params[key])):
                for k in keys:
                    dr.set_grad(params[k], 0.0)
                tangent = np.zeros(dr.width(params[key]), dtype=np.float32)
                tangent[j] = 1.0
                dr.set_grad(params[key], type(params[key])(tangent))
                image = render()
                dr.forward_to(image)
                out.append(float(dr.sum(dr.grad(image) * weights, axis=None).array[0]))
        out = np.array(out)
    for k in keys:
        dr.disable_grad(params[k])
    params.update()
    return out
