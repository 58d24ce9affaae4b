"""The plugin's lobes as records: one per lobe present, built once when the BSDF
is loaded, that ``eval``, ``pdf`` and ``sample`` loop over.

A lobe is a weight texture times a normalized shape. Two shapes exist:

* :class:`MicrofacetLobe`: ``D(h) G / (4 cos_i cos_o)`` with a Beckmann or GGX
  distribution of width ``alpha = sqrt(2) * sigma`` (``width`` is the RMS
  slope sigma; an anisotropic lobe has ``width`` = sigma_u along the shading
  frame's s axis and ``width_v`` = sigma_v along its t axis), sampled through
  its visible normals. The specular lobe
  (``polarizing``: its weight multiplies the facet's Fresnel Mueller matrix)
  and the directional diffuse lobe (depolarized) are of this shape.
* :class:`LambertianLobe`: ``1 / pi``, cosine-sampled, depolarized: the ideal
  diffuse lobe.

Every method returns the *unweighted* value times ``cos_o`` (what Mitsuba's
``eval`` returns), its sampling density or a sampled direction, all in the
local shading frame; the BSDF applies the weight and, for the polarizing
lobe, the Fresnel Mueller matrix.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import drjit as dr
import mitsuba as mi

from .microfacet import shadowing_g, visible_g1

_INV_PI = 1.0 / math.pi
_SQRT2 = math.sqrt(2.0)


@dataclass(frozen=True)
class HalfVector:
    """What every microfacet lobe of one evaluation shares: the half vector
    ``h = normalize(wi + wo)``, ``cos_h = h.z``, ``cos_beta = wi.h = wo.h`` (the
    angle of incidence on the facet) and ``1 / (4 cos_i)`` (0 where inactive)."""

    h: object
    cos_h: object
    cos_beta: object
    inv_4cos_i: object

    @staticmethod
    def of(wi, wo, active):
        # cos(beta) = |wi + wo| / 2, symmetric in wi and wo: for nearly opposite
        # grazing directions dot(wi, h) depends on which of the two carries the
        # larger float32 rounding (it differed 17x between transport modes).
        half = wi + wo
        h = dr.normalize(half)  # rounded as in roughconductor
        cos_i = mi.Frame3f.cos_theta(wi)
        return HalfVector(h, mi.Frame3f.cos_theta(h), 0.5 * dr.norm(half),
                          dr.select(active, dr.rcp(4.0 * cos_i), 0.0))


@dataclass(frozen=True)
class MicrofacetLobe:
    """A microfacet lobe: ``weight`` (texture), ``width`` (RMS slope sigma,
    float texture; sigma_u where ``width_v``, sigma_v, is given: anisotropic), ``distribution`` (``mi.MicrofacetType``), ``shadowing``
    (``"vgroove"`` or ``"smith"``), ``flags`` (its lobe type, ``GlossyReflection``), ``index``
    (component index), ``polarizing`` (Fresnel Mueller matrix or depolarizer)."""

    name: str
    weight: object
    width: object
    distribution: object
    shadowing: str
    flags: object
    index: int
    polarizing: bool
    width_v: object = None

    def microfacets(self, si, active):
        """Mitsuba's distribution of this lobe at ``si`` (visible-normal sampling),
        alpha_u along the shading frame's s axis, alpha_v along t."""
        alpha_u = _SQRT2 * self.width.eval_1(si, active)
        if self.width_v is None:
            return mi.MicrofacetDistribution(self.distribution, alpha_u, True)
        return mi.MicrofacetDistribution(self.distribution, alpha_u,
                                         _SQRT2 * self.width_v.eval_1(si, active), True)

    def sample_direction(self, si, sample2, active):
        """A direction drawn from the visible normals seen from ``si.wi``."""
        m, _ = self.microfacets(si, active).sample(si.wi, sample2)
        return mi.reflect(si.wi, m)

    def eval_pdf(self, si, wo, half, active, prob, want_value, want_pdf):
        """``(D G / (4 cos_i), prob x pdf)``: the unweighted value times cos_o
        (None unless ``want_value``) and the density of sampling ``wo`` times
        the lobe's selection probability ``prob`` (None unless ``want_pdf``)."""
        distribution = self.microfacets(si, active)
        # cos(beta) > 0 whenever both directions are above the horizon; it can
        # only round to 0 (exactly opposite directions on the horizon).
        D = dr.select(half.cos_beta > 0, distribution.eval(half.h), 0.0)
        pdf = value = None
        if want_pdf:
            # Visible-normal density mapped through the reflection Jacobian.
            pdf = prob * D * visible_g1(distribution, si.wi) * half.inv_4cos_i
        if want_value:
            G = shadowing_g(self.shadowing, distribution, si.wi, wo, half.cos_h, half.cos_beta)
            value = D * G * half.inv_4cos_i
        return value, pdf

    def sample_alone(self, si, sample2, active):
        """Sampling when this lobe is the only one enabled: ``(wo, pdf, value,
        h, active)`` with the value in closed form. D cancels in value / pdf:
        pdf = D G1(wi) / (4 cos_i) and value = D G / (4 cos_i) = pdf G / G1(wi)."""
        distribution = self.microfacets(si, active)
        m, _ = distribution.sample(si.wi, sample2)
        wo = mi.reflect(si.wi, m)
        cos_beta = dr.dot(si.wi, m)
        active = active & (mi.Frame3f.cos_theta(wo) > 0) & (cos_beta > 0)
        g1 = visible_g1(distribution, si.wi)
        pdf = distribution.eval(m) * g1 * dr.rcp(4.0 * mi.Frame3f.cos_theta(si.wi))
        G = shadowing_g(self.shadowing, distribution, si.wi, wo, mi.Frame3f.cos_theta(m), cos_beta)
        return wo, pdf, G * dr.rcp(g1) * pdf, m, active


@dataclass(frozen=True)
class LambertianLobe:
    """The ideal diffuse lobe ``1 / pi``: ``weight`` (texture), ``flags`` (``DiffuseReflection``),
    ``index``; never polarizing, no width."""

    name: str
    weight: object
    flags: object
    index: int
    polarizing: bool = False
    width: object = None

    def sample_direction(self, si, sample2, active):
        return mi.warp.square_to_cosine_hemisphere(sample2)

    def eval_pdf(self, si, wo, half, active, prob, want_value, want_pdf):
        cos_o = mi.Frame3f.cos_theta(wo)
        value = _INV_PI * cos_o if want_value else None
        pdf = prob * mi.warp.square_to_cosine_hemisphere_pdf(wo) if want_pdf else None
        return value, pdf

    def sample_alone(self, si, sample2, active):
        wo = mi.warp.square_to_cosine_hemisphere(sample2)
        pdf = mi.warp.square_to_cosine_hemisphere_pdf(wo)
        return wo, pdf, pdf, None, active  # value = cos_o / pi = pdf
