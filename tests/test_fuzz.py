"""Fuzz test of the plugin: 10^5 random direction pairs over random parameters
(the CI share of ``validation/stress.py``, which runs 10^6; both run
``mitsuba_pbrdf.checks.stress``).

Directions: generic, grazing (cos theta down to 1e-7), exact normal incidence
and exit, exact retro-reflection and mirror pairs (collinear: the Mueller
rotation singularity), near-mirror pairs for narrow lobes, nearly opposite
grazing pairs, and directions at or below the horizon. Parameters: sigma 1e-4..2,
sigma_dd 1e-3..5, k = 0 (dielectric) to 100, n from 0.05 (n < 1) to 10, weights
0 and 1e3, per-lane textures, named conductors, wavelengths over 360-830 nm.
The generator is documented in ``mitsuba_pbrdf/checks/fuzz_inputs.py``, every
check in ``mitsuba_pbrdf/checks/stress.py``.

Every eval, pdf, eval_pdf and sample result, both transport modes, must be
finite, non-negative where it must be, physically realizable (Cloude's
coherency matrix, tolerance REALIZABILITY_TOL: 16 float32 roundings of M00,
derived in checks/realizability.py) and zero below the horizon; and within
ACCURACY_UNITS float32 roundings of the float64 reference once the problem's own
conditioning kappa is accounted for (checks/conditioning.py explains kappa,
checks/stress.py the bound).
"""

import mitsuba as mi
import numpy as np
import pytest

from mitsuba_pbrdf import use_variant
from mitsuba_pbrdf import frames, reference
from mitsuba_pbrdf.checks import stress


@pytest.fixture(scope="module")
def tally():
    use_variant("llvm_ad_spectral_polarized")
    return stress.run(samples=100_000, seed=2024)


def test_fuzz_covers_the_regions(tally):
    assert tally.samples >= 100_000
    for region, count in tally.compared.items():
        assert count > 1000, region          # every region was compared with the reference


@pytest.mark.parametrize("check", [
    "finite value", "finite value_ep", "finite pdf", "finite pdf_ep", "finite weight",
    "finite bs_pdf", "finite brdf", "pdf >= 0", "M00 >= 0", "weight M00 >= 0",
    "sample pdf >= 0", "abs(M_ij) <= M00", "eval == eval_pdf", "pdf == eval_pdf",
    "zero below horizon", "sample zero below horizon",
    "sampled below horizon has zero weight", "realizable value", "realizable weight",
    "zero reference -> zero plugin", "sample pdf == pdf(sampled wo)",
    "sample weight == eval / pdf"])
def test_fuzz_check_never_fails(tally, check):
    assert check in tally.failures
    assert tally.failures[check] == 0, (tally.examples.get(check),
                                        sorted(tally.failing_configs.get(check, ())))


def test_fuzz_accuracy_within_float32_of_the_conditioning(tally):
    """Worst error per region in units of u (1 + kappa) (stress.ACCURACY_UNITS),
    nearly opposite grazing pairs included (the plugin's cos(beta) = |wi + wo|/2
    is symmetric in the two directions)."""
    print("\nworst |dM|/M00 per region:", {r: f"{e:.2e}" for r, e in tally.worst.items()})
    print("in units of u (1 + kappa):", {r: f"{e:.3g}" for r, e in tally.worst_units.items()})
    for region, units in tally.worst_units.items():
        assert units <= stress.ACCURACY_UNITS, (region, tally.worst_case.get(region))


def test_eval_is_the_same_in_both_transport_modes_for_nearly_opposite_grazing_pairs():
    use_variant("llvm_ad_spectral_polarized")
    to_viewer = np.array([[-0.9379628896713257, 0.3467355966567993, 1.8534957746396685e-07]])
    to_light = np.array([[0.9379963278770447, -0.3466451168060303, 3.581859800760867e-06]])
    bsdf = mi.load_dict({"type": "pbrdf", "ks": 0.0, "kdd": 1.0, "sigma_dd": 3.8,
                         "dd_distribution": "ggx"})
    radiance = frames.eval_global(bsdf, to_viewer, to_light, mode="radiance")[0, 0, 0, 0]
    importance = frames.eval_global(bsdf, to_viewer, to_light, mode="importance")[0, 0, 0, 0]
    ti, pi_ = frames.to_angles(to_light)
    tr, pr = frames.to_angles(to_viewer)
    expected = reference.directional_diffuse(ti, pi_, tr, pr, np.float32(3.8), "vgroove", "ggx")[0]
    # Same physical pair: the modes may differ by float32 rounding of a symmetric
    # expression only (1e-3 is generous for that). The reference is checked
    # loosely: the pair is ill-conditioned (kappa ~ 1e5 u).
    assert abs(radiance / importance - 1) < 1e-3, (radiance, importance, expected)
    assert abs(radiance / expected - 1) < 0.05, (radiance, importance, expected)
