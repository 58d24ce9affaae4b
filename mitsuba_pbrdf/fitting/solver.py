"""Least-squares fit of the pBRDF model to measurements
(:class:`~mitsuba_pbrdf.measured.Measurements`).


**Parameters.** The complex index n + ik per distinct wavelength, and
``sigma, ks, kdd, sigma_dd, kid`` shared by all wavelengths (the model:
``docs/model.md``; the fit: ``docs/fitting.md``). ``--material`` starts n, k from Mitsuba's tabulated spectra (else
n = 1.5, k = 5); ``--fix`` holds parameters (``n``/``k`` for all
wavelengths, or ``n@633=1.2`` for one). The *two-component* model is the
specular lobe plus the ideal diffuse one (``kdd = 0``: the model the paper
modifies); ``--model both`` (default) fits both and reports each error, as the
paper compares them.

**Backends.** ``reference`` (default): ``scipy.optimize.least_squares``
(trust-region reflective, bounds) on the float64 NumPy reference evaluator,
Jacobian by finite differences. ``drjit``: the same solver on the Dr.Jit
plugin (float32), Jacobian by Dr.Jit forward-mode derivatives (one pass per
parameter). Both give the same parameters; ``reference`` is faster on the
data sizes of goniometer measurements (``validation/fit_synthetic.md``, section 3).

Parameter uncertainties come from the singular values of the weighted
Jacobian at the optimum (:mod:`.identifiability`; without given
uncertainties, those of the assumed ones, scaled up by the reduced chi-square
when it exceeds 1): parameters the data cannot determine
are reported as undetermined, never with a small +/- from a pseudo-inverse.
They are meaningful only where the fit is good and the parameter is not at a
bound (reported).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Dict, List

import numpy as np

from .. import reference as ref
from ..measured.measurements import Measurements
from .backends import BACKENDS, weights
from .identifiability import analyze
from .layout import ANISOTROPIC, MODELS, SCALE_FLOORS, ParameterLayout, parse_assignments
from .observables import model_observables

__all__ = ["FitResult", "fit_model", "fit_models"]


@dataclass
class FitResult:
    """Outcome of :func:`fit_model`. ``values`` / ``errors``: ``n``, ``k``
    (arrays over ``wavelengths``) and the shared parameters; ``errors`` is NaN
    for fixed parameters and ``inf`` for parameters the data leave
    undetermined (:mod:`.identifiability`; listed in ``undetermined``, with
    the groups that move together in ``correlated``); ``at_bound`` lists
    parameters stopped at a bound."""
    model: str
    backend: str
    wavelengths: np.ndarray
    values: Dict
    errors: Dict
    chi2: float
    dof: int
    residuals: Dict[str, np.ndarray]      # model - data, NaN where not measured
    rms: Dict[str, float]                 # RMS of model - data per quantity
    relative_rms: Dict[str, float]        # RMS of (model - data) / data where |data| >= 1 % of max
    seconds: float
    evaluations: int
    success: bool
    message: str
    free: List[str] = field(default_factory=list)
    at_bound: List[str] = field(default_factory=list)
    shadowing: str = "vgroove"
    dd_distribution: str = "beckmann"
    undetermined: List[str] = field(default_factory=list)   # labels, e.g. "n(633 nm)"
    correlated: List[List[str]] = field(default_factory=list)  # groups moving together
    fixed: List[str] = field(default_factory=list)
    anisotropic: bool = False
    distribution: str = "beckmann"        # the specular lobe's
    #: anisotropic fits: refined parameter -> (difference of its refinements,
    #: its standard uncertainty; inf where the data leave it undetermined)
    anisotropy: Dict = field(default_factory=dict)

    @property
    def reduced_chi2(self):
        return self.chi2 / max(self.dof, 1)

    def as_dict(self):
        """JSON-ready: an undetermined parameter's error is ``None`` (null), a
        fixed one's NaN becomes ``None`` too (listed apart in ``fixed``)."""
        def conv(v):
            if isinstance(v, np.ndarray):
                return [conv(float(a)) for a in v]
            return None if isinstance(v, float) and not math.isfinite(v) else v
        return {"model": self.model, "backend": self.backend,
                "wavelengths": self.wavelengths.tolist(),
                "values": {k: conv(v) for k, v in self.values.items()},
                "errors": {k: conv(v) for k, v in self.errors.items()},
                "chi2": self.chi2, "dof": self.dof, "reduced_chi2": self.reduced_chi2,
                "rms": {k: conv(v) for k, v in self.rms.items()},
                "relative_rms": {k: conv(v) for k, v in self.relative_rms.items()},
                "seconds": self.seconds,
                "evaluations": self.evaluations, "success": self.success,
                "message": self.message, "at_bound": self.at_bound,
                "undetermined": self.undetermined, "correlated": self.correlated,
                "fixed": self.fixed,
                "shadowing": self.shadowing, "dd_distribution": self.dd_distribution,
                "anisotropic": self.anisotropic, "distribution": self.distribution,
                "anisotropy": {base: {"difference": d, "uncertainty": conv(float(sd))}
                               for base, (d, sd) in self.anisotropy.items()}}


def fit_model(data: Measurements, model="three", backend="reference", shadowing="vgroove",
              dd_distribution="beckmann", material=None, init=None, fix=None, starts=3,
              rel_uncertainty=0.05, abs_uncertainty=0.005, seed=0,
              anisotropic=False, distribution="beckmann") -> FitResult:
    """Least-squares fit of one model (``"three"`` or ``"two"``) to ``data``.

    ``init`` / ``fix``: {name: value} (``n``, ``k``, ``n@<nm>``, ``k@<nm>``,
    ``sigma``, ``ks``, ``kdd``, ``sigma_dd``, ``kid``) or ``"name=value,..."``.
    ``material``: starting n, k from Mitsuba's tabulated spectra. ``starts``:
    the fit runs from the initial values and from ``starts - 1`` random
    perturbations of them (sigma and n, k by up to x2), keeping the lowest
    chi-square. ``anisotropic``: fit ``sigma_u`` and ``sigma_v`` instead of
    ``sigma`` (:mod:`.layout`); the result's ``anisotropy`` gives their
    difference and its uncertainty (measurements must resolve azimuths).
    """
    from scipy.optimize import least_squares

    if model not in MODELS:
        raise ValueError(f"model must be one of {', '.join(MODELS)}, not {model!r}")
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {', '.join(BACKENDS)}, not {backend!r}")
    init = parse_assignments(init, "init")
    fix = parse_assignments(fix, "fix")
    if isinstance(starts, bool) or not isinstance(starts, (int, np.integer)) or starts < 1:
        raise ValueError(f"starts must be a whole number >= 1, got {starts!r}")
    for name, v in (("rel_uncertainty", rel_uncertainty), ("abs_uncertainty", abs_uncertainty)):
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
            raise ValueError(f"{name} must be a finite number >= 0, got {v!r}")
    if rel_uncertainty == 0 and abs_uncertainty == 0 and set(data.observed) - set(data.uncertainty):
        raise ValueError("rel_uncertainty and abs_uncertainty are both 0: the measurements "
                         "without given uncertainties would have none")
    wavelengths = data.wavelengths
    if material is not None:
        try:
            n0, k0 = ref.conductor_ior(material, wavelengths)
        except ValueError as e:
            raise ValueError(f"material {material!r}: {e}") from None
        init = dict({f"n@{w:g}": v for w, v in zip(wavelengths, n0)},
                    **{f"k@{w:g}": v for w, v in zip(wavelengths, k0)}, **init)
    layout = ParameterLayout(wavelengths, model, init, fix, anisotropic)
    names, obs, unc, index = weights(data, rel_uncertainty, abs_uncertainty)
    n_obs = sum(len(o) for o in obs)
    if n_obs <= len(layout.free):
        raise ValueError(f"{n_obs} measured values cannot determine {len(layout.free)} "
                         f"free parameters")
    evaluator = BACKENDS[backend](data, layout, shadowing, dd_distribution, distribution)

    def residuals(x):
        model_values = evaluator.observables(x)
        return np.concatenate([(model_values[q][i] - o) / u
                               for q, o, u, i in zip(names, obs, unc, index)])

    def jacobian(x):
        cols = evaluator.jacobian_columns(x)
        return np.stack([np.concatenate([cols[p][q][i] / u for q, u, i in
                                         zip(names, unc, index)]) for p in layout.free], 1)

    jac = jacobian if hasattr(evaluator, "jacobian_columns") else "2-point"

    lo, hi = layout.bounds()
    x0 = np.clip(layout.vector(), lo, hi)
    rng = np.random.default_rng(seed)
    t0 = time.perf_counter()
    best = None
    tol = 1e-10 if backend == "reference" else 1e-7   # float32 residuals: looser tolerances
    for start in range(starts):
        x_start = x0.copy()
        if start:
            for i, name in enumerate(layout.free):
                if name.partition("@")[0] in SCALE_FLOORS:      # indices and widths
                    x_start[i] *= math.exp(rng.uniform(-math.log(2), math.log(2)))
            x_start = np.clip(x_start, lo + 1e-9, hi)
        sol = least_squares(residuals, x_start, jac=jac, bounds=(lo, hi), method="trf",
                            x_scale="jac", ftol=tol, xtol=tol, gtol=tol, max_nfev=400)
        if best is None or sol.cost < best.cost:
            best = sol
    seconds = time.perf_counter() - t0

    values = layout.unpack(best.x)
    chi2 = float(2 * best.cost)
    dof = n_obs - len(layout.free)
    # assumed uncertainties: scaled up by the reduced chi-square when the residuals
    # are larger, never down (a fit to exact data does not make the data exact)
    chi2_scale = (max(chi2 / max(dof, 1), 1.0) if any(q not in data.uncertainty for q in names)
                  else 1.0)
    sd, undetermined, groups, cov = analyze(best.jac, layout.free, best.x, chi2_scale,
                                            with_covariance=True)
    errors = {"n": np.full(len(wavelengths), np.nan), "k": np.full(len(wavelengths), np.nan)}
    errors.update({p: math.nan for p in layout.shared})
    for name, s in zip(layout.free, sd):
        p, _, j = name.partition("@")
        if j:
            errors[p][int(j)] = s
        else:
            errors[p] = float(s)
    at_bound = [layout.label(n) for n, x, a, b in zip(layout.free, best.x, lo, hi)
                if x <= a * (1 + 1e-6) + 1e-12 or x >= b * (1 - 1e-6)]

    anisotropy = {}
    for base, (u, v) in ANISOTROPIC.items():
        if anisotropic and u in layout.free and v in layout.free:
            i, j = layout.free.index(u), layout.free.index(v)
            var = cov[i, i] + cov[j, j] - 2 * cov[i, j]
            split = (math.inf if u in undetermined or v in undetermined
                     else math.sqrt(max(float(var), 0.0)))
            anisotropy[base] = (values[u] - values[v], split)

    final = model_observables(data, values, shadowing, dd_distribution, distribution=distribution)
    resid, rms, rel = {}, {}, {}
    for q, y in data.observed.items():
        r = final[q] - y
        resid[q] = r
        ok = np.isfinite(y)
        rms[q] = float(np.sqrt(np.mean(r[ok] ** 2)))
        # relative error where the value is >= 1 % of the column's largest
        # (a goniometer's useful dynamic range; tiny values make ratios meaningless)
        pos = ok & (np.abs(y) >= 0.01 * np.nanmax(np.abs(y)))
        rel[q] = float(np.sqrt(np.mean((r[pos] / y[pos]) ** 2))) if pos.any() else math.nan
    return FitResult(model, backend, wavelengths, values, errors, chi2, dof, resid, rms, rel,
                     seconds, evaluator.count, bool(best.success), str(best.message),
                     [layout.label(n) for n in layout.free], at_bound, shadowing, dd_distribution,
                     [layout.label(n) for n in undetermined],
                     [[layout.label(n) for n in g] for g in groups],
                     [layout.label(n) for n in _all_names(len(wavelengths), layout.shared)
                      if n not in layout.free], bool(anisotropic), distribution, anisotropy)


def _all_names(W, shared):
    return [f"{p}@{j}" for p in ("n", "k") for j in range(W)] + list(shared)


def fit_models(data: Measurements, models=("three", "two"), **options) -> Dict[str, FitResult]:
    """:func:`fit_model` for each of ``models`` with the same options."""
    return {m: fit_model(data, model=m, **options) for m in models}
