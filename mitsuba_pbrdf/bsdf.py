"""The ``pbrdf`` plugin: three-component polarized BRDF for metals.

.. list-table::
   :header-rows: 1

   * - Parameter
     - Type
     - Description
     - Default
     - Differentiable
   * - ``material``
     - string
     - Named conductor from Mitsuba's tabulated spectra (``Al``, ``Cu``, ``Au``,
       ``Ag``, ...). Mutually exclusive with ``eta``/``k``.
     - ``Al``
     - no
   * - ``eta``, ``k``
     - spectrum or texture
     - Complex index of refraction N = n + ik of the metal (dimensionless).
     - from ``material``
     - yes
   * - ``sigma``
     - float or texture
     - RMS microfacet slope per axis of the specular lobe (paper Eq. 3);
       Beckmann width alpha = sqrt(2) * sigma. At least 7.07e-5 (Mitsuba's
       microfacet distributions clamp alpha to 1e-4).
     - 0.1
     - yes
   * - ``ks``
     - spectrum or texture
     - Weight of the specular (polarizing) lobe.
     - 1.0
     - yes
   * - ``kdd``
     - spectrum or texture
     - Weight of the directional diffuse (depolarized) lobe.
     - 0.0
     - yes
   * - ``sigma_dd``
     - float or texture
     - RMS slope of the directional diffuse lobe (alpha_dd = sqrt(2) * sigma_dd),
       at least 7.07e-5.
     - 0.5
     - yes
   * - ``kid``
     - spectrum or texture
     - Weight of the ideal (Lambertian, depolarized) diffuse lobe.
     - 0.0
     - yes
   * - ``shadowing``
     - string
     - ``vgroove`` (Torrance-Sparrow/Blinn, the paper's) or ``smith`` (Beckmann
       Smith, as Mitsuba's ``roughconductor``).
     - ``vgroove``
     - no
   * - ``dd_distribution``
     - string
     - Normal distribution of the directional diffuse lobe: ``beckmann`` or ``ggx``.
     - ``beckmann``
     - no
   * - ``sampling``
     - string
     - ``mixture`` (lobe mixture, see below) or ``cosine`` (cosine-weighted
       hemisphere sampling only: the baseline benchmarks compare against).
     - ``mixture``
     - no

The model (paper Eq. 2, 5, 6; ``MODEL.md``)::

    F(wi, wr) = ks * D(h) G F_mueller(beta) / (4 cos_i cos_r)            (specular)
              + [kdd * Ddd(h) G / (4 cos_i cos_r) + kid / pi] * D0       (depolarized)

with h the half vector, beta the angle between the light and h, F_mueller the
Mueller matrix of Fresnel reflection on a facet of index n + ik rotated from the
facet's s/p frame into Mitsuba's implicit Stokes bases, and D0 the ideal
depolarizer. In unpolarized variants only the intensity (M00) is computed.

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

import math

import drjit as dr
import mitsuba as mi

from . import params
from .ior import complex_ior_textures

# Lobe names, in component order.
SPECULAR, DIRECTIONAL_DIFFUSE, IDEAL_DIFFUSE = "specular", "directional_diffuse", "ideal_diffuse"

_INV_PI = 1.0 / math.pi
_SQRT2 = math.sqrt(2.0)

#: Smallest accepted sigma, sigma_dd: Mitsuba's microfacet distributions clamp
#: the Beckmann/GGX width alpha = sqrt(2) sigma to 1e-4.
MIN_SIGMA = 1e-4 / _SQRT2


class _PolarizedBRDFMethods:
    """Variant-independent body of the plugin; :func:`plugin_class` copies it
    into a subclass of the active variant's ``mi.BSDF`` (``_base``)."""

    _base = None

    def __init__(self, props):
        self._base.__init__(self, props)
        tex = params.texture

        has_ior = "eta" in props or "k" in props
        if has_ior and "material" in props:
            raise ValueError("pbrdf: give either 'material' or 'eta'/'k', not both")
        if has_ior:
            if "eta" not in props or "k" not in props:
                raise ValueError("pbrdf: 'eta' and 'k' must be given together")
            self.material = None
            self.eta = tex(props, "eta", 0.0, spectral=True, positive=True)
            self.k = tex(props, "k", 0.0, spectral=True)
        else:
            if "material" in props and props.type("material") != mi.Properties.Type.String:
                raise TypeError("pbrdf: parameter 'material' must be a string such as 'Al'")
            self.material = props["material"] if "material" in props else "Al"
            self.eta, self.k = complex_ior_textures(self.material)

        self.sigma = tex(props, "sigma", 0.1, spectral=False, positive=True, minimum=MIN_SIGMA)
        self.ks = tex(props, "ks", 1.0, spectral=True)
        self.kdd = tex(props, "kdd", 0.0, spectral=True)
        self.sigma_dd = tex(props, "sigma_dd", 0.5, spectral=False, positive=True, minimum=MIN_SIGMA)
        self.kid = tex(props, "kid", 0.0, spectral=True)
        self.shadowing = params.choice(props, "shadowing", ("vgroove", "smith"), "vgroove")
        self.dd_distribution = params.choice(props, "dd_distribution", ("beckmann", "ggx"), "beckmann")
        self._dd_type = (mi.MicrofacetType.Beckmann if self.dd_distribution == "beckmann"
                         else mi.MicrofacetType.GGX)
        self.sampling = params.choice(props, "sampling", ("mixture", "cosine"), "mixture")

        weights = {SPECULAR: self.ks, DIRECTIONAL_DIFFUSE: self.kdd, IDEAL_DIFFUSE: self.kid}
        self.lobes = [lobe for lobe, w in weights.items() if not params.is_constant_zero(w)]
        self._lobe_type = {
            SPECULAR: mi.BSDFFlags.GlossyReflection,
            DIRECTIONAL_DIFFUSE: mi.BSDFFlags.GlossyReflection,
            IDEAL_DIFFUSE: mi.BSDFFlags.DiffuseReflection,
        }
        self.m_components = [self._lobe_type[lobe] | mi.BSDFFlags.FrontSide for lobe in self.lobes]
        self.m_flags = mi.BSDFFlags.Empty
        for flags in self.m_components:
            self.m_flags = self.m_flags | flags

    # ------------------------------------------------------------------ traversal

    def _parameter_table(self):
        """name -> (texture, flags, positive) of every exposed parameter."""
        diff = mi.ParamFlags.Differentiable
        disc = mi.ParamFlags.Differentiable | mi.ParamFlags.Discontinuous
        table = {"eta": (self.eta, disc, True), "k": (self.k, disc, False)}
        if SPECULAR in self.lobes:
            table.update(sigma=(self.sigma, disc, True), ks=(self.ks, diff, False))
        if DIRECTIONAL_DIFFUSE in self.lobes:
            table.update(kdd=(self.kdd, diff, False), sigma_dd=(self.sigma_dd, disc, True))
        if IDEAL_DIFFUSE in self.lobes:
            table.update(kid=(self.kid, diff, False))
        return table

    def traverse(self, callback):
        for name, (texture, flags, _) in self._parameter_table().items():
            callback.put(name, texture, flags)

    def parameters_changed(self, keys):
        # Textures refresh their own state; re-check values an update may have broken.
        for name, (texture, _, positive) in self._parameter_table().items():
            if not keys or any(k == name or k.startswith(name + ".") for k in keys):
                params.check_texture_values(name, texture, positive)

    def to_string(self):
        ior = f"material = {self.material!r}" if self.material else f"eta = {self.eta},\n  k = {self.k}"
        return (f"PolarizedBRDF[\n  {ior},\n  lobes = {self.lobes},\n"
                f"  sigma = {self.sigma},\n  ks = {self.ks},\n  kdd = {self.kdd},\n"
                f"  sigma_dd = {self.sigma_dd},\n  kid = {self.kid},\n"
                f"  shadowing = {self.shadowing!r},\n  dd_distribution = {self.dd_distribution!r},\n"
                f"  sampling = {self.sampling!r}\n]")

    # ------------------------------------------------------------------ BSDF API

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
            return self._sample_record(si.wi, mi.Float(0.0), mi.UInt32(0), mi.UInt32(0),
                                       mi.Bool(False), dr.zeros(mi.Spectrum))
        if self.sampling == "cosine":
            wo = mi.warp.square_to_cosine_hemisphere(sample2)
            value, pdf = self._eval_pdf(ctx, si, wo, active)
            lobe = enabled[0]
            return self._sample_record(wo, pdf, mi.UInt32(self.lobes.index(lobe)),
                                       mi.UInt32(self._component_flags(lobe)), active, value)
        if len(enabled) == 1:
            return self._sample_single_lobe(ctx, si, sample2, active, enabled[0])
        probs = self._lobe_probabilities(ctx, si, active)

        # Pick a lobe with sample1, then draw a direction from it with sample2.
        wo = mi.Vector3f(0.0, 0.0, 1.0)
        component = mi.UInt32(0)
        sampled_type = mi.UInt32(0)
        cdf = mi.Float(0.0)
        for lobe in enabled:
            chosen = active & (sample1 >= cdf) & (sample1 < cdf + probs[lobe])
            if lobe == enabled[-1]:  # guard against rounding at the top of the cdf
                chosen = active & (sample1 >= cdf) & (probs[lobe] > 0)
            cdf = cdf + probs[lobe]
            wo = dr.select(chosen, self._sample_lobe(lobe, si, sample2, chosen), wo)
            component = dr.select(chosen, self.lobes.index(lobe), component)
            sampled_type = dr.select(chosen, self._component_flags(lobe), sampled_type)

        # One-sample MIS: the weight is the full value over the mixture pdf.
        value, pdf = self._eval_pdf(ctx, si, wo, active, probs=probs)
        return self._sample_record(wo, pdf, component, sampled_type, active, value)

    # ------------------------------------------------------------------ sampling

    def _sample_single_lobe(self, ctx, si, sample2, active, lobe):
        """Sampling when one lobe is enabled: its own pdf, and a weight in
        closed form (for microfacet lobes D cancels: value/pdf = G / G1(wi))."""
        polarized = mi.is_polarized
        if lobe == IDEAL_DIFFUSE:
            wo = mi.warp.square_to_cosine_hemisphere(sample2)
            pdf = mi.warp.square_to_cosine_hemisphere_pdf(wo)
            value = _depolarized(self.kid.eval(si, active) * pdf, polarized)  # kid cos / pi
        else:
            distribution = self._distribution(lobe, si, active)
            m, _ = distribution.sample(si.wi, sample2)
            wo = mi.reflect(si.wi, m)
            cos_beta = dr.dot(si.wi, m)
            active &= (mi.Frame3f.cos_theta(wo) > 0) & (cos_beta > 0)
            g1 = _visible_g1(distribution, si.wi)
            # Visible-normal density mapped through the reflection Jacobian:
            # pdf = D G1(wi) / (4 cos_i). value = D G F / (4 cos_i) = pdf (G / G1(wi)) F.
            pdf = distribution.eval(m) * g1 * dr.rcp(4.0 * mi.Frame3f.cos_theta(si.wi))
            shadowing = self._shadowing(distribution, si.wi, wo, m, mi.Frame3f.cos_theta(m), cos_beta)
            g = shadowing * dr.rcp(g1) * pdf
            if lobe == DIRECTIONAL_DIFFUSE:
                value = _depolarized(self.kdd.eval(si, active) * g, polarized)
            else:
                value = self._specular_value(ctx, si, wo, m, self.ks.eval(si, active) * g, active)
        index = self.lobes.index(lobe)
        return self._sample_record(wo, pdf, mi.UInt32(index), mi.UInt32(self._component_flags(lobe)),
                                   active, value)

    @staticmethod
    def _sample_record(wo, pdf, component, sampled_type, active, value):
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

    # ------------------------------------------------------------------ internals

    def _enabled(self, ctx, lobe):
        return ctx.is_enabled(self._lobe_type[lobe], self.lobes.index(lobe))

    def _enabled_lobes(self, ctx):
        """The lobes that exist and that ``ctx`` selects (a Python-level choice:
        nothing else is traced)."""
        return [lobe for lobe in self.lobes if self._enabled(ctx, lobe)]

    def _component_flags(self, lobe):
        return int(self.m_components[self.lobes.index(lobe)])

    def _specular_value(self, ctx, si, wo, h, weight, active):
        """``weight`` x the facet's Fresnel reflection: a Mueller matrix in
        polarized variants, the unpolarized reflectance otherwise."""
        eta, k = self.eta.eval(si, active), self.k.eval(si, active)
        if mi.is_polarized:
            return _specular_mueller(ctx, si, wo, h, eta, k, weight)
        return weight * _fresnel_unpolarized(dr.dot(si.wi, h), eta, k)

    def _alpha(self, texture, si, active):
        """Beckmann width alpha = sqrt(2) sigma (paper Eq. 3 -> MODEL.md)."""
        return _SQRT2 * texture.eval_1(si, active)

    def _lobe_probabilities(self, ctx, si, active):
        """Lobe selection probabilities (scalar per sample), proportional to each
        lobe's estimated albedo for direction ``si.wi``."""
        enabled = self._enabled_lobes(ctx)
        if len(enabled) <= 1:  # nothing to choose: no estimate to trace
            return {lobe: mi.Float(1.0 if lobe in enabled else 0.0) for lobe in self.lobes}
        estimates = {}
        for lobe in enabled:
            if lobe == SPECULAR:
                fresnel = _fresnel_unpolarized(mi.Frame3f.cos_theta(si.wi),
                                               self.eta.eval(si, active), self.k.eval(si, active))
                estimate = self.ks.eval(si, active) * fresnel
            else:
                estimate = (self.kdd if lobe == DIRECTIONAL_DIFFUSE else self.kid).eval(si, active)
            estimates[lobe] = dr.maximum(dr.mean(estimate, axis=0), 0.0)
        total = mi.Float(0.0)
        for e in estimates.values():
            total = total + e
        uniform = 1.0 / max(len(estimates), 1)
        return {lobe: (dr.select(total > 0, estimates[lobe] / total, uniform)
                       if lobe in estimates else mi.Float(0.0))
                for lobe in self.lobes}

    def _distribution(self, lobe, si, active):
        if lobe == SPECULAR:
            return mi.MicrofacetDistribution(mi.MicrofacetType.Beckmann,
                                             self._alpha(self.sigma, si, active), True)
        return mi.MicrofacetDistribution(self._dd_type, self._alpha(self.sigma_dd, si, active), True)

    def _sample_lobe(self, lobe, si, sample2, active):
        if lobe == IDEAL_DIFFUSE:
            return mi.warp.square_to_cosine_hemisphere(sample2)
        m, _ = self._distribution(lobe, si, active).sample(si.wi, sample2)
        return mi.reflect(si.wi, m)

    def _shadowing(self, distribution, wi, wo, h, cos_h, cos_beta):
        if self.shadowing == "smith":
            # Smith G1(wi) G1(wo) without Mitsuba's per-direction facet-side test
            # dot(v, h) cos(v) > 0: for nearly opposite grazing directions float32
            # rounding of the inputs' lengths can flip one dot product (wi.h and
            # wo.h differ by (|wi|^2 - |wo|^2) / |wi + wo|); the side test here is
            # the symmetric cos(beta) > 0 that the caller applies.
            return _smith_g1(distribution, wi) * _smith_g1(distribution, wo)
        # V-groove (Torrance-Sparrow/Blinn): min(1, 2 cos_h cos_o / cos_b, 2 cos_h cos_i / cos_b)
        two_cos_h = 2.0 * cos_h / cos_beta
        return dr.minimum(1.0, two_cos_h * dr.minimum(mi.Frame3f.cos_theta(wi),
                                                       mi.Frame3f.cos_theta(wo)))

    def _eval_pdf(self, ctx, si, wo, active, want_value=True, want_pdf=True, probs=None):
        polarized = mi.is_polarized
        wi = si.wi
        cos_i, cos_o = mi.Frame3f.cos_theta(wi), mi.Frame3f.cos_theta(wo)
        active = mi.Bool(active) & (cos_i > 0) & (cos_o > 0)
        # Half vector and cos(beta) = wi.h = wo.h = |wi + wo| / 2, the angle of
        # incidence on the facet, in a form symmetric in wi and wo: for nearly
        # opposite grazing directions dot(wi, h) depends on which of the two
        # carries the larger float32 rounding (it differed 17x between modes).
        half = wi + wo
        h = dr.normalize(half)  # rounded as in roughconductor
        cos_h = mi.Frame3f.cos_theta(h)
        cos_beta = 0.5 * dr.norm(half)
        inv_4cos_i = dr.select(active, dr.rcp(4.0 * cos_i), 0.0)  # f * cos_o = ... / (4 cos_i)

        zero = dr.zeros(mi.Spectrum) if polarized else mi.UnpolarizedSpectrum(0.0)
        value, pdf = zero, mi.Float(0.0)
        if want_pdf and self.sampling == "cosine":
            if self._enabled_lobes(ctx):
                pdf = mi.warp.square_to_cosine_hemisphere_pdf(wo)
            want_pdf = False
        if want_pdf and probs is None:
            probs = self._lobe_probabilities(ctx, si, active)

        for lobe in self.lobes:
            if not self._enabled(ctx, lobe):
                continue
            if lobe == IDEAL_DIFFUSE:
                if want_value:
                    value = value + _depolarized(self.kid.eval(si, active) * (_INV_PI * cos_o), polarized)
                if want_pdf:
                    pdf = pdf + probs[lobe] * mi.warp.square_to_cosine_hemisphere_pdf(wo)
                continue

            distribution = self._distribution(lobe, si, active)
            # cos(beta) > 0 whenever both directions are above the horizon; it
            # can only round to 0 (exactly opposite directions on the horizon).
            D = dr.select(cos_beta > 0, distribution.eval(h), 0.0)
            if want_pdf:
                # Visible-normal sampling density, mapped through the reflection Jacobian.
                pdf = pdf + probs[lobe] * D * _visible_g1(distribution, wi) * inv_4cos_i
            if not want_value:
                continue
            scale = D * self._shadowing(distribution, wi, wo, h, cos_h, cos_beta) * inv_4cos_i
            if lobe == DIRECTIONAL_DIFFUSE:
                value = value + _depolarized(self.kdd.eval(si, active) * scale, polarized)
            else:
                value = value + self._specular_value(ctx, si, wo, h, self.ks.eval(si, active) * scale,
                                                     active)

        value = dr.select(active, value, zero)
        pdf = dr.select(active & dr.isfinite(pdf), pdf, 0.0)
        return value, pdf


def _smith_g1(distribution, v):
    """Mitsuba's Smith G1 of direction ``v`` (isotropic: it depends on v only),
    without the facet-side test, which the callers apply symmetrically."""
    return distribution.smith_g1(v, mi.Vector3f(0.0, 0.0, 1.0))


def _visible_g1(distribution, wi):
    """Smith G1(wi) of the distribution that visible-normal sampling draws
    from, exactly: Mitsuba samples Beckmann's visible normals exactly but its
    ``smith_g1`` uses a rational approximation (< 0.35 % error), which would bias
    the pdf and so every sampling weight by G1_exact / G1_approx. GGX's G1 is
    exact in Mitsuba already. The facet-side test (cos beta > 0) is the caller's.

    Beckmann: G1 = 1 / (1 + Lambda(a)), Lambda = (erf(a) - 1) / 2 + exp(-a^2) / (2 a sqrt(pi)),
    a = 1 / (alpha tan(theta)).
    """
    if distribution.type() != mi.MicrofacetType.Beckmann:
        return _smith_g1(distribution, wi)
    cos = mi.Frame3f.cos_theta(wi)
    tan = dr.safe_sqrt(1.0 - cos * cos) / cos
    a = dr.rcp(distribution.alpha() * tan)
    lam = 0.5 * (dr.erf(a) - 1.0) + dr.exp(-a * a) / (2.0 * a * math.sqrt(math.pi))
    return dr.select(cos > 0, dr.select(tan == 0, 1.0, dr.rcp(1.0 + lam)), 0.0)


def _depolarized(value, polarized):
    return mi.depolarizer(value) if polarized else value


# ---------------------------------------------------------------------- Fresnel

def _fresnel_amplitudes(cos_beta, eta, k):
    """Complex reflection amplitudes (a_s, a_p) as (re, im) pairs, vectorized over
    wavelengths, for a facet of index N = eta + i k seen at ``cos_beta``.

    a_s = (cos - w) / (cos + w),  a_p = (w - N^2 cos) / (w + N^2 cos),
    w = sqrt(N^2 - sin^2) = N cos_t on the principal branch (Im w >= 0: the
    transmitted wave decays), Fresnel's sign convention for a_p as in Mitsuba
    (a_p = a_s at normal incidence).
    """
    c = dr.clip(cos_beta, 0.0, 1.0)
    n2_re = eta * eta - k * k  # N^2
    n2_im = 2.0 * eta * k
    u_re = n2_re - (1.0 - c * c)  # N^2 - sin^2
    u_im = n2_im
    # Numerically stable principal square root of u.
    modulus = dr.sqrt(dr.fma(u_re, u_re, u_im * u_im))
    t = dr.sqrt(dr.maximum(0.5 * (modulus + dr.abs(u_re)), 0.0))
    safe_t = dr.select(t > 0, t, 1.0)
    # u_im = 2 n k >= 0 (k >= 0 is validated; k = -0.0 must act as +0.0, so no
    # copysign): the root with Im w >= 0.
    w_re = dr.select(u_re >= 0, t, dr.abs(u_im) / (2.0 * safe_t))
    w_im = dr.select(u_re >= 0, dr.abs(u_im) / (2.0 * safe_t), t)

    def ratio(a_re, a_im, b_re, b_im):  # (a - b) / (a + b) as (re, im)
        num_re, num_im = a_re - b_re, a_im - b_im
        den_re, den_im = a_re + b_re, a_im + b_im
        inv = dr.rcp(dr.maximum(den_re * den_re + den_im * den_im, 1e-30))
        return ((num_re * den_re + num_im * den_im) * inv,
                (num_im * den_re - num_re * den_im) * inv)

    a_s = ratio(c, 0.0 * c, w_re, w_im)
    a_p = ratio(w_re, w_im, n2_re * c, n2_im * c)
    return a_s, a_p


def _fresnel_unpolarized(cos_beta, eta, k):
    """Unpolarized reflectance (R_s + R_p) / 2."""
    (s_re, s_im), (p_re, p_im) = _fresnel_amplitudes(cos_beta, eta, k)
    return 0.5 * (s_re * s_re + s_im * s_im + p_re * p_re + p_im * p_im)


def _fresnel_mueller_entries(cos_beta, eta, k):
    """Entries (A, B, C, S) of the facet's reflection Mueller matrix in its s/p frame,

        [[A, B, 0,  0],
         [B, A, 0,  0],
         [0, 0, C, -S],
         [0, 0, S,  C]],

    A = (R_s + R_p)/2, B = (R_s - R_p)/2, C + iS = r_p conj(r_s) in Mitsuba 3.9's
    convention: N = n - ik (time factor exp(+i w t)) and the Verdet sign of r_p
    (r_p = -r_s at normal incidence), i.e. r_s = conj(a_s), r_p = -conj(a_p)
    with the amplitudes of :func:`_fresnel_amplitudes`."""
    (s_re, s_im), (p_re, p_im) = _fresnel_amplitudes(cos_beta, eta, k)
    r_s = s_re * s_re + s_im * s_im
    r_p = p_re * p_re + p_im * p_im
    return (0.5 * (r_s + r_p), 0.5 * (r_s - r_p),
            -(p_re * s_re + p_im * s_im), p_im * s_re - p_re * s_im)


def _specular_mueller(ctx, si, wo, h, eta, k, weight):
    """``weight`` x Fresnel Mueller matrix of the facet with normal ``h``, rotated
    from the facet's s/p frames into Mitsuba's implicit Stokes bases."""
    # Light arrives along -wo_hat and leaves along wi_hat.
    radiance = ctx.mode == mi.TransportMode.Radiance
    wo_hat = wo if radiance else si.wi
    wi_hat = si.wi if radiance else wo

    # cos(beta) from the incident side, as roughconductor computes it (same
    # value, same float32 rounding).
    A, B, C, S = (weight * e for e in _fresnel_mueller_entries(dr.dot(wo_hat, h), eta, k))
    M = dr.zeros(mi.Spectrum, dr.width(weight))
    M[0, 0] = A
    M[0, 1] = B
    M[1, 0] = B
    M[1, 1] = A
    M[2, 2] = C
    M[2, 3] = -S
    M[3, 2] = S
    M[3, 3] = C

    # The facet's s axis is perpendicular to its plane of reflection.
    s_in = dr.cross(h, -wo_hat)
    s_out = dr.cross(h, wi_hat)
    # At normal incidence on the facet (retro-reflection) any s axis
    # perpendicular to h serves, as long as input and output share it.
    collinear = dr.squared_norm(s_in) < 1e-12
    s_any = mi.coordinate_system(h)[0]
    s_in = dr.select(collinear, s_any, dr.normalize(s_in))
    s_out = dr.select(collinear, s_any, dr.normalize(s_out))
    return mi.mueller.rotate_mueller_basis(M, -wo_hat, s_in, mi.mueller.stokes_basis(-wo_hat),
                                           wi_hat, s_out, mi.mueller.stokes_basis(wi_hat))


_classes = {}


def plugin_class():
    """The ``pbrdf`` BSDF class for the active Mitsuba variant."""
    variant = mi.variant()
    if variant not in _classes:
        body = {k: v for k, v in vars(_PolarizedBRDFMethods).items()
                if k not in ("__dict__", "__weakref__")}
        body.update(__doc__=__doc__, _base=mi.BSDF)
        _classes[variant] = type("PolarizedBRDF", (mi.BSDF,), body)
    return _classes[variant]
