"""Tests of the NumPy float64 reference evaluator, ``mitsuba_pbrdf.reference``.

Two kinds of checks:

* physics the reference must satisfy on its own (Fresnel limits, realizable
  Mueller matrices, reciprocity, normalized distributions, the paper's Eq. 3);
* agreement with Mitsuba's built-in ``roughconductor`` element by element,
  which pins down every sign convention (frames, r_p, S3) the reference claims
  in its module docstring.

Tolerances: pure float64 identities use ~1e-12 relative; comparisons with
Mitsuba (float32) use bounds derived in the test that states them.
"""

import sys
import zlib

import numpy as np
import pytest

from proof.mitsuba_g1 import mitsuba_beckmann_G1
from mitsuba_pbrdf import reference as ref

METALS = ("Al", "Cu", "Au", "Ag")
WAVELENGTHS = np.array([420.5, 530.25, 611.0, 700.75])   # exactly representable in float32


@pytest.fixture(autouse=True)
def restore_mitsuba_variant():
    """Leave the Mitsuba variant as it was found (other test modules rely on it)."""
    mi = sys.modules.get("mitsuba")
    previous = mi.variant() if mi is not None else None
    yield
    mi = sys.modules.get("mitsuba")
    if previous is not None and mi.variant() != previous:
        mi.set_variant(previous)


def mitsuba_variant(name):
    """Mitsuba with variant ``name`` set. Mitsuba is a dependency and the
    variants named here ship in its wheel: a broken install fails these tests
    (they pin the sign conventions) instead of skipping them."""
    import mitsuba as mi

    mi.set_variant(name)
    return mi


def random_geometry(rng, n, min_cos=0.05):
    cos_i, cos_r = rng.uniform(min_cos, 1.0, (2, n))
    phi_i, phi_r = rng.uniform(-np.pi, np.pi, (2, n))
    return np.arccos(cos_i), phi_i, np.arccos(cos_r), phi_r


def unit(theta, phi):
    return np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], -1)


# ---------------------------------------------------------------------------
# Index of refraction tables
# ---------------------------------------------------------------------------

def test_conductor_ior_interpolates_mitsuba_tables():
    names = ref.available_materials()
    assert set(METALS) <= set(names) and names == sorted(names)
    (wl, n_table), (wl_k, k_table) = ref.materials._ior_tables("Cu")
    # at the table's own nodes the interpolation returns the tabulated values
    n, k = ref.conductor_ior("Cu", wl[5:10])
    np.testing.assert_array_equal(n, n_table[5:10])
    # midway between nodes: the average (linear interpolation, like Mitsuba's "irregular")
    mid = 0.5 * (wl[5:10] + wl[6:11])
    n, _ = ref.conductor_ior("Cu", mid)
    np.testing.assert_allclose(n, 0.5 * (n_table[5:10] + n_table[6:11]), rtol=1e-14)
    # broadcasting over arbitrary shapes
    n, k = ref.conductor_ior("Al", WAVELENGTHS.reshape(2, 2))
    assert n.shape == k.shape == (2, 2) and np.all(k > 0)


def test_conductor_ior_rejects_unknown_material_and_range():
    with pytest.raises(ValueError, match=r"'Unobtainium'.*Cu"):
        ref.conductor_ior("Unobtainium", 500.0)
    with pytest.raises(ValueError, match="range"):
        ref.conductor_ior("Cu", 100.0)


# ---------------------------------------------------------------------------
# Fresnel reflection at a facet
# ---------------------------------------------------------------------------

@pytest.mark.parametrize("material", METALS)
def test_fresnel_normal_incidence(material):
    wl = np.array([400.0, 500.0, 600.0, 700.0, 800.0])
    n, k = ref.conductor_ior(material, wl)
    expected = ((n - 1) ** 2 + k**2) / ((n + 1) ** 2 + k**2)
    r_s, r_p = ref.fresnel_amplitudes(1.0, n, k)
    np.testing.assert_allclose(abs(r_s) ** 2, expected, rtol=1e-12)
    np.testing.assert_allclose(abs(r_p) ** 2, expected, rtol=1e-12)
    # sign convention: right-handed (s, p, d) frames, a mirror reverses the field
    np.testing.assert_allclose(r_p, -r_s, rtol=1e-12)
    M = ref.fresnel_mueller(1.0, n, k)
    np.testing.assert_allclose(M[:, 0, 0], expected, rtol=1e-12)
    np.testing.assert_allclose(np.diagonal(M, axis1=-2, axis2=-1),
                               expected[:, None] * [1, 1, -1, -1], rtol=1e-12, atol=1e-15)


def moeller_reflectances(cos_t, n, k):
    """R_s, R_p in real arithmetic (Moeller, "Optics"; the form of Mitsuba's
    fresnel_conductor), an independent check of the complex formulas."""
    c2 = cos_t**2
    s2 = 1 - c2
    t1 = n**2 - k**2 - s2
    a2pb2 = np.sqrt(t1**2 + 4 * n**2 * k**2)
    a = np.sqrt(0.5 * (a2pb2 + t1))
    term1, term2 = a2pb2 + c2, 2 * cos_t * a
    Rs = (term1 - term2) / (term1 + term2)
    term3, term4 = a2pb2 * c2 + s2**2, term2 * s2
    return Rs, Rs * (term3 - term4) / (term3 + term4)


def test_fresnel_bounded_and_matches_real_form():
    rng = np.random.default_rng(1)
    cos_b = rng.uniform(0, 1, 20000)
    n = rng.uniform(0.05, 4.0, cos_b.size)
    k = rng.uniform(0.0, 10.0, cos_b.size)
    r_s, r_p = ref.fresnel_amplitudes(cos_b, n, k)
    assert np.all(abs(r_s) <= 1 + 1e-12) and np.all(abs(r_p) <= 1 + 1e-12)
    Rs, Rp = moeller_reflectances(cos_b, n, k)
    np.testing.assert_allclose(abs(r_s) ** 2, Rs, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(abs(r_p) ** 2, Rp, rtol=1e-9, atol=1e-12)
    # The wave decays into the metal: with exp(-i w t) and N = n + ik,
    # w = N cos(theta_t) has Im(w) >= 0, so r_s = (cos b - w) / (cos b + w) has
    # Im(r_s) = -2 cos(b) Im(w) / |cos b + w|^2 <= 0, strictly where k > 0 and
    # cos b > 0 (N = n - ik would flip it, and the sign of every retardance).
    assert np.all(np.imag(r_s) <= 1e-15)
    strict = (k > 1e-3) & (cos_b > 1e-3)
    assert np.all(np.imag(r_s[strict]) < 0)


def assert_realizable(M, rng, n_inputs=64):
    """M00 >= |M0j| and a degree of polarization <= 1 for random fully
    polarized input Stokes vectors (Jones-derived matrices keep it at 1)."""
    scale = M[..., 0, 0]
    floor = 1e-14 * scale.max()             # float64 underflow of the far tail of D
    assert np.all(scale >= np.sqrt(np.sum(M[..., 0, 1:] ** 2, axis=-1)) * (1 - 1e-12) - floor)
    v = rng.normal(size=(n_inputs, 3))
    stokes = np.concatenate([np.ones((n_inputs, 1)), v / np.linalg.norm(v, axis=1, keepdims=True)], 1)
    out = np.einsum("...ij,sj->...si", M, stokes)
    polarized = np.sqrt(np.sum(out[..., 1:] ** 2, axis=-1))
    assert np.all(out[..., 0] >= 0)
    assert np.all(polarized <= out[..., 0] * (1 + 1e-12) + floor)
    return polarized, out[..., 0]


def test_mueller_matrices_are_realizable():
    rng = np.random.default_rng(2)
    cos_b = rng.uniform(0, 1, 2000)
    n, k = rng.uniform(0.05, 4.0, (2, cos_b.size)) * [[1], [2.5]]
    pol, s0 = assert_realizable(ref.fresnel_mueller(cos_b, n, k), rng)
    np.testing.assert_allclose(pol, s0, rtol=1e-10)        # pure (non-depolarizing)
    ti, pi_, tr, pr = random_geometry(rng, 2000)
    n, k = ref.conductor_ior("Au", 550.0)
    F = ref.pbrdf(ti, pi_, tr, pr, n, k, 0.25, shadowing="smith")
    pol, s0 = assert_realizable(F, rng)
    np.testing.assert_allclose(pol, s0, rtol=1e-12, atol=1e-14 * s0.max())
    F = ref.pbrdf(ti, pi_, tr, pr, n, k, 0.25, kdd=0.2, kid=0.1)
    pol, s0 = assert_realizable(F, rng)
    assert np.all(pol < s0)                                   # diffuse terms depolarize


def pseudo_brewster_angle(n, k):
    """Root of dR_p/dtheta by bisection on the real-arithmetic R_p."""
    def slope(t, h=1e-7):
        return moeller_reflectances(np.cos(t + h), n, k)[1] - moeller_reflectances(np.cos(t - h), n, k)[1]
    lo, hi = 0.1, 0.5 * np.pi - 1e-4
    assert slope(lo) < 0 < slope(hi)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if slope(mid) < 0 else (lo, mid)
    return 0.5 * (lo + hi)


@pytest.mark.parametrize("material", METALS)
def test_rp_minimum_at_pseudo_brewster_angle(material):
    theta = np.linspace(0, 0.5 * np.pi, 200001)                 # step 7.9e-6 rad
    for wl in (450.0, 650.0):
        n, k = ref.conductor_ior(material, wl)
        r_s, r_p = ref.fresnel_amplitudes(np.cos(theta), n, k)
        Rp = abs(r_p) ** 2
        i = np.argmin(Rp)
        assert 0 < i < theta.size - 1                          # an interior minimum
        theta_pb = pseudo_brewster_angle(n, k)
        assert abs(theta[i] - theta_pb) < 2 * (theta[1] - theta[0])
        assert np.all(np.diff(Rp[: i + 1]) <= 1e-15) and np.all(np.diff(Rp[i:]) >= -1e-15)
        assert Rp[i] < abs(r_s[i]) ** 2
    # k -> 0: the Brewster angle of a dielectric, where R_p vanishes
    r_s, r_p = ref.fresnel_amplitudes(np.cos(np.arctan(1.5)), 1.5, 0.0)
    assert abs(r_p) < 1e-15 and abs(pseudo_brewster_angle(1.5, 1e-9) - np.arctan(1.5)) < 1e-6


def test_fresnel_amplitudes_match_mitsuba_conjugate():
    """Pins the complex convention: Mitsuba evaluates with n - ik, so its
    amplitudes are the complex conjugates of the reference's (same r_p sign)."""
    mi = mitsuba_variant("llvm_ad_spectral_polarized")
    import drjit as dr

    cos_b = np.linspace(0.0, 1.0, 101)
    for n, k in [(1.2, 7.0), (0.27, 3.6), (1.4, 1.7)]:
        eta = dr.llvm.ad.Complex2f(mi.Float(n), mi.Float(k))
        a_s, a_p = mi.fresnel_polarized(mi.Float(cos_b), eta)[:2]
        a_s = np.array(dr.real(a_s)) + 1j * np.array(dr.imag(a_s))
        a_p = np.array(dr.real(a_p)) + 1j * np.array(dr.imag(a_p))
        r_s, r_p = ref.fresnel_amplitudes(cos_b, np.float32(n), np.float32(k))
        np.testing.assert_allclose(a_s, np.conj(r_s), atol=2e-6)
        np.testing.assert_allclose(a_p, np.conj(r_p), atol=2e-6)
        M_mi = np.array(mi.mueller.specular_reflection(mi.Float(cos_b), eta))   # (4, 4, n)
        M_ref = ref.fresnel_mueller(cos_b, np.float32(n), np.float32(k))
        np.testing.assert_allclose(np.moveaxis(M_mi, -1, 0), M_ref, atol=3e-6)


# ---------------------------------------------------------------------------
# Distributions and shadowing
# ---------------------------------------------------------------------------

@pytest.mark.parametrize("sigma", [0.05, 0.2, 0.5])
def test_paper_eq3_is_beckmann_times_cosine(sigma):
    a = np.linspace(0, 1.5, 301)
    p = ref.gaussian_slope_pdf(a, sigma)
    np.testing.assert_allclose(p, ref.beckmann_D(np.cos(a), np.sqrt(2) * sigma) * np.cos(a),
                               rtol=1e-12, atol=1e-300)


def hemisphere_integral(f):
    """2 pi int_0^{pi/2} f(theta) sin(theta) dtheta on a grid dense near 0."""
    theta = np.concatenate([[0.0], np.geomspace(1e-7, 0.5 * np.pi, 400001)])
    y = f(theta) * np.sin(theta)
    return 2 * np.pi * np.sum(0.5 * (y[1:] + y[:-1]) * np.diff(theta))


@pytest.mark.parametrize("alpha", [0.02, 0.1, 0.5, 1.0])
def test_distributions_are_normalized(alpha):
    for D in (ref.beckmann_D, ref.ggx_D):
        total = hemisphere_integral(lambda t: D(np.cos(t), alpha) * np.cos(t))
        assert total == pytest.approx(1.0, abs=1e-6), D.__name__


@pytest.mark.parametrize("alpha", [0.1, 0.5, 1.2])
@pytest.mark.parametrize("distribution", ["beckmann", "ggx"])
def test_smith_G1_matches_slope_integral(alpha, distribution):
    """Lambda(theta) = int_{cot}^{inf} (q - cot) P(q) dq / cot, P the 1D slope
    marginal: Gaussian of std alpha/sqrt(2) (Beckmann), 1/(2 alpha (1+q^2/alpha^2)^1.5) (GGX)."""
    u = np.geomspace(1e-12, 1e12, 200001)                     # q - cot(theta)
    for theta in (0.3, 0.9, 1.3, 1.5):
        mu = 1 / np.tan(theta)
        q = mu + u
        if distribution == "beckmann":
            P = np.exp(-q**2 / alpha**2) / (alpha * np.sqrt(np.pi))
        else:
            P = 1.0 / (2 * alpha * (1 + q**2 / alpha**2) ** 1.5)
        integrand = u * P
        lam = np.sum(0.5 * (integrand[1:] + integrand[:-1]) * np.diff(u)) / mu
        G1 = ref.smith_G1(np.cos(theta), alpha, distribution)
        assert G1 == pytest.approx(1 / (1 + lam), rel=1e-7)
    assert ref.smith_G1(1.0, alpha, distribution) == 1.0
    assert ref.smith_G1(-0.2, alpha, distribution) == 0.0


def test_mitsuba_rational_G1_within_its_stated_bound():
    cos_t = np.linspace(1e-3, 1, 100001)
    exact = ref.smith_G1(cos_t, 1.0, "beckmann")
    rel = np.abs(mitsuba_beckmann_G1(cos_t, 1.0) / exact - 1)
    assert 1e-3 < rel.max() < 0.0035


def test_vgroove_shadowing():
    rng = np.random.default_rng(3)
    ti, pi_, tr, pr = random_geometry(rng, 5000, min_cos=1e-3)
    g = ref.geometry._geometry(ti, pi_, tr, pr)
    G = ref.shadowing_G(ti, tr, g["cos_h"], g["cos_b"], 0.3, "vgroove")
    assert np.all((G >= 0) & (G <= 1))
    G_swapped = ref.shadowing_G(tr, ti, g["cos_h"], g["cos_b"], 0.3, "vgroove")
    np.testing.assert_array_equal(G, G_swapped)
    assert np.all(G[np.minimum(np.cos(ti), np.cos(tr)) < 1e-3 * g["cos_b"]] < 0.01)  # grazing
    assert ref.shadowing_G(0.4, 0.4, 1.0, np.cos(0.4), 0.3, "vgroove") == 1.0  # mirror geometry


# ---------------------------------------------------------------------------
# Frames and rotation angles
# ---------------------------------------------------------------------------

def signed_angle(d, a, b):
    return np.arctan2(np.einsum("...i,...i", d, np.cross(a, b)), np.einsum("...i,...i", a, b))


def test_rotation_angles_match_vector_form_and_priest_germer():
    rng = np.random.default_rng(4)
    ti, pi_, tr, pr = random_geometry(rng, 20000)
    wi, wr = unit(ti, pi_), unit(tr, pr)
    z = np.array([0.0, 0.0, 1.0])

    def normalize(v):
        return v / np.linalg.norm(v, axis=-1, keepdims=True)

    s_in, s_out = normalize(np.cross(z, -wi)), normalize(np.cross(z, wr))
    s_f = normalize(np.cross(wi, wr))
    eta_i, eta_r = ref.rotation_angles(ti, pi_, tr, pr)
    wrap = lambda x: np.angle(np.exp(1j * x))
    np.testing.assert_allclose(wrap(eta_i - signed_angle(-wi, s_in, s_f)), 0, atol=1e-9)
    np.testing.assert_allclose(wrap(eta_r - signed_angle(wr, s_out, s_f)), 0, atol=1e-9)

    # the Priest-Germer forms of docs/model.md, where they are well conditioned
    g = ref.geometry._geometry(ti, pi_, tr, pr)
    ok = g["sin_b"] > 1e-3
    cos_eta_i = (g["cos_h"] - g["cos_i"] * g["cos_b"]) / (g["sin_i"] * g["sin_b"])
    cos_eta_r = (g["cos_h"] - g["cos_r"] * g["cos_b"]) / (g["sin_r"] * g["sin_b"])
    np.testing.assert_allclose(np.cos(eta_i)[ok], cos_eta_i[ok], atol=1e-8)
    np.testing.assert_allclose(np.cos(eta_r)[ok], cos_eta_r[ok], atol=1e-8)
    sign = np.sign(np.sin(pr - pi_))
    assert np.all(np.sign(np.sin(eta_i)) == sign) and np.all(np.sign(np.sin(eta_r)) == sign)
    # cos theta_h and cos beta of the angle form equal h.z and wi.h
    h = normalize(wi + wr)
    np.testing.assert_allclose(g["cos_h"], h[:, 2], atol=1e-12)
    np.testing.assert_allclose(g["cos_b"], np.einsum("ij,ij->i", wi, h), atol=1e-12)


def test_specular_matches_vector_form_rotation():
    """The angle-form Jones derivation equals the Mueller-form rotation of the
    facet matrix with vector-derived angles (Mitsuba's recipe, in float64)."""
    rng = np.random.default_rng(5)
    ti, pi_, tr, pr = random_geometry(rng, 5000)
    n, k = ref.conductor_ior("Cu", 600.0)
    wi, wr = unit(ti, pi_), unit(tr, pr)
    z = np.array([0.0, 0.0, 1.0])
    normalize = lambda v: v / np.linalg.norm(v, axis=-1, keepdims=True)
    h = normalize(wi + wr)
    s_f = normalize(np.cross(h, -wi))
    theta_in = signed_angle(-wi, s_f, normalize(np.cross(z, -wi)))     # facet -> global
    theta_out = signed_angle(wr, s_f, normalize(np.cross(z, wr)))
    M_f = ref.fresnel_mueller(np.einsum("ij,ij->i", wi, h), n, k)
    M = ref.rotator(theta_out) @ M_f @ np.swapaxes(ref.rotator(theta_in), -1, -2)
    F = ref.specular(ti, pi_, tr, pr, n, k, 0.3, "none")
    ok = F[:, 0, 0] > 1e-200                    # not in D's float64 underflow (denormals)
    F, M = F[ok] / F[ok, :1, :1], M[ok] / M[ok, :1, :1]
    assert np.abs(F - M).max() < 1e-12


@pytest.mark.parametrize("material", METALS)
def test_reflected_light_is_s_polarized(material):
    theta = np.linspace(0.1, 1.45, 28)
    n, k = ref.conductor_ior(material, WAVELENGTHS)
    F = ref.pbrdf(theta[:, None], 0.3, theta[:, None], 0.3 + np.pi, n, k, 0.2, kid=0.05)
    S = F @ np.array([1.0, 0.0, 0.0, 0.0])
    assert np.all(S[..., 1] > 0)                       # S1 = I_s - I_p > 0
    np.testing.assert_allclose(S[..., 2:], 0, atol=1e-12 * S[..., :1].max())
    # at the mirror direction the specular part is (R_s - R_p)/(R_s + R_p) polarized
    Fs = ref.specular(theta[:, None], 0.3, theta[:, None], 0.3 + np.pi, n, k, 0.2)
    r_s, r_p = ref.fresnel_amplitudes(np.cos(theta)[:, None], n, k)
    dop = (abs(r_s) ** 2 - abs(r_p) ** 2) / (abs(r_s) ** 2 + abs(r_p) ** 2)
    np.testing.assert_allclose(Fs[..., 1, 0] / Fs[..., 0, 0], dop, rtol=1e-12)


def test_in_plane_block_diagonal():
    rng = np.random.default_rng(6)
    ti, pi_, tr, _ = random_geometry(rng, 2000)
    n, k = ref.conductor_ior("Al", WAVELENGTHS)
    for dphi in (np.pi, -np.pi, 0.0):                  # forward and backward scattering plane
        F = ref.pbrdf(ti[:, None], pi_[:, None], tr[:, None], (pi_ + dphi)[:, None], n, k, 0.3,
                      kdd=0.1, kid=0.1)
        off = [(0, 2), (0, 3), (1, 2), (1, 3), (2, 0), (2, 1), (3, 0), (3, 1)]
        for i, j in off:
            np.testing.assert_allclose(F[..., i, j], 0, atol=1e-12 * F[..., 0, 0].max())
        assert np.abs(F[..., 2, 3]).max() > 1e-3 * F[..., 0, 0].max()   # retardance is there


def test_reciprocity():
    """M00 is symmetric under wi <-> wr; the whole matrix obeys the Mueller
    reciprocity theorem M(r -> i) = Q M(i -> r)^T Q, Q = diag(1, 1, -1, 1)
    (van de Hulst), in the global s/p frames."""
    rng = np.random.default_rng(7)
    ti, pi_, tr, pr = random_geometry(rng, 3000)
    n, k = ref.conductor_ior("Cu", WAVELENGTHS)
    Q = np.diag([1.0, 1.0, -1.0, 1.0])
    for shadowing in ref.SHADOWING_KINDS:
        for dd in ref.DISTRIBUTIONS:
            args = dict(sigma=0.2, kdd=0.3, sigma_dd=0.4, kid=0.05, shadowing=shadowing,
                        dd_distribution=dd)
            A = ref.pbrdf(ti[:, None], pi_[:, None], tr[:, None], pr[:, None], n, k, **args)
            B = ref.pbrdf(tr[:, None], pr[:, None], ti[:, None], pi_[:, None], n, k, **args)
            np.testing.assert_allclose(B[..., 0, 0], A[..., 0, 0], rtol=1e-12)
            err = np.abs(B - Q @ np.swapaxes(A, -1, -2) @ Q)
            assert np.all(err <= 1e-12 * A[..., :1, :1]), (shadowing, dd)


# ---------------------------------------------------------------------------
# The assembled model
# ---------------------------------------------------------------------------

def test_pbrdf_composition_and_broadcasting():
    rng = np.random.default_rng(8)
    ti, pi_, tr, pr = (a[:, None] for a in random_geometry(rng, 50))
    n, k = ref.conductor_ior("Ag", WAVELENGTHS)
    ks, kdd, kid = np.array([0.9, 0.8, 0.7, 0.6]), 0.2, np.array([0.01, 0.02, 0.03, 0.04])
    F = ref.pbrdf(ti, pi_, tr, pr, n, k, 0.15, ks=ks, kdd=kdd, sigma_dd=0.45, kid=kid,
                  shadowing="smith", dd_distribution="ggx")
    assert F.shape == (50, 4, 4, 4) and F.dtype == np.float64
    Fs = ref.specular(ti, pi_, tr, pr, n, k, 0.15, "smith")
    fdd = ref.directional_diffuse(ti, pi_, tr, pr, 0.45, "smith", "ggx")
    expected = ks[:, None, None] * Fs
    expected[..., 0, 0] += kdd * fdd + kid / np.pi
    np.testing.assert_allclose(F, expected, rtol=1e-14, atol=0)
    # one wavelength at a time gives the same numbers
    F1 = ref.pbrdf(ti[:, 0], pi_[:, 0], tr[:, 0], pr[:, 0], n[2], k[2], 0.15, ks=ks[2], kdd=kdd,
                   sigma_dd=0.45, kid=kid[2], shadowing="smith", dd_distribution="ggx")
    np.testing.assert_allclose(F1, F[:, 2], rtol=1e-14)
    # fs = D G M / (4 cos cos) with D of alpha = sqrt(2) sigma (paper Eq. 4)
    g = ref.geometry._geometry(ti, pi_, tr, pr)
    D = ref.beckmann_D(g["cos_h"], np.sqrt(2) * 0.15)
    G = ref.shadowing_G(ti, tr, g["cos_h"], g["cos_b"], np.sqrt(2) * 0.15, "smith")
    R = 0.5 * (np.abs(np.stack(ref.fresnel_amplitudes(g["cos_b"], n, k))) ** 2).sum(0)
    np.testing.assert_allclose(Fs[..., 0, 0], D * G * R / (4 * np.cos(ti) * np.cos(tr)), rtol=1e-12)
    with pytest.raises(ValueError, match="shadowing"):
        ref.pbrdf(0.1, 0, 0.1, np.pi, 1.0, 5.0, 0.1, shadowing="blinn")


def test_singular_geometries_are_finite():
    n, k = ref.conductor_ior("Au", 600.0)
    cases = np.array([
        # theta_i, phi_i, theta_r, phi_r
        [0.0, 0.0, 0.0, 0.0],            # normal incidence and exitance
        [0.0, 1.0, 0.4, 2.0],            # normal incidence
        [0.4, 1.0, 0.0, 2.0],            # normal exitance
        [0.4, 1.0, 0.4, 1.0],            # retro-reflection (sin beta = 0)
        [0.4, 1.0, 0.4, 1.0 + np.pi],    # in-plane mirror direction
        [0.5 * np.pi, 0.0, 0.3, 2.0],    # grazing
        [1e-12, 0.3, 0.4, 2.0],          # almost normal
        [-0.3, 0.2, 0.3, 0.2],           # negative zenith = phi + pi: mirror of the next
        [0.3, 0.2 + np.pi, 0.3, 0.2],
    ])
    for shadowing in ref.SHADOWING_KINDS:
        F = ref.pbrdf(*cases.T, n, k, 0.2, kdd=0.1, kid=0.1, shadowing=shadowing)
        assert np.all(np.isfinite(F))
        np.testing.assert_allclose(F[7], F[8], rtol=1e-12)
    # retro-reflection: the facet matrix R diag(1, 1, -1, -1), whatever the frames
    Fs = ref.specular(*cases[3], n, k, 0.2)
    np.testing.assert_allclose(Fs / Fs[0, 0], np.diag([1.0, 1.0, -1.0, -1.0]), atol=1e-12)
    # below the horizon: zero
    F = ref.pbrdf([1.7, 0.3], 0.0, [0.3, 1.7], 1.0, n, k, 0.2, kdd=0.1, kid=0.1)
    assert np.all(F == 0)


def test_normal_incidence_frame_is_surface_x_axis():
    n, k = ref.conductor_ior("Cu", 550.0)
    tr, pr = 0.5, 2.0
    F0 = ref.pbrdf(0.0, np.array([0.0, 1.0, 3.0]), tr, pr, n, k, 0.2)
    np.testing.assert_allclose(F0, np.broadcast_to(F0[0], F0.shape), rtol=1e-14)
    # the limit along phi_i = pi/2, where s_in = (sin phi_i, -cos phi_i, 0) = (1, 0, 0)
    Fe = ref.pbrdf(1e-7, 0.5 * np.pi, tr, pr, n, k, 0.2)
    np.testing.assert_allclose(F0[0], Fe, atol=1e-5 * Fe[0, 0])
    # exitance: the limit along phi_r = -pi/2, where s_out = (-sin phi_r, cos phi_r, 0) = (1, 0, 0)
    F0 = ref.pbrdf(0.5, 2.0, 0.0, np.array([0.0, 1.0]), n, k, 0.2)
    Fe = ref.pbrdf(0.5, 2.0, 1e-7, -0.5 * np.pi, n, k, 0.2)
    np.testing.assert_allclose(F0, np.broadcast_to(Fe, F0.shape), atol=1e-5 * Fe[0, 0])


# ---------------------------------------------------------------------------
# Agreement with Mitsuba's roughconductor: pins every sign
# ---------------------------------------------------------------------------

@pytest.fixture
def frames():
    mitsuba_variant("llvm_ad_spectral_polarized")
    from mitsuba_pbrdf import frames as mitsuba_frames
    return mitsuba_frames


def reference_for(mf, wi_hat, wo_hat, n, k, alpha, mitsuba_g1=False):
    """The reference at Mitsuba's directions (wo_hat -> wi, wi_hat -> wr), Smith
    shadowing, optionally with Mitsuba's rational G1 in place of the exact one."""
    ti, pi_ = mf.to_angles(wo_hat)
    tr, pr = mf.to_angles(wi_hat)
    R = ref.pbrdf(ti[:, None], pi_[:, None], tr[:, None], pr[:, None], n, k,
                  alpha / np.sqrt(2), shadowing="smith", kdd=0.0, kid=0.0)
    if mitsuba_g1:
        cos_i, cos_r = np.cos(ti), np.cos(tr)
        ratio = (mitsuba_beckmann_G1(cos_i, alpha) * mitsuba_beckmann_G1(cos_r, alpha)
                 / (ref.smith_G1(cos_i, alpha) * ref.smith_G1(cos_r, alpha)))
        R = R * ratio.reshape((-1,) + (1,) * (R.ndim - 1))
    return R


@pytest.mark.parametrize("mode", ["radiance", "importance"])
@pytest.mark.parametrize("material,sigma", [("Al", 0.1), ("Cu", 0.3)])
def test_agreement_with_mitsuba_roughconductor(frames, material, sigma, mode):
    """roughconductor (Beckmann, alpha = sqrt(2) sigma) vs the reference with
    Smith shadowing, all 16 elements, 10,000 direction pairs x 4 wavelengths.

    Tight bound, with Mitsuba's rational Smith G1 substituted into the reference:
    |dM_ij| <= 1e-4 M00 + 1e-7 max(M00). Float32 gives ~6e-8 relative per
    operation; the Beckmann exponent tan^2(th)/alpha^2 (up to ~46 before Mitsuba
    flushes D*cos < 1e-20 to 0) amplifies direction rounding ~100x; the frame
    rotations add ~1e-7 rad. Measured: <= 1.1e-5 M00. The absolute term covers
    that flush and float32 underflow in the far tail.

    Loose bound with the exact Smith G1: |dM_ij| <= 7.1e-3 M00 + 1e-7 max(M00),
    from Mitsuba's stated 0.35 % error of its rational G1 (two factors).
    """
    mi = mitsuba_variant("llvm_ad_spectral_polarized")
    mf = frames
    alpha = float(np.float32(np.sqrt(2) * sigma))
    bsdf = mi.load_dict({"type": "roughconductor", "distribution": "beckmann",
                         "alpha": alpha, "material": material})
    rng = np.random.default_rng(zlib.crc32(f"{material}/{mode}".encode()))
    wi_hat, wo_hat = mf.random_directions(10000, rng)
    M = mf.eval_global(bsdf, wi_hat, wo_hat, WAVELENGTHS, mode)
    assert M.shape == (10000, 4, 4, 4) and np.all(np.isfinite(M))

    n, k = ref.conductor_ior(material, WAVELENGTHS)
    for mitsuba_g1, rtol in [(True, 1e-4), (False, 7.1e-3)]:
        R = reference_for(mf, wi_hat, wo_hat, n, k, alpha, mitsuba_g1)
        m00 = R[..., :1, :1]
        bound = rtol * m00 + 1e-7 * m00.max()
        err = np.abs(M - R)
        bad = err > bound
        if bad.any():
            i = np.argwhere(bad)[0]
            raise AssertionError(
                f"{bad.sum()} elements off (mitsuba_g1={mitsuba_g1}); first at sample {i[0]}, "
                f"band {i[1]}, m{i[2]}{i[3]}: mitsuba {M[tuple(i)]:.6g}, reference {R[tuple(i)]:.6g}")

    # every element is exercised (so a sign flip could not hide), except m03 and
    # m30, which vanish identically for a Fresnel reflection
    R = reference_for(mf, wi_hat, wo_hat, n, k, alpha)
    size = (np.abs(R) / (R[..., :1, :1] + 1e-300)).max(axis=(0, 1))
    assert np.all(np.delete(size.ravel(), [3, 12]) > 0.05)
    assert np.all(size.ravel()[[3, 12]] < 1e-12)


def test_mitsuba_frames_other_variants():
    """eval_global in the scalar, mono and unpolarized variants agrees with the
    reference (explicit eta/k: mono/RGB variants have no wavelengths)."""
    eta, k = 1.2, 7.0
    alpha = float(np.float32(0.3))
    rng = np.random.default_rng(9)
    from mitsuba_pbrdf import frames as mf

    for variant, n_dirs in [("scalar_spectral_polarized", 40), ("llvm_ad_mono_polarized", 2000),
                            ("llvm_ad_rgb", 2000), ("llvm_ad_spectral", 2000)]:
        mi = mitsuba_variant(variant)
        bsdf = mi.load_dict({"type": "roughconductor", "distribution": "beckmann",
                             "alpha": alpha, "eta": eta, "k": k})
        wi_hat, wo_hat = mf.random_directions(n_dirs, rng)
        R = reference_for(mf, wi_hat, wo_hat, np.float32(eta), np.float32(k), alpha,
                          mitsuba_g1=True)[:, 0]
        bands = {"scalar_spectral_polarized": 4, "llvm_ad_mono_polarized": 1,
                 "llvm_ad_rgb": 3, "llvm_ad_spectral": 4}[variant]
        for mode in ("radiance", "importance"):
            M = mf.eval_global(bsdf, wi_hat, wo_hat, WAVELENGTHS, mode)
            if mi.is_polarized:
                assert M.shape == (n_dirs, bands, 4, 4)
                expected = R[:, None]
            else:
                assert M.shape == (n_dirs, bands)
                expected = R[:, None, 0, 0]
            scale = R[:, 0, 0].reshape((-1,) + (1,) * (M.ndim - 1))
            assert np.all(np.abs(M - expected) <= 1e-4 * scale + 1e-7 * R[:, 0, 0].max())
        value, pdf = mf.eval_pdf_global(bsdf, wi_hat, wo_hat, WAVELENGTHS, "radiance")
        # eval_pdf and eval are separate float32 code paths in roughconductor
        np.testing.assert_allclose(value, mf.eval_global(bsdf, wi_hat, wo_hat, WAVELENGTHS),
                                   rtol=1e-5, atol=1e-7 * np.abs(value).max())
        assert pdf.shape == (n_dirs,) and np.all(pdf >= 0) and np.any(pdf > 0)


# ---------------------------------------------------------------- PBRDFParams and small pieces
# (gaps found by mutation testing: validation/mutation.md)

def test_params_validate_names_each_bad_parameter():
    from mitsuba_pbrdf.reference.params import PBRDFParams

    assert PBRDFParams(material="Cu").validate().material == "Cu"
    explicit = PBRDFParams(eta=1.2, k=7.0).validate()
    assert explicit.material is None                    # an explicit n + ik wins
    cases = [(dict(eta=1.2), "both eta and k"), (dict(material=None), "give a material"),
             (dict(material="Xx"), "unknown material"), (dict(eta=0.0, k=1.0), "eta"),
             (dict(eta=1.0, k=-1.0), "k"), (dict(sigma=0.0), "sigma"),
             (dict(sigma_dd=float("nan")), "sigma_dd"), (dict(kid=-1e-9), "kid"),
             (dict(ks="x"), "ks must be a number"), (dict(shadowing="none"), "shadowing"),
             (dict(dd_distribution="beckman"), "dd_distribution")]
    for kwargs, message in cases:
        with pytest.raises(ValueError, match=message):
            PBRDFParams(**kwargs).validate()
    PBRDFParams(kid=0.0, kdd=0.0, ks=0.0, dd_distribution="ggx", shadowing="smith").validate()


def test_params_ior_label_and_lobes():
    from mitsuba_pbrdf.reference.params import PBRDFParams

    n, k = PBRDFParams(eta=1.2, k=7.0).ior([450.0, 650.0])
    assert np.all(n == 1.2) and np.all(k == 7.0)
    np.testing.assert_array_equal(PBRDFParams(material="Au").ior([550.0]),
                                  ref.conductor_ior("Au", [550.0]))
    assert PBRDFParams(eta=1.2, k=7.0).label().startswith("n=1.2, k=7")
    assert PBRDFParams(material="Cu", kdd=0.2, kid=0.1).label() == \
        "Cu, σ=0.1, ks=1, kdd=0.2 (σdd=0.5, beckmann), kid=0.1, G=vgroove"
    p = PBRDFParams(material="Cu", kdd=0.2, kid=0.1)
    angles = (0.4, 0.1, 0.7, 2.9)
    parts = [p.evaluate(*angles, [550.0], lobe=lobe)
             for lobe in ("specular", "directional_diffuse", "ideal_diffuse")]
    np.testing.assert_allclose(sum(parts), p.evaluate(*angles, [550.0]), rtol=1e-12)
    np.testing.assert_allclose(parts[2][..., 0, 0], 0.1 / np.pi, rtol=1e-12)
    with pytest.raises(ValueError, match="unknown lobe"):
        p.evaluate(*angles, [550.0], lobe="diffuse")


def test_dop_of_unpolarized_input():
    from mitsuba_pbrdf.reference.params import check_theta_i, dop_unpolarized

    M = np.zeros((3, 4, 4))
    M[0, 0, 0], M[0, 1, 0], M[0, 2, 0], M[0, 3, 0] = 2.0, 0.6, -0.8, 0.0   # DoP 0.5
    M[1, 0, 0], M[1, 3, 0] = 1.0, -0.3                                    # circular 0.3
    np.testing.assert_allclose(dop_unpolarized(M), [0.5, 0.3, 0.0])       # M00 = 0 -> 0
    check_theta_i(0.0)
    check_theta_i(89.99)
    for bad in (90.0, -1.0):
        with pytest.raises(ValueError, match="theta_i"):
            check_theta_i(bad)


def test_reference_pieces_vanish_at_and_below_the_horizon():
    """D and G are 0 for cos <= 0 (the horizon included), the ideal diffuse
    lobe below the horizon, as the plugin's one-sided surface. (An angle
    cannot put cos exactly at 0: cos(pi / 2) = 6e-17 in float64.)"""
    for D in (ref.beckmann_D, ref.ggx_D):
        assert np.all(D(np.array([0.0, -0.3]), 0.3) == 0)
    below = np.pi / 2 + 0.1
    assert np.all(ref.ideal_diffuse(np.array([below, 0.3]), np.array([0.3, below])) == 0)
    G = ref.shadowing_G(np.array([below, 0.3, 0.3]), np.array([0.3, 0.3, 0.3]),
                        np.array([0.9, 0.9, 0.9]), np.array([0.5, 0.0, -0.1]), 0.3)
    assert np.all(G == 0)
