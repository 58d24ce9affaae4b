"""Gradients with respect to ``polarized_sky``'s ``dolp_max`` through the
package's ``stokes_prb`` integrator, against finite differences.

A copper ``pbrdf`` sphere on a rough aluminium ground under the sky, max
depth 3 (the sky seen, reflected, and sampled by next-event estimation). The
loss is the sum of the S1 and S2 channels. No sampled direction depends on
``dolp_max`` and the emitted Stokes vector is linear in it, so the loss is
exactly linear: a finite difference over the whole range [0, 0.6] with the
same random numbers is the derivative, up to float32 rounding of the summed
image (432 pixels x 6 channels, each sum's relative error <= 2592 x 6e-8 =
1.6e-4 in the worst case, typically far less): ``REL = 2e-4``.

``mi.render`` draws the gradient pass's random numbers from its own seed
(``seed_grad``, different from the primal's by default, so that a loss and
its gradient are not correlated): the finite difference uses that seed.
"""

import drjit as dr
import mitsuba as mi
import numpy as np
import pytest

from proof import polarized_light as pl

REL = 2e-4
SUN = pl.sun_vector(35.0, 40.0)


def scene(integrator, model):
    return mi.load_dict({
        "type": "scene", "integrator": integrator,
        "sensor": pl.camera([0, -3, 1.2], [0, 0, 0.3], [0, 0, 1], fov=40, width=24, height=18),
        "sky": {"type": "polarized_sky", "sun_direction": SUN.tolist(), "dolp_max": 0.6,
                "model": model},
        "sphere": {"type": "sphere", "center": [0, 0, 0.5], "radius": 0.5,
                   "bsdf": {"type": "pbrdf", "material": "Cu", "sigma": 0.1, "kdd": 0.1}},
        "ground": {"type": "rectangle", "to_world": mi.ScalarTransform4f().scale(10),
                   "bsdf": {"type": "roughconductor", "material": "Al", "alpha": 0.2}}})


def loss(image):
    return dr.sum(dr.ravel(sum(image[..., c] for c in range(6, 12))))


@pytest.mark.parametrize("model", ["rayleigh", "berry"])
def test_stokes_prb_gradient_of_dolp_max_matches_finite_differences(model):
    prb = scene({"type": "stokes_prb", "max_depth": 3}, model)
    path = scene({"type": "stokes", "inner": {"type": "path", "max_depth": 3}}, model)
    params = mi.traverse(prb)
    key = "sky.dolp_max"

    def loss_at(value):
        params[key] = value
        params.update()
        return float(loss(mi.render(prb, spp=16, seed=4))[0])

    slope = (loss_at(0.6) - loss_at(0.0)) / 0.6
    assert abs(loss_at(0.3) - 0.3 * slope - loss_at(0.0)) < REL * abs(0.3 * slope)   # linear
    # stokes_prb renders what stokes + path renders
    params[key] = 0.6
    params.update()
    assert np.abs(np.array(mi.render(prb, spp=16, seed=4))
                  - np.array(mi.render(path, spp=16, seed=4))).max() < 1e-5
    dr.enable_grad(params[key])
    params.update()
    dr.backward(loss(mi.render(prb, params, spp=16, seed=3, seed_grad=4)))
    gradient = float(dr.grad(params[key])[0])
    assert abs(slope) > 1          # not vacuous
    assert abs(gradient - slope) < REL * abs(slope), (gradient, slope)
