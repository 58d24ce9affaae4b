"""``stokes_envmap``: an environment map of Stokes vectors.

.. list-table::
   :header-rows: 1

   * - Parameter
     - Type
     - Description
     - Default
     - Flags
   * - ``filename``
     - string
     - A Stokes OpenEXR in latitude-longitude layout: channels
       ``S0.<band> ... S3.<band>`` (the files ``pbrdf render`` and
       :func:`mitsuba_pbrdf.stokes.write_stokes_exr` write; bands ``R, G, B``,
       ``Y``, or any names), in the lat-long Stokes basis below. Refused at
       load time if a channel is missing, or a texel is NaN or infinite, has
       a negative luminance S0, or a degree of polarization above 1 (beyond
       float rounding, 1e-3 of S0).
     - (required)
     - --
   * - ``scale``
     - float
     - Factor on the radiance. Valid: >= 0.
     - 1
     - ``intensity.scale``
   * - ``to_world``
     - transform
     - Local-to-world transform, as Mitsuba's ``envmap`` (local +Y up): a
       rotation (a uniform scale and a translation change nothing); refused
       at load time if singular, not finite, mirroring, shearing or scaling
       unevenly.
     - identity
     - --

**Layout** (Mitsuba's ``envmap``'s): column ``i`` of a ``W x H`` image holds
azimuth ``phi = 2 pi (i + 0.5) / W``, row ``j`` polar angle
``theta = pi j / (H - 1)`` (row 0 the zenith, +Y), and the texel is the
light arriving from the local direction
``d = (sin phi sin theta, cos theta, -cos phi sin theta)``.

**Stokes basis of a texel.** For light from ``d`` (propagating along
``w = -d``), x is the direction of increasing azimuth ``e_phi =
normalize(-d_z, 0, d_x)`` and y = ``w x x``, which points towards the zenith:
the basis of a camera looking at ``d`` with its up towards +Y, x to the right
in the panorama, angles counter-clockwise as the viewer sees them. (At the
poles, where ``e_phi`` vanishes, x is the local +X.) A lat-long capture by a
polarization camera turned about the vertical axis is in this basis.

**Emission.** The intensity is Mitsuba's ``envmap`` built from the S0 bands
(negative band values, which the sRGB conversion of saturated spectra can
produce, clipped to 0): its radiance, its spectral upsampling and its
importance sampling, which follows S0. The polarization is the luminance
Stokes vector of the file (Rec. 709 weights over R, G, B; the mean of other
bands), interpolated bilinearly as Stokes vectors (S1..S3 and S0 each, then
divided) on ``envmap``'s grid, rotated from the lat-long basis into
``mi.mueller.stokes_basis(w)``: one normalized Stokes vector for all
wavelengths of a direction (a band-dependent polarization is averaged). In
unpolarized variants the emitter is that ``envmap``.

XML::

    <emitter type="stokes_envmap">
        <string name="filename" value="sky_stokes.exr"/>
    </emitter>

:func:`build_class` defines the class on the active variant's Mitsuba base
class; :func:`mitsuba_pbrdf.registry.plugin_class` calls it once per variant.
"""

from __future__ import annotations

import math
import os

import drjit as dr
import mitsuba as mi
import numpy as np

from . import wrapped
from .. import properties as read
from ..mueller import basis, emitted, intensity


_NAME = "stokes_envmap"


def load_stokes_map(path):
    """``(s0_rgb (H, W, 3), luminance Stokes (H, W, 4))`` of a Stokes EXR,
    float32, checked; one-line ``ValueError`` naming the file otherwise."""
    from ..stokes import luminance_stokes, read_stokes_exr
    from ..stokes.quality import assess

    try:
        image = read_stokes_exr(path)
    except (OSError, ValueError) as error:
        raise ValueError(f"{_NAME}: parameter 'filename': {' '.join(str(error).split())}") \
            from None
    height, width = image.stokes.shape[:2]
    if width < 2 or height < 2:
        raise ValueError(f"{_NAME}: parameter 'filename': {path} is {width} x {height}; a "
                         "latitude-longitude map needs at least 2 x 2 texels")
    quality = assess(image)
    for mask, what in ((quality.non_finite, "a NaN or infinite value"),
                       (quality.negative_s0, "a negative luminance S0"),
                       (quality.overpolarized, "a degree of polarization above 1")):
        if mask.any():
            j, i = np.argwhere(mask)[0]
            raise ValueError(f"{_NAME}: parameter 'filename': {os.path.basename(path)} has "
                             f"{int(mask.sum())} texel(s) with {what} (first at column {i}, "
                             f"row {j})")
    bands = image.bands
    if all(b in bands for b in "RGB"):
        s0 = np.stack([image.stokes[:, :, 0, bands.index(b)] for b in "RGB"], -1)
    else:
        s0 = np.repeat(image.stokes[:, :, 0, :].mean(-1, keepdims=True), 3, -1)
    return np.maximum(s0, 0.0).astype(np.float32), luminance_stokes(image).astype(np.float32)


def _configure(props):
    """The checked parameters of a ``stokes_envmap``, as attributes."""
    filename = read.string(props, _NAME, "filename")
    path = str(mi.file_resolver().resolve(filename))
    if not os.path.isfile(path):
        raise ValueError(f"{_NAME}: parameter 'filename': {filename}: no such file")
    scale = read.declared(props, _NAME, "scale")
    m = np.array(read.rotation(props, _NAME, "to_world"), np.float64)
    s0, stokes = load_stokes_map(path)
    config = {"bitmap": mi.Bitmap(s0), "scale": scale}
    if "to_world" in props:
        config["to_world"] = read.as_transform(m)
    return {"filename": filename, "inner": read.create("envmap", **config),
            "to_local": [[float(c) for c in row] for row in m.T],
            "to_world_rows": [[float(c) for c in row] for row in m],
            "height": stokes.shape[0], "width": stokes.shape[1],
            "stokes": mi.Float(stokes.ravel())}


def build_class():
    """``StokesEnvmap`` on the active variant's base class (registry.plugin_class)."""
    class StokesEnvmap(wrapped.emitter_base(_configure)):
        """An environment map of Stokes vectors (module docstring)."""

        def __init__(self, props):
            super().__init__(props)
            self.m_flags = mi.EmitterFlags.Infinite | mi.EmitterFlags.SpatiallyVarying

        # -------------------------------------------------------------- polarization

        @staticmethod
        def _apply(rows, v):
            return mi.Vector3f(*(dr.fma(r[0], v.x, dr.fma(r[1], v.y, r[2] * v.z)) for r in rows))

        def _lookup(self, d):
            """The luminance Stokes vector (4 Floats) at local direction ``d``,
            bilinear on envmap's grid (columns at (i + 0.5) / W, wrapping; rows
            at j / (H - 1))."""
            w, h = self.width, self.height
            u = dr.atan2(d.x, -d.z) * (0.5 / math.pi)
            v = dr.safe_acos(d.y) * (1.0 / math.pi)
            x = dr.fma(u - dr.floor(u), w, -0.5)
            x = dr.select(x < 0, x + w, x)
            y = dr.clip(v * (h - 1), 0.0, h - 1.0)
            i0 = mi.UInt32(dr.minimum(dr.floor(x), w - 1))
            j0 = mi.UInt32(dr.minimum(dr.floor(y), h - 2))
            fx, fy = x - mi.Float(i0), y - mi.Float(j0)
            i1 = dr.select(i0 + 1 >= w, i0 + 1 - w, i0 + 1)
            out = []
            for c in range(4):
                def texel(i, j, c=c):
                    return dr.gather(mi.Float, self.stokes, (j * w + i) * 4 + c)
                top = dr.lerp(texel(i0, j0), texel(i1, j0), fx)
                bottom = dr.lerp(texel(i0, j0 + 1), texel(i1, j0 + 1), fx)
                out.append(dr.lerp(top, bottom, fy))
            return out

        def _ratios(self, w):
            """(q, u, v) of the light propagating along ``w`` (world), in
            ``stokes_basis(w)``."""
            d = self._apply(self.to_local, -w)
            s0, s1, s2, s3 = self._lookup(d)
            inv = dr.select(s0 > 0, dr.rcp(s0), 0.0)
            q, u, v = s1 * inv, s2 * inv, s3 * inv
            # the lat-long basis: x along increasing azimuth (local), into world
            east = mi.Vector3f(-d.z, 0.0, d.x)
            east = dr.select(dr.squared_norm(east) > 1e-12, east, mi.Vector3f(1.0, 0.0, 0.0))
            east = dr.normalize(self._apply(self.to_world_rows, east))
            x, y = basis(w)
            c, s = dr.dot(east, x), dr.dot(east, y)     # east = c x + s y
            cos2, sin2 = c * c - s * s, 2.0 * c * s
            return cos2 * q - sin2 * u, sin2 * q + cos2 * u, v

        def light(self, value, w, wavelengths=None):
            """The ``envmap``'s ``value`` for light propagating along ``w``,
            polarized (unchanged in unpolarized variants)."""
            if not mi.is_polarized:
                return value
            q, u, v = self._ratios(w)
            return emitted(intensity(value), q, u, v)

        # -------------------------------------------------------------- Emitter API

        def sample_wavelengths(self, si, sample, active=True):
            # envmap draws wavelengths from a texture coordinate, not a direction
            return self.inner.sample_wavelengths(si, sample, active)

        def traverse(self, callback):
            callback.put("intensity", self.inner, mi.ParamFlags.Differentiable)

        def to_string(self):
            return (f"StokesEnvmap[\n  filename = {self.filename!r},\n"
                    f"  resolution = {self.width} x {self.height}\n]")

    return StokesEnvmap
