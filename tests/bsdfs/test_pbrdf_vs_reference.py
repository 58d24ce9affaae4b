"""The Dr.Jit plugin against the float64 NumPy reference evaluator.

Each configuration: >= 10,000 random direction pairs (half of them near the
specular direction) x 4 wavelengths, both transport modes, all 16 Mueller
elements, the plugin's matrices rotated from Mitsuba's implicit Stokes bases
into the reference's global s/p frames (mitsuba_pbrdf.frames).

Tolerance per element: |dM_ij| <= 1e-4 M00 + floor, per lane. The plugin runs
in float32 (~6e-8 relative rounding per operation); the Beckmann exponent
tan^2(theta_h)/alpha^2 (up to ~46 before D underflows) amplifies the rounding of
the directions about 100x, and the two frame rotations add ~1e-7 rad.
|M_ij| <= M00 for a physical Mueller matrix, so M00 sets each element's scale.
The floor is the lane's own underflow size: Mitsuba's microfacet
distributions return D = 0 where D cos(theta_h) < 1e-20, so a microfacet lobe
of weight w can lose at most w 1e-20 / (4 cos_h cos_i cos_o) /sr (:func:`floor`).
The printout gives the share of entries where the floor is the larger term
and the median effective tolerance.

With shadowing="smith" the plugin uses Mitsuba's rational approximation of the
Beckmann Smith G1 (< 0.35 % error, the same as roughconductor): the reference's
exact G1 is replaced by that approximation for the Beckmann lobes, so the
comparison stays at float32 precision; GGX's Smith G1 is exact in both.
"""

import zlib

import mitsuba as mi
import numpy as np
import pytest

from mitsuba_pbrdf import frames as mf
from bsdf_harness import WAVELENGTHS
from mitsuba_pbrdf import reference as ref
from proof.mitsuba_g1 import mitsuba_beckmann_G1

N_PAIRS = 10_000

CONFIGS = {
    "Al-vgroove-beckmann": dict(material="Al", sigma=0.1, kdd=0.2, sigma_dd=0.5, kid=0.05),
    "Cu-smith-beckmann": dict(material="Cu", sigma=0.3, kdd=0.3, sigma_dd=0.8, kid=0.1,
                              shadowing="smith"),
    "Au-vgroove-ggx": dict(material="Au", sigma=0.05, kdd=0.5, sigma_dd=0.3,
                           dd_distribution="ggx"),
    "Ag-smith-ggx": dict(material="Ag", sigma=0.6, ks=0.7, kdd=0.1, sigma_dd=1.5, kid=0.2,
                         shadowing="smith", dd_distribution="ggx"),
    "Cu-narrow-specular-only": dict(material="Cu", sigma=0.02),
    "dielectric-smith": dict(eta=1.5, k=0.0, sigma=0.2, ks=0.5, kid=0.3, shadowing="smith"),
}


def reference_matrix(config, wi_hat, wo_hat):
    """Reference BRDF (n, 4 wavelengths, 4, 4) at Mitsuba's directions
    (wo_hat: towards the light, wi_hat: towards the viewer)."""
    c = dict(dict(ks=1.0, kdd=0.0, sigma_dd=0.5, kid=0.0, shadowing="vgroove",
                  dd_distribution="beckmann"), **config)
    if "material" in c:
        n, k = ref.conductor_ior(c["material"], WAVELENGTHS)
    else:
        n, k = np.full(len(WAVELENGTHS), c["eta"]), np.full(len(WAVELENGTHS), c["k"])
    ti, pi_ = mf.to_angles(wo_hat)
    tr, pr = mf.to_angles(wi_hat)
    angles = (ti[:, None], pi_[:, None], tr[:, None], pr[:, None])

    def smith_correction(alpha, distribution):
        """Mitsuba's approximate Beckmann G1 x G1 over the exact one, shape (n, 1)."""
        if c["shadowing"] != "smith" or distribution != "beckmann":
            return np.ones((len(ti), 1))
        cos_i, cos_r = np.cos(ti), np.cos(tr)
        ratio = (mitsuba_beckmann_G1(cos_i, alpha) * mitsuba_beckmann_G1(cos_r, alpha)
                 / (ref.smith_G1(cos_i, alpha) * ref.smith_G1(cos_r, alpha)))
        return ratio[:, None]

    sigma, sigma_dd = np.float32(c["sigma"]), np.float32(c["sigma_dd"])
    F = c["ks"] * ref.specular(*angles, n, k, sigma, c["shadowing"]) \
        * smith_correction(np.sqrt(2) * sigma, "beckmann")[..., None, None]
    fdd = ref.directional_diffuse(*angles, sigma_dd, c["shadowing"], c["dd_distribution"]) \
        * smith_correction(np.sqrt(2) * sigma_dd, c["dd_distribution"])
    F[..., 0, 0] += c["kdd"] * fdd + c["kid"] * ref.ideal_diffuse(*angles[0::2])
    return F


def floor(config, wi_hat, wo_hat):
    """Per-lane absolute tolerance (n, 1, 1, 1), 1/sr: the value the
    microfacet lobes can lose to Mitsuba's cut-off D cos(theta_h) < 1e-20."""
    c = dict(dict(ks=1.0, kdd=0.0), **config)
    h = wi_hat + wo_hat
    cos_h = h[:, 2] / np.linalg.norm(h, axis=1)
    weight = c["ks"] + c["kdd"]
    f = weight * 1e-20 / (4 * np.maximum(cos_h, 1e-30) * wi_hat[:, 2] * wo_hat[:, 2])
    return f[:, None, None, None]


@pytest.mark.parametrize("mode", ["radiance", "importance"])
@pytest.mark.parametrize("name", sorted(CONFIGS))
def test_plugin_matches_reference(name, mode):
    config = CONFIGS[name]
    bsdf = mi.load_dict(dict({"type": "pbrdf"}, **config))
    rng = np.random.default_rng(zlib.crc32(f"{name}/{mode}".encode()))
    wi_hat, wo_hat = mf.random_directions(N_PAIRS, rng)
    M = mf.eval_global(bsdf, wi_hat, wo_hat, WAVELENGTHS, mode)
    R = reference_matrix(config, wi_hat, wo_hat)
    assert M.shape == R.shape == (N_PAIRS, len(WAVELENGTHS), 4, 4)
    assert np.all(np.isfinite(M))

    m00 = R[..., :1, :1]
    err = np.abs(M - R)
    lane_floor = floor(config, wi_hat, wo_hat)
    tolerance = 1e-4 * m00 + lane_floor
    bad = err > tolerance
    if bad.any():
        i = tuple(np.argwhere(bad)[0])
        raise AssertionError(
            f"{bad.sum()} elements off; first at pair {i[0]}, band {i[1]}, m{i[2]}{i[3]}: "
            f"plugin {M[i]:.6g}, reference {R[i]:.6g}, M00 {R[i[:2] + (0, 0)]:.6g}")
    # Report figures (pytest -s): worst error per element relative to M00.
    rel = (err / np.maximum(m00, 1e-300)).max(axis=(0, 1))
    print(f"\n{name} {mode}: max |dM|/M00 per element\n{np.array2string(rel, precision=2)}")
    effective = (tolerance / np.maximum(m00, 1e-300))[..., 0, 0]
    floored = np.broadcast_to(lane_floor > 1e-4 * m00, m00.shape)[..., 0, 0]
    print(f"floor dominates on {floored.mean():.1%} of (pair, wavelength) entries, all with "
          f"M00 <= {R[..., 0, 0][floored].max(initial=0):.1e} /sr (largest M00 "
          f"{R[..., 0, 0].max():.1e}); effective tolerance relative to M00 elsewhere: median "
          f"{np.median(effective[~floored]):.2e}, max {effective[~floored].max():.2e}")
    # Every element of the polarized lobe is exercised (so no sign can hide),
    # except m03 and m30 which vanish for Fresnel reflection; a dielectric
    # (k = 0) has no retardance, so there the circular elements vanish too.
    size = (np.abs(R) / np.maximum(m00, 1e-300)).max(axis=(0, 1))
    exercised = [0, 1, 2, 4, 5, 6, 8, 9, 10, 15] if config.get("k", 1) == 0 else \
        [i for i in range(16) if i not in (3, 12)]
    assert np.all(size.ravel()[exercised] > 0.01)


@pytest.mark.parametrize("variant", ["llvm_ad_mono_polarized", "llvm_ad_rgb", "llvm_ad_spectral",
                                     "scalar_spectral_polarized"], indirect=True)
def test_other_variants_match_reference(variant):
    """Mono, RGB and unpolarized variants: constant n + ik (these variants have
    no wavelengths); unpolarized variants return M00 only."""
    config = dict(eta=1.2, k=7.0, sigma=0.2, kdd=0.3, sigma_dd=0.6, kid=0.1)
    bsdf = mi.load_dict(dict({"type": "pbrdf"}, **config))
    n_pairs = 40 if variant.startswith("scalar") else 4000
    wi_hat, wo_hat = mf.random_directions(n_pairs, np.random.default_rng(11))
    R = reference_matrix(config, wi_hat, wo_hat)[:, :1]
    for mode in ("radiance", "importance"):
        M = mf.eval_global(bsdf, wi_hat, wo_hat, WAVELENGTHS, mode)
        if not mi.is_polarized:
            M, expected = M, np.broadcast_to(R[..., 0, 0], M.shape)
            lane_floor = floor(config, wi_hat, wo_hat)[:, :, 0, 0]
            assert np.all(np.abs(M - expected) <= 1e-4 * expected + lane_floor)
        else:
            m00 = R[..., :1, :1]
            assert np.all(np.abs(M - R) <= 1e-4 * m00 + floor(config, wi_hat, wo_hat))
