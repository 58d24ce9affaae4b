"""Scenes that pin down a shading-frame wrapper: a plane tilted by ``tilt``
towards ``azimuth`` against a flat plane whose constant normal map (or linear
height ramp) encodes the same normal, both seen by an orthographic camera from
above and lit by one directional light, so every pixel of either image sees the
same geometry (docs/normal-maps.md).

Scene dictionaries for ``mi.load_dict`` (a variant must be set); angles in
degrees, the camera looking down -z at the origin, the flat plane z = 0 with
its shading frame on the world axes (s = x, n = z).
"""

from __future__ import annotations

import math

import numpy as np

#: Direction towards the light (world, unnormalized): 20° off the camera axis,
#: so it stays above every tilted plane up to 60° at every azimuth.
LIGHT_TOWARDS = (0.3, 0.2, 1.0)


def tilted_normal(tilt, azimuth):
    """Unit normal tilted by ``tilt`` from +z towards ``azimuth`` (degrees)."""
    t, a = math.radians(tilt), math.radians(azimuth)
    return np.array([math.sin(t) * math.cos(a), math.sin(t) * math.sin(a), math.cos(t)])


def normalmap_bitmap(normal):
    """A 1 x 1 raw RGB bitmap texture encoding ``normal`` ((n + 1) / 2)."""
    import mitsuba as mi

    colour = (np.asarray(normal, dtype=np.float32) + 1.0) / 2.0
    return {"type": "bitmap", "raw": True, "filter_type": "nearest",
            "bitmap": mi.Bitmap(colour.reshape(1, 1, 3))}


def height_ramp_bitmap(normal, size=8, extent=20.0):
    """A one-channel raw bitmap of the heights of the plane with ``normal``
    over a square of side ``extent`` (uv in [0, 1]^2; u along +x, v along +y
    on the flat plane ``plane(extent)``): h = -(nx x + ny y) / nz, sampled at
    ``size`` x ``size`` texels (bilinear interpolation keeps a ramp exact).
    Returns ``(texture dict, scale)``: heights normalized to [0, 1] and the
    ``scale`` that restores them."""
    import mitsuba as mi

    nx, ny, nz = normal
    # texel centres in scene units: u, v in [0, 1] -> x, y in [-extent/2, extent/2]
    centres = ((np.arange(size) + 0.5) / size - 0.5) * extent
    x, y = np.meshgrid(centres, centres)
    h = -(nx * x + ny * y) / nz
    low, span = h.min(), max(h.max() - h.min(), 1e-12)
    data = ((h - low) / span).astype(np.float32).reshape(size, size, 1)
    return ({"type": "bitmap", "raw": True, "filter_type": "bilinear", "wrap_mode": "clamp",
             "bitmap": mi.Bitmap(data)}, float(span))


def plane(bsdf, tilt=0.0, azimuth=0.0, extent=20.0):
    """A square ``rectangle`` of side ``extent`` through the origin, its
    normal tilted by ``tilt`` towards ``azimuth``, with ``bsdf``."""
    import mitsuba as mi

    normal = tilted_normal(tilt, azimuth)
    axis = np.cross([0.0, 0.0, 1.0], normal)
    to_world = mi.ScalarTransform4f().scale([extent / 2] * 3)
    if np.linalg.norm(axis) > 1e-9:
        to_world = mi.ScalarTransform4f().rotate(list(axis / np.linalg.norm(axis)), tilt) @ to_world
    return {"type": "rectangle", "to_world": to_world, "bsdf": bsdf}


def scene(shape, size=8, spp=4, light=LIGHT_TOWARDS, integrator="path"):
    """A scene dict: ``shape``, an orthographic camera of ``size`` x ``size``
    pixels seeing a 1 x 1 patch of it from above, a directional light of
    irradiance 1 arriving from ``light`` (towards the light), and the
    ``stokes`` integrator around ``integrator`` (max_depth 2: direct light)."""
    import mitsuba as mi

    towards = np.asarray(light, dtype=float) / np.linalg.norm(light)
    camera = mi.ScalarTransform4f().look_at(origin=[0, 0, 5], target=[0, 0, 0], up=[0, 1, 0])
    return {
        "type": "scene",
        "integrator": {"type": "stokes", "integrator": {"type": integrator, "max_depth": 2}},
        "sensor": {"type": "orthographic", "to_world": camera @ mi.ScalarTransform4f().scale(0.5),
                   "film": {"type": "hdrfilm", "width": size, "height": size,
                            "rfilter": {"type": "box"}},
                   "sampler": {"type": "independent", "sample_count": spp}},
        "light": {"type": "directional", "direction": list(-towards), "irradiance": 1.0},
        "plate": shape,
    }
