"""A scene to invert: a ``pbrdf`` sphere under soft boxes, as a scene dict."""

import mitsuba as mi


def sphere_scene(width=64, height=64, spp=16, max_depth=3, bsdf=None, integrator="path",
                 fov=32.0):
    """Scene dict: a ``pbrdf`` sphere (shape id ``object``) on a grey diffuse
    floor, lit by a soft box above the camera (highlights near normal
    incidence), one behind on the right (highlights at 60-70 degrees, strongly
    s-polarized) and a dim sky, inside Mitsuba's ``stokes`` integrator.

    ``bsdf``: the sphere's BSDF dict (default: a metal with n = 2, k = 4,
    sigma = 0.12 and small diffuse lobes). ``integrator``: ``path`` (or
    ``direct``, which ignores ``max_depth``)."""
    T = mi.ScalarTransform4f
    bsdf = bsdf or {"type": "pbrdf", "eta": 2.0, "k": 4.0, "sigma": 0.12, "ks": 1.0,
                    "kdd": 0.1, "sigma_dd": 0.5, "kid": 0.03}
    inner = {"type": integrator}
    if integrator != "direct":
        inner["max_depth"] = int(max_depth)
    return {
        "type": "scene",
        "integrator": {"type": "stokes", "integrator": inner},
        "sensor": {"type": "perspective", "fov": float(fov),
                   "to_world": T().look_at(origin=[0, 1.6, 5.0], target=[0, 0.9, 0],
                                           up=[0, 1, 0]),
                   "sampler": {"type": "independent", "sample_count": int(spp)},
                   "film": {"type": "hdrfilm", "width": int(width), "height": int(height),
                            "pixel_format": "rgb", "rfilter": {"type": "box"}}},
        "object": {"type": "sphere", "center": [0, 1, 0], "radius": 1.0, "bsdf": bsdf},
        "floor": {"type": "rectangle", "to_world": T().scale(20).rotate([1, 0, 0], -90),
                  "bsdf": {"type": "diffuse", "reflectance": 0.3}},
        "key": {"type": "rectangle",
                "to_world": T().look_at(origin=[-1.5, 4.5, 5.0], target=[0, 1, 0],
                                        up=[0, 1, 0]).scale(0.7),
                "emitter": {"type": "area", "radiance": 25.0}},
        "back": {"type": "rectangle",
                 "to_world": T().look_at(origin=[4.5, 2.5, -3.0], target=[0, 1, 0],
                                         up=[0, 1, 0]).scale(0.8),
                 "emitter": {"type": "area", "radiance": 40.0}},
        "sky": {"type": "constant", "radiance": 0.15},
    }
