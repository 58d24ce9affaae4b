"""Physics checks on the float64 reference and on the plugin: the CI share of
``validation/physics.py``, ``validation/furnace.py`` and
``validation/rendered_stokes.py`` (the same ``mitsuba_pbrdf.diagnostics`` and ``proof`` functions,
fewer samples). Run with ``pytest -s`` to see each table.

Float32 tolerances use u = 2^-24 (the unit roundoff of float32); each bound
says which operations it counts.
"""

import numpy as np
import pytest

from mitsuba_pbrdf import use_variant
from mitsuba_pbrdf.diagnostics import furnace, physics, realizability
from proof import furnace_study, mirror_fresnel
from proof import rendered

U32 = 2.0 ** -24
U64 = 2.0 ** -53


@pytest.fixture(autouse=True)
def main_variant():
    use_variant("llvm_ad_spectral_polarized")


def show(headers, rows):
    """Print a table (seen with ``pytest -s``)."""
    def cell(v):
        return f"{v:.6g}" if isinstance(v, (float, np.floating)) else str(v)

    print("\n" + " | ".join(headers))
    for row in rows:
        print(" | ".join(cell(v) for v in row))


# ---------------------------------------------------------------------------
# Fresnel
# ---------------------------------------------------------------------------

def test_fresnel_reflectance_at_normal_incidence():
    """R = ((n-1)^2 + k^2) / ((n+1)^2 + k^2) from Mitsuba's tabulated n, k (Al,
    Cu, Au, Ag; 8 wavelengths 400-800 nm) against R recovered from the BRDF at
    exact normal incidence and exit (R = 4 pi alpha^2 M00).

    Reference: ~30 float64 operations, so 1e-12 relative is 100x their
    rounding. Plugin: n and k come from float32 spectrum tables and their
    interpolation (~1e-7 relative each; dR/R is at most ~2x as sensitive),
    plus ~40 float32 operations for D(0) and the complex amplitudes: at most
    ~100 u = 6e-6, bound 1e-5."""
    rows = mirror_fresnel.normal_incidence()
    show(["metal", "λ", "n", "k", "R closed form", "R reference", "R plugin"], rows)
    for metal, wl, n, k, closed, ref, plugin in rows:
        assert 0.3 < closed < 1.0
        assert abs(ref / closed - 1) < 1e-12, (metal, wl)
        assert abs(plugin / closed - 1) < 1e-5, (metal, wl)


def test_pseudo_brewster_angle():
    """The minimum of R_p (Al, Cu at 450 and 632.8 nm, Au, Ag, and Brewster's
    arctan(n) of a dielectric) against the closed-form Fresnel R_p's.

    A minimum this flat is located only as well as R_p is known: an error e
    (relative to M00 ~ (R_s + R_p)/2, from which R_p = M00 - M01 is computed)
    moves it by up to sqrt(2 e M00 / R_p''). mirror_fresnel.pseudo_brewster reports
    that resolution for the plugin's e = 2e-6 (~30 float32 operations); the
    reference's e is ~10 float64 roundings, 1e-15, i.e. its resolution is
    sqrt(1e-15 / 2e-6) of the plugin's, plus the golden-section search's 1e-10
    rad. Both must be within twice their resolution."""
    rows = mirror_fresnel.pseudo_brewster()
    show(["case", "λ", "n", "k", "closed (°)", "reference (°)", "plugin (°)", "res. (°)",
          "R_p min"], rows)
    for name, wl, n, k, closed, ref, plugin, res32, rp_min in rows:
        res64 = res32 * np.sqrt(1e-15 / 2e-6) + np.degrees(1e-10)
        assert abs(ref - closed) <= 2 * res64, (name, wl, ref - closed, res64)
        assert abs(plugin - closed) <= 2 * res32, (name, wl, plugin - closed, res32)
        assert 45 < closed < 85
    dielectric = [r for r in rows if r[0].startswith("dielectric")][0]
    assert abs(dielectric[4] - np.degrees(np.arctan(1.5))) < 1e-7      # Brewster: arctan(n)
    assert dielectric[8] < 1e-12                                       # R_p vanishes there


def test_reflected_light_is_s_polarized_and_its_dop_rises_to_pseudo_brewster():
    """Unpolarized light reflected into the mirror direction (incidence
    1-89.5 deg): S1 > 0 (s-polarized), S2 = S3 = 0 (in the plane of incidence
    the facet and global frames coincide: only rounding of the frame rotations
    remains, a few u of M00 in float32, bound 16 u), and the DOP rises
    monotonically up to the pseudo-Brewster angle and peaks beyond it."""
    rows = mirror_fresnel.s_polarization()
    show(["metal", "λ", "lobes", "engine", "min S1/S0", "max |S2|,|S3|/S0", "rising",
          "θpB", "DOP(θpB)", "θ max DOP", "max DOP"], rows)
    for metal, wl, lobes, engine, min_s1, max_s23, rising, pb, dop_pb, theta_max, dop_max in rows:
        label = (metal, wl, lobes, engine)
        assert min_s1 > 0, label
        assert max_s23 <= (1e-12 if engine == "reference" else 16 * U32), label
        assert rising, label
        assert theta_max >= pb - 0.25, label        # 0.25 deg: the angle grid
        assert dop_max >= dop_pb > 0, label


# ---------------------------------------------------------------------------
# Reciprocity and realizability
# ---------------------------------------------------------------------------

def test_reciprocity():
    """M00(wi, wr) = M00(wr, wi) and M(r, i) = Q M(i, r)^T Q over 10,000 random
    pairs x 4 wavelengths for five configurations (Smith/V-groove, Beckmann/GGX,
    narrow specular, dielectric, total internal reflection).

    Reference: the model is reciprocal, to float64 rounding (1e-12 of M00).
    Plugin: each of the two evaluations is within 1e-4 M00 of the reference,
    the bound tests/bsdfs/test_pbrdf_vs_reference.py derives for these directions
    (cos theta >= 0.02), so their difference is within 2e-4 M00."""
    rows = physics.reciprocity(pairs=10_000)
    show(["configuration", "engine", "M00 asymmetry", "Q M^T Q"], rows)
    for name, engine, m00, full in rows:
        bound = 1e-12 if engine == "reference" else 2e-4
        assert m00 <= bound and full <= bound, (name, engine, m00, full)


@pytest.mark.slow
def test_mueller_matrices_are_realizable():
    """Cloude's coherency matrix has no negative eigenvalue and the output DOP
    is <= 1 for 69 input Stokes vectors, over 10,000 random pairs (down to
    cos theta = 1e-3) plus normal, retro-reflection, mirror and grazing pairs.

    Reference: float64 rounding, 1e-12 of M00. Plugin: its matrix is assembled
    from realizable factors, so only the rounding of its entries counts:
    eigenvalues within realizability.REALIZABILITY_TOL (16 u) of M00; the output's
    polarized part moves by at most ||dM||_2 <= ||dM||_F <= 16 u M00 per unit
    input, 32 u allowed for the DOP excess."""
    rows = physics.realizability(pairs=10_000)
    show(["configuration", "engine", "matrices", "min eigenvalue / M00", "DOP excess",
          "min M00"], rows)
    for name, engine, count, lam, excess, _ in rows:
        assert count > 5000, (name, engine)
        lam_tol, dop_tol = ((1e-12, 1e-12) if engine == "reference"
                            else (realizability.REALIZABILITY_TOL,
                                  2 * realizability.REALIZABILITY_TOL))
        assert lam >= -lam_tol, (name, engine, lam)
        assert excess <= dop_tol, (name, engine, excess)


def test_reciprocity_and_realizability_checks_apply_to_any_bsdf():
    """The same checks on Mitsuba's own ``roughconductor`` (Al, Beckmann alpha
    0.2), through the functions a user would call on any BSDF: 10,000 random
    pairs x 3 wavelengths.

    Realizability: roughconductor also multiplies a Jones-derived Fresnel
    matrix by a non-negative D G / (4 cos) and rotates frames, so the same
    bounds as the plugin's hold (realizability.REALIZABILITY_TOL, twice that
    for the DOP excess), above M00 = 1e-30 (NORMAL_FLOOR of float32).
    Reciprocity: in this reduced case it equals pbrdf within 1e-5 M00 per
    element (tests/bsdfs/test_pbrdf_roughconductor.py), which is within 1e-4 M00 of the
    exactly reciprocal reference: 2 x (1e-4 + 1e-5) = 2.2e-4 for the difference
    of two evaluations."""
    import mitsuba as mi

    from mitsuba_pbrdf import frames

    bsdf = mi.load_dict({"type": "roughconductor", "material": "Al", "alpha": 0.2,
                         "distribution": "beckmann"})
    to_viewer, to_light = frames.random_directions(10_000, np.random.default_rng(5))
    M = physics.mueller_global(bsdf, to_viewer, to_light, (450.0, 550.0, 650.0))
    count, lam, excess, _ = realizability.realizability(M, floor=physics.NORMAL_FLOOR["plugin"])
    print(f"\nroughconductor: {count} matrices, min eigenvalue {lam:.2e} M00, "
          f"DOP excess {excess:.2e} M00")
    assert count > 20_000
    assert lam >= -realizability.REALIZABILITY_TOL
    assert excess <= 2 * realizability.REALIZABILITY_TOL
    m00, full = physics.reciprocity_errors(
        lambda v, l: physics.mueller_global(bsdf, v, l, (450.0, 550.0, 650.0)),
        to_viewer, to_light)
    print(f"reciprocity: M00 {m00:.2e}, Q M^T Q {full:.2e}")
    assert m00 <= 2.2e-4 and full <= 2.2e-4


# ---------------------------------------------------------------------------
# White furnace
# ---------------------------------------------------------------------------

FURNACE_POINTS = [("beckmann", 0.2, "vgroove", a) for a in (0.0, 60.0, 85.0)] + \
                 [("ggx", 0.5, "smith", a) for a in (0.0, 60.0, 85.0)] + \
                 [("ggx", 1.0, "vgroove", 40.0), ("Al", 0.2, "vgroove", 40.0)]


@pytest.mark.parametrize("lobe,sigma,shadowing,angle", FURNACE_POINTS)
def test_albedo_of_each_lobe_plugin_sampling_vs_reference_quadrature(lobe, sigma, shadowing, angle):
    """Directional-hemispherical albedo by the plugin's own importance sampling
    (2^18 samples) against the reference's half-vector quadrature (128^2
    nodes; its error estimated by halving the nodes). z = |difference| /
    (sqrt(s.e.^2 + quadrature error^2) + 1e-4 x albedo) <= 5, the 1e-4 covering
    the perfect conductor's R >= 0.9999 and float32 weights."""
    ref, qerr = furnace.reference_albedo_with_error(lobe, angle, sigma, shadowing, n=128)
    mc, se = furnace.plugin_albedo(lobe, angle, sigma, shadowing, samples=1 << 18)
    row = dict(lobe=lobe, sigma=sigma, shadowing=shadowing, angle=angle, reference=ref,
               quadrature_error=qerr, plugin=mc, stderr=se)
    z = furnace_study.compare(row)
    print(f"\n{lobe} σ {sigma} {shadowing} {angle}°: reference {ref:.5f} ± {qerr:.1e}, "
          f"plugin {mc:.5f} ± {se:.1e}, z = {z:.2f}")
    assert z <= 5


def test_white_furnace_energy_balance():
    """Without Fresnel (F = 1) the microfacet lobe never creates energy with
    V-groove or Smith shadowing (albedo <= 1 + quadrature error) at any
    roughness or incidence; without shadowing (Priest-Germer) it does at
    grazing incidence; the loss grows with roughness (normal incidence)."""
    sigmas, angles = (0.05, 0.2, 0.5, 1.0), (0.0, 40.0, 70.0, 85.0, 89.5)
    for shadowing in ("vgroove", "smith"):
        albedo = {}
        for s in sigmas:
            for a in angles:
                value, err = furnace.reference_albedo_with_error("beckmann", a, s, shadowing, n=128)
                assert value <= 1 + err + 1e-9, (shadowing, s, a, value, err)
                albedo[s, a] = value
        at_normal = [albedo[s, 0.0] for s in sigmas]
        assert all(x >= y for x, y in zip(at_normal, at_normal[1:])), (shadowing, at_normal)
    none, err = furnace.reference_albedo_with_error("beckmann", 85.0, 0.5, "none", n=128)
    assert none > 1.5 + err


def test_sample_weights_are_unbiased_for_beckmann_lobes():
    """E[weight] over the plugin's own sampling equals the albedo (reference
    quadrature, error 5e-6) within 4 standard errors (2^20 samples) plus 1e-4
    (the perfect conductor's R >= 0.9999): sigma 0.05, V-groove, 85 deg, where
    a pdf with Mitsuba's approximate Beckmann G1 (which its visible-normal
    sampler does not draw from) biased the weights by -0.33 % (13 s.e.)."""
    ref, qerr = furnace.reference_albedo_with_error("beckmann", 85.0, 0.05, "vgroove", n=256)
    mc, se = furnace.plugin_albedo("beckmann", 85.0, 0.05, "vgroove", samples=1 << 20)
    print(f"\nreference {ref:.6f} ± {qerr:.1e}, plugin {mc:.6f} ± {se:.1e}, ratio {mc / ref:.5f}")
    assert abs(mc - ref) <= 4 * np.hypot(se, qerr) + 1e-4 * ref


@pytest.mark.parametrize("angle", [0.0, 85.0])
def test_albedo_of_the_ideal_diffuse_lobe_alone(angle):
    """kid = 1 alone: every sample weight is eval / pdf = kid = 1 (cosine
    sampling of a cosine lobe), so the Monte Carlo albedo is 1 with no noise;
    1e-6 allows float32 rounding of cos / pi over cos / pi. (Found at pi while
    bsdf.py's single-lobe sampling was being written; fixed.)"""
    mc, se = furnace.plugin_albedo("lambert", angle, 1.0, "vgroove", samples=1 << 12)
    assert abs(mc - 1.0) < 1e-6 and se < 1e-6, (mc, se)


# ---------------------------------------------------------------------------
# Rendered Stokes images
# ---------------------------------------------------------------------------

@pytest.mark.parametrize("scene,metal", [("plate", "Al"), ("sphere", "Cu")])
@pytest.mark.slow
def test_rendered_stokes_image_polarization(scene, metal):
    """A rendered Stokes image (llvm_ad_spectral_polarized, 8 passes x 128 spp)
    against the reference evaluator and against geometry.

    Per pixel the difference of the mean image to the expected value has the
    standard error s.e. estimated from the 8 passes. Unbiased rendering means:
    the image mean of the differences is within 4 standard errors of 0 (its
    s.e. is sqrt(sum s.e.^2) / N), and the RMS difference equals the RMS s.e.:
    with N >= 300 pixels their ratio scatters by ~1/sqrt(2N) < 4 %, 1.25 allows
    6 such spreads (a systematic error as large as the noise gives 1.41).
    Systematic allowances: the reference's footprint quadrature (a third of its
    8x8 - 4x4 difference, Richardson), and for the geometric AoLP rule its
    evaluation on the pixel's central ray instead of the footprint."""
    r = rendered.measure(scene, metal, spp=128, passes=8)
    print("\n" + ", ".join(f"{k}: {v:.3g}" if isinstance(v, float) else f"{k}: {v}"
                           for k, v in r.items() if k != "images"))
    assert r["pixels"] >= 300 and r["polarized_pixels"] >= 300
    assert r["dolp_ref_max"] > 0.03                      # the image shows polarization
    footprint = r["footprint_rms"] / 3
    assert abs(r["dolp_bias"]) <= 4 * r["dolp_bias_se"] + footprint
    assert r["dolp_rms_error"] <= 1.25 * r["dolp_rms_se"] + footprint
    aolp_footprint = r["aolp_footprint_rms_deg"] / 3
    assert abs(r["aolp_ref_mean_error_deg"]) <= 4 * r["aolp_mean_se_deg"] + aolp_footprint
    assert r["aolp_ref_rms_error_deg"] <= 1.25 * r["aolp_rms_se_deg"] + aolp_footprint
    # polarization perpendicular to the plane of incident and reflected ray
    assert r["aolp_rms_error_deg"] <= 1.25 * r["aolp_rms_se_deg"] + r["aolp_geometry_rms_deg"]
    if scene == "plate":                                 # rays in the plane of incidence
        assert r["in_plane_pixels"] >= 40
        assert abs(r["aolp_in_plane_mean_deg"]) <= 4 * r["aolp_in_plane_mean_se_deg"] + aolp_footprint
