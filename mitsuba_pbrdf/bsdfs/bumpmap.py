"""``polarized_bumpmap``: Mitsuba's ``bumpmap`` with the Stokes bases put right.

.. list-table::
   :header-rows: 1

   * - Parameter
     - Type
     - Description
     - Default
     - Flags
   * - (nested texture)
     - texture (``bitmap`` with ``raw`` = true, one channel)
     - The height field, in scene units per unit of ``scale`` (any name).
       Only its UV gradient matters: a constant offset changes nothing.
       Non-finite heights, and textures without a UV gradient
       (``eval_1_grad``: a ``checkerboard``), are refused at load time and
       at ``parameters_changed``.
     - (required)
     - |exposed|, |differentiable|, |discontinuous|
   * - (nested plugin)
     - bsdf
     - The BSDF the bump map perturbs (``pbrdf``, ``roughconductor``, ...).
     - (required)
     - |exposed|, |differentiable|, |discontinuous|
   * - ``scale``
     - float
     - Multiplier of the height gradient; a finite number (not a boolean), re-checked at ``parameters_changed``.
     - 1
     - |exposed|
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

A drop-in replacement for Mitsuba 3.9.1's ``bumpmap``. The shading normal is
that of the displaced surface p + scale · h(u, v) · n: with the height's UV
gradient (h_u, h_v), dp/du gains n·h_u·scale and dp/dv gains n·h_v·scale (the
change of n itself is neglected), and the normal is their normalized cross
product; the tangent is ``dp_du`` projected off it. Same ``eval``/``pdf``/
``eval_pdf``/``sample`` steps, flags and traversal (``nested_texture.data``,
``nested_bsdf.*``, ``scale``) as ``bumpmap``, so unpolarized variants give
what ``bumpmap`` gives; in polarized variants the nested Mueller matrix is
rotated from the perturbed frame's Stokes bases into the unperturbed frame's
(:func:`mitsuba_pbrdf.mueller.to_unperturbed_bases`, docs/conventions.md), which ``bumpmap`` leaves out.

Kept from ``bumpmap``: the tangent is ``dp_du`` in world coordinates
projected off the normal in shading coordinates. On shapes whose shading frame
is not the world's axes, this turns the perturbed tangent about the normal.
Isotropic nested BSDFs do not see the tangent (and the Stokes correction uses
whatever tangent the frame has), anisotropic ones do. Changed: where that
projection vanishes (shorter than 1e-3 |dp_du|: a shape turned so that its
world ``dp_du`` lies along the local normal, e.g. a rectangle turned 90° about
y with a flat height map), ``bumpmap``'s frame degenerates and it renders
nearly black; ``polarized_bumpmap`` takes the shading frame's x axis projected
off the normal there (as ``normalmap`` does).

XML::

    <bsdf type="polarized_bumpmap">
        <texture name="height" type="bitmap">
            <boolean name="raw" value="true"/>
            <string name="filename" value="textures/height.exr"/>
        </texture>
        <float name="scale" value="0.5"/>
        <bsdf type="roughconductor"/>
    </bsdf>

:func:`build_class` defines the class on the active variant's Mitsuba base
class; :func:`mitsuba_pbrdf.registry.plugin_class` calls it once per variant.
"""

from __future__ import annotations

import math

import drjit as dr
import mitsuba as mi
import numpy as np

from . import perturbed
from .. import properties as read
from ..schema import parameter


_NAME = "polarized_bumpmap"


def check_heights(texture):
    """Raise a one-line ``ValueError`` if the height texture stores a NaN or
    infinite value, or cannot be evaluated the way the kernel evaluates it
    (``eval_1_grad``: a bitmap has it, a ``checkerboard`` has not)."""
    params = mi.traverse(texture)
    for key in params.keys():
        if key.split(".")[-1] in ("data", "value"):
            values = np.asarray(dr.detach(params[key]).numpy() if hasattr(params[key], "numpy")
                                else params[key], dtype=np.float64)
            if not np.all(np.isfinite(values)):
                raise ValueError(f"{_NAME}: the height texture contains NaN or infinite values")
    si = dr.zeros(mi.SurfaceInteraction3f)
    si.uv = mi.Point2f(0.5, 0.5)
    try:
        with dr.suspend_grad():  # a check: no derivative graph (parameters_changed runs in AD)
            grad = texture.eval_1_grad(si)
            dr.eval(grad)
        finite = bool(np.all(np.isfinite(np.array([np.asarray(grad.x), np.asarray(grad.y)],
                                                  dtype=np.float64))))
    except Exception as e:  # noqa: BLE001 - Mitsuba's "not implemented", whatever its type
        reason = " ".join(str(e).split()) or type(e).__name__
        raise ValueError(f"{_NAME}: the height texture ({texture.class_name()}) has no UV "
                         f"gradient, which the bump map needs (eval_1_grad: {reason}); give a "
                         "one-channel bitmap with raw = true") from None
    if not finite:
        raise ValueError(f"{_NAME}: the height texture's gradient is NaN or infinite")


def check_scale(scale):
    """The bump map's ``scale`` as a float: a finite number, not a boolean
    (``true`` is not a scale); a one-line ``ValueError`` otherwise."""
    if isinstance(scale, bool) or not isinstance(scale, (int, float)) \
            or not math.isfinite(scale):
        raise ValueError(f"{_NAME}: parameter 'scale' must be a finite number, got {scale!r}")
    return float(scale)


def bumpmap_frame(texture, scale, si, flip_invalid_normals, active):
    """The perturbed frame of ``bumpmap`` in the unperturbed shading frame S
    (see the module docstring for the tangent), and in world space."""
    grad_uv = scale * texture.eval_1_grad(si, active)
    n_sh = si.sh_frame.n
    dp_du = dr.fma(n_sh, grad_uv.x - dr.dot(n_sh, si.dp_du), si.dp_du)
    dp_dv = dr.fma(n_sh, grad_uv.y - dr.dot(n_sh, si.dp_dv), si.dp_dv)

    n = dr.normalize(dr.cross(dp_du, dp_dv))
    n = dr.select(dr.dot(si.n, n) < 0.0, -n, n)  # the geometric normal's side
    n = si.to_local(n)
    if flip_invalid_normals:
        # Ensure that shading normals always face the incident direction.
        flip = mi.Frame3f.cos_theta(si.wi) * dr.dot(si.wi, n) <= 0.0
        n = dr.select(flip, mi.Vector3f(-n.x, -n.y, n.z), n)

    frame_si = dr.zeros(mi.Frame3f)
    frame_si.n = n
    # bumpmap's tangent: dp_du (world) projected off n (shading frame) ...
    s = dr.fma(-n, dr.dot(n, si.dp_du), si.dp_du)
    # ... which vanishes where dp_du is along the local normal (a shape turned
    # so that its world dp_du points along local z): there bumpmap's frame is
    # degenerate (black); take S's x axis projected off n instead.
    s = dr.select(dr.squared_norm(s) > 1e-6 * dr.squared_norm(si.dp_du), s,
                  dr.fma(-n, n.x, mi.Vector3f(1.0, 0.0, 0.0)))
    frame_si.s = dr.normalize(s)
    frame_si.t = dr.cross(n, frame_si.s)

    return frame_si, perturbed.to_world_frame(si, frame_si)


def build_class():
    """``PolarizedBumpMap`` on the active variant's base class (registry.plugin_class)."""
    class PolarizedBumpMap(perturbed.wrapper_base(_NAME, zero_pdf_on_wrong_side=False)):
        """Mitsuba's ``bumpmap`` with the nested Mueller matrix rotated into the
        unperturbed frame's Stokes bases (module docstring)."""

        def __init__(self, props):
            super().__init__(props)
            textures = read.nested_objects(props, mi.Texture)
            if len(textures) != 1:
                raise ValueError(f"{_NAME}: exactly one nested height texture must be given, "
                                 f"found {len(textures)}")
            self.nested_texture = next(iter(textures.values()))
            check_heights(self.nested_texture)
            scale = props.get("scale", parameter("scale", _NAME).default)
            self.scale = mi.Float(check_scale(scale))
            self.m_flags = self.nested_bsdf.flags()

        def traverse(self, callback):
            disc = mi.ParamFlags.Differentiable | mi.ParamFlags.Discontinuous
            callback.put("nested_bsdf", self.nested_bsdf, disc)
            callback.put("nested_texture", self.nested_texture, disc)
            callback.put("scale", self.scale, mi.ParamFlags.NonDifferentiable)

        def parameters_changed(self, keys):
            # every update re-checked, as at load time (the normal map does the same)
            if not keys or any(k.startswith("nested_texture") for k in keys):
                check_heights(self.nested_texture)
            if not keys or "scale" in keys:
                values = np.atleast_1d(np.asarray(dr.detach(self.scale), dtype=np.float64))
                if values.size != 1 or not np.all(np.isfinite(values)):
                    raise ValueError(f"{_NAME}: parameter 'scale' must be a finite number, got "
                                     f"{values.tolist()}")

        def frame(self, si, active=True):
            return bumpmap_frame(self.nested_texture, self.scale, si, self.flip_invalid_normals,
                                 active)

        def to_string(self):
            return (f"PolarizedBumpMap[\n  nested_bsdf = {self.nested_bsdf},\n"
                    f"  nested_texture = {self.nested_texture},\n  scale = {self.scale},\n"
                    f"  flip_invalid_normals = {self.flip_invalid_normals},\n"
                    f"  use_shadowing_function = {self.use_shadowing_function}\n]")

    return PolarizedBumpMap
