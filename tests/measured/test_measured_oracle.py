"""Mitsuba's ``measured_polarized`` as an independent oracle in a render
(proof/measured_oracle.py; the full study is validation/measured_oracle.py).

A table exported from the model and the model itself render the same sphere
(directional light, orthographic camera, ``stokes`` + ``direct``). Both run in
``scalar_spectral_polarized``: measured_polarized is compiled C++ there (its
JIT kernel in the LLVM variants takes minutes to compile the first time), the
two renders draw the same sub-pixel positions (same seed; the direct
integrator with a delta light never samples the BSDF), so their per-pixel
difference is the table's interpolation error at those positions.

Tolerance per pixel, predicted before rendering (``predict_direct``): the
largest difference between the emulated table lookup and the float64 model over
an 8 x 8 sub-pixel grid (an average of differences cannot exceed their
maximum), for S0 relative to the pixel's S0, DoLP and AoLP, plus float32
floors (1e-4 relative S0, 1e-4 DoLP, 0.01 deg AoLP: two float32 plugins and
Mitsuba's frame rotations; the measured agreement is ~1e-5). AoLP is compared
where DoLP > 0.02. A table whose Stokes x-axes are taken in the plane of reflection instead of
perpendicular to it (the classic s/p swap) must fail the same comparison. (A
mirrored p axis, or x_f = V x L instead of L x V, leaves a reflection's facet
matrix unchanged and is rightly invisible.)
"""

import numpy as np
import pytest

from mitsuba_pbrdf.measured import export, pbsdf
from proof import measured_oracle as oracle
from mitsuba_pbrdf.reference.params import PBRDFParams

PARAMS = PBRDFParams(eta=0.9, k=2.4, sigma=0.15, kdd=0.1, sigma_dd=0.5, kid=0.02)
PLUGIN = {"type": "pbrdf", "eta": 0.9, "k": 2.4, "sigma": 0.15, "kdd": 0.1, "sigma_dd": 0.5,
          "kid": 0.02}
SIZE, SPP = 18, 16
FLOORS = dict(s0=1e-4, dolp=1e-4, aolp=0.01)


def excess(model, table, prediction):
    """Per quantity: the largest |table - model| / tolerance over valid pixels."""
    qm, qt = oracle.quantities(model), oracle.quantities(table)
    v = prediction["valid"] & (qm[0] > 1e-3 * qm[0].max())
    pol = v & (qm[1] > 0.02)
    with np.errstate(invalid="ignore", divide="ignore"):
        return {"s0": (np.abs(qt[0] - qm[0]) / qm[0]
                       / (prediction["bound_s0"] + FLOORS["s0"]))[v].max(),
                "dolp": (np.abs(qt[1] - qm[1]) / (prediction["bound_dolp"] + FLOORS["dolp"]))[v].max(),
                "aolp": (np.abs(oracle.angle_difference(qt[2], qm[2]))
                         / (prediction["bound_aolp"] + FLOORS["aolp"]))[pol].max(),
                "pixels": int(v.sum()), "polarized": int(pol.sum())}


@pytest.fixture(scope="module")
def renders(tmp_path_factory):
    from mitsuba_pbrdf import use_variant

    folder = tmp_path_factory.mktemp("oracle")
    good = str(folder / "model.pbsdf")
    export.export_pbsdf(good, PARAMS, export.Grid(25, 40, 40))
    table = pbsdf.read_pbsdf(good)
    mirrored = str(folder / "mirrored.pbsdf")
    # Stokes x-axes in the plane of reflection instead of perpendicular to it
    # (rotated by 90 deg: m01, m10, m23, m32 change sign)
    D = np.diag([1.0, -1.0, -1.0, 1.0]).astype(np.float32)
    pbsdf.write_pbsdf(mirrored, D @ np.asarray(table.M) @ D, table.phi_d, table.theta_d,
                      table.theta_h, table.wavelengths)
    use_variant("scalar_spectral_polarized")
    try:
        out = {name: oracle.render_stokes(oracle.sphere_scene(bsdf, SIZE, SPP), seed=7)
               for name, bsdf in (("model", PLUGIN),
                                  ("table", {"type": "measured_polarized", "filename": good}),
                                  ("mirrored", {"type": "measured_polarized",
                                                "filename": mirrored}))}
    finally:
        use_variant("llvm_ad_spectral_polarized")
    # the prediction traces Mitsuba's camera rays in a JIT variant (vectorized)
    out["prediction"] = oracle.predict_direct(table, PARAMS, oracle.sphere_scene(PLUGIN, SIZE, SPP),
                                              SIZE)
    return out


def test_measured_polarized_agrees_within_predicted_interpolation_error(renders):
    e = excess(renders["model"], renders["table"], renders["prediction"])
    assert e["pixels"] > 60 and e["polarized"] > 20, e
    assert e["s0"] <= 1 and e["dolp"] <= 1 and e["aolp"] <= 1, e


def test_a_frame_error_is_caught(renders):
    """The same comparison on a table with its Stokes frames rotated by 90 deg
    (s and p swapped: the reflected light's AoLP turns by 90 deg) fails by far."""
    e = excess(renders["model"], renders["mirrored"], renders["prediction"])
    assert e["aolp"] > 10, e
