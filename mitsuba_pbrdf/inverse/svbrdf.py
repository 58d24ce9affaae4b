"""Recovery of spatially varying BSDF parameters: a roughness (``sigma``) map
and a directional-diffuse (``kdd``) map of a textured ``pbrdf`` sphere, fitted
to Stokes images with polarized path replay (``stokes_prb``).

The sphere's ``sigma`` and ``kdd`` are single-channel bitmaps (raw values,
``TEXELS x TEXELS``; RGB upsampling in spectral variants assumes reflectances
in [0, 1], so the index n, k stays uniform), seen by three cameras under two
area lights and a dim sky (:func:`svbrdf_scene`). Target images are rendered
with :func:`true_maps`; the maps then start uniform (:data:`START`) and Adam
fits their texels to the targets (:func:`recover`: ``mi.render`` +
``dr.backward``, the memory of a primal render whatever the number of
texels). Used by examples/svbrdf_recovery.py and validation/svbrdf_recovery.py;
a polarized variant with ``stokes_prb`` registered must be set.
"""

from __future__ import annotations

import numpy as np

#: Texels along each side of the fitted maps.
TEXELS = 8
#: bounds of the fitted texels (sigma >= pbrdf's minimum, kdd >= 0)
BOUNDS = {"sigma": (0.03, 0.6), "kdd": (0.0, 1.0)}
START = {"sigma": 0.2, "kdd": 0.2}


def true_maps(texels=TEXELS):
    """(sigma, kdd) maps, float32 (texels, texels): smooth patterns that
    differ from each other (a roughness gradient with a band, two kdd blobs)."""
    v, u = np.meshgrid(np.linspace(0, 1, texels), np.linspace(0, 1, texels), indexing="ij")
    sigma = 0.08 + 0.22 * u + 0.1 * (np.abs(v - 0.5) < 0.15)
    kdd = (0.05 + 0.35 * np.exp(-((u - 0.3) ** 2 + (v - 0.35) ** 2) / 0.03)
           + 0.25 * np.exp(-((u - 0.75) ** 2 + (v - 0.7) ** 2) / 0.02))
    return sigma.astype(np.float32), kdd.astype(np.float32)


def svbrdf_scene(sigma, kdd, size=64, spp=16, max_depth=2):
    """The scene (three sensors) with the maps ``sigma``, ``kdd`` (arrays)."""
    import mitsuba as mi

    T = mi.ScalarTransform4f

    def bitmap(data):
        return {"type": "bitmap", "bitmap": mi.Bitmap(np.asarray(data, np.float32)[..., None]),
                "raw": True, "filter_type": "bilinear"}

    def sensor(origin):
        return {"type": "perspective", "fov": 30,
                "to_world": T().look_at(origin=origin, target=[0, 1, 0], up=[0, 1, 0]),
                "sampler": {"type": "independent", "sample_count": spp},
                "film": {"type": "hdrfilm", "width": size, "height": size, "pixel_format": "rgb",
                         "rfilter": {"type": "box"}}}

    return {
        "type": "scene",
        "integrator": {"type": "stokes_prb", "max_depth": max_depth},
        "view0": sensor([0, 1.8, 4.5]),
        "view1": sensor([3.6, 2.2, 2.6]),
        "view2": sensor([-3.4, 1.2, 3.0]),
        "object": {"type": "sphere", "center": [0, 1, 0], "radius": 1.0,
                   "bsdf": {"type": "pbrdf", "eta": 1.5, "k": 3.5, "ks": 1.0,
                            "sigma": bitmap(sigma), "kdd": bitmap(kdd), "sigma_dd": 0.5}},
        "key": {"type": "rectangle",
                "to_world": T().look_at(origin=[-2.0, 4.0, 4.0], target=[0, 1, 0],
                                        up=[0, 1, 0]).scale(0.9),
                "emitter": {"type": "area", "radiance": 20.0}},
        "rim": {"type": "rectangle",
                "to_world": T().look_at(origin=[4.0, 2.0, -2.5], target=[0, 1, 0],
                                        up=[0, 1, 0]).scale(0.9),
                "emitter": {"type": "area", "radiance": 30.0}},
        "sky": {"type": "constant", "radiance": 0.1},
    }


def render_views(scene, spp, seed):
    """One render (NumPy, (H, W, channels)) per sensor of *scene*, each with its own seed."""
    import mitsuba as mi

    return [np.array(mi.render(scene, sensor=i, spp=spp, seed=seed + 101 * i))
            for i in range(len(scene.sensors()))]


def recover(components=(0, 1, 2), iterations=60, lr=0.02, lr_decay=0.97, size=64, spp=16,
            target_spp=128, seed=0, log=print):
    """Fit the two maps to targets rendered with :func:`true_maps` (Adam,
    :func:`~mitsuba_pbrdf.inverse.driver.run_adam`: learning rate
    ``lr * lr_decay**it``, fresh seeds every iteration and view).

    Returns a dict: ``truth``, ``start`` and ``recovered`` maps ({name:
    array}), ``loss`` (per iteration, sum over views), ``visible`` (texels
    that received a gradient), ``seconds``."""
    import drjit as dr
    import mitsuba as mi

    from .driver import learning_rates, run_adam
    from .losses import stokes_loss

    truth = dict(zip(("sigma", "kdd"), true_maps()))
    scene = mi.load_dict(svbrdf_scene(truth["sigma"], truth["kdd"], size=size, spp=spp))
    targets = render_views(scene, target_spp, seed=10_000 + seed)
    losses = [stokes_loss(scene, t, components) for t in targets]

    params = mi.traverse(scene)
    keys = {name: f"object.bsdf.{name}.data" for name in truth}
    start = {name: np.full_like(truth[name], START[name]) for name in truth}
    touched = {name: np.zeros(truth[name].shape, bool) for name in truth}

    def gradient(opt, it, seeds):  # the views' gradients add up on the texels
        params.update(opt)
        total = 0.0
        for view, loss in enumerate(losses):
            value = loss(mi.render(scene, params, sensor=view, spp=spp, seed=seeds[view]))
            dr.backward(value)
            total += float(value[0])
        for name, key in keys.items():
            touched[name] |= np.array(dr.grad(opt[key]))[..., 0] != 0
        return total

    def clamp(opt):
        for name, key in keys.items():
            opt[key] = dr.clip(opt[key], *BOUNDS[name])

    def progress(it, total):
        if log and (it % 10 == 0 or it == iterations - 1):
            log(f"  iteration {it:3d}: loss {total:.5f}")

    run = run_adam({key: mi.TensorXf(start[name][..., None]) for name, key in keys.items()},
                   gradient, learning_rates(lr, iterations, lr_decay=lr_decay), seed=seed,
                   renders=len(losses), clamp=clamp, callback=progress)
    params.update(run.optimizer)
    recovered = {name: np.array(params[key])[..., 0].copy() for name, key in keys.items()}
    return {"truth": truth, "start": start, "recovered": recovered, "loss": run.loss,
            "visible": touched, "seconds": run.seconds}


def map_errors(result):
    """RMS error of each recovered map against the truth over the texels
    that received a gradient, and the same for the starting map."""
    out = {}
    for name, truth in result["truth"].items():
        mask = result["visible"][name]
        out[name] = {kind: float(np.sqrt(np.mean((result[kind][name][mask] - truth[mask]) ** 2)))
                     for kind in ("start", "recovered")}
    return out
