"""The plugin's lobes as records: one per lobe present, built once when the BSDF
is loaded, that ``eval``, ``pdf`` and ``sample`` loop over.

A lobe is a weight texture times a normalized shape. Two shapes exist:

* :class:`MicrofacetLobe`: ``D(h) G / (4 cos_i cos_o)`` with a Beckmann or GGX
  distribution of width ``alpha = sqrt(2) * sigma`` (``width`` is a
  :class:`Width`: the RMS slope sigma, or Mitsuba's alpha; an anisotropic lobe
  has ``width`` along the shading frame's s axis and ``width_v`` along its t
  axis), sampled through
  its visible normals. The specular lobe
  (``polarizing``: its weight multiplies the facet's Fresnel Mueller matrix)
  and the directional diffuse lobe (depolarized) are of this shape.
* :class:`LambertianLobe`: ``1 / pi``, cosine-sampled, depolarized: the ideal
  diffuse lobe.
* :class:`DeltaLobe`: the specular lobe's smooth limit (sigma = 0), a mirror:
  ``eval`` and ``pdf`` are 0 (a delta has no density), sampling returns the
  mirror direction with pdf 1 (times its selection probability), as Mitsuba's
  ``conductor`` does.

Each lobe has four straight methods, all in the local shading frame:
``value`` (the *unweighted* value times ``cos_o``, what Mitsuba's ``eval``
returns), ``pdf`` (the density of sampling ``wo``, times the lobe's selection
probability), ``sample_direction`` (a direction drawn from it) and
``sample_alone`` (a :class:`LobeSample`, when it is the only lobe enabled). The
BSDF applies the weight and, for the polarizing lobe, the Fresnel Mueller
matrix at the facet normal, and returns what it sampled as Mitsuba's record,
:func:`sample_record`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Dict, NamedTuple, Optional

import drjit as dr
import mitsuba as mi

from .microfacet import visible_g1
from .pbrdf_properties import Width

_INV_PI = 1.0 / math.pi


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


class Evaluation(NamedTuple):
    """One evaluation of the BSDF at ``si`` towards ``wo``: where it is
    ``active`` (both directions above the surface) and its :class:`HalfVector`."""

    si: object
    wo: object
    active: object
    half: HalfVector

    @staticmethod
    def of(si, wo, active):
        active = (mi.Bool(active) & (mi.Frame3f.cos_theta(si.wi) > 0)
                  & (mi.Frame3f.cos_theta(wo) > 0))
        return Evaluation(si, wo, active, HalfVector.of(si.wi, wo, active))


class LobeSample(NamedTuple):
    """A direction drawn from one lobe alone: ``wo``, its ``pdf``, the
    unweighted ``value`` times ``cos_o``, the ``facet_normal`` the Fresnel
    reflection is taken at (the sampled microfacet normal; the surface normal
    for the Lambertian lobe, which has no facets) and where it is ``active``."""

    wo: object
    pdf: object
    value: object
    facet_normal: object
    active: object


@dataclass(frozen=True)
class MicrofacetLobe:
    """A microfacet lobe: ``weight`` (texture), ``width`` (a :class:`Width`;
    along the s axis where ``width_v``, along t, is given: anisotropic),
    ``distribution`` (``mi.MicrofacetType``), ``shadowing`` (a function of
    :data:`.microfacet.SHADOWING`), ``flags`` (its lobe type, ``GlossyReflection``),
    ``index`` (component index), ``polarizing``
    (Fresnel Mueller matrix or depolarizer), ``textures``, its parameters by
    name as ``traverse`` exposes them, and ``projected``: whether Smith's G1
    projects the widths on the azimuth (anisotropic widths that may differ,
    decided when the lobe is built, never from traced values)."""

    name: str
    weight: object
    width: Width
    distribution: object
    shadowing: Callable
    flags: object
    index: int
    polarizing: bool
    textures: Dict[str, object]
    width_v: Optional[Width] = None
    projected: bool = False
    delta: bool = False

    @property
    def anisotropic(self):
        return self.width_v is not None

    def microfacets(self, si, active):
        """Mitsuba's distribution of this lobe at ``si`` (visible-normal sampling),
        alpha_u along the shading frame's s axis, alpha_v along t."""
        alpha_u = self.width.alpha(si, active)
        if self.width_v is None:
            return mi.MicrofacetDistribution(self.distribution, alpha_u, True)
        return mi.MicrofacetDistribution(self.distribution, alpha_u,
                                         self.width_v.alpha(si, active), True)

    def sample_direction(self, si, sample2, active):
        """A direction drawn from the visible normals seen from ``si.wi``."""
        m, _ = self.microfacets(si, active).sample(si.wi, sample2)
        return mi.reflect(si.wi, m)

    @staticmethod
    def _D(distribution, half):
        # cos(beta) > 0 whenever both directions are above the horizon; it can
        # only round to 0 (exactly opposite directions on the horizon).
        return dr.select(half.cos_beta > 0, distribution.eval(half.h), 0.0)

    def value(self, ev: Evaluation):
        """``D G / (4 cos_i)``: the unweighted value times cos_o."""
        distribution = self.microfacets(ev.si, ev.active)
        G = self.shadowing(distribution, ev.si.wi, ev.wo, ev.half.cos_h, ev.half.cos_beta)
        return self._D(distribution, ev.half) * G * ev.half.inv_4cos_i

    def pdf(self, ev: Evaluation, prob):
        """``prob`` times the density of sampling ``wo``: the visible-normal
        density mapped through the reflection Jacobian."""
        distribution = self.microfacets(ev.si, ev.active)
        return (prob * self._D(distribution, ev.half) * visible_g1(distribution, ev.si.wi, self.projected)
                * ev.half.inv_4cos_i)

    def sample_alone(self, si, sample2, active) -> LobeSample:
        """Sampling when this lobe is the only one enabled, the value in closed
        form. D cancels in value / pdf: pdf = D G1(wi) / (4 cos_i) and
        value = D G / (4 cos_i) = pdf G / G1(wi)."""
        distribution = self.microfacets(si, active)
        m, _ = distribution.sample(si.wi, sample2)
        wo = mi.reflect(si.wi, m)
        cos_beta = dr.dot(si.wi, m)
        active = active & (mi.Frame3f.cos_theta(wo) > 0) & (cos_beta > 0)
        g1 = visible_g1(distribution, si.wi, self.projected)
        pdf = distribution.eval(m) * g1 * dr.rcp(4.0 * mi.Frame3f.cos_theta(si.wi))
        G = self.shadowing(distribution, si.wi, wo, mi.Frame3f.cos_theta(m), cos_beta)
        return LobeSample(wo, pdf, G * dr.rcp(g1) * pdf, m, active)


@dataclass(frozen=True)
class LambertianLobe:
    """The ideal diffuse lobe ``1 / pi``: ``weight`` (texture), ``flags``
    (``DiffuseReflection``), ``index``, ``textures``; never polarizing, no width."""

    name: str
    weight: object
    flags: object
    index: int
    textures: Dict[str, object]
    polarizing: bool = False
    anisotropic: bool = False
    delta: bool = False

    def sample_direction(self, si, sample2, active):
        return mi.warp.square_to_cosine_hemisphere(sample2)

    def value(self, ev: Evaluation):
        return _INV_PI * mi.Frame3f.cos_theta(ev.wo)

    def pdf(self, ev: Evaluation, prob):
        return prob * mi.warp.square_to_cosine_hemisphere_pdf(ev.wo)

    def sample_alone(self, si, sample2, active) -> LobeSample:
        wo = mi.warp.square_to_cosine_hemisphere(sample2)
        pdf = mi.warp.square_to_cosine_hemisphere_pdf(wo)
        return LobeSample(wo, pdf, pdf, mi.Vector3f(0.0, 0.0, 1.0), active)   # value = cos_o / pi = pdf


@dataclass(frozen=True)
class DeltaLobe:
    """The smooth specular lobe: ``weight`` (texture), ``flags``
    (``DeltaReflection``), ``index``, ``textures`` (its weight: a delta has no
    width to expose), ``polarizing`` (the Fresnel Mueller matrix at the
    surface normal). The BSDF leaves it out of ``eval`` and ``pdf``."""

    name: str
    weight: object
    flags: object
    index: int
    textures: Dict[str, object]
    polarizing: bool = True
    anisotropic: bool = False
    delta: bool = True

    def sample_direction(self, si, sample2, active):
        return mirror(si.wi)

    def sample_alone(self, si, sample2, active) -> LobeSample:
        """The mirror direction, pdf 1 and unweighted value 1 (the weight and
        Fresnel factor at the normal are the BSDF's), as Mitsuba's conductor."""
        one = dr.full(mi.Float, 1.0, dr.width(si.wi))
        return LobeSample(mirror(si.wi), one, one, mi.Vector3f(0.0, 0.0, 1.0), active)


def mirror(wi):
    """The mirror direction of ``wi`` about the shading normal (local frame)."""
    return mi.Vector3f(-wi.x, -wi.y, wi.z)


def sample_record(wo, pdf, component, sampled_type, active, value):
    """``(BSDFSample3f, weight = value / pdf)``, zero where inactive or where
    the pdf is 0 or not finite."""
    active = active & (pdf > 0) & dr.isfinite(pdf)
    bs = dr.zeros(mi.BSDFSample3f)
    bs.wo = wo
    bs.pdf = dr.select(active, pdf, 0.0)
    bs.eta = 1.0
    bs.sampled_component = component
    bs.sampled_type = sampled_type
    zero = dr.zeros(mi.Spectrum) if mi.is_polarized else mi.UnpolarizedSpectrum(0.0)
    weight = dr.select(active, value * dr.rcp(pdf), zero)
    return bs, weight
