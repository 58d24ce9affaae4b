"""What the BSDF tests share: the test wavelengths, surface interactions and
directions in the local frame, sampling two BSDFs with the same random
numbers, the suite's chi-square test of sampling against pdf, and Mitsuba
results as NumPy arrays. (Fixtures, and the suite's variant, are
``conftest.py``'s.)"""

import drjit as dr
import mitsuba as mi
import numpy as np

from mitsuba_pbrdf.diagnostics.scene_match import tile_means  # noqa: F401 (the tests' unit)
from proof import polarized_chi2

#: Wavelengths (nm) used for spectral evaluations in tests.
WAVELENGTHS = (450.0, 520.0, 600.0, 690.0)


def make_si(wi):
    """A batch of surface interactions in the local frame with directions `wi`
    (numpy (n, 3)) and, in spectral variants, the test wavelengths."""
    wi = np.atleast_2d(np.asarray(wi, dtype=np.float32))
    si = dr.zeros(mi.SurfaceInteraction3f, len(wi))
    si.wi = mi.Vector3f(*wi.T) if not mi.variant().startswith("scalar") else mi.Vector3f(*wi[0])
    if mi.is_spectral:
        si.wavelengths = mi.UnpolarizedSpectrum(*WAVELENGTHS)
    return si


def sample_both(a, b, wi, rng):
    """Sample BSDFs `a` and `b` at the directions `wi` (numpy (n, 3)) with the
    same random numbers drawn from `rng`: ``(bs_a, w_a, bs_b, w_b)``."""
    si = make_si(wi)
    s1 = mi.Float(rng.random(len(wi)).astype(np.float32))
    s2 = mi.Point2f(*rng.random((2, len(wi))).astype(np.float32))
    ctx = mi.BSDFContext()
    return (*a.sample(ctx, si, s1, s2), *b.sample(ctx, si, s1, s2))


def to_vector(w):
    w = np.atleast_2d(np.asarray(w, dtype=np.float32))
    return mi.Vector3f(*w.T) if not mi.variant().startswith("scalar") else mi.Vector3f(*w[0])


def hemisphere_pairs(n, seed=0, near_specular=0.5, min_cos=1e-3):
    """Random direction pairs (wi, wo) in the upper hemisphere, numpy float64
    (m, 3) with m <= n; a share `near_specular` has wo close to the mirror
    direction about a slightly tilted normal, to exercise narrow lobes."""
    rng = np.random.default_rng(seed)

    def unit(v):
        return v / np.linalg.norm(v, axis=-1, keepdims=True)

    wi = unit(rng.normal(size=(n, 3)) * [1, 1, 0] + [0, 0, 1] * np.abs(rng.normal(size=(n, 1))))
    wo = unit(rng.normal(size=(n, 3)) * [1, 1, 0] + [0, 0, 1] * np.abs(rng.normal(size=(n, 1))))
    m = int(n * near_specular)
    h = unit(rng.normal(size=(m, 3)) * [0.15, 0.15, 0] + [0, 0, 1])
    wo[:m] = 2 * np.sum(wi[:m] * h, axis=1, keepdims=True) * h - wi[:m]
    keep = (wi[:, 2] > min_cos) & (wo[:, 2] > min_cos)
    return wi[keep], wo[keep]


#: Family-wise significance of the suite's chi-square goodness-of-fit tests of
#: sampling against pdf, and their number: each runs at the Sidak-corrected
#: level 1 - (1 - 0.01)^(1/19) = 5.3e-4 (Mitsuba's ChiSquareTest.run(test_count=)),
#: so a correct sampler fails one of them with probability 1 %.
CHI2_SIGNIFICANCE = 0.01
CHI2_TESTS = 19  # tests/bsdfs/test_pbrdf.py: 5 configurations x 3 angles; tests/bsdfs/test_sampling.py: 1;
#                  tests/bsdfs/test_microfacet.py: 3 (tests/bsdfs/test_sampling.py checks the sum)


def chi2_sampling_test(config, wi, sample_count, res=101, ires=8):
    """Mitsuba's chi-square test of ``bsdf.sample`` against ``bsdf.pdf`` for the
    ``pbrdf`` ``config`` at the local direction ``wi``, in the suite's polarized
    spectral variant at the test wavelengths, through the polarized adapter of
    :mod:`proof.polarized_chi2`, with the suite's family-wise correction;
    ``.passed`` holds the result."""
    return polarized_chi2.chi2_sampling_test(config, wi, sample_count, WAVELENGTHS,
                                             CHI2_SIGNIFICANCE, CHI2_TESTS, res, ires)


def as_numpy(value):
    """Mitsuba result -> numpy float64 with the lane (sample) axis first and,
    for Mueller matrices, shape (n, n_wavelengths, 4, 4)."""
    a = np.array(value, dtype=np.float64)
    scalar = mi.variant().startswith("scalar")
    if a.ndim == (3 if scalar else 4):  # Mueller matrix: (4, 4, n_wavelengths[, n])
        return a.transpose((2, 0, 1) if scalar else (3, 2, 0, 1))
    return a if scalar or a.ndim == 0 else np.moveaxis(a, -1, 0)
