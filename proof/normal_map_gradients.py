"""Texel gradients of ``polarized_normalmap`` and ``polarized_bumpmap``: the
derivative of a fixed random linear functional of a Stokes render with
respect to every texel of the normal map (or of the bump map's height
texture), by ``stokes_prb`` (reverse mode), by Mitsuba's ``path`` in AD mode
and by central finite differences of the same renders (common random
numbers). Used by tests/inverse/test_normals.py and
validation/shape_from_polarization.py.

The scene is :mod:`proof.tilted_plane`'s: a flat plate under
one directional light, orthographic camera, ``pbrdf`` (gold) with
``sampling = "cosine"``. The light is reached only by emitter sampling (a
BSDF-sampled ray leaves the scene), so ``path`` AD differentiates exactly
the estimator ``stokes_prb`` replays, sample for sample: the two must agree
to float32 rounding, not only in expectation. A variant must be set.
"""

from __future__ import annotations

import numpy as np

WRAPPERS = ("polarized_normalmap", "polarized_bumpmap")
KEYS = {"polarized_normalmap": "plate.bsdf.normalmap.data",
        "polarized_bumpmap": "plate.bsdf.nested_texture.data"}


def texel_scene(wrapper: str, texels: int = 3, seed: int = 4, size: int = 8):
    """``(scene, key)``: the plate with a random normal map (or height map)
    of ``texels`` x ``texels``, and the traverse key of its texels."""
    import mitsuba as mi

    from proof import tilted_plane as tp

    rng = np.random.default_rng(seed)
    nested = {"type": "pbrdf", "material": "Au", "sigma": 0.2, "sampling": "cosine"}
    if wrapper == "polarized_normalmap":
        colours = rng.normal(size=(texels, texels, 3)) * [0.4, 0.4, 0.1] + [0.0, 0.0, 1.0]
        colours = (colours / np.linalg.norm(colours, axis=2, keepdims=True) + 1.0) / 2.0
        texture = {"type": "bitmap", "raw": True,
                   "bitmap": mi.Bitmap(colours.astype(np.float32))}
        bsdf = {"type": wrapper, "normalmap": texture, "bsdf": nested}
    elif wrapper == "polarized_bumpmap":
        texture = {"type": "bitmap", "raw": True, "bitmap": mi.Bitmap(
            rng.uniform(size=(texels, texels, 1)).astype(np.float32))}
        bsdf = {"type": wrapper, "height": texture, "scale": 0.2, "bsdf": nested}
    else:
        raise ValueError(f"wrapper must be one of {WRAPPERS}, got {wrapper!r}")
    scene = mi.load_dict(tp.scene(tp.plane(bsdf, extent=1.2), size=size,
                                  light=tp.tilted_normal(50.0, 25.0)))
    return scene, KEYS[wrapper]


def compare(wrapper: str, spp: int = 4, seed: int = 1, h: float = 2e-3, texels: int = 3,
            finite_differences: bool = True) -> dict:
    """Gradients of one random functional w.r.t. every texel, float64 arrays:
    ``prb`` (stokes_prb, reverse), ``path`` (path AD, reverse), ``fd``
    (central differences, step *h* in texel value, stokes_prb primal renders
    with the derivative passes' seed *seed*, so the random numbers are common;
    left out when *finite_differences* is false)."""
    import mitsuba as mi

    from .render_gradients import functional_gradient, random_functional

    scene, key = texel_scene(wrapper, texels=texels)
    size = scene.sensors()[0].film().crop_size()
    weights = random_functional(size[1], size[0], seed=2)
    prb = mi.load_dict({"type": "stokes_prb", "max_depth": 2})
    path = mi.load_dict({"type": "stokes", "integrator": {"type": "path", "max_depth": 2}})
    # the derivative passes of both integrators draw seed_grad's random numbers
    common = dict(spp=spp, seed=seed + 50_000, seed_grad=seed)
    out = {"prb": functional_gradient(scene, [key], weights, integrator=prb, **common),
           "path": functional_gradient(scene, [key], weights, integrator=path, **common)}

    if not finite_differences:
        return out
    params = mi.traverse(scene)
    base = np.array(params[key], dtype=np.float32)
    w = np.array(weights, dtype=np.float64)

    def functional(data):
        params[key] = mi.TensorXf(data.reshape(base.shape))
        params.update()
        image = mi.render(scene, integrator=prb, spp=spp, seed=seed)
        return float(np.sum(np.array(image, dtype=np.float64) * w))

    fd = np.zeros(base.size)
    for j in range(base.size):
        plus, minus = base.copy().ravel(), base.copy().ravel()
        plus[j] += h
        minus[j] -= h
        fd[j] = (functional(plus) - functional(minus)) / (2 * h)
    params[key] = mi.TensorXf(base)
    params.update()
    out["fd"] = fd
    return out


def relative_differences(result: dict) -> dict:
    """max |a - b| / max |b| for stokes_prb against path AD and against FD."""
    scale = lambda b: max(float(np.max(np.abs(b))), 1e-30)  # noqa: E731
    out = {"prb vs path AD": float(np.max(np.abs(result["prb"] - result["path"])))
           / scale(result["path"])}
    if "fd" in result:
        out["prb vs FD"] = float(np.max(np.abs(result["prb"] - result["fd"]))) / scale(result["fd"])
    return out
