"""A fit of a whole measurement campaign (mitsuba_pbrdf.fitting.subsample):
the starts on a subsample and the polish on all rows reach the all-rows
optimum and say so; the subsample keeps every wavelength and the whole data's
objective; the lobes' geometry, computed once, gives the reference's numbers.
Times and memory at 2e5 and 1e6 rows: benchmarks/fit_campaign.py (no timing here)."""

import numpy as np
import pytest

from mitsuba_pbrdf import fitting, reference
from mitsuba_pbrdf.fitting import objectives, subsample
from mitsuba_pbrdf.measured import Measurements

#: GGX lobes shaped like a metal (docs/fitting.md), aluminium's index at 633 nm.
TRUTH = dict(material="Al", sigma=0.05, ks=0.5, kdd=0.1, sigma_dd=0.3, kid=0.02)


@pytest.fixture(scope="module")
def data():
    return fitting.synthetic_measurements(TRUTH, quantities=("m00",), noise=0.02, seed=3,
                                          distribution="ggx", dd_distribution="ggx")


def fit(data, start_rows):
    return fitting.fit_model(data, "three", material="Al", distribution="ggx",
                             dd_distribution="ggx", start_rows=start_rows)


def test_starts_on_a_subsample_reach_the_all_rows_optimum_and_say_so(data):
    """Starts on 150 of the 270 rows, then the polish on all: the same optimum as
    starts on all rows (the same objective and basin; the solver's tolerances are
    1e-10, so 1e-6 relative is far above their difference), within 3 standard
    uncertainties of the truth; the report and the JSON say what was done."""
    sampled, whole = fit(data, 150), fit(data, None)
    for p in ("sigma", "ks", "kdd", "sigma_dd", "kid"):
        assert sampled.values[p] == pytest.approx(whole.values[p], rel=1e-6), p
        assert abs(sampled.values[p] - TRUTH[p]) <= 3 * sampled.errors[p], p
        assert sampled.errors[p] == pytest.approx(whole.errors[p], rel=1e-4), p
    assert sampled.chi2 == pytest.approx(whole.chi2, rel=1e-9)
    note = "7 starts on 150 of 270 rows, the best polished on all"
    assert sampled.start_note == note and whole.start_note == "7 starts on all 270 rows"
    assert note in fitting.report(data, {"three": sampled})
    js = sampled.as_dict()
    assert (js["rows"], js["start_rows"], js["start_note"]) == (270, 150, note)
    assert whole.as_dict()["start_rows"] is None


def test_the_polish_is_reported_as_the_last_step(data):
    seen = []
    fitting.fit_model(data, "two", material="Al", start_rows=100, progress=seen.append)
    finished = [p for p in seen if p.finished]
    assert [p.polish for p in finished] == [False] * 4 + [True]
    assert {p.starts for p in seen} == {5} and finished[-1].start == 5


def test_subsample_keeps_every_wavelength_in_proportion():
    wl = np.repeat([450.0, 633.0, 900.0], [900, 90, 10])
    ones = np.ones(len(wl))
    d = Measurements(30 * ones, 0 * ones, 30 * ones, 180 * ones, wl, {"m00": ones}, {})
    rows = subsample.sample_rows(d, 100, seed=1)
    assert np.all(np.diff(rows) > 0)
    counts = [int(np.sum(wl[rows] == w)) for w in (450.0, 633.0, 900.0)]
    assert counts == [90, 9, 1]
    assert subsample.sample(d, [], 1000) is None and subsample.sample(d, [], None) is None


@pytest.mark.parametrize("objective", ["log", "linear", "cosine"])
def test_subsample_terms_are_the_whole_datas_objective(data, objective):
    """The sample's residuals are the whole data's at those rows: the same floor,
    scale and uncertainties (drawn from the whole data, not the sample's), for
    a quantity measured in some rows only."""
    d = Measurements(data.theta_i, data.phi_i, data.theta_r, data.phi_r, data.wavelength,
                     {"m00": data.observed["m00"].copy()}, {})
    d.observed["m00"][::7] = np.nan
    terms = objectives.make_terms(d, objective, 0.05, 0.005)
    rows, sub, sub_terms = subsample.sample(d, terms, 60, seed=2)
    model = d.observed["m00"] * 1.1
    whole = np.full(len(d), np.nan)
    whole[terms[0].rows] = terms[0].residuals(model[terms[0].rows])
    t = sub_terms[0]
    assert np.array_equal(t.residuals(model[rows][t.rows]), whole[rows][t.rows])
    assert np.array_equal(rows[t.rows], rows[np.isfinite(sub.observed["m00"])])


@pytest.mark.parametrize("shadowing", ["vgroove", "smith", "none"])
def test_lobes_on_a_geometry_computed_once_equal_the_reference(shadowing):
    """``geometry=`` (kept across widths, as a fit does; the V-groove G kept
    with it) gives exactly the numbers of a fresh call, lobe by lobe."""
    rng = np.random.default_rng(4)
    a = (rng.uniform(0, 1.5, 500), rng.uniform(-3, 3, 500), rng.uniform(0, 1.5, 500),
         rng.uniform(-3, 3, 500))
    g = reference.bistatic_geometry(*a)
    for sigma in (0.02, 0.3):
        for d in ("beckmann", "ggx"):
            assert np.array_equal(
                reference.specular_unpolarized(*a, 1.3, 6.5, sigma, shadowing, d, geometry=g),
                reference.specular_unpolarized(*a, 1.3, 6.5, sigma, shadowing, d))
            assert np.array_equal(
                reference.directional_diffuse(*a, sigma, shadowing, d, geometry=g),
                reference.directional_diffuse(*a, sigma, shadowing, d))
        assert np.array_equal(reference.specular(*a, 1.3, 6.5, sigma, shadowing, geometry=g),
                              reference.specular(*a, 1.3, 6.5, sigma, shadowing))
    # the scalar form is the microfacet lobe times the unpolarized Fresnel factor
    assert np.allclose(reference.specular(*a, 1.3, 6.5, 0.1, shadowing)[:, 0, 0],
                       reference.microfacet_lobe(*a, 0.1, shadowing)
                       * reference.fresnel_unpolarized(g["cos_b"], 1.3, 6.5),
                       rtol=1e-12, atol=0)
