"""Evaluating and sampling a nested BSDF in a perturbed shading frame: the
common body of ``polarized_normalmap`` and ``polarized_bumpmap``.

The steps are those of Mitsuba 3.9.1's ``normalmap`` and ``bumpmap``
(``src/bsdfs/normalmap.cpp``, ``bumpmap.cpp``), in the same order and with the
same arithmetic, so that unpolarized variants give the same numbers; the one
addition is :func:`~mitsuba_pbrdf.mueller.to_unperturbed_bases` on the returned
Mueller matrix in polarized variants.

``frame_si`` is the perturbed frame P written in the unperturbed shading frame
S (``si.wi``, ``wo`` are S-local); ``frame_world`` is P in world space (the
nested BSDF's ``si.sh_frame``). Plain functions: ``mi.*`` is looked up when
called, so this module serves every variant. :func:`wrapper_base` gives
both wrappers their shared reads and their eval, pdf, eval_pdf and sample as
a base class built on the active variant's ``mi.BSDF`` (nanobind takes one
base, no mix-in).
"""

import drjit as dr
import mitsuba as mi

from .. import properties as read
from ..mueller import to_unperturbed_bases


def shadow_terminator(perturbed_n, wo):
    """Estevez et al. 2019's microfacet shadowing of a perturbed normal (the
    ``use_shadowing_function`` factor of Mitsuba's ``normalmap``/``bumpmap``):
    ``2 / (1 + sqrt(1 + a² tan² θo))`` with ``a² = min(tan² θn / 8, 1)``, θn
    the tilt of ``perturbed_n`` and θo that of ``wo``, both against the
    unperturbed normal (S-local vectors). Dimensionless, in (0, 1]."""
    alpha2 = dr.minimum(0.125 * mi.Frame3f.tan_theta_2(perturbed_n), 1.0)
    return 2.0 / (1.0 + dr.sqrt(1.0 + alpha2 * mi.Frame3f.tan_theta_2(wo)))


def perturbed_interaction(si, frame_si, frame_world):
    """A copy of ``si`` whose shading frame is the perturbed one, ``wi`` in it."""
    perturbed_si = mi.SurfaceInteraction3f(si)
    perturbed_si.sh_frame = frame_world
    perturbed_si.wi = frame_si.to_local(si.wi)
    return perturbed_si


def _zero():
    return dr.zeros(mi.Spectrum) if mi.is_polarized else mi.UnpolarizedSpectrum(0.0)


def _same_side(wo, perturbed_wo):
    """``wo`` above (below) the unperturbed horizon and ``perturbed_wo`` above
    (below) the perturbed one."""
    return mi.Frame3f.cos_theta(wo) * mi.Frame3f.cos_theta(perturbed_wo) > 0.0


def eval_pdf(nested, ctx, si, wo, active, frame_si, frame_world, shadowing,
             want_value=True, want_pdf=True):
    """``(value, pdf)`` of ``nested`` in the perturbed frame, the value's
    Mueller matrix in the unperturbed frame's Stokes bases; the one not wanted
    is None."""
    perturbed_si = perturbed_interaction(si, frame_si, frame_world)
    perturbed_wo = frame_si.to_local(wo)
    active = mi.Bool(active) & _same_side(wo, perturbed_wo)
    if want_value and want_pdf:
        value, pdf = nested.eval_pdf(ctx, perturbed_si, perturbed_wo, active)
    elif want_value:
        value, pdf = nested.eval(ctx, perturbed_si, perturbed_wo, active), None
    else:
        value, pdf = None, nested.pdf(ctx, perturbed_si, perturbed_wo, active)
    if value is not None:
        value = to_unperturbed_bases(ctx, value, frame_si, perturbed_wo, perturbed_si.wi)
        if shadowing:
            value = value * shadow_terminator(frame_si.n, wo)
        value = dr.select(active, value, _zero())
    if pdf is not None:
        pdf = dr.select(active, pdf, 0.0)
    return value, pdf


def sample(nested, ctx, si, sample1, sample2, active, frame_si, frame_world, shadowing,
           zero_pdf_on_wrong_side):
    """``(BSDFSample3f, weight)`` of ``nested`` sampled in the perturbed frame;
    ``bs.wo`` in the unperturbed frame, the weight's Mueller matrix in its
    Stokes bases. ``zero_pdf_on_wrong_side``: also zero ``bs.pdf`` where the
    sample is discarded (``normalmap`` does, ``bumpmap`` does not)."""
    perturbed_si = perturbed_interaction(si, frame_si, frame_world)
    bs, weight = nested.sample(ctx, perturbed_si, sample1, sample2, active)
    active = mi.Bool(active) & dr.any(mi.unpolarized_spectrum(weight) != 0.0)

    # A copy: ``bs.wo`` is a view of the record's field, which the next lines overwrite.
    perturbed_wo = mi.Vector3f(bs.wo)
    wo = frame_si.to_world(perturbed_wo)
    active &= _same_side(perturbed_wo, wo)
    if zero_pdf_on_wrong_side:
        bs.pdf = dr.select(active, bs.pdf, 0.0)
    bs.wo = wo

    weight = to_unperturbed_bases(ctx, weight, frame_si, perturbed_wo, perturbed_si.wi)
    if shadowing:
        weight = weight * shadow_terminator(frame_si.n, wo)
    return bs, dr.select(active, weight, _zero())


# ------------------------------------------------- the wrappers' base class


def to_world_frame(si, frame_si):
    """The perturbed frame *frame_si* (in the shading frame of *si*) in world
    space: the ``frame_world`` the steps above take."""
    frame_world = dr.zeros(mi.Frame3f)
    frame_world.n = si.to_world(frame_si.n)
    frame_world.s = si.to_world(frame_si.s)
    frame_world.t = si.to_world(frame_si.t)
    return frame_world


def wrapper_base(plugin, zero_pdf_on_wrong_side):
    """The active variant's ``mi.BSDF`` with what both map wrappers share: the
    reads of the nested BSDF and of the declared ``flip_invalid_normals`` and
    ``use_shadowing_function`` of plugin *plugin*, and eval, pdf, eval_pdf,
    sample of ``nested_bsdf`` in the frame the subclass's ``frame(si,
    active)`` gives, times the shadowing factor where
    ``use_shadowing_function``. *zero_pdf_on_wrong_side*: Mitsuba's
    ``normalmap`` zeroes the pdf of a sample whose direction changes side,
    ``bumpmap`` does not."""

    class PerturbedWrapper(mi.BSDF):
        def __init__(self, props):
            super().__init__(props)
            self.nested_bsdf = read.single_nested(props, plugin, mi.BSDF)
            self.flip_invalid_normals = read.declared(props, plugin, "flip_invalid_normals")
            self.use_shadowing_function = read.declared(props, plugin, "use_shadowing_function")
            self.m_components = [self.nested_bsdf.flags(i)
                                 for i in range(self.nested_bsdf.component_count())]

        def eval(self, ctx, si, wo, active=True):
            return eval_pdf(self.nested_bsdf, ctx, si, wo, active, *self.frame(si, active),
                            self.use_shadowing_function, want_pdf=False)[0]

        def pdf(self, ctx, si, wo, active=True):
            return eval_pdf(self.nested_bsdf, ctx, si, wo, active, *self.frame(si, active),
                            self.use_shadowing_function, want_value=False)[1]

        def eval_pdf(self, ctx, si, wo, active=True):
            return eval_pdf(self.nested_bsdf, ctx, si, wo, active, *self.frame(si, active),
                            self.use_shadowing_function)

        def sample(self, ctx, si, sample1, sample2, active=True):
            return sample(self.nested_bsdf, ctx, si, sample1, sample2, active,
                          *self.frame(si, active), self.use_shadowing_function,
                          zero_pdf_on_wrong_side=zero_pdf_on_wrong_side)

        def eval_diffuse_reflectance(self, si, active=True):
            return self.nested_bsdf.eval_diffuse_reflectance(si, active)

    return PerturbedWrapper
