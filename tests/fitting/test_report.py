"""What the fit's report says (mitsuba_pbrdf.fitting.report, .diagnosis):
regions exclusive and counted in order, no +/- for a parameter at its bound
(null in the JSON, with the reason), and the reciprocity of light/detector-
swapped pairs, with a warning outside [0.8, 1.25]."""

import numpy as np
import pytest

from mitsuba_pbrdf import fitting
from mitsuba_pbrdf.fitting import diagnosis
from mitsuba_pbrdf.measured import Measurements
from mitsuba_pbrdf.measured.pairs import matching_pairs


def test_regions_say_they_are_exclusive_and_count_what_went_to_grazing():
    """Two detectors on the mirror direction, one of them grazing: the peak
    holds one, and says one more was counted as grazing."""
    ti = np.array([30.0, 80.0, 30.0])
    data = Measurements(ti, np.zeros(3), np.array([30.0, 80.0, 60.0]), np.full(3, 180.0),
                        np.full(3, 550.0), {"m00": np.ones(3)})
    terms = fitting.objectives.make_terms(data, "linear", 0.05, 0.005)
    rows = {g.name: g for g in diagnosis.regional_fit(data, {"m00": np.ones(3)}, terms)}
    assert [g.order for g in rows.values()] == [1, 2, 4]
    peak = rows["specular peak"]
    assert (peak.values, peak.counted_earlier) == (1, 1)
    assert peak.label == ("2. specular peak (not grazing, detector within 2 deg of the mirror "
                          "direction; 1 more values within it counted as grazing)")
    assert rows["grazing"].label.startswith("1. grazing (")
    assert peak.as_dict()["label"] == peak.label


@pytest.fixture(scope="module")
def no_floor():
    """Data without a Lambertian floor: kid stops at its bound 0."""
    truth = dict(n=1.2, k=7.26, sigma=0.12, ks=0.9, kdd=0.15, sigma_dd=0.45, kid=0.0)
    data = fitting.synthetic_measurements(truth, quantities=("m00",), noise=0.02,
                                          noise_floor=0.0, seed=1)
    return data, fitting.fit_model(data, "three", material="Al")


def test_no_uncertainty_is_printed_for_a_parameter_at_its_bound(no_floor):
    data, r = no_floor
    assert "kid" in r.at_bound
    text = fitting.report(data, {"three": r})
    line = next(l for l in text.splitlines() if l.startswith("| kid |"))
    assert "+/-" not in line and "(at a bound: no uncertainty)" in line
    js = r.as_dict()
    assert js["errors"]["kid"] is None and js["error_reasons"]["kid"] == "at a bound"
    assert js["error_reasons"]["sigma"] != "at a bound"
    assert js["error_reasons"]["n(633 nm)"] == "fixed"


def swapped(ratio, rows=40, seed=0):
    """Rows in swapped pairs (theta_i > theta_r in the first of each) whose
    m00 differ by *ratio*, with 2 % noise."""
    rng = np.random.default_rng(seed)
    a_i, a_r = rng.uniform(40, 70, rows).round(1), rng.uniform(5, 35, rows).round(1)
    dphi = rng.uniform(100, 260, rows).round(1)
    value = rng.uniform(0.1, 1.0, rows)
    noise = np.exp(0.02 * rng.normal(size=2 * rows))
    return Measurements(np.r_[a_i, a_r], np.zeros(2 * rows), np.r_[a_r, a_i],
                        np.r_[dphi, 360.0 - dphi], np.full(2 * rows, 633.0),
                        {"m00": np.r_[ratio * value, value] * noise})


def test_reciprocal_data_give_a_ratio_near_1_and_no_warning():
    s = diagnosis.reciprocity(swapped(1.0))
    assert s.pairs == 40 and abs(np.log(s.median_ratio)) < 0.02 and not s.warning


@pytest.mark.parametrize("ratio", [1.57, 1 / 1.57])
def test_data_that_are_not_reciprocal_are_warned_of(ratio):
    data = swapped(ratio)
    s = diagnosis.reciprocity(data)
    assert s.pairs == 40 and s.median_ratio == pytest.approx(ratio, rel=0.03)
    assert s.warning.startswith("warning: the data are not reciprocal") and "\n" not in s.warning
    r = fitting.fit_model(data, "two", material="Al", starts=1)
    assert s.warning in r.warnings and r.as_dict()["reciprocity"]["pairs"] == 40
    text = fitting.report(data, {"two": r})
    assert "reciprocity: 40 light/detector-swapped pairs" in text


def test_data_without_swapped_pairs_say_nothing():
    data = fitting.synthetic_measurements(dict(material="Al", sigma=0.1, ks=0.5, kdd=0.1,
                                               sigma_dd=0.3, kid=0.02), quantities=("m00",),
                                          theta_i=(20.0,), out_of_plane=False)
    assert diagnosis.reciprocity(data) is None


def test_pairs_are_found_across_the_azimuth_seam_and_within_a_wavelength():
    """dphi = -180 and +179.995 are 0.005 deg apart; rows of another wavelength never pair."""
    data = Measurements(np.array([50.0, 20.0, 20.0]), np.array([0.0, 0.0, 0.0]),
                        np.array([20.0, 50.0, 50.0]), np.array([180.0, 179.995, 180.0]),
                        np.array([500.0, 500.0, 600.0]), {"m00": np.ones(3)})
    assert matching_pairs(data).tolist() == [[0, 1], [1, 0]]
