"""The reference evaluator's anisotropic and GGX lobes, checked against
quantities computed another way: normalization of D over the hemisphere,
Smith's Lambda by direct integration of the 2-D slope density, the
isotropic limit, the symmetry that swaps the axes, reciprocity."""

import numpy as np
import pytest
from scipy import integrate

from mitsuba_pbrdf import reference as ref
from mitsuba_pbrdf.reference.anisotropic import half_vector_slopes

WIDTHS = [(0.2, 0.05), (0.05, 0.5), (0.3, 0.3), (1.0, 0.1)]


@pytest.mark.parametrize("distribution", ["beckmann", "ggx"])
@pytest.mark.parametrize("alpha_u, alpha_v", WIDTHS)
def test_anisotropic_D_is_normalized(distribution, alpha_u, alpha_v):
    """int D(h) cos(theta_h) dw_h = 1 over the hemisphere, by quadrature in
    (theta_h, phi_h): theta_h through t = tan(theta_h) / alpha_max (nodes follow
    the lobe; GGX's tail up to t = 1e4, beyond which it holds ~1e-8), the
    periodic trapezoid rule in phi. Tolerance 5e-4; measured errors 8e-6 to 7.7e-5."""
    a_max = max(alpha_u, alpha_v)
    t = np.linspace(0.0, 8.0, 1200)
    if distribution == "ggx":
        t = np.concatenate([t, np.geomspace(8.0, 1e4, 600)[1:]])
    phi = (np.arange(256) + 0.5) * 2 * np.pi / 256
    theta = np.arctan(t * a_max)
    T, PHI = np.meshgrid(theta, phi, indexing="ij")
    h = np.stack([np.sin(T) * np.cos(PHI), np.sin(T) * np.sin(PHI), np.cos(T)], -1)
    D = ref.anisotropic_D(h[..., 2], -h[..., 0] / h[..., 2], -h[..., 1] / h[..., 2],
                          alpha_u, alpha_v, distribution)
    inner = (D * np.cos(T) * np.sin(T)).mean(axis=1) * 2 * np.pi
    assert integrate.trapezoid(inner, theta) == pytest.approx(1.0, abs=5e-4)


@pytest.mark.parametrize("distribution", ["beckmann", "ggx"])
def test_anisotropic_D_reduces_to_the_isotropic_one(distribution):
    rng = np.random.default_rng(1)
    cos_h = rng.uniform(0.05, 1.0, 500)
    phi = rng.uniform(0, 2 * np.pi, 500)
    tan = np.sqrt(1 - cos_h**2) / cos_h
    p, q = -tan * np.cos(phi), -tan * np.sin(phi)
    iso = (ref.beckmann_D if distribution == "beckmann" else ref.ggx_D)(cos_h, 0.3)
    # atol: values below 1e-300 are subnormal, with fewer significant digits
    np.testing.assert_allclose(ref.anisotropic_D(cos_h, p, q, 0.3, 0.3, distribution), iso,
                               rtol=1e-12, atol=1e-300)


@pytest.mark.parametrize("distribution", ["beckmann", "ggx"])
@pytest.mark.parametrize("theta, phi", [(0.6, 0.0), (1.2, 0.7), (1.45, 2.0), (0.9, -1.3)])
def test_smith_lambda_by_integrating_the_slope_density(distribution, theta, phi):
    """Smith's Lambda of direction (theta, phi) is
    int_{q > mu} (q - mu) P_phi(q) dq / mu, mu = cot(theta), with P_phi the
    density of the slope along phi, obtained here by integrating the 2-D
    slope density across phi (no projected width assumed). The reference's
    G1 uses the projected width; they agree to quadrature precision (1e-6)."""
    alpha_u, alpha_v = 0.4, 0.08
    mu = 1.0 / np.tan(theta)
    c, s = np.cos(phi), np.sin(phi)

    def marginal(q):      # slope q along phi, r across it
        f = lambda r: ref.slope_density(q * c - r * s, q * s + r * c, alpha_u, alpha_v,
                                        distribution)
        return integrate.quad(f, -np.inf, np.inf, epsabs=1e-12, limit=200)[0]

    lam = integrate.quad(lambda q: (q - mu) * marginal(q), mu, np.inf, epsabs=1e-12,
                         limit=200)[0] / mu
    G1 = ref.smith_G1_anisotropic(theta, phi, alpha_u, alpha_v, distribution)
    assert G1 == pytest.approx(1.0 / (1.0 + lam), rel=1e-6)


ANGLES = np.random.default_rng(2).uniform([0, -np.pi, 0, -np.pi],
                                          [1.5, np.pi, 1.5, np.pi], (3000, 4)).T


@pytest.mark.parametrize("shadowing", ["vgroove", "smith"])
@pytest.mark.parametrize("distribution", ["beckmann", "ggx"])
def test_equal_widths_give_the_isotropic_lobe(shadowing, distribution):
    """The anisotropic code path (slopes, projected widths) with sigma_u =
    sigma_v equals the isotropic one (theta_h, one width) to float64 rounding."""
    args = dict(shadowing=shadowing, distribution=distribution)
    iso = ref.specular(*ANGLES, 0.9, 6.0, 0.2, **args)
    aniso = ref.specular(*ANGLES, 0.9, 6.0, 0.7, sigma_u=0.2, sigma_v=0.2, **args)
    np.testing.assert_allclose(aniso, iso, rtol=1e-9, atol=1e-12 * np.abs(iso).max())
    dd_iso = ref.directional_diffuse(*ANGLES, 0.4, shadowing, distribution)
    dd = ref.directional_diffuse(*ANGLES, 0.9, shadowing, distribution, sigma_dd_u=0.4,
                                 sigma_dd_v=0.4)
    np.testing.assert_allclose(dd, dd_iso, rtol=1e-9, atol=1e-12 * dd_iso.max())


@pytest.mark.parametrize("distribution", ["beckmann", "ggx"])
def test_swapping_the_widths_is_a_quarter_turn(distribution):
    """sigma_u <-> sigma_v is the same surface turned by 90 degrees: equal
    M00 and DoP with both azimuths advanced by pi/2 (the Mueller matrix itself
    is in the global s/p frames, which turn with the directions)."""
    ti, pi_, tr, pr = ANGLES
    a = ref.specular(ti, pi_, tr, pr, 0.9, 6.0, 0.1, "smith", distribution, 0.3, 0.03)
    b = ref.specular(ti, pi_ + np.pi / 2, tr, pr + np.pi / 2, 0.9, 6.0, 0.1, "smith",
                     distribution, 0.03, 0.3)
    np.testing.assert_allclose(b, a, rtol=1e-9, atol=1e-12 * np.abs(a).max())


def test_anisotropic_pbrdf_is_reciprocal():
    ti, pi_, tr, pr = ANGLES
    args = dict(ks=0.8, kdd=0.2, kid=0.05, sigma_u=0.25, sigma_v=0.04, distribution="ggx",
                sigma_dd_u=0.6, sigma_dd_v=0.2, shadowing="smith")
    A = ref.pbrdf(ti, pi_, tr, pr, 1.2, 7.0, 0.1, **args)
    B = ref.pbrdf(tr, pr, ti, pi_, 1.2, 7.0, 0.1, **args)
    # Mueller reciprocity: M(r -> i) = Q M(i -> r)^T Q, Q = diag(1, 1, -1, 1)
    Q = np.diag([1.0, 1.0, -1.0, 1.0])
    np.testing.assert_allclose(B, Q @ np.swapaxes(A, -1, -2) @ Q, rtol=1e-9,
                               atol=1e-12 * np.abs(A).max())


def test_the_stretched_highlight_follows_the_narrow_axis():
    """sigma_u > sigma_v: the lobe is wider across x (azimuth 0) than across
    y. Moving the viewer off the mirror direction by the same angle along x
    keeps more of the peak than along y."""
    peak = ref.specular(0.5, np.pi, 0.5, 0.0, 0.9, 6.0, 0.1, sigma_u=0.3, sigma_v=0.03)[0, 0]
    p, q = half_vector_slopes(0.5, np.pi, 0.5, 0.0)
    assert abs(p) < 1e-12 and abs(q) < 1e-12
    along_x = ref.specular(0.5, np.pi, 0.6, 0.0, 0.9, 6.0, 0.1, sigma_u=0.3, sigma_v=0.03)[0, 0]
    along_y = ref.specular(0.5, np.pi, 0.5, 0.1 / np.sin(0.5), 0.9, 6.0, 0.1, sigma_u=0.3,
                           sigma_v=0.03)[0, 0]
    assert along_x > 0.5 * peak > along_y


def test_params_record_takes_the_new_parameters():
    p = ref.PBRDFParams(material="Al", sigma_u=0.3, sigma_v=0.03, distribution="ggx").validate()
    M = p.evaluate(0.5, np.pi, 0.5, 0.0, [550.0])
    direct = ref.specular(0.5, np.pi, 0.5, 0.0, *p.ior([550.0]), 0.1, "vgroove", "ggx", 0.3, 0.03)
    np.testing.assert_allclose(M, direct, rtol=1e-12)
    assert "σu=0.3" in p.label() and "GGX" in p.label()
    for bad in (dict(sigma_u=-1.0), dict(sigma_v=float("nan")), dict(distribution="phong")):
        with pytest.raises(ValueError):
            ref.PBRDFParams(**bad).validate()
