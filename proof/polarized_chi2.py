"""Mitsuba's chi-square test of a BSDF's ``sample`` against its ``pdf`` in a
polarized variant, shared by tests/ and validation/.

Mitsuba's ``chi2.BSDFAdapter`` tests ``weight == 0`` on the whole
(unpolarized) spectrum, which fails on Mueller matrices: here a sample counts
unless its weight's M00 is 0 at every wavelength (M00 = 0 implies M = 0 for a
physical Mueller matrix), as Mitsuba's adapter drops zero-weight samples.
"""

import drjit as dr
import mitsuba as mi


def chi2_sampling_test(config, wi, sample_count, wavelengths, significance, test_count,
                       res=101, ires=8):
    """The ChiSquareTest of BSDF ``config`` (a ``mi.load_dict`` dict) at the
    local direction ``wi`` and the given wavelengths (nm), after ``run`` at
    ``significance`` with Mitsuba's Sidak correction for ``test_count`` tests;
    ``.passed`` holds the result."""
    bsdf = mi.load_dict(config)
    ctx = mi.BSDFContext()

    def interaction(n):
        si = dr.zeros(mi.SurfaceInteraction3f, n)
        si.wi = mi.Vector3f(*[float(x) for x in wi])
        si.wavelengths = mi.UnpolarizedSpectrum(*wavelengths)
        return si

    def sample_func(sample):
        bs, weight = bsdf.sample(ctx, interaction(dr.width(sample)), sample[0],
                                 mi.Point2f(sample[1], sample[2]))
        keep = dr.any(mi.unpolarized_spectrum(weight) != 0)
        return bs.wo, dr.select(keep, mi.Float(1.0), mi.Float(0.0))

    def pdf_func(wo):
        return bsdf.pdf(ctx, interaction(dr.width(wo)), wo)

    test = mi.chi2.ChiSquareTest(domain=mi.chi2.SphericalDomain(), sample_func=sample_func,
                                 pdf_func=pdf_func, sample_dim=3, sample_count=sample_count,
                                 res=res, ires=ires)
    test.passed = test.run(significance_level=significance, test_count=test_count, quiet=True)
    return test
