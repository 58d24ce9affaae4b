"""Is each view's texel gradient of recover_normals's loss a descent direction?
For the plate of proof/sfp_study.py (aluminium or copper, three views, flat
start), the gradient of every view's loss by stokes_prb at high spp, and the
central finite difference of that view's loss along the summed gradient's
direction (the same random numbers on both sides). Run by
validation/sfp_accuracy.py ``run view-gradients``; prints one line per view.
"""

from __future__ import annotations

import numpy as np


def _flat_plate(metal, texels, size, target_spp):
    """The three views' targets of the true plate, the plate with a flat
    normal map, its normal map's parameter key, its parameters, a stokes_prb
    of depth 3 and the flat map's texels (a tensor in colour encoding)."""
    import mitsuba as mi

    from mitsuba_pbrdf.inverse.normals import scenes as ns
    from mitsuba_pbrdf.inverse.normals.inputs import find_normalmap

    truth = ns.true_normals(texels)
    targets = ns.render_targets(mi.load_dict(ns.plate_scene(truth, metal=metal, views=3,
                                                            size=size)), spp=target_spp)
    flat = np.zeros_like(truth)
    flat[..., 2] = 1.0
    scene = mi.load_dict(ns.plate_scene(flat, metal=metal, views=3, size=size))
    key, _ = find_normalmap(scene)
    params = mi.traverse(scene)
    integrator = mi.load_dict({"type": "stokes_prb", "max_depth": 3})
    base = mi.TensorXf(((flat + 1.0) / 2.0).astype(np.float32))
    return targets, scene, key, params, integrator, base


def view_gradients(metal="Al", spp=256, eps=2e-3, texels=16, size=48, target_spp=256):
    """``{view: (g . d, FD of L along d, |g|)}`` with d the unit direction of
    minus the summed gradient; a descent direction has both negative."""
    import drjit as dr
    import mitsuba as mi

    from mitsuba_pbrdf.inverse.normals.targets import observable_loss

    targets, scene, key, params, integrator, base = _flat_plate(metal, texels, size, target_spp)
    losses = [observable_loss(scene, t, "stokes", sensor=i) for i, t in enumerate(targets)]
    grads = []
    for view, loss in enumerate(losses):
        x = mi.TensorXf(base)
        dr.enable_grad(x)
        params[key] = x
        params.update()
        value = loss(mi.render(scene, params, sensor=view, integrator=integrator, spp=spp,
                               seed=5))
        dr.backward(value)
        grads.append(np.array(dr.grad(x), np.float64))
    total = sum(grads)
    d = -total / np.linalg.norm(total)

    def value_at(step, view):
        params[key] = mi.TensorXf((np.array(base) + step * d).astype(np.float32))
        params.update()
        return float(losses[view](mi.render(scene, params, sensor=view, integrator=integrator,
                                             spp=spp, seed=5))[0])

    out = {}
    for view in range(3):
        fd = (value_at(eps, view) - value_at(-eps, view)) / (2 * eps)
        out[view] = (float(np.sum(grads[view] * d)), fd, float(np.linalg.norm(grads[view])))
    return out


def gradient_noise(metal="Al", spp=16, seeds=8, reference_spp=1024, texels=16, size=48,
                   target_spp=256):
    """``{view: (|mean gradient at reference_spp|, RMS over seeds of |g_spp - that|)}``
    at the flat start: how much of each view's per-iteration gradient is noise."""
    import drjit as dr
    import mitsuba as mi

    from mitsuba_pbrdf.inverse.normals.targets import observable_loss

    targets, scene, key, params, integrator, base = _flat_plate(metal, texels, size, target_spp)

    def grad(view, n, seed):
        loss = observable_loss(scene, targets[view], "stokes", sensor=view)
        x = mi.TensorXf(base)
        dr.enable_grad(x)
        params[key] = x
        params.update()
        dr.backward(loss(mi.render(scene, params, sensor=view, integrator=integrator, spp=n,
                                   seed=seed)))
        return np.array(dr.grad(x), np.float64).ravel()

    out = {}
    for view in range(3):
        mean = grad(view, reference_spp, 999)
        noise = [np.linalg.norm(grad(view, spp, s) - mean) for s in range(seeds)]
        out[view] = (float(np.linalg.norm(mean)), float(np.sqrt(np.mean(np.square(noise)))))
    return out
