"""Fitting the model to goniometer data: recovery, identifiability, two- versus
three-component error, and the two backends' time and robustness.

    python validation/fit_synthetic.py [--quick]

Writes ``validation/fit_synthetic.md`` and ``validation/figures/fit_example.png``.
Data: ``mitsuba_pbrdf.fitting.synthetic_measurements`` of the three-component
model (Al-like n = 1.2, k = 7.26 at 633 nm; sigma = 0.12, ks = 0.9, kdd = 0.15,
sigma_dd = 0.45, kid = 0.02; V-groove, Beckmann), incidence 20, 45 and 70
degrees, detector every 2 degrees in plane plus 27 out-of-plane directions
per incidence (270 measurements per wavelength), 2 % Gaussian noise plus
1e-4 of the maximum, given as the uncertainty.
"""

import argparse
import math
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
FIGURES = os.path.join(HERE, "figures")
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

TRUTH = dict(n=1.2, k=7.26, sigma=0.12, ks=0.9, kdd=0.15, sigma_dd=0.45, kid=0.02)
SHARED = ("sigma", "ks", "kdd", "sigma_dd", "kid")


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--quick", action="store_true")
    p.add_argument("--out", default=os.path.join(HERE, "fit_synthetic.md"))
    args = p.parse_args(argv)
    from mitsuba_pbrdf import fitting as fit
    from mitsuba_pbrdf.measured import read_measurements

    L = ["# Fitting the pBRDF to goniometer measurements (synthetic)", "",
         "`python validation/fit_synthetic.py` (this file). Data: "
         + __doc__.split("\n\n")[2].split("Data: ", 1)[1].replace("``", "`").replace("\n", " "),
         ""]

    # 1. Recovery and identifiability: M00 alone versus M00 + DoLP
    L += ["## Recovered versus true parameters", "",
          "Three-component fit (`reference` backend, 3 starting points from Al's tabulated "
          "n, k), standard uncertainties from the Jacobian at the optimum.", "",
          "| parameter | true | from M00 | from M00 + DoLP | from M00, m10, m20, m22 |",
          "|---|---|---|---|---|"]
    cases = {"m00": ("m00",), "m00+dolp": ("m00", "dolp"), "elements": ("m00", "m10", "m20", "m22")}
    fits = {name: fit.fit_model(fit.synthetic_measurements(TRUTH, quantities=q, seed=1), "three",
                                material="Al")
            for name, q in cases.items()}

    def cell(r, name):
        v = r.values[name][0] if name in ("n", "k") else r.values[name]
        e = r.errors[name][0] if name in ("n", "k") else r.errors[name]
        flag = " (at bound)" if any(b.startswith(name + "(") or b == name for b in r.at_bound) else ""
        if not np.isfinite(e):  # the data do not determine it: no +/- to give
            return f"{v:.4g} (undetermined){flag}"
        return f"{v:.4g} +/- {e:.2g}{flag}"

    for name in ("n", "k") + SHARED:
        L.append(f"| {name} | {TRUTH[name]:.4g} | " + " | ".join(cell(r, name) for r in fits.values())
                 + " |")
    L += ["", "Reduced chi-square: " + ", ".join(f"{n} {r.reduced_chi2:.3f}" for n, r in fits.items())
          + ". From M00 alone, n and k are not identifiable (the unpolarized reflectance of a "
          "metal hardly varies with incidence angle below 70 degrees and ks absorbs its level): "
          "the fit reports them undetermined (no +/- is given) and may end at a bound. The degree "
          "of linear polarization, or the Mueller elements, pin them to a few percent. The "
          "roughness and the lobe weights are recovered from M00 alone.", ""]

    # 2. Two- versus three-component
    data = fit.synthetic_measurements(TRUTH, seed=1)
    both = fit.fit_models(data, material="Al")
    L += ["## Two- versus three-component model", "",
          "The same M00 + DoLP data fitted by both models (the report `pbrdf-fit` prints):", "",
          "| model | reduced chi2 | M00 relative RMS error (values >= 1 % of max) | "
          "DoLP RMS error |", "|---|---|---|---|"]
    for r in both.values():
        L.append(f"| {r.model}-component | {r.reduced_chi2:.3g} | "
                 f"{100 * r.relative_rms['m00']:.2f} % | {r.rms['dolp']:.2e} |")
    L += ["", "The two-component model (specular + Lambertian) cannot put the broad "
          "directional-diffuse light around the specular peak anywhere but in a wider "
          "specular lobe and a larger Lambertian term, and misses both the peak and the "
          "wings. Figure (`pbrdf-fit tests/data/fit_example.csv --material Al --plot ...`):", "",
          "![fit](figures/fit_example.png)", ""]
    os.makedirs(FIGURES, exist_ok=True)
    example = read_measurements(os.path.join(ROOT, "tests", "data", "fit_example.csv"))
    fit.plot_fit(example, fit.fit_models(example, material="Al"),
                 os.path.join(FIGURES, "fit_example.png"), title="tests/data/fit_example.csv")

    # 3. Timing of the backends
    L += ["## Backends: time", "",
          "`reference`: scipy `least_squares` (TRF) on the float64 NumPy evaluator, "
          "2-point finite-difference Jacobian. `drjit`: the same solver on the Dr.Jit plugin "
          "(float32), Jacobian by forward-mode AD (one pass per parameter). Three-component "
          "model, M00 + DoLP, one starting point (Al's n, k), wall time on 2 cores (shared; "
          "the first `drjit` fit includes JIT compilation, ~5 s, later ones use the kernel "
          "cache).", "",
          "| measurements | wavelengths | backend | time | model evaluations | chi2 | "
          "largest parameter difference / uncertainty |", "|---|---|---|---|---|---|---|"]
    sizes = [(1, None), (3, None)] if args.quick else [(1, None), (3, None), (3, 0.5), (3, 0.1)]
    for n_wl, step in sizes:
        theta_r = None if step is None else np.arange(-80.0, 80.01, step)
        wls = (633.0,) if n_wl == 1 else (450.0, 550.0, 633.0)
        truth = dict(TRUTH, material="Al")
        truth.pop("n"), truth.pop("k")
        d = fit.synthetic_measurements(truth, wavelengths=wls, theta_r=theta_r, seed=3)
        res = {}
        for backend in ("reference", "drjit"):
            res[backend] = fit.fit_model(d, "three", backend=backend, material="Al", starts=1)
        a, b = res["reference"], res["drjit"]
        diff = max([np.max(np.abs(a.values[q] - b.values[q]) / a.errors[q]) for q in ("n", "k")]
                   + [abs(a.values[q] - b.values[q]) / a.errors[q] for q in SHARED])
        for backend, r in res.items():
            L.append(f"| {len(d)} | {n_wl} | {backend} | {r.seconds:.2f} s | {r.evaluations} | "
                     f"{r.chi2:.1f} | {diff:.2g} |")

    # 4. Robustness: random starting points
    trials = 4 if args.quick else 12
    rng = np.random.default_rng(5)
    L += ["", "## Backends: robustness", "",
          f"{trials} random starting points (n, k, sigma, sigma_dd scaled by a factor in "
          "[1/3, 3], ks, kdd, kid in [1/3, 3]), one start each, M00 + DoLP at 633 nm. "
          "Success: chi-square within 1 % of the best found.", "",
          "| backend | successes | median time |", "|---|---|---|"]
    inits = []
    for _ in range(trials):
        s = {q: TRUTH[q] * math.exp(rng.uniform(-math.log(3), math.log(3)))
             for q in ("n", "k") + SHARED}
        inits.append(",".join(f"{q}={v:.5g}" for q, v in s.items()))
    outcome = {}
    for backend in ("reference", "drjit"):
        rs = [fit.fit_model(data, "three", backend=backend, init=i, starts=1) for i in inits]
        outcome[backend] = rs
    best = min(r.chi2 for rs in outcome.values() for r in rs)
    for backend, rs in outcome.items():
        ok = sum(r.chi2 <= 1.01 * best for r in rs)
        L.append(f"| {backend} | {ok} / {len(rs)} | {np.median([r.seconds for r in rs]):.2f} s |")
    L += ["", "Both backends reach the same optimum (parameter differences far below the "
          "uncertainties). The reference backend is the default: on goniometer-sized data "
          "(hundreds to a few thousand measurements) each Dr.Jit evaluation costs ~30-80 ms of "
          "tracing whatever the size, against ~1 ms for NumPy; with ~10^4 measurements and more "
          "(imaging goniometers) the Dr.Jit Jacobian, exact and one pass per parameter, "
          "overtakes the finite differences (table above): `--backend drjit`."]
    with open(args.out, "w") as f:
        f.write("\n".join(L) + "\n")
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
