"""The ``pbrdf`` plugin: three-component polarized BRDF for metals.

Parameters (declared in :mod:`mitsuba_pbrdf.schema`; the table is appended to
the class's docstring from there):

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

The surface is one-sided: directions below the horizon give zero. A lobe whose
weight is exactly zero at load time is dropped entirely (not evaluated, not
sampled, not in the flags, not traversed); give it a small non-zero weight to
optimize it. Components, in order of the lobes present: specular
(GlossyReflection), directional diffuse (GlossyReflection), ideal diffuse
(DiffuseReflection).

Sampling picks a lobe with probabilities proportional to an estimate of each
lobe's albedo for the current direction (ks times the unpolarized Fresnel
reflectance at the incidence angle, kdd, kid; averaged over wavelengths),
then samples the specular and directional diffuse lobes by Beckmann/GGX
visible-normal sampling and the ideal diffuse lobe by cosine-weighted
hemisphere sampling. The returned pdf is the mixture pdf (one-sample MIS).

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


import drjit as dr
import mitsuba as mi

from .. import schema
from ..variant import require_variant
from . import params
from .fresnel import fresnel_unpolarized, specular_mueller
from .ior import complex_ior_textures
from .lobes import HalfVector, LambertianLobe, MicrofacetLobe

#: The Mitsuba variant whose ``mi.BSDF`` this module's class derives from;
#: :func:`mitsuba_pbrdf.registry.variant_module` runs the module once per variant.
VARIANT = require_variant().variant()


def _read_ior(props):
    """``(material or None, eta, k)`` from ``material`` or ``eta``/``k``."""
    has_ior = "eta" in props or "k" in props
    if has_ior and "material" in props:
        raise ValueError("pbrdf: give either 'material' or 'eta'/'k', not both")
    if has_ior:
        if "eta" not in props or "k" not in props:
            raise ValueError("pbrdf: 'eta' and 'k' must be given together")
        return (None, params.declared(props, schema.parameter("eta"), 0.0),
                params.declared(props, schema.parameter("k"), 0.0))
    if "material" in props and props.type("material") != mi.Properties.Type.String:
        raise TypeError("pbrdf: parameter 'material' must be a string such as 'Al'")
    material = props["material"] if "material" in props else schema.DEFAULTS["material"]
    return (material, *complex_ior_textures(material))


def _depolarized(value):
    """A scalar BRDF value as a Mueller matrix: the ideal depolarizer times it."""
    return mi.depolarizer(value) if mi.is_polarized else value


class PolarizedBRDF(mi.BSDF):
    __doc__ = __doc__ + "\n" + schema.rst_table()

    def __init__(self, props):
        super().__init__(props)
        self.material, self.eta, self.k = _read_ior(props)
        for p in schema.PARAMETERS:       # every other parameter, read and checked
            if p.plugin and p.refines:
                setattr(self, p.name, self._refinement(props, p))
            elif p.plugin and p.kind in ("float", "spectrum") and p.name not in ("eta", "k"):
                setattr(self, p.name, params.declared(props, p))
            elif p.plugin and p.kind == "choice":
                setattr(self, p.name, params.choice(props, p.name, p.choices, p.default))
        self.lobes = self._build_lobes()
        self.m_components = [lobe.flags | mi.BSDFFlags.FrontSide for lobe in self.lobes]
        self.m_flags = mi.BSDFFlags.Empty
        for flags in self.m_components:
            self.m_flags = self.m_flags | flags

    def _refinement(self, props, p):
        """A refinement (``sigma_u``) as given, else the refined parameter's
        texture (``sigma``) where any of its refinements is given, else None
        (the lobe is isotropic)."""
        if p.name in props:
            return params.declared(props, p)
        if any(name in props for name in schema.REFINEMENTS[p.refines]):
            return getattr(self, p.refines)
        return None

    def _anisotropic(self, lobe):
        """Whether lobe *lobe* was given anisotropic widths."""
        return (lobe in schema.ANISOTROPIC_WIDTHS
                and getattr(self, schema.ANISOTROPIC_WIDTHS[lobe][0]) is not None)

    def _build_lobes(self):
        """One record per lobe whose weight is not exactly zero, in component
        order (:data:`schema.LOBES`): specular, directional diffuse, ideal
        diffuse."""
        lobes = []
        for name, (weight, width) in schema.LOBES.items():
            if not params.is_constant_zero(getattr(self, weight)):
                widths = [getattr(self, w) for w in
                          schema.exposed_widths(name, self._anisotropic(name))]
                lobes.append(self._lobe(name, getattr(self, weight), widths, len(lobes)))
        return lobes

    def _lobe(self, name, weight, widths, index):
        """The record of lobe *name*: the polarizing specular lobe, the
        depolarized directional diffuse lobe (each with one width, or two:
        anisotropic), the Lambertian lobe."""
        glossy, diffuse = mi.BSDFFlags.GlossyReflection, mi.BSDFFlags.DiffuseReflection
        types = {"beckmann": mi.MicrofacetType.Beckmann, "ggx": mi.MicrofacetType.GGX}
        width_v = widths[1] if len(widths) == 2 else None
        if name == "specular":
            return MicrofacetLobe(name, weight, widths[0], types[self.distribution],
                                  self.shadowing, glossy, index, polarizing=True, width_v=width_v)
        if name == "directional_diffuse":
            return MicrofacetLobe(name, weight, widths[0], types[self.dd_distribution],
                                  self.shadowing, glossy, index, polarizing=False,
                                  width_v=width_v)
        return LambertianLobe(name, weight, diffuse, index)

    # -------------------------------------------------------------- traversal

    def _parameter_table(self):
        """name -> (texture, flags, positive, minimum) of every exposed
        parameter: the index, then each present lobe's weight and width."""
        exposed = ["eta", "k"]
        for lobe in self.lobes:
            exposed += [schema.LOBES[lobe.name][0],
                        *schema.exposed_widths(lobe.name, self._anisotropic(lobe.name))]
        table = {}
        for name in exposed:
            p = schema.parameter(name)
            flags = mi.ParamFlags.Differentiable
            if p.discontinuous:
                flags = flags | mi.ParamFlags.Discontinuous
            table[name] = (getattr(self, name), flags, p.positive, p.floor)
        return table

    def traverse(self, callback):
        for name, (texture, flags, _, _) in self._parameter_table().items():
            callback.put(name, texture, flags)

    def parameters_changed(self, keys):
        # Textures refresh their own state; re-check values an update may have broken.
        for name, (texture, _, positive, minimum) in self._parameter_table().items():
            if not keys or any(k == name or k.startswith(name + ".") for k in keys):
                params.check_texture_values(name, texture, positive, minimum,
                                            spectral=schema.parameter(name).kind == "spectrum")

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
        value, _ = self._eval_pdf(ctx, si, wo, active, want_pdf=False)
        return value

    def pdf(self, ctx, si, wo, active=True):
        _, pdf = self._eval_pdf(ctx, si, wo, active, want_value=False)
        return pdf

    def eval_pdf(self, ctx, si, wo, active=True):
        return self._eval_pdf(ctx, si, wo, active)

    def sample(self, ctx, si, sample1, sample2, active=True):
        cos_i = mi.Frame3f.cos_theta(si.wi)
        active = mi.Bool(active) & (cos_i > 0)
        enabled = self._enabled_lobes(ctx)
        if not enabled:
            return _sample_record(si.wi, mi.Float(0.0), mi.UInt32(0), mi.UInt32(0),
                                  mi.Bool(False), dr.zeros(mi.Spectrum))
        if self.sampling == "cosine":
            wo = mi.warp.square_to_cosine_hemisphere(sample2)
            value, pdf = self._eval_pdf(ctx, si, wo, active)
            return _sample_record(wo, pdf, mi.UInt32(enabled[0].index),
                                  mi.UInt32(self._component_flags(enabled[0])), active, value)
        if len(enabled) == 1:
            lobe = enabled[0]
            wo, pdf, value, h, active = lobe.sample_alone(si, sample2, active)
            value = self._weighted(lobe, ctx, si, wo, h, value, active)
            return _sample_record(wo, pdf, mi.UInt32(lobe.index),
                                  mi.UInt32(self._component_flags(lobe)), active, value)
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
        value, pdf = self._eval_pdf(ctx, si, wo, active, probs=probs)
        return _sample_record(wo, pdf, component, sampled_type, active, value)

    # -------------------------------------------------------------- internals

    def _enabled_lobes(self, ctx):
        """The lobes that ``ctx`` selects (a Python-level choice: nothing else
        is traced)."""
        return [lobe for lobe in self.lobes if ctx.is_enabled(lobe.flags, lobe.index)]

    def _component_flags(self, lobe):
        return int(self.m_components[lobe.index])

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

    def _eval_pdf(self, ctx, si, wo, active, want_value=True, want_pdf=True, probs=None):
        wi = si.wi
        cos_i, cos_o = mi.Frame3f.cos_theta(wi), mi.Frame3f.cos_theta(wo)
        active = mi.Bool(active) & (cos_i > 0) & (cos_o > 0)
        half = HalfVector.of(wi, wo, active)
        enabled = self._enabled_lobes(ctx)

        zero = dr.zeros(mi.Spectrum) if mi.is_polarized else mi.UnpolarizedSpectrum(0.0)
        value, pdf = zero, mi.Float(0.0)
        if want_pdf and self.sampling == "cosine":
            if enabled:
                pdf = mi.warp.square_to_cosine_hemisphere_pdf(wo)
            want_pdf = False
        if want_pdf and probs is None:
            probs = self._lobe_probabilities(ctx, si, active)

        for lobe in enabled:
            lobe_value, lobe_pdf = lobe.eval_pdf(si, wo, half, active,
                                                 probs[lobe.index] if want_pdf else None,
                                                 want_value, want_pdf)
            if want_pdf:
                pdf = pdf + lobe_pdf
            if want_value:
                value = value + self._weighted(lobe, ctx, si, wo, half.h, lobe_value, active)

        value = dr.select(active, value, zero)
        pdf = dr.select(active & dr.isfinite(pdf), pdf, 0.0)
        return value, pdf



def _sample_record(wo, pdf, component, sampled_type, active, value):
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
