"""``polarized_normalmap``: Mitsuba's ``normalmap`` with the Stokes bases put right.

.. list-table::
   :header-rows: 1

   * - Parameter
     - Type
     - Description
     - Default
     - Flags
   * - ``normalmap``
     - texture (``bitmap`` with ``raw`` = true)
     - Perturbed normals in the unperturbed shading frame, encoded as
       colour = (n + 1) / 2 per component (x along the shading tangent
       ``dp_du``, z along the shading normal; (0.5, 0.5, 1) changes nothing).
       Need not be unit length; a texel whose decoded normal is shorter than
       1e-3 (no direction), points into the surface (z < 0: blue below 0.495,
       e.g. an all-zero texel) or is not finite is refused at load time and at
       ``parameters_changed`` (every texel of a raw bitmap; other textures on
       a 64 x 64 grid of uv).
     - (required)
     - |exposed|, |differentiable|, |discontinuous|
   * - (nested plugin)
     - bsdf
     - The BSDF the normal map perturbs (``pbrdf``, ``roughconductor``, ...).
     - (required)
     - |exposed|, |differentiable|
   * - ``flip_invalid_normals``
     - boolean
     - Mirror the perturbed normal's tangential part where it faces away from the viewer (Schüssler et al. 2017), as Mitsuba's ``normalmap`` and ``bumpmap`` do.
     - true
     - --
   * - ``use_shadowing_function``
     - boolean
     - Multiply by Estevez et al. 2019's shadowing term of the perturbed normal (softens the bump-terminator edge), as Mitsuba's ``normalmap`` and ``bumpmap`` do.
     - true
     - --

A drop-in replacement for Mitsuba 3.9.1's ``normalmap``: same parameters,
same perturbed shading frame, same ``eval``/``pdf``/``eval_pdf``/``sample``
steps, flags and traversal (keys ``normalmap.data``, ``nested_bsdf.*``). In
unpolarized variants it gives what ``normalmap`` gives. In polarized variants
``normalmap`` hands the integrator the nested BSDF's Mueller matrix in the
Stokes bases of the perturbed frame, which the integrator reads as those of the
unperturbed frame: the intensity is right, the angle of linear polarization is
not (off by up to 45° on a tilted plane). ``polarized_normalmap`` rotates both
bases into the unperturbed frame's (:func:`mitsuba_pbrdf.mueller.to_unperturbed_bases`; the derivation is in
docs/conventions.md): a constant normal map then renders as the physically
tilted plane in DoLP and AoLP.

The intensity keeps ``normalmap``'s own factor, Estevez's shadowing term
``2 / (1 + sqrt(1 + a² tan² θo))``, ``a² = min(tan² θn / 8, 1)`` (θn: tilt of
the mapped normal, θo: angle of the light direction from the unperturbed
normal). On a plane lit by a directional light it is a constant: about 0.98 at
a 30° tilt and 0.66 at 60° for light arriving 70° off the unperturbed normal.
``use_shadowing_function`` = false removes it, and then a constant normal map
matches the tilted plane in S0 too.

Fallback (never NaN): where the bilinearly interpolated normal between texels
has (almost) zero length (shorter than 1e-3), the unperturbed normal is used;
where the normal is exactly along the tangent (±1, 0, 0), the tangent is
taken from the bitangent. ``normalmap`` builds a NaN frame at both, which its
horizon tests turn into black.

XML::

    <bsdf type="polarized_normalmap">
        <texture name="normalmap" type="bitmap">
            <boolean name="raw" value="true"/>
            <string name="filename" value="textures/plate_normals.png"/>
        </texture>
        <bsdf type="pbrdf">
            <string name="material" value="Al"/>
        </bsdf>
    </bsdf>

:func:`build_class` defines the class on the active variant's Mitsuba base
class; :func:`mitsuba_pbrdf.registry.plugin_class` calls it once per variant.
"""

from __future__ import annotations

import drjit as dr
import mitsuba as mi
import numpy as np

from . import perturbed


#: Decoded normals shorter than this have no usable direction (an 8-bit
#: texel's step is 2/255 = 0.008 per component).
MIN_NORMAL_LENGTH = 1e-3

#: A texel whose decoded normal has z below -this x its length points into the
#: surface and is refused (the tolerance keeps 8-bit encodings of tangent
#: normals, blue 127 for 127.5, which decode to z = -0.004).
INWARD_TOLERANCE = 0.01

_NAME = "polarized_normalmap"


def texel_normals(texture):
    """The decoded normals 2 c - 1 (N x 3 float64) of ``texture``: every texel
    of a bitmap as stored (raw bitmaps, and any bitmap outside spectral
    variants); otherwise the texture evaluated on a 64 x 64 grid of uv.
    Raises if a bitmap does not have three channels."""
    params = mi.traverse(texture)
    data_keys = [k for k in params.keys() if k.split(".")[-1] == "data"]
    if data_keys:
        data = np.asarray(params[data_keys[0]], dtype=np.float64)
        if data.ndim == 3 and data.shape[2] != 3:
            raise ValueError(f"{_NAME}: parameter 'normalmap' must have 3 channels (x, y, z), "
                             f"got {data.shape[2]}")
        # spectral variants store a non-raw RGB bitmap as upsampling coefficients
        if not mi.is_spectral or "raw = 1" in str(texture):
            return 2.0 * data.reshape(-1, 3) - 1.0
    if mi.variant().startswith("scalar"):
        return np.zeros((0, 3))  # one lane per call: not checked
    u, v = np.meshgrid((np.arange(64) + 0.5) / 64, (np.arange(64) + 0.5) / 64)
    si = dr.zeros(mi.SurfaceInteraction3f, u.size)
    si.uv = mi.Point2f(mi.Float(u.ravel()), mi.Float(v.ravel()))
    colour = texture.eval_3(si)
    return 2.0 * np.stack([np.asarray(c, dtype=np.float64) for c in colour], axis=1) - 1.0


def check_normal_texels(texture):
    """Raise a one-line ``ValueError`` if a texel of ``texture`` decodes to a
    normal that is not finite or shorter than :data:`MIN_NORMAL_LENGTH`."""
    normals = texel_normals(texture)
    if normals.size == 0:
        return
    if not np.all(np.isfinite(normals)):
        raise ValueError(f"{_NAME}: parameter 'normalmap' contains NaN or infinite texels")
    lengths = np.linalg.norm(normals, axis=1)
    short = int(np.argmin(lengths))
    if lengths[short] < MIN_NORMAL_LENGTH:
        raise ValueError(f"{_NAME}: parameter 'normalmap' has a texel of zero length (texel "
                         f"{short}, colour {tuple(round(c, 4) for c in (normals[short] + 1) / 2)}"
                         f" decodes to a normal of length {lengths[short]:.2g}); "
                         f"(0.5, 0.5, 1) is the unperturbed normal")
    inward = normals[:, 2] < -INWARD_TOLERANCE * lengths
    if np.any(inward):
        first = int(np.argmax(inward))
        raise ValueError(f"{_NAME}: parameter 'normalmap' has {int(inward.sum())} of "
                         f"{len(normals)} texels pointing into the surface (texel {first}, "
                         f"colour {tuple(round(float(c), 4) for c in (normals[first] + 1) / 2)} decodes "
                         f"to z = {normals[first, 2]:.3g} < 0); the blue channel must be >= 0.5 "
                         "((0.5, 0.5, 1) is the unperturbed normal)")


def normalmap_frame(texture, si, flip_invalid_normals, active):
    """The perturbed frame ``(frame_si, frame_world)`` of ``normalmap``: the
    texture's normal in the unperturbed shading frame S, its tangent the
    projection of S's x axis; both written in S and in world space."""
    n = dr.fma(mi.Vector3f(texture.eval_3(si, active)), 2.0, -1.0)
    if flip_invalid_normals:
        # Ensure that shading normals always face the incident direction.
        flip = mi.Frame3f.cos_theta(si.wi) * dr.dot(si.wi, n) <= 0.0
        n = dr.select(flip, mi.Vector3f(-n.x, -n.y, n.z), n)
    # Fallback where normalmap returns NaN: an interpolated normal of ~zero length.
    n = dr.select(dr.squared_norm(n) > MIN_NORMAL_LENGTH ** 2, n, mi.Vector3f(0.0, 0.0, 1.0))

    frame_si = dr.zeros(mi.Frame3f)
    frame_si.n = dr.normalize(n)
    s = dr.fma(-frame_si.n, frame_si.n.x, mi.Vector3f(1.0, 0.0, 0.0))
    # ... and a normal along the tangent: take the bitangent's projection.
    s = dr.select(dr.squared_norm(s) > 1e-12, s,
                  dr.fma(-frame_si.n, frame_si.n.y, mi.Vector3f(0.0, 1.0, 0.0)))
    frame_si.s = dr.normalize(s)
    frame_si.t = dr.cross(frame_si.n, frame_si.s)

    return frame_si, perturbed.to_world_frame(si, frame_si)


def build_class():
    """``PolarizedNormalMap`` on the active variant's base class (registry.plugin_class)."""
    class PolarizedNormalMap(perturbed.wrapper_base(_NAME, zero_pdf_on_wrong_side=True)):
        """Mitsuba's ``normalmap`` with the nested Mueller matrix rotated into the
        unperturbed frame's Stokes bases (module docstring)."""

        def __init__(self, props):
            super().__init__(props)
            if "normalmap" not in props or not isinstance(props["normalmap"], mi.Texture):
                raise ValueError(f"{_NAME}: parameter 'normalmap' must be a texture "
                                 "(a bitmap with raw = true)")
            self.normalmap = props["normalmap"]
            check_normal_texels(self.normalmap)
            self.m_flags = mi.BSDFFlags.Empty
            for flags in self.m_components:
                self.m_flags = self.m_flags | flags

        def traverse(self, callback):
            callback.put("nested_bsdf", self.nested_bsdf, mi.ParamFlags.Differentiable)
            callback.put("normalmap", self.normalmap,
                         mi.ParamFlags.Differentiable | mi.ParamFlags.Discontinuous)

        def parameters_changed(self, keys):
            if not keys or any(k == "normalmap" or k.startswith("normalmap.") for k in keys):
                check_normal_texels(self.normalmap)

        def frame(self, si, active=True):
            return normalmap_frame(self.normalmap, si, self.flip_invalid_normals, active)

        def to_string(self):
            return (f"PolarizedNormalMap[\n  nested_bsdf = {self.nested_bsdf},\n"
                    f"  normalmap = {self.normalmap},\n"
                    f"  flip_invalid_normals = {self.flip_invalid_normals},\n"
                    f"  use_shadowing_function = {self.use_shadowing_function}\n]")

    return PolarizedNormalMap
