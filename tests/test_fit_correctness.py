"""The fitter's correctness where its options meet (issue 35): the DoLP
derivative of a lobe that underflows, options a model lacks, an objective per
observable, index tables built in memory, empty or all-zero columns, and the
log objective's floor. Each test failed on the code before its fix."""

import math
import os
import warnings

import numpy as np
import pytest

from mitsuba_pbrdf import fitting
from mitsuba_pbrdf.cli import main
from mitsuba_pbrdf.fitting.lobes import observable_derivatives
from mitsuba_pbrdf.fitting.observables import observables_from_mueller

DATA = os.path.join(os.path.dirname(__file__), "data")
EXAMPLE = os.path.join(DATA, "fit_example.csv")
TRUTH = dict(n=1.2, k=7.26, sigma=0.12, ks=0.9, kdd=0.15, sigma_dd=0.45, kid=0.02)


def small(quantities=("m00", "dolp"), seed=3, **values):
    """A small synthetic set (incidence 30 and 60 deg, detector every 8 deg)."""
    truth = dict(TRUTH, **values)
    return fitting.synthetic_measurements(truth, theta_i=(30.0, 60.0),
                                          theta_r=np.arange(-76.0, 77.0, 8.0),
                                          quantities=quantities, noise=0.01, seed=seed)


# ---------------------------------------------------------------- DoLP of an underflowing lobe

def test_dolp_derivative_is_finite_where_m00_underflows():
    """A Beckmann lobe of width 0.01 is ~1e-318 /sr 30 deg off its peak (a
    subnormal number): its square is 0, so the old quotient rule gave 0/0. The
    ratio form gives the derivative of DoLP = hypot(M10, M20) / M00 exactly:
    checked against the quotient rule evaluated on values scaled up by 1e300
    (DoLP and its derivative are invariant under M, dM -> c M, c dM)."""
    rng = np.random.default_rng(0)
    M = np.zeros((3, 4, 4))
    M[:, 0, 0] = [1e-318, 3e-310, 0.5]
    M[:, 1, 0] = [-4e-319, 1e-310, -0.2]
    M[:, 2, 0] = [2e-319, -5e-311, 0.1]
    dM = np.zeros_like(M)
    dM[:, :3, 0] = rng.normal(size=(3, 3)) * M[:, 0, 0, None]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        d = observable_derivatives(M, dM, ["dolp"])["dolp"]
        dolp = observables_from_mueller(M, ["dolp"])["dolp"]
    c = np.array([1e300, 1e300, 1.0])[:, None]
    m00, m10, m20 = (M[:, i, 0] * c[:, 0] for i in range(3))
    d00, d10, d20 = (dM[:, i, 0] * c[:, 0] for i in range(3))
    lin = np.hypot(m10, m20)
    want = (m10 * d10 + m20 * d20) / lin / m00 - lin * d00 / m00 ** 2
    assert np.all(np.isfinite(d))
    np.testing.assert_allclose(dolp, lin / m00, rtol=1e-3)     # subnormals: ~17 bits
    np.testing.assert_allclose(d, want, rtol=1e-3)


def test_two_component_fit_with_kid_fixed_runs(capsys):
    """``--model two --fix kid=0`` on the example file: its narrow start
    (sigma = 0.01) made the DoLP derivative 0/0 ('array must not contain infs
    or NaNs'); now it fits, without a RuntimeWarning."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        status = main(["fit", EXAMPLE, "--model", "two", "--fix", "kid=0",
                       "--distribution", "beckmann"])
    captured = capsys.readouterr()
    assert status == 0, captured.err
    assert "| kid | 0 (fixed) |" in captured.out
