"""``polarized_twosided``: Mitsuba's ``twosided`` with the back side's Stokes bases put right.

.. list-table::
   :header-rows: 1

   * - Parameter
     - Type
     - Description
     - Default
     - Flags
   * - (nested plugin)
     - bsdf
     - One BRDF for both sides (``pbrdf``, ``roughconductor``, ...), or two:
       the front's, then the back's. No transmission.
     - (required)
     - |exposed|, |differentiable|

A drop-in replacement for Mitsuba 3.9.1's ``twosided``: same flags,
components, traversal (``brdf_0``, ``brdf_1``) and steps. On the back side
(``si.wi`` below the horizon) it evaluates and samples the nested BRDF at
the directions mirrored through the surface (z negated), as ``twosided``
does, so unpolarized variants give what ``twosided`` gives, and so does S0.

In polarized variants ``twosided`` hands the integrator the mirrored
evaluation's Mueller matrix unchanged: its Stokes bases are those of the
mirrored directions, mirrored back they are left-handed and turned about the
ray, so the coupling of S1 with S2 and S3 changes sign and the angle of
linear polarization of light reflected on the back comes out mirrored
(``roughconductor`` as ``pbrdf``; tests/bsdfs/test_perturbed.py). Here the matrix is
mapped back: ``D M D`` with ``D = diag(1, 1, -1, -1)`` (the mirror's change of
handedness), then one Stokes rotator per side from the mirrored basis to
Mitsuba's basis of the actual direction. The back side is then the front
seen from below: the front turned 180 degrees about the tangent.

XML::

    <bsdf type="polarized_twosided">
        <bsdf type="pbrdf">
            <string name="material" value="Au"/>
        </bsdf>
    </bsdf>

:func:`build_class` defines the class on the active variant's Mitsuba base
class; :func:`mitsuba_pbrdf.registry.plugin_class` calls it once per variant.
"""

from __future__ import annotations

import drjit as dr
import mitsuba as mi

from ..mueller import rotate_mueller, rotator_entries
from .. import properties as read


_NAME = "polarized_twosided"


def _mirror(v):
    """``v`` (local) mirrored through the surface."""
    return mi.Vector3f(v.x, v.y, -v.z)


def to_back_bases(ctx, value, wo_m, wi_m, back):
    """On the lanes ``back``: ``value``, a Mueller matrix the nested BRDF
    returned for the mirrored local directions ``wo_m``, ``wi_m``, in the
    Stokes bases of the actual (mirrored back) directions; other lanes and
    unpolarized variants unchanged."""
    if not mi.is_polarized:
        return value
    radiance = ctx.mode == mi.TransportMode.Radiance
    wo_hat, wi_hat = (wo_m, wi_m) if radiance else (wi_m, wo_m)
    sides = []
    for forward_m in (-wo_hat, wi_hat):
        forward = _mirror(forward_m)
        sides.append(rotator_entries(forward, _mirror(mi.mueller.stokes_basis(forward_m)),
                                     mi.mueller.stokes_basis(forward)))
    flipped = mi.Spectrum(value)
    for i in range(4):
        for j in range(4):
            if (i >= 2) != (j >= 2):      # D M D
                flipped[i, j] = -value[i, j]
    return dr.select(back, rotate_mueller(flipped, *sides), value)


def build_class():
    """``PolarizedTwoSided`` on the active variant's base class (registry.plugin_class)."""
    class PolarizedTwoSided(mi.BSDF):
        """Mitsuba's ``twosided`` with the back side's Mueller matrix in the right
        Stokes bases (module docstring)."""

        def __init__(self, props):
            bsdfs = list(read.nested_objects(props, mi.BSDF).values())
            if not 1 <= len(bsdfs) <= 2:
                raise ValueError(f"{_NAME}: one or two nested BSDFs must be given, found "
                                 f"{len(bsdfs)}")
            for b in bsdfs:
                if b.flags() & mi.BSDFFlags.Transmission:
                    raise ValueError(f"{_NAME}: only BSDFs without a transmission component "
                                     "can be nested")
            super().__init__(props)
            self.brdf = bsdfs if len(bsdfs) == 2 else bsdfs * 2
            self.m_components = []
            for side, (keep, drop) in enumerate(((mi.BSDFFlags.FrontSide, mi.BSDFFlags.BackSide),
                                                 (mi.BSDFFlags.BackSide, mi.BSDFFlags.FrontSide))):
                for i in range(self.brdf[side].component_count()):
                    self.m_components.append((self.brdf[side].flags(i) & ~drop) | keep)
            self.m_flags = mi.BSDFFlags.Empty
            for flags in self.m_components:
                self.m_flags = self.m_flags | flags

        def _shared(self):
            return self.brdf[0] is self.brdf[1]

        def _back_ctx(self, ctx):
            if ctx.component == 0xFFFFFFFF or self._shared():
                return ctx
            back = mi.BSDFContext(ctx)
            back.component = ctx.component - self.brdf[0].component_count()
            return back

        def _sides(self, ctx, si, wo, active, call):
            """``call(bsdf, ctx, si, wo, mask)`` on the front, and on the back at
            the mirrored directions (``wo`` None for sampling): (front result,
            back result, back mask, mirrored si)."""
            back = active & (mi.Frame3f.cos_theta(si.wi) < 0.0)
            front = active & (mi.Frame3f.cos_theta(si.wi) > 0.0)
            si_m = mi.SurfaceInteraction3f(si)
            si_m.wi = _mirror(si.wi)
            wo_m = None if wo is None else _mirror(wo)
            if self._shared():
                si_s = mi.SurfaceInteraction3f(si)
                si_s.wi = dr.select(back, si_m.wi, si.wi)
                wo_s = None if wo is None else dr.select(back, wo_m, wo)
                result = call(self.brdf[0], ctx, si_s, wo_s, active)
                return result, result, back, si_s
            return (call(self.brdf[0], ctx, si, wo, front),
                    call(self.brdf[1], self._back_ctx(ctx), si_m, wo_m, back), back, si_m)

        def eval(self, ctx, si, wo, active=True):
            front, value, back, si_m = self._sides(
                ctx, si, wo, mi.Bool(active), lambda b, c, s, w, m: b.eval(c, s, w, m))
            value = to_back_bases(ctx, value, _mirror(wo), si_m.wi, back)
            return dr.select(back, value, front)

        def pdf(self, ctx, si, wo, active=True):
            front, pdf, back, _ = self._sides(
                ctx, si, wo, mi.Bool(active), lambda b, c, s, w, m: b.pdf(c, s, w, m))
            return dr.select(back, pdf, front)

        def eval_pdf(self, ctx, si, wo, active=True):
            (fv, fp), (bv, bp), back, si_m = self._sides(
                ctx, si, wo, mi.Bool(active), lambda b, c, s, w, m: b.eval_pdf(c, s, w, m))
            bv = to_back_bases(ctx, bv, _mirror(wo), si_m.wi, back)
            return dr.select(back, bv, fv), dr.select(back, bp, fp)

        def sample(self, ctx, si, sample1, sample2, active=True):
            (fs, fw), (bs, bw), back, si_m = self._sides(
                ctx, si, None, mi.Bool(active),
                lambda b, c, s, w, m: b.sample(c, s, sample1, sample2, m))
            wo_m = mi.Vector3f(bs.wo)       # a copy: the record's field is a view
            bw = to_back_bases(ctx, bw, wo_m, si_m.wi, back)
            bs.wo = dr.select(back, _mirror(wo_m), bs.wo)
            return dr.select(back, bs, fs), dr.select(back, bw, fw)

        def eval_diffuse_reflectance(self, si, active=True):
            back = mi.Frame3f.cos_theta(si.wi) < 0.0
            si_m = mi.SurfaceInteraction3f(si)
            si_m.wi = _mirror(si.wi)
            return dr.select(back, self.brdf[1].eval_diffuse_reflectance(si_m, active),
                             self.brdf[0].eval_diffuse_reflectance(si, active))

        def traverse(self, callback):
            callback.put("brdf_0", self.brdf[0], mi.ParamFlags.Differentiable)
            callback.put("brdf_1", self.brdf[1], mi.ParamFlags.Differentiable)

        def to_string(self):
            return f"PolarizedTwoSided[\n  brdf[0] = {self.brdf[0]},\n  brdf[1] = {self.brdf[1]}\n]"

    return PolarizedTwoSided
