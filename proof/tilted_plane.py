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
    """A 2 x 2 raw RGB bitmap texture encoding ``normal`` ((n + 1) / 2)
    everywhere (Mitsuba refuses to update a bitmap smaller than 2 x 2)."""
    import mitsuba as mi

    colour = (np.asarray(normal, dtype=np.float32) + 1.0) / 2.0
    return {"type": "bitmap", "raw": True, "filter_type": "nearest",
            "bitmap": mi.Bitmap(np.tile(colour, (2, 2, 1)))}


def height_ramp_bitmap(normal, size=8, extent=20.0):
    """A one-channel raw float32 bitmap texture of the heights (scene units,
    for ``scale`` = 1) of the plane through the origin with ``normal``, over
    the flat square ``plane(extent)`` (uv in [0, 1]^2; u along +x, v along +y):
    h = -(nx x + ny y) / nz at ``size`` x ``size`` texel centres, which
    bilinear interpolation (clamped at the border) turns into an exact ramp."""
    import mitsuba as mi

    nx, ny, nz = normal
    centres = ((np.arange(size) + 0.5) / size - 0.5) * extent
    x, y = np.meshgrid(centres, centres)
    heights = (-(nx * x + ny * y) / nz).astype(np.float32).reshape(size, size, 1)
    return {"type": "bitmap", "raw": True, "filter_type": "bilinear", "wrap_mode": "clamp",
            "bitmap": mi.Bitmap(heights)}


def plane(bsdf, tilt=0.0, azimuth=0.0, extent=20.0):
    """A square ``rectangle`` of side ``extent`` through the origin, its
    normal tilted by ``tilt`` towards ``azimuth``, with ``bsdf``."""
    import mitsuba as mi

    return {"type": "rectangle", "to_world": _tilt(tilt, azimuth) @
            mi.ScalarTransform4f().scale([extent / 2] * 3), "bsdf": bsdf}


def _tilt(tilt, azimuth):
    """The rotation taking +z to :func:`tilted_normal`."""
    import mitsuba as mi

    normal = tilted_normal(tilt, azimuth)
    axis = np.cross([0.0, 0.0, 1.0], normal)
    if np.linalg.norm(axis) < 1e-9:
        return mi.ScalarTransform4f()
    return mi.ScalarTransform4f().rotate(list(axis / np.linalg.norm(axis)), tilt)


def scene(shape, size=8, spp=4, light=LIGHT_TOWARDS, integrator="path"):
    """A scene dict: ``shape``, an orthographic camera of ``size`` x ``size``
    pixels seeing a 1 x 1 patch of it from above, a directional light of
    irradiance 1 arriving from ``light`` (towards the light), and the
    ``stokes`` integrator around ``integrator`` (max_depth 2: direct light)."""
    return _scene({"plate": shape}, size, 0.5, spp, light, integrator)


def _scene(shapes, size, half_extent, spp, light, integrator):
    import mitsuba as mi

    towards = np.asarray(light, dtype=float) / np.linalg.norm(light)
    camera = mi.ScalarTransform4f().look_at(origin=[0, 0, 5], target=[0, 0, 0], up=[0, 1, 0])
    return {
        "type": "scene",
        "integrator": {"type": "stokes", "integrator": {"type": integrator, "max_depth": 2}},
        "sensor": {"type": "orthographic",
                   "to_world": camera @ mi.ScalarTransform4f().scale(half_extent),
                   "film": {"type": "hdrfilm", "width": size, "height": size,
                            "rfilter": {"type": "box"}},
                   "sampler": {"type": "independent", "sample_count": spp}},
        "light": {"type": "directional", "direction": list(-towards), "irradiance": 1.0},
        **shapes,
    }


# ------------------------------------------------------------------ many configurations


def light_towards(tilt, azimuth):
    """The light of :func:`compare`: near the mirror direction of the camera
    axis about the tilted normal but off its plane of incidence (so the AoLP
    is not pinned to a symmetry axis), oblique enough that metals polarize
    visibly, and above both planes: min(max(2 tilt, 50°), 70°) from the
    camera axis, 25° of azimuth from the normal's."""
    return tilted_normal(min(max(2.0 * tilt, 50.0), 70.0), azimuth + 25.0)


class Comparison:
    """The tilted plane and the same plane flat under a wrapper, loaded once
    and updated per ``(tilt, azimuth)`` through ``mi.traverse`` (the kernels
    are compiled once, not once per configuration).

    ``wrapper``: ``"normalmap"``, ``"polarized_normalmap"`` (a constant normal
    map), ``"bumpmap"`` or ``"polarized_bumpmap"`` (a linear height ramp);
    ``nested``: the BSDF dict; ``extra``: more wrapper parameters."""

    def __init__(self, wrapper, nested, size=8, spp=4, integrator="path", **extra):
        import mitsuba as mi

        self.wrapper, self.spp = wrapper, spp
        self.bump = wrapper.endswith("bumpmap")
        if self.bump:
            flat = {"type": wrapper, "height": height_ramp_bitmap((0.0, 0.0, 1.0)),
                    "bsdf": nested, **extra}
        else:
            flat = {"type": wrapper, "normalmap": normalmap_bitmap((0.0, 0.0, 1.0)),
                    "bsdf": nested, **extra}
        self.tilted = mi.load_dict(scene(plane(nested), size, spp, integrator=integrator))
        self.mapped = mi.load_dict(scene(plane(flat), size, spp, integrator=integrator))

    def render(self, tilt, azimuth, seed=1):
        """``(tilted, mapped)`` Stokes images (:class:`StokesImage`) of the
        plane tilted by ``tilt`` towards ``azimuth`` (degrees) under
        :func:`light_towards`."""
        import mitsuba as mi

        from mitsuba_pbrdf.stokes.image import from_mitsuba

        normal = tilted_normal(tilt, azimuth)
        towards = light_towards(tilt, azimuth)
        light = mi.ScalarTransform4f().look_at(origin=[0, 0, 0], target=list(-towards),
                                               up=_perpendicular(towards))
        images = []
        for which, scene_ in (("tilted", self.tilted), ("mapped", self.mapped)):
            params = mi.traverse(scene_)
            params["light.to_world"] = light
            if which == "tilted":
                params["plate.to_world"] = plane({}, tilt, azimuth)["to_world"]
            elif self.bump:
                heights = np.array(height_ramp_bitmap(normal)["bitmap"], dtype=np.float32)
                params["plate.bsdf.nested_texture.data"] = mi.TensorXf(
                    heights.reshape(heights.shape[0], heights.shape[1], 1))
            else:
                params["plate.bsdf.normalmap.data"] = mi.TensorXf(
                    np.array(normalmap_bitmap(normal)["bitmap"], dtype=np.float32))
            params.update()
            image = np.array(mi.render(scene_, spp=self.spp, seed=seed), dtype=np.float32)
            images.append(from_mitsuba(image, scene_.sensors()[0].film()))
        return tuple(images)


def _perpendicular(v):
    """A unit vector perpendicular to ``v``."""
    helper = [1.0, 0.0, 0.0] if abs(v[0]) < 0.9 else [0.0, 1.0, 0.0]
    p = np.cross(v, helper)
    return list(p / np.linalg.norm(p))
