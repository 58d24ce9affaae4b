"""A scene to recover normals from: a metal plate with a bumpy
``polarized_normalmap`` of known form, lit by an environment map and an area
light, seen by one or three cameras (:func:`plate_scene`); used by
validation/shape_from_polarization.py, the tests and examples.

Units: the plate is the square [-1, 1]^2 at z = 0 (scene units), its
tangent frame on the world axes (x = dp_du, z = normal); heights of
:func:`bumpy_heights` are in texel widths (see :mod:`.texels`).
"""

from __future__ import annotations

import math
import os

import numpy as np

from .texels import normalmap_texture, normals_from_heights

#: Camera azimuths (degrees, around +z) of the views; view 0 first.
VIEW_AZIMUTHS = (-90.0, 30.0, 150.0)
#: Camera angle from the plate's normal (degrees): metals polarize more towards grazing.
VIEW_ZENITH = 55.0


def bumpy_heights(texels: int = 32, amplitude: float = 0.6) -> np.ndarray:
    """A height field (texels, texels) in texel widths: four Gaussian bumps
    and dents and a diagonal ripple, scaled so the steepest normal is tilted
    by about ``atan(amplitude * ...)``; smooth at the texel scale."""
    v, u = np.meshgrid((np.arange(texels) + 0.5) / texels, (np.arange(texels) + 0.5) / texels,
                       indexing="ij")
    h = np.zeros_like(u)
    for cu, cv, a, w in ((0.3, 0.3, 1.0, 0.12), (0.72, 0.35, -0.8, 0.1),
                         (0.35, 0.75, -0.7, 0.14), (0.7, 0.72, 0.9, 0.11)):
        h += a * np.exp(-((u - cu) ** 2 + (v - cv) ** 2) / (2 * w * w))
    h += 0.15 * np.sin(2 * math.pi * 2.0 * (u + v))
    return amplitude * texels * 0.1 * h


def true_normals(texels: int = 32, amplitude: float = 0.6) -> np.ndarray:
    """The unit normals (texels, texels, 3) of :func:`bumpy_heights`."""
    return normals_from_heights(bumpy_heights(texels, amplitude))


def environment(width: int = 64) -> "object":
    """A small lat-long environment bitmap (linear RGB): a bright sky gradient
    with azimuthal bands, a dim ground; structure that metals reflect."""
    import mitsuba as mi

    h = width // 2
    theta = (np.arange(h) + 0.5) / h * math.pi            # from +y (Mitsuba's envmap up)
    phi = (np.arange(width) + 0.5) / width * 2 * math.pi
    t, p = np.meshgrid(theta, phi, indexing="ij")
    up = np.cos(t)
    sky = np.where(up > 0, 0.4 + 0.6 * up + 0.25 * np.cos(3 * p) * np.sin(t), 0.08)
    rgb = np.stack([sky * 0.9, sky, sky * 1.1], axis=-1).astype(np.float32)
    return mi.Bitmap(rgb)


def _sensor(azimuth, size, spp, distance=4.0):
    import mitsuba as mi

    z, a = math.radians(VIEW_ZENITH), math.radians(azimuth)
    origin = [distance * math.sin(z) * math.cos(a), distance * math.sin(z) * math.sin(a),
              distance * math.cos(z)]
    return {"type": "perspective", "fov": 32,
            "to_world": mi.ScalarTransform4f().look_at(origin=origin, target=[0, 0, 0],
                                                       up=[0, 0, 1]),
            "sampler": {"type": "independent", "sample_count": spp},
            "film": {"type": "hdrfilm", "width": size, "height": size, "pixel_format": "rgb",
                     "rfilter": {"type": "box"}}}


def plate_scene(normals, metal: str = "Cu", views: int = 1, size: int = 48, spp: int = 16,
                sigma=0.15, max_depth: int = 3) -> dict:
    """The scene dict: the plate with ``polarized_normalmap`` (``normals``,
    (H, W, 3) unit vectors) over ``pbrdf`` (``material`` *metal*, roughness
    *sigma*: a number or an (H', W') map), an environment map rotated so its
    up is +z, a rectangular area light, ``views`` (1..3) cameras of
    ``size`` x ``size`` pixels; the shape's id is ``plate``."""
    import mitsuba as mi

    T = mi.ScalarTransform4f
    if np.ndim(sigma) == 2:
        sigma = {"type": "bitmap", "raw": True, "filter_type": "bilinear",
                 "bitmap": mi.Bitmap(np.asarray(sigma, np.float32)[..., None])}
    else:
        sigma = float(sigma)
    scene = {
        "type": "scene",
        "integrator": {"type": "stokes_prb", "max_depth": max_depth},
        "plate": {"type": "rectangle",
                  "bsdf": {"type": "polarized_normalmap", "normalmap": normalmap_texture(normals),
                           "bsdf": {"type": "pbrdf", "material": metal, "sigma": sigma}}},
        "sky": {"type": "envmap", "bitmap": environment(),
                "to_world": T().rotate([1, 0, 0], 90)},
        "key": {"type": "rectangle",
                "to_world": T().look_at(origin=[1.5, 2.0, 3.0], target=[0, 0, 0],
                                        up=[0, 0, 1]).scale(0.6),
                "emitter": {"type": "area", "radiance": 8.0}},
    }
    for i in range(views):
        scene[f"view{i}"] = _sensor(VIEW_AZIMUTHS[i], size, spp)
    return scene


def render_targets(scene, spp: int, seed: int = 10_000):
    """One render (NumPy (H, W, C)) per sensor, each with its own seed."""
    import mitsuba as mi

    return [np.array(mi.render(scene, sensor=i, spp=spp, seed=seed + 101 * i))
            for i in range(len(scene.sensors()))]


PLATE_XML = """<scene version="3.0.0">
    <default name="spp" value="{spp}"/>
    <default name="width" value="{size}"/>
    <default name="height" value="{size}"/>
    <default name="max_depth" value="3"/>
    <default name="material" value="{metal}"/>
    <default name="sigma" value="{sigma}"/>
    <integrator type="stokes_prb"><integer name="max_depth" value="$max_depth"/></integrator>
    <sensor type="perspective">
        <float name="fov" value="32"/>
        <transform name="to_world">
            <lookat origin="{ox:.6f}, {oy:.6f}, {oz:.6f}" target="0, 0, 0" up="0, 0, 1"/>
        </transform>
        <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
        <film type="hdrfilm">
            <integer name="width" value="$width"/><integer name="height" value="$height"/>
            <string name="pixel_format" value="rgb"/><rfilter type="box"/>
        </film>
    </sensor>
    <shape type="rectangle" id="plate">
        <bsdf type="polarized_normalmap">
            <texture name="normalmap" type="bitmap">
                <boolean name="raw" value="true"/>
                <string name="filename" value="{normals}"/>
            </texture>
            <bsdf type="pbrdf"><string name="material" value="$material"/>
                <float name="sigma" value="$sigma"/></bsdf>
        </bsdf>
    </shape>
    <emitter type="constant"><rgb name="radiance" value="0.5"/></emitter>
    <shape type="rectangle">
        <transform name="to_world">
            <scale value="0.6"/>
            <lookat origin="1.5, 2, 3" target="0, 0, 0" up="0, 0, 1"/>
        </transform>
        <emitter type="area"><rgb name="radiance" value="8"/></emitter>
    </shape>
</scene>
"""


def write_plate_files(folder, normals, metal: str = "Cu", size: int = 32, spp: int = 16,
                      sigma: float = 0.15) -> str:
    """Write ``folder/plate_normals.exr`` (the normal map, colour (n + 1) / 2)
    and ``folder/plate.xml`` (the plate under a constant sky and an area
    light, one camera as view 0 of :func:`plate_scene`), atomically; returns
    the XML's path. A small scene for ``pbrdf recover-normals``; *metal*,
    *size*, *spp* and *sigma* are its ``<default>`` s ``material``, ``width``
    and ``height``, ``spp``, ``sigma`` (and ``max_depth``, 3), so ``pbrdf
    render plate.xml -D spp=256`` renders a target. ``plate_normals.exr`` is
    what ``recover-normals --truth`` takes (:func:`read_normal_map`)."""
    from ...outputs import escape_text, write_text
    from ...stokes.exr import write_exr

    folder = os.fspath(folder)
    colour = ((np.asarray(normals, np.float32) + 1.0) / 2.0).astype(np.float32)
    write_exr(os.path.join(folder, "plate_normals.exr"),
              {c: colour[..., i] for i, c in enumerate("RGB")})
    z, a = math.radians(VIEW_ZENITH), math.radians(VIEW_AZIMUTHS[0])
    origin = 4.0 * np.array([math.sin(z) * math.cos(a), math.sin(z) * math.sin(a), math.cos(z)])
    text = PLATE_XML.format(ox=origin[0], oy=origin[1], oz=origin[2], spp=int(spp),
                            size=int(size), normals="plate_normals.exr",
                            metal=escape_text(metal, "xml"),
                            sigma=float(sigma))
    return write_text(os.path.join(folder, "plate.xml"), text)


def read_normal_map(path) -> np.ndarray:
    """Unit normals (H, W, 3) from an EXR: channels X, Y, Z (``pbrdf
    recover-normals``' ``normals.exr``) or R, G, B holding the colour encoding
    (n + 1) / 2 (a normal-map texture, such as :func:`write_plate_files`'
    ``plate_normals.exr``). ValueError naming the file otherwise."""
    from ...stokes.exr import read_exr_channels

    channels = read_exr_channels(path)
    if all(c in channels for c in "XYZ"):
        normals = np.stack([channels[c] for c in "XYZ"], axis=-1).astype(np.float64)
    elif all(c in channels for c in "RGB"):
        normals = 2.0 * np.stack([channels[c] for c in "RGB"], axis=-1).astype(np.float64) - 1.0
    else:
        raise ValueError(f"{os.fspath(path)}: a normal map needs channels X, Y, Z (unit normals) "
                         f"or R, G, B (colour (n + 1) / 2); it has {', '.join(channels)}")
    length = np.linalg.norm(normals, axis=-1, keepdims=True)
    if not np.all(np.isfinite(normals)) or np.any(length < 0.5) or np.any(length > 1.5):
        raise ValueError(f"{os.fspath(path)}: not a normal map (vectors of length "
                         f"{length.min():.3g} to {length.max():.3g}, not about 1)")
    return (normals / length).astype(np.float32)
