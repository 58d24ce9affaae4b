"""Mitsuba's own ``measured_polarized`` as an independent oracle: render a
``.pbsdf`` table exported from the model and the model itself (``pbrdf``) in
the same scene, and predict, before rendering, how far apart the two may be.

The scene (:func:`sphere_scene`): a unit sphere under an unpolarized
directional light of flat spectrum, seen by an orthographic camera, box pixel
filter, ``stokes`` + ``direct`` integrators (one emitter sample per pixel
sample, no BSDF sampling: a delta light), or ``path`` for a path-traced
variant with a constant environment. With spectrally flat n, k and weights the
table's 5 wavelengths (and ``measured_polarized``'s clamping outside them)
do not matter.

**Prediction** (:func:`predict_direct`): Mitsuba's own camera rays on a
regular sub-pixel grid hit the sphere; at each hit the table is read with the
NumPy emulation of ``measured_polarized`` (:mod:`.lookup`) and the model is
evaluated with the float64 reference; the reflected Stokes vectors (light
unpolarized, irradiance 1, times cos theta of the light) are rotated into one
frame fixed in the world and averaged over the pixel. The pixel's predicted
bound on ``|table - model|`` is the largest difference of its sub-pixel samples
(an average of differences cannot exceed their maximum), for S0 relative to
the pixel's S0, DoLP and AoLP (degrees). A render's pixel averages the same
quantities over random sub-pixel positions, so ``|measured_polarized - pbrdf|``
must stay within that bound, up to float32 rounding.
"""

from __future__ import annotations

import numpy as np

from mitsuba_pbrdf import reference as ref
from mitsuba_pbrdf.measured.lookup import lookup
from mitsuba_pbrdf.measured.pbsdf import PbsdfTable
from mitsuba_pbrdf.measured.rusinkiewicz import angles, global_axis

__all__ = ["sphere_scene", "render_stokes", "quantities", "predict_direct", "LIGHT"]

#: Direction the light travels (world), and the camera looks along -z.
LIGHT = (-0.93, -0.3, -0.2)


def _unit(v):
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def sphere_scene(bsdf: dict, size=64, spp=64, light=LIGHT, integrator="direct", max_depth=3,
                 environment=0.0):
    """A Mitsuba scene dict: the unit sphere with ``bsdf`` (a plugin dict),
    ``size`` x ``size`` pixels, orthographic camera on +z looking at the
    origin (view 2.2 wide), directional light along ``light``."""
    import mitsuba as mi

    T = mi.ScalarTransform4f
    inner = ({"type": "direct", "emitter_samples": 1, "bsdf_samples": 0}
             if integrator == "direct" else {"type": "path", "max_depth": max_depth})
    scene = {
        "type": "scene",
        "integrator": {"type": "stokes", "integrator": inner},
        "sensor": {"type": "orthographic",
                   "to_world": T().look_at(origin=[0, 0, 3], target=[0, 0, 0], up=[0, 1, 0])
                   @ T().scale([1.1, 1.1, 1.0]),
                   "film": {"type": "hdrfilm", "width": size, "height": size,
                            "rfilter": {"type": "box"}, "pixel_format": "rgb"},
                   "sampler": {"type": "independent", "sample_count": spp}},
        "sphere": {"type": "sphere", "bsdf": bsdf},
        "light": {"type": "directional", "direction": list(map(float, light)),
                  "irradiance": {"type": "uniform", "value": 1.0}},
    }
    if environment:
        scene["environment"] = {"type": "constant",
                                "radiance": {"type": "uniform", "value": float(environment)}}
    return scene


def render_stokes(scene: dict, seed=0):
    """Render; the luminance Stokes vector of each pixel, (H, W, 4) float64 in
    the camera's Stokes frame."""
    import mitsuba as mi

    from mitsuba_pbrdf.stokes.image import from_mitsuba, luminance_stokes

    loaded = mi.load_dict(scene)
    image = mi.render(loaded, seed=seed)
    stokes = from_mitsuba(image, loaded.sensors()[0].film())
    return luminance_stokes(stokes).astype(np.float64)


def quantities(S, eps=1e-12):
    """``(S0, DoLP, AoLP in degrees)`` of Stokes vectors (..., 4)."""
    s0 = S[..., 0]
    with np.errstate(invalid="ignore", divide="ignore"):
        dolp = np.where(s0 > eps, np.hypot(S[..., 1], S[..., 2]) / s0, 0.0)
    return s0, dolp, np.degrees(0.5 * np.arctan2(S[..., 2], S[..., 1]))


def angle_difference(a, b):
    """AoLP difference in degrees, wrapped to (-90, 90]."""
    return (a - b + 90.0) % 180.0 - 90.0


def _hits(scene_dict, size, sub):
    """Mitsuba's camera rays through a sub x sub grid in every pixel and their
    hits on the sphere: world directions, shading frames, validity (needs a
    JIT variant: the rays are traced as one array)."""
    import drjit as dr
    import mitsuba as mi

    scene = mi.load_dict(dict(scene_dict, sphere={"type": "sphere"}))
    sensor = scene.sensors()[0]
    u = (np.arange(sub) + 0.5) / sub
    iy, ix, sy, sx = np.meshgrid(np.arange(size), np.arange(size), u, u, indexing="ij")
    pos = mi.Point2f(((ix + sx) / size).ravel().astype(np.float32),
                     ((iy + sy) / size).ravel().astype(np.float32))
    rays, _ = sensor.sample_ray(0.0, 0.5, pos, mi.Point2f(0.5, 0.5))
    si = scene.ray_intersect(rays)
    frame = si.sh_frame
    get = lambda v: np.stack([np.asarray(c, dtype=np.float64) for c in (v.x, v.y, v.z)], -1)
    hit = np.asarray(si.is_valid(), dtype=bool)
    dr.eval(frame.s, frame.t, frame.n)
    return (hit, get(rays.d), get(frame.s), get(frame.t), get(frame.n))


def predict_direct(table: PbsdfTable, params: ref.PBRDFParams, scene_dict: dict, size,
                   light=LIGHT, sub=8, wavelength=550.0, min_cos=0.05):
    """Per-pixel prediction for the ``direct`` scene (see the module docstring).

    Returns a dict of (size, size) arrays: ``model`` and ``table`` (pixel
    Stokes vectors, world frame), ``bound_s0`` (relative), ``bound_dolp``,
    ``bound_aolp`` (degrees), and ``valid``: pixels whose every sub-pixel ray
    hits the sphere with both the light and the camera more than
    ``asin(min_cos)`` above the local horizon."""
    hit, d, s, t, n = _hits(scene_dict, size, sub)
    to_local = lambda w: np.stack([np.sum(w * s, -1), np.sum(w * t, -1), np.sum(w * n, -1)], -1)
    V = to_local(-d)
    L = to_local(np.broadcast_to(-_unit(light), d.shape))
    ok = hit & (V[:, 2] > min_cos) & (L[:, 2] > min_cos)
    M_table = lookup(table, L, V, wavelength)
    M_model = params.evaluate(*angles(L, V), [wavelength])[:, 0]
    cos_l = np.clip(L[:, 2], 0.0, None)[:, None]
    stokes = {k: np.where(ok[:, None], M[:, :, 0] * cos_l, 0.0)
              for k, M in (("table", M_table), ("model", M_model))}
    # output frame: the reference's global s-axis of V, in the world; rotate
    # each Stokes vector to the world-fixed axis x_ref about the view direction
    s_out = global_axis(V)
    s_world = s_out[:, :1] * s + s_out[:, 1:2] * t + s_out[:, 2:] * n
    view = -d
    x_ref = _unit(np.cross([0.0, 1.0, 0.0], view))
    angle = np.arctan2(np.sum(view * np.cross(s_world, x_ref), -1), np.sum(s_world * x_ref, -1))
    R = ref.rotator(angle)
    shape = (size, size, sub * sub, 4)
    out = {k: (R @ v[..., None])[..., 0].reshape(shape) for k, v in stokes.items()}
    valid = ok.reshape(shape[:3]).all(-1)
    pixel = {k: v.mean(2) for k, v in out.items()}
    q_t, q_m = quantities(out["table"]), quantities(out["model"])
    with np.errstate(invalid="ignore", divide="ignore"):
        bound_s0 = np.abs(q_t[0] - q_m[0]).max(-1) / pixel["model"][..., 0]
    return {"model": pixel["model"], "table": pixel["table"], "valid": valid,
            "bound_s0": bound_s0, "bound_dolp": np.abs(q_t[1] - q_m[1]).max(-1),
            "bound_aolp": np.abs(angle_difference(q_t[2], q_m[2])).max(-1)}
