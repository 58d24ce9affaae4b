"""Study: the model fitted to real measurements, objective by objective.

    python validation/fit_real.py [--quick]   (-> fit_real.md, figures/fit_real_*.png)

Three parts, each with every objective of ``fitting.objectives``:

1. **A known truth shaped like a real metal** (``synthetic``): the three-
   component model with GGX lobes (a near-mirror spike sigma = 0.006, a narrow
   lobe sigma_dd = 0.1, a Lambertian floor kid / pi = 1e-3 /sr six decades under
   the peak), on the geometry of the MERL aluminium cut, with 5 % log-normal
   noise and no uncertainties given. Which objective recovers the truth?
2. **A real metal**: MERL's aluminium, in-plane cut (validation/data/merl_aluminium/),
   unpolarized, n and k held at aluminium's. Three against two components, with
   Beckmann and GGX lobes: the RMS of ln(model / data) over the file and by
   region of the reflection (fitting.diagnosis), and the fit's time.
3. **A real diffuser, polarized**: NIST's Mueller-matrix BRDF of PTFE at 351,
   532, 633 and 1064 nm (all 16 elements), both models, Beckmann lobes (the
   paper's), n and k fitted from PTFE's index (n = 1.35, k = 0.01).

No tolerance is set here: the study reports. ``tests/fitting/test_fit_real.py`` asserts
the properties it shows at CI size. ``--quick``: part 1 with the log and linear
objectives, part 2 with GGX, part 3 at 532 nm.
"""

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from validation import common  # noqa: E402

ALUMINIUM = os.path.join(common.HERE, "data", "merl_aluminium", "aluminium_inplane.csv")
PTFE = os.path.join(common.HERE, "data", "nist_ptfe", "PTFE.data.csv")
TRUTH = dict(sigma=0.006, ks=0.15, kdd=0.04, sigma_dd=0.1, kid=3e-3)
SHARED = ("sigma", "ks", "kdd", "sigma_dd", "kid")
REGIONS = ("specular peak", "near-specular", "off-specular", "grazing")


def objectives(quick):
    from mitsuba_pbrdf.fitting.objectives import OBJECTIVES
    return ("log", "linear") if quick else tuple(OBJECTIVES)


def metal_like(seed=0, noise=0.05):
    from mitsuba_pbrdf import fitting, reference
    from mitsuba_pbrdf.measured import Measurements, read_measurements

    geometry = read_measurements(ALUMINIUM)
    n, k = reference.conductor_ior("Al", geometry.wavelengths)
    clean = fitting.model_observables(geometry, dict(TRUTH, n=n, k=k), dd_distribution="ggx",
                                      distribution="ggx", names=["m00"])["m00"]
    noisy = clean * np.exp(noise * np.random.default_rng(seed).normal(size=clean.shape))
    return Measurements(geometry.theta_i, geometry.phi_i, geometry.theta_r, geometry.phi_r,
                        geometry.wavelength, {"m00": noisy}, {}, "metal-like"), clean


def synthetic(quick):
    from mitsuba_pbrdf import fitting

    data, clean = metal_like()
    rows = []
    for objective in objectives(quick):
        t0 = time.perf_counter()
        r = fitting.fit_model(data, "three", material="Al", distribution="ggx",
                              dd_distribution="ggx", objective=objective)
        model = data.observed["m00"] + r.residuals["m00"]
        truth_ln = float(np.sqrt(np.mean(np.log(model / clean) ** 2)))
        rows.append([objective] + [f"{r.values[p]:.4g} ({r.values[p] / TRUTH[p]:.2f}x)"
                                   for p in SHARED]
                    + [truth_ln, r.rms_ln, f"{time.perf_counter() - t0:.1f} s"])
    headers = (["objective"] + [f"{p} (true {TRUTH[p]:g})" for p in SHARED]
               + ["RMS ln(model/truth)", "RMS ln(model/data)", "time"])
    return common.table(headers, rows)


def region(r, name):
    return next((g.rms_ln for g in r.regions if g.name == name), float("nan"))


def aluminium(quick):
    from mitsuba_pbrdf import fitting
    from mitsuba_pbrdf.fitting.plots import plot_fit
    from mitsuba_pbrdf.measured import read_measurements

    data = read_measurements(ALUMINIUM)
    rows, best = [], {}
    for objective in objectives(quick):
        for distribution in (("ggx",) if quick else ("beckmann", "ggx")):
            t0 = time.perf_counter()
            results = fitting.fit_models(data, material="Al", distribution=distribution,
                                         objective=objective)
            seconds = time.perf_counter() - t0
            for m, r in results.items():
                rows.append([objective, distribution, m, r.rms_ln]
                            + [region(r, g) for g in REGIONS]
                            + [r.reduced_chi2, f"{r.values['sigma']:.3g}",
                               f"{r.values['sigma_dd']:.3g}" if m == "three" else "–",
                               f"{seconds:.1f} s"])
            if objective in ("log", "linear") and distribution == "ggx":
                best[objective] = results
    t0 = time.perf_counter()
    auto = fitting.fit_models(data, material="Al", distribution="auto")
    auto_seconds = time.perf_counter() - t0
    figures = {}
    for objective, results in best.items():
        path = common.figure_path(f"fit_real_aluminium_{objective}")
        plot_fit(data, results, path, title=f"MERL aluminium, {objective} objective, GGX lobes")
        figures[objective] = os.path.relpath(path, common.HERE)
    headers = (["objective", "lobes", "model", "RMS ln(model/data)"]
               + [f"RMS ln, {g}" for g in REGIONS]
               + ["reduced χ²", "sigma", "sigma_dd", "both models' time"])
    return common.table(headers, rows), figures, auto, auto_seconds


def ptfe(quick):
    from mitsuba_pbrdf import fitting
    from mitsuba_pbrdf.measured import read_measurements
    from mitsuba_pbrdf.measured.selection import select_wavelengths

    data = read_measurements(PTFE)
    rows = []
    wavelengths = (532.0,) if quick else (351.0, 532.0, 633.0, 1064.0)
    for w in wavelengths:
        d = select_wavelengths(data, [w])
        for objective in objectives(quick):
            t0 = time.perf_counter()
            results = fitting.fit_models(d, init=dict(n=1.35, k=0.01), objective=objective,
                                         distribution="beckmann")
            seconds = time.perf_counter() - t0
            for m, r in results.items():
                rows.append([f"{w:g}", objective, m, r.rms_ln, r.reduced_chi2,
                             f"{r.values['n'][0]:.3g}", f"{r.values['k'][0]:.3g}",
                             len(r.warnings), f"{seconds:.1f} s"])
    headers = ["λ (nm)", "objective", "model", "RMS ln(model/data) m00", "reduced χ²", "n", "k",
               "warnings", "both models' time"]
    return common.table(headers, rows)


#: What the tables show (written for the full run of 2026-12-02; the figures it quotes are
#: that run's, the claims hold for the quick run too).
READING = """
## Reading

* **Which objective recovers a metal.** On the known truth, `log` and `relative` recover every
  parameter within 1 % and leave a residual equal to the noise (RMS ln(model/data) 0.050 for
  5 % noise); `log-cosine` recovers the lobes within 1 % and the Lambertian floor within 5 %.
  `linear` with assumed uncertainties (5 % of each value + 0.5 % of the largest, about 3 /sr)
  fits the spike and lets every value under a few per steradian count for nothing: the floor
  comes out 9x too high and the narrow lobe 20 % too wide. `cosine` weighs rho cos(theta_i)
  uniformly, so everything but the spike is invisible to it: it drops the directional diffuse
  lobe and puts the floor 70x too high. Its and `log-cosine`'s uncertainties are formal: they
  are weightings, not noise models.
* **A real metal.** On MERL's aluminium the logarithmic objectives fit the whole range and the
  linear and cosine ones fit the peak only (RMS ln 3.5-5.2, a factor 30-170 off in the tail). With
  `log`, the three-component model beats the two-component one in every region of the
  reflection (0.384 against 0.699 over the file with GGX lobes, 0.60 against 1.11 with
  Beckmann): the paper's claim holds on a real metal once the fit respects all decades. GGX
  lobes fit this sample better than Beckmann's Gaussian slopes (the measured lobes have heavier
  tails). The specular peak itself stays the worst region (RMS ln 0.8): the measured spike,
  1.4 degrees wide, is narrower than the lobe that also fits its shoulders. Reduced chi-square
  of 59 with 5 % assumed relative uncertainty: the model, not the noise, limits the fit, and the
  report says so.
* **A diffuser.** PTFE's M00 spans less than a decade, so the objectives hardly differ on it
  (RMS ln 0.054-0.073); `cosine` shifts the fitted index most, since it weighs M00 against the
  other elements differently. Its fitted index is no material's whichever the objective.
"""


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="the CI-sized run")
    args = parser.parse_args(argv)
    started = time.perf_counter()
    part1 = synthetic(args.quick)
    part2, figures, auto, auto_seconds = aluminium(args.quick)
    part3 = ptfe(args.quick)
    three, two = auto["three"], auto["two"]
    text = f"""# The model fitted to real measurements, objective by objective

Generated by `python validation/fit_real.py{' --quick' if args.quick else ''}` on the 2-core
machine ({time.perf_counter() - started:.0f} s). Objectives: `docs/fitting.md` and
`mitsuba_pbrdf/fitting/objectives.py`; regions: `mitsuba_pbrdf/fitting/diagnosis.py`.

## 1. A known truth shaped like a real metal

Three-component model, GGX lobes, aluminium's index; on the MERL cut's 1,785 in-plane
geometries; 5 % log-normal noise, no uncertainties given. Fitted with each objective (GGX
lobes, 7 starts, n and k held at aluminium's). The recovered value and its ratio to the truth:

{part1}

## 2. A real metal: MERL aluminium, in plane

1,785 values from 1e-3 to 2e3 /sr (six decades), unpolarized, n and k held at aluminium's
(550 nm nominal). RMS of ln(model / data) over the file and by region (peak: within 2° of the
mirror direction; near: 2-10°; off: beyond; grazing: light or detector at 75° or more):

{part2}

With the defaults (`pbrdf fit aluminium_inplane.csv --material Al`: the log objective chosen by
`auto`, Beckmann and GGX tried, the better kept): three components {three.rms_ln:.3f}
({three.distribution_choice}), two components {two.rms_ln:.3f} ({two.distribution_choice}),
both models, all starts, both distributions in {auto_seconds:.1f} s.

![MERL aluminium, log objective]({figures.get('log', '')})

![MERL aluminium, linear objective]({figures.get('linear', '')})

## 3. A real diffuser, polarized: NIST's PTFE

All 16 Mueller elements (the objectives change m00's residual only; the other elements are
linear with the assumed uncertainties), Beckmann lobes, starting from PTFE's index:

{part3}

The fitted index stays an effective one (n below 1 with k below 1, `validation/fit_ptfe.md`): each
fit warns so (`warnings`), naming the remedies.
{READING}"""
    common.write_markdown("fit_real", text)


if __name__ == "__main__":
    main()
