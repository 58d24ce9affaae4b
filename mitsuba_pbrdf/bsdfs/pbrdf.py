"""The ``pbrdf`` plugin: three-component polarized BRDF for metals.

Parameters (declared in :mod:`mitsuba_pbrdf.schema`, each read by name in the
constructor; the table below is ``schema_tables.rst_table()``, written here so that the
source reads as the documentation, and ``tests/test_schema.py`` checks that the
two agree):

.. list-table::
   :header-rows: 1

   * - Parameter
     - Type
     - Description
     - Default
     - Flags
   * - ``material``
     - string
     - Named conductor from Mitsuba's tabulated spectra; mutually exclusive with eta and k.
     - ``Al``
     - --
   * - ``eta``
     - spectrum or texture
     - Real part n of the metal's complex index of refraction N = n + ik. Valid: > 0.
     - from material
     - exposed, differentiable, discontinuous
   * - ``k``
     - spectrum or texture
     - Imaginary part k (extinction coefficient) of the complex index N = n + ik. Valid: >= 0.
     - from material
     - exposed, differentiable, discontinuous
   * - ``sigma``
     - float or texture
     - RMS microfacet slope per axis of the specular lobe (paper Eq. 3); Beckmann width alpha = sqrt(2) sigma (Mitsuba clamps alpha >= 1e-4, hence the floor). 0 is the smooth limit: a delta lobe, Mitsuba's conductor. Valid: 0 (smooth: a mirror) or >= 7.07e-05.
     - 0.1
     - exposed where the lobe is isotropic, differentiable, discontinuous
   * - ``alpha``
     - float or texture
     - Mitsuba's roughness (roughconductor's alpha, Beckmann or GGX as distribution says): the specular lobe's width alpha = sqrt(2) sigma, given instead of sigma. Valid: 0 (smooth: a mirror) or >= 0.0001.
     - --
     - exposed where the lobe is isotropic, differentiable, discontinuous
   * - ``sigma_u``
     - float or texture
     - RMS slope of the specular lobe along the shading frame's s axis (dp_du); alpha_u = sqrt(2) sigma_u. Giving sigma_u or sigma_v makes the lobe anisotropic. Valid: 0 (smooth: a mirror) or >= 7.07e-05.
     - ``sigma``
     - exposed where the lobe is anisotropic, differentiable, discontinuous
   * - ``alpha_u``
     - float or texture
     - Mitsuba's alpha_u: the specular lobe's width along s, alpha_u = sqrt(2) sigma_u, given instead of sigma_u. Valid: 0 (smooth: a mirror) or >= 0.0001.
     - --
     - exposed where the lobe is anisotropic, differentiable, discontinuous
   * - ``sigma_v``
     - float or texture
     - RMS slope of the specular lobe along the shading frame's t axis (n x dp_du); alpha_v = sqrt(2) sigma_v. 0 only with sigma_u = 0 (smooth). Valid: 0 (smooth: a mirror) or >= 7.07e-05.
     - ``sigma``
     - exposed where the lobe is anisotropic, differentiable, discontinuous
   * - ``alpha_v``
     - float or texture
     - Mitsuba's alpha_v: the specular lobe's width along t, alpha_v = sqrt(2) sigma_v, given instead of sigma_v. Valid: 0 (smooth: a mirror) or >= 0.0001.
     - --
     - exposed where the lobe is anisotropic, differentiable, discontinuous
   * - ``distribution``
     - string
     - Normal distribution of the specular lobe: beckmann (the paper's Gaussian slopes) or ggx (Trowbridge-Reitz), both of width alpha = sqrt(2) sigma. Valid: ``beckmann`` or ``ggx``.
     - ``beckmann``
     - --
   * - ``ks``
     - spectrum or texture
     - Weight k_s of the specular (polarizing) lobe (paper Eq. 2). Valid: >= 0.
     - 1
     - exposed, differentiable
   * - ``kdd``
     - spectrum or texture
     - Weight k_dd of the directional diffuse (depolarized) lobe (paper Eq. 2). Valid: >= 0.
     - 0
     - exposed, differentiable
   * - ``sigma_dd``
     - float or texture
     - RMS slope of the directional diffuse lobe (alpha_dd = sqrt(2) sigma_dd). Valid: >= 7.07e-05.
     - 0.5
     - exposed where the lobe is isotropic, differentiable, discontinuous
   * - ``sigma_dd_u``
     - float or texture
     - RMS slope of the directional diffuse lobe along the s axis; giving sigma_dd_u or sigma_dd_v makes that lobe anisotropic. Valid: >= 7.07e-05.
     - ``sigma_dd``
     - exposed where the lobe is anisotropic, differentiable, discontinuous
   * - ``sigma_dd_v``
     - float or texture
     - RMS slope of the directional diffuse lobe along the t axis. Valid: >= 7.07e-05.
     - ``sigma_dd``
     - exposed where the lobe is anisotropic, differentiable, discontinuous
   * - ``kid``
     - spectrum or texture
     - Weight k_id of the ideal (Lambertian, depolarized) diffuse lobe (paper Eq. 2). Valid: >= 0.
     - 0
     - exposed, differentiable
   * - ``shadowing``
     - string
     - Shadowing-masking G: vgroove (Torrance-Sparrow/Blinn, the paper's) or smith (Smith's, as Mitsuba's roughconductor). Valid: ``vgroove`` or ``smith``.
     - ``vgroove``
     - --
   * - ``dd_distribution``
     - string
     - Normal distribution of the directional diffuse lobe. Valid: ``beckmann`` or ``ggx``.
     - ``beckmann``
     - --
   * - ``sampling``
     - string
     - mixture (lobes chosen by estimated albedo) or cosine (cosine-weighted hemisphere only: the benchmarks' baseline). Valid: ``mixture`` or ``cosine``.
     - ``mixture``
     - --

exposed: in ``mi.traverse``; differentiable: gradients flow to it;
discontinuous: flagged ``ParamFlags.Discontinuous``, as Mitsuba's
``roughconductor`` flags its index and roughness (the sampling distribution
depends on them). The weight and width of a lobe that is absent (weight
exactly 0 at load time) are not exposed.

The model (paper Eq. 2, 5, 6; ``docs/model.md``)::

    F(wi, wr) = ks * D(h) G F_mueller(beta) / (4 cos_i cos_r)            (specular)
              + [kdd * Ddd(h) G / (4 cos_i cos_r) + kid / pi] * D0       (depolarized)

with h the half vector, beta the angle between the light and h, F_mueller the
Mueller matrix of Fresnel reflection on a facet of index n + ik rotated from the
facet's s/p frame into Mitsuba's implicit Stokes bases, and D0 the ideal
depolarizer. In unpolarized variants only the intensity (M00) is computed.

Anisotropy: ``sigma_u``/``sigma_v`` (``sigma_dd_u``/``sigma_dd_v``) are the
RMS slopes along the shading frame's s axis (``dp_du``) and t axis, each
defaulting to ``sigma`` (``sigma_dd``); where neither is given the lobe is
isotropic and ``traverse`` exposes ``sigma``, else the lobe is anisotropic and
``traverse`` exposes ``sigma_u`` and ``sigma_v`` instead (the schema's
``refines`` relation). ``distribution`` is the specular lobe's Beckmann or GGX.
Mitsuba's names ``alpha``, ``alpha_u``, ``alpha_v`` (alpha = sqrt(2) sigma, for
GGX too) are taken instead of ``sigma``, ``sigma_u``, ``sigma_v``, never both;
``traverse`` exposes a width under the name it is given.

The surface is one-sided: directions below the horizon give zero. A lobe whose
weight is exactly zero at load time is dropped entirely (not evaluated, not
sampled, not in the flags, not traversed); give it a small non-zero weight to
optimize it. Components, in order of the lobes present: specular
(GlossyReflection; DeltaReflection where smooth), directional diffuse
(GlossyReflection), ideal diffuse (DiffuseReflection).

Smooth limit: ``sigma = 0`` (``alpha = 0``, or ``sigma_u = sigma_v = 0``), a
constant 0 when loaded, makes the specular lobe a delta, Mitsuba's
``conductor``: ``eval`` and ``pdf`` leave it out, ``sample`` picks it with
its selection probability P (pdf 1 alone) and returns the mirror direction
with weight ks F / P, F the Fresnel Mueller matrix at the normal. Zero along
one axis only, a texture that is 0 somewhere only, and ``sampling="cosine"``
(which cannot find a delta) are refused. Its width is not traversed: there is
no derivative by sigma at 0 (a render's is 0 there to first order where the
light seen in the mirror is smooth, the facet slopes having zero mean);
derivatives by eta, k and ks are as for a rough lobe.

Sampling picks a lobe with probabilities proportional to an estimate of each
lobe's albedo for the current direction (ks times the unpolarized Fresnel
reflectance at the incidence angle, kdd, kid; averaged over wavelengths),
then samples the specular and directional diffuse lobes by Beckmann/GGX
visible-normal sampling and the ideal diffuse lobe by cosine-weighted
hemisphere sampling (the smooth lobe: its mirror direction). The returned pdf is
the mixture pdf (one-sample MIS).

XML::

    <bsdf type="pbrdf">
        <string name="material" value="Cu"/>
        <float name="sigma" value="0.1"/>
        <spectrum name="kdd" value="0.2"/>
        <float name="sigma_dd" value="0.5"/>
        <spectrum name="kid" value="0.05"/>
    </bsdf>
"""

from __future__ import annotations

from typing import NamedTuple, Optional

import drjit as dr
import mitsuba as mi

from .. import properties, schema
from . import pbrdf_properties
from .fresnel import fresnel_unpolarized, specular_mueller
from .ior import complex_ior_textures
from .lobes import DeltaLobe, Evaluation, LambertianLobe, MicrofacetLobe, sample_record
from .microfacet import SHADOWING

_NAME = "pbrdf"


def _read_ior(props):
    """``(material or None, eta, k)`` from ``material`` or ``eta``/``k``."""
    has_ior = "eta" in props or "k" in props
    if has_ior and "material" in props:
        raise ValueError("pbrdf: give either 'material' or 'eta'/'k', not both")
    if has_ior:
        if "eta" not in props or "k" not in props:
            raise ValueError("pbrdf: 'eta' and 'k' must be given together")
        return (None, pbrdf_properties.declared(props, schema.parameter("eta"), 0.0),
                pbrdf_properties.declared(props, schema.parameter("k"), 0.0))
    if "material" in props and props.type("material") != mi.Properties.Type.String:
        raise TypeError("pbrdf: parameter 'material' must be a string such as 'Al'")
    material = props["material"] if "material" in props else schema.DEFAULTS["material"]
    return (material, *complex_ior_textures(material))


def _depolarized(value):
    """A scalar BRDF value as a Mueller matrix: the ideal depolarizer times it."""
    return mi.depolarizer(value) if mi.is_polarized else value


def _read(props, name):
    """Float or spectrum parameter *name*, read and checked against its declaration."""
    return pbrdf_properties.declared(props, schema.parameter(name))


def _exposed_widths(widths):
    """``{name: texture}`` of a lobe's widths (None: absent) as given."""
    return {w.name: w.texture for w in widths if w is not None}


class Exposed(NamedTuple):
    """A parameter as ``traverse`` exposes it: its texture, its flags, and what
    ``parameters_changed`` re-checks (> 0 where ``positive``, >= ``floor``; a
    ``spectral`` texture, or a float one evaluated as the kernel does)."""

    texture: object
    flags: object
    positive: bool
    floor: Optional[float]
    spectral: bool


def build_class():
    """``PolarizedBRDF`` on the active variant's base class (registry.plugin_class)."""
    class PolarizedBRDF(mi.BSDF):
        __doc__ = __doc__

        def __init__(self, props):
            super().__init__(props)
            # Each parameter read once by name and checked (schema.py declares them;
            # tests/test_schema.py checks that these reads match the declarations).
            self.material, self.eta, self.k = _read_ior(props)
            self.sigma = pbrdf_properties.read_width(props, "sigma")
            self.sigma_u = pbrdf_properties.read_refinement(props, "sigma_u", self.sigma)
            self.sigma_v = pbrdf_properties.read_refinement(props, "sigma_v", self.sigma)
            self.distribution = properties.declared(props, _NAME, "distribution")
            self.ks = _read(props, "ks")
            self.kdd = _read(props, "kdd")
            self.sigma_dd = pbrdf_properties.read_width(props, "sigma_dd")
            self.sigma_dd_u = pbrdf_properties.read_refinement(props, "sigma_dd_u", self.sigma_dd)
            self.sigma_dd_v = pbrdf_properties.read_refinement(props, "sigma_dd_v", self.sigma_dd)
            self.kid = _read(props, "kid")
            self.shadowing = properties.declared(props, _NAME, "shadowing")
            self.dd_distribution = properties.declared(props, _NAME, "dd_distribution")
            self.sampling = properties.declared(props, _NAME, "sampling")

            self.lobes = self._build_lobes()
            # a component's flags: its lobe type, front side, and anisotropic where it is
            self.m_components = [lobe.flags | mi.BSDFFlags.FrontSide
                                 | (mi.BSDFFlags.Anisotropic if lobe.anisotropic else 0)
                                 for lobe in self.lobes]
            self.m_flags = mi.BSDFFlags.Empty
            for flags in self.m_components:
                self.m_flags = self.m_flags | flags

        def _build_lobes(self):
            """One record per lobe whose weight is not exactly zero, in component
            order: specular, directional diffuse, ideal diffuse. A microfacet lobe
            with refined widths is anisotropic (its component flags then carry
            ``BSDFFlags.Anisotropic``). A specular lobe of widths exactly 0 is
            the smooth limit, a :class:`DeltaLobe` (``DeltaReflection``)."""
            glossy, diffuse = mi.BSDFFlags.GlossyReflection, mi.BSDFFlags.DiffuseReflection
            types = {"beckmann": mi.MicrofacetType.Beckmann, "ggx": mi.MicrofacetType.GGX}
            shadowing = SHADOWING[self.shadowing]
            lobes = []
            widths = (self.sigma, None) if self.sigma_u is None else (self.sigma_u, self.sigma_v)
            smooth = pbrdf_properties.is_smooth(*widths)
            if smooth and self.sampling == "cosine" and not pbrdf_properties.is_constant_zero(self.ks):
                raise ValueError("pbrdf: parameter 'sampling' is 'cosine', which cannot sample the "
                                 "smooth specular lobe (sigma = 0); use 'mixture'")
            if smooth and not pbrdf_properties.is_constant_zero(self.ks):
                lobes.append(DeltaLobe("specular", self.ks, mi.BSDFFlags.DeltaReflection, len(lobes),
                                       textures={"ks": self.ks}))
            elif not pbrdf_properties.is_constant_zero(self.ks):
                textures = {"ks": self.ks, **_exposed_widths(widths)}
                lobes.append(MicrofacetLobe("specular", self.ks, widths[0], types[self.distribution],
                                            shadowing, glossy, len(lobes), polarizing=True,
                                            textures=textures, width_v=widths[1],
                                            projected=pbrdf_properties.projected(*widths)))
            if not pbrdf_properties.is_constant_zero(self.kdd):
                widths = ((self.sigma_dd, None) if self.sigma_dd_u is None
                          else (self.sigma_dd_u, self.sigma_dd_v))
                textures = {"kdd": self.kdd, **_exposed_widths(widths)}
                lobes.append(MicrofacetLobe("directional_diffuse", self.kdd, widths[0],
                                            types[self.dd_distribution], shadowing, glossy, len(lobes),
                                            polarizing=False, textures=textures, width_v=widths[1],
                                            projected=pbrdf_properties.projected(*widths)))
            if not pbrdf_properties.is_constant_zero(self.kid):
                lobes.append(LambertianLobe("ideal_diffuse", self.kid, diffuse, len(lobes),
                                            textures={"kid": self.kid}))
            return lobes

        # -------------------------------------------------------------- traversal

        def _exposed(self):
            """name -> :class:`Exposed` of every parameter ``traverse`` exposes:
            the index, then each present lobe's weight and widths."""
            textures = {"eta": self.eta, "k": self.k}
            for lobe in self.lobes:
                textures.update(lobe.textures)
            exposed = {}
            for name, texture in textures.items():
                p = schema.parameter(name)
                flags = mi.ParamFlags.Differentiable
                if p.discontinuous:
                    flags = flags | mi.ParamFlags.Discontinuous
                exposed[name] = Exposed(texture, flags, p.positive, p.floor, p.kind == "spectrum")
            return exposed

        def traverse(self, callback):
            for name, exposed in self._exposed().items():
                callback.put(name, exposed.texture, exposed.flags)

        def parameters_changed(self, keys):
            # Textures refresh their own state; re-check values an update may have broken.
            for name, exposed in self._exposed().items():
                if not keys or any(k == name or k.startswith(name + ".") for k in keys):
                    pbrdf_properties.check_texture_values(name, exposed.texture, exposed.positive,
                                                exposed.floor, spectral=exposed.spectral)

        def to_string(self):
            ior = (f"material = {self.material!r}" if self.material
                   else f"eta = {self.eta},\n  k = {self.k}")
            rest = "".join(f",\n  {p.name} = {getattr(self, p.name)!r}" if p.kind == "choice"
                           else f",\n  {p.name} = {getattr(self, p.name)}"
                           for p in schema.PARAMETERS
                           if p.plugin and p.kind != "material" and p.name not in ("eta", "k"))
            return (f"PolarizedBRDF[\n  {ior},\n  lobes = {[lobe.name for lobe in self.lobes]}"
                    f"{rest}\n]")

        # -------------------------------------------------------------- BSDF API

        def eval(self, ctx, si, wo, active=True):
            ev = Evaluation.of(si, wo, active)
            return self._value(ctx, ev)

        def pdf(self, ctx, si, wo, active=True):
            ev = Evaluation.of(si, wo, active)
            return self._pdf(ctx, ev)

        def eval_pdf(self, ctx, si, wo, active=True):
            ev = Evaluation.of(si, wo, active)
            return self._value(ctx, ev), self._pdf(ctx, ev)

        def sample(self, ctx, si, sample1, sample2, active=True):
            cos_i = mi.Frame3f.cos_theta(si.wi)
            active = mi.Bool(active) & (cos_i > 0)
            enabled = self._enabled_lobes(ctx)
            if not enabled:
                return sample_record(si.wi, mi.Float(0.0), mi.UInt32(0), mi.UInt32(0),
                                      mi.Bool(False), dr.zeros(mi.Spectrum))
            if self.sampling == "cosine":
                wo = mi.warp.square_to_cosine_hemisphere(sample2)
                ev = Evaluation.of(si, wo, active)
                return sample_record(wo, self._pdf(ctx, ev), mi.UInt32(enabled[0].index),
                                      mi.UInt32(self._component_flags(enabled[0])), ev.active,
                                      self._value(ctx, ev))
            if len(enabled) == 1:
                lobe = enabled[0]
                s = lobe.sample_alone(si, sample2, active)
                value = self._weighted(lobe, ctx, si, s.wo, s.facet_normal, s.value, s.active)
                return sample_record(s.wo, s.pdf, mi.UInt32(lobe.index),
                                      mi.UInt32(self._component_flags(lobe)), s.active, value)
            probs = self._lobe_probabilities(ctx, si, active)

            # Pick a lobe with sample1, then draw a direction from it with sample2.
            wo = mi.Vector3f(0.0, 0.0, 1.0)
            component = mi.UInt32(0)
            sampled_type = mi.UInt32(0)
            cdf = mi.Float(0.0)
            for lobe in enabled:
                prob = probs[lobe.index]
                chosen = active & (sample1 >= cdf) & (sample1 < cdf + prob)
                if lobe is enabled[-1]:  # guard against rounding at the top of the cdf
                    chosen = active & (sample1 >= cdf) & (prob > 0)
                cdf = cdf + prob
                wo = dr.select(chosen, lobe.sample_direction(si, sample2, chosen), wo)
                component = dr.select(chosen, lobe.index, component)
                sampled_type = dr.select(chosen, self._component_flags(lobe), sampled_type)

            # One-sample MIS: the weight is the full value over the mixture pdf.
            ev = Evaluation.of(si, wo, active)
            pdf, value = self._pdf(ctx, ev, probs), self._value(ctx, ev)
            delta = next((lobe for lobe in enabled if lobe.delta), None)
            if delta is not None:
                # A delta's sample is weighed alone (the other lobes have no mass
                # on its direction): its selection probability, its value there.
                on_delta = sampled_type == self._component_flags(delta)
                pdf = dr.select(on_delta, probs[delta.index], pdf)
                value = dr.select(on_delta, self._weighted(delta, ctx, si, wo, mi.Vector3f(0, 0, 1),
                                                           1.0, ev.active), value)
            return sample_record(wo, pdf, component, sampled_type, ev.active, value)

        # -------------------------------------------------------------- internals

        def _enabled_lobes(self, ctx):
            """The lobes that ``ctx`` selects (a Python-level choice: nothing else
            is traced)."""
            return [lobe for lobe in self.lobes if ctx.is_enabled(lobe.flags, lobe.index)]

        def _component_flags(self, lobe):
            """A sample's ``sampled_type``: the lobe's type on the front side."""
            return int(lobe.flags | mi.BSDFFlags.FrontSide)

        def _weighted(self, lobe, ctx, si, wo, h, value, active):
            """The lobe's weight times its unweighted ``value`` (times cos_o): a
            depolarizer, or for the polarizing lobe the facet's Fresnel
            reflection (Mueller matrix in polarized variants)."""
            weight = lobe.weight.eval(si, active) * value
            if not lobe.polarizing:
                return _depolarized(weight)
            eta, k = self.eta.eval(si, active), self.k.eval(si, active)
            if mi.is_polarized:
                return specular_mueller(ctx, si, wo, h, eta, k, weight)
            return weight * fresnel_unpolarized(dr.dot(si.wi, h), eta, k)

        def _lobe_probabilities(self, ctx, si, active):
            """Lobe selection probabilities (scalar per sample) by component
            index, proportional to each enabled lobe's estimated albedo for
            ``si.wi``: ks times the unpolarized Fresnel reflectance at the
            incidence angle, kdd, kid, averaged over wavelengths."""
            enabled = self._enabled_lobes(ctx)
            if len(enabled) <= 1:  # nothing to choose: no estimate to trace
                return [mi.Float(1.0 if lobe in enabled else 0.0) for lobe in self.lobes]
            estimates = {}
            for lobe in enabled:
                estimate = lobe.weight.eval(si, active)
                if lobe.polarizing:
                    estimate = estimate * fresnel_unpolarized(
                        mi.Frame3f.cos_theta(si.wi), self.eta.eval(si, active),
                        self.k.eval(si, active))
                estimates[lobe.index] = dr.maximum(dr.mean(estimate, axis=0), 0.0)
            total = mi.Float(0.0)
            for e in estimates.values():
                total = total + e
            uniform = 1.0 / len(estimates)
            return [dr.select(total > 0, estimates[lobe.index] / total, uniform)
                    if lobe.index in estimates else mi.Float(0.0) for lobe in self.lobes]

        def _value(self, ctx, ev):
            """The sum of the enabled lobes' weighted values (0 where inactive)."""
            zero = dr.zeros(mi.Spectrum) if mi.is_polarized else mi.UnpolarizedSpectrum(0.0)
            value = zero
            for lobe in self._enabled_lobes(ctx):
                if lobe.delta:  # no value off its direction, none measurable on it
                    continue
                value = value + self._weighted(lobe, ctx, ev.si, ev.wo, ev.half.h, lobe.value(ev),
                                               ev.active)
            return dr.select(ev.active, value, zero)

        def _pdf(self, ctx, ev, probs=None):
            """The mixture density of sampling ``ev.wo``, with the lobe
            probabilities *probs* where ``sample`` has them already (the cosine
            density where ``sampling`` is ``cosine``)."""
            enabled = self._enabled_lobes(ctx)
            pdf = mi.Float(0.0)
            if self.sampling == "cosine":
                if enabled:
                    pdf = mi.warp.square_to_cosine_hemisphere_pdf(ev.wo)
            else:
                if probs is None:
                    probs = self._lobe_probabilities(ctx, ev.si, ev.active)
                for lobe in enabled:
                    if not lobe.delta:   # a delta has no density
                        pdf = pdf + lobe.pdf(ev, probs[lobe.index])
            return dr.select(ev.active & dr.isfinite(pdf), pdf, 0.0)

    return PolarizedBRDF

