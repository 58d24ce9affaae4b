"""The normal-mapped plate of the gallery (``normalmap.png``, drawn by
:func:`mitsuba_pbrdf.visualization.gallery.render_normalmap_plate`): a hammered
aluminium plate (``scenes/gallery/plate.xml``) rendered with Mitsuba's
``normalmap`` and with ``polarized_normalmap``; same intensity and DoLP, a
different AoLP inside the dimples (docs/normal-maps.md).

``write_hammered_normal_map`` makes the shipped normal map
(``scenes/gallery/plate_normals.exr``); ``aolp_difference`` measures the
difference the picture's title states."""

from __future__ import annotations

import numpy as np

#: The two wrappers drawn, with their column labels.
WRAPPERS = (("normalmap", "Mitsuba's normalmap"),
            ("polarized_normalmap", "polarized_normalmap"))


def hammered_normals(size=64, dimples=5, seed=19, depth=0.55):
    """Normals (size, size, 3), float32, unit length, in the plate's shading
    frame (x along u, y along v, z the plate's normal) of a periodic field of
    jittered spherical dimples, ``dimples`` per side; ``depth`` sets their
    steepness (tilts up to about 30°)."""
    rng = np.random.default_rng(seed)
    u = (np.arange(size) + 0.5) / size
    x, y = np.meshgrid(u, u)
    height = np.zeros((size, size))
    cell = 1.0 / dimples
    for i in range(dimples):
        for j in range(dimples):
            cx, cy = (np.array([i, j]) + 0.5 + rng.uniform(-0.25, 0.25, 2)) * cell
            radius = cell * rng.uniform(0.45, 0.7)
            dx = (x - cx + 0.5) % 1.0 - 0.5  # periodic: the map tiles
            dy = (y - cy + 0.5) % 1.0 - 0.5
            d2 = (dx * dx + dy * dy) / (radius * radius)
            height -= np.where(d2 < 1.0, (1.0 - d2) ** 2, 0.0) * radius * depth
    gy, gx = np.gradient(height, 1.0 / size)
    normals = np.stack([-gx, -gy, np.ones_like(height)], axis=-1)
    return (normals / np.linalg.norm(normals, axis=-1, keepdims=True)).astype(np.float32)


def write_hammered_normal_map(path, **options) -> str:
    """Write :func:`hammered_normals` encoded as (n + 1) / 2 to the OpenEXR
    file ``path`` (half floats; read it with ``raw`` = true); returns the path."""
    import mitsuba as mi

    from ..outputs import atomic_path

    colours = (hammered_normals(**options) + 1.0) / 2.0
    bitmap = mi.Bitmap(colours, mi.Bitmap.PixelFormat.RGB).convert(
        mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float16, srgb_gamma=False)
    with atomic_path(path) as tmp:
        bitmap.write(str(tmp))
    return str(path)


def aolp_difference(a, b, min_dolp=0.02):
    """Largest and median |AoLP(a) − AoLP(b)| (degrees, modulo 180°) over the
    pixels of two Stokes images where both DoLPs (luminance) exceed ``min_dolp``."""
    from ..stokes.image import aolp, dolp, luminance_stokes

    sa, sb = luminance_stokes(a), luminance_stokes(b)
    mask = (dolp(sa, axis=-1) > min_dolp) & (dolp(sb, axis=-1) > min_dolp)
    diff = np.degrees(aolp(sa, axis=-1) - aolp(sb, axis=-1))
    diff = np.abs((diff + 90.0) % 180.0 - 90.0)[mask]
    return (float(diff.max()), float(np.median(diff))) if diff.size else (0.0, 0.0)
