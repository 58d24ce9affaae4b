"""Shared test set-up: the suite's default variant, and fixtures that switch
variants (``mitsuba_pbrdf.use_variant`` sets one and registers the plugin)."""

import drjit as dr
import mitsuba as mi
import numpy as np
import pytest

from mitsuba_pbrdf import use_variant

use_variant("llvm_ad_spectral_polarized")

#: Wavelengths (nm) used for spectral evaluations in tests.
WAVELENGTHS = (450.0, 520.0, 600.0, 690.0)


@pytest.fixture
def variant(request):
    use_variant(request.param)
    yield request.param
    use_variant("llvm_ad_spectral_polarized")


@pytest.fixture
def restore_variant():
    """For modules whose code under test switches Mitsuba's variant: put back
    the one the suite was on (and its plugin registration) after each test."""
    before = mi.variant()
    yield
    if mi.variant() != before:
        use_variant(before)


def make_si(wi):
    """A batch of surface interactions in the local frame with directions `wi`
    (numpy (n, 3)) and, in spectral variants, the test wavelengths."""
    wi = np.atleast_2d(np.asarray(wi, dtype=np.float32))
    si = dr.zeros(mi.SurfaceInteraction3f, len(wi))
    si.wi = mi.Vector3f(*wi.T) if not mi.variant().startswith("scalar") else mi.Vector3f(*wi[0])
    if mi.is_spectral:
        si.wavelengths = mi.UnpolarizedSpectrum(*WAVELENGTHS)
    return si


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


def as_numpy(value):
    """Mitsuba result -> numpy float64 with the lane (sample) axis first and,
    for Mueller matrices, shape (n, n_wavelengths, 4, 4)."""
    a = np.array(value, dtype=np.float64)
    scalar = mi.variant().startswith("scalar")
    if a.ndim == (3 if scalar else 4):  # Mueller matrix: (4, 4, n_wavelengths[, n])
        return a.transpose((2, 0, 1) if scalar else (3, 2, 0, 1))
    return a if scalar or a.ndim == 0 else np.moveaxis(a, -1, 0)
