"""Least-squares fit of the pBRDF model to measurements
(:class:`~mitsuba_pbrdf.measured.Measurements`).


**Parameters.** The complex index n + ik per distinct wavelength, and
``sigma, ks, kdd, sigma_dd, kid`` shared by all wavelengths (the model:
``docs/model.md``; the fit: ``docs/fitting.md``). ``--material`` (or
``--nk``) gives n, k from tabulated spectra: the start of a polarized fit,
fixed for unpolarized data, which cannot determine them (else n = 1.5,
k = 5); ``--fix`` holds parameters (``n``/``k`` for all wavelengths, or
``n@633=1.2`` for one). What is minimized: :mod:`.objectives`; where it
starts: :mod:`.starts`; how well it fits, by region: :mod:`.diagnosis`. The *two-component* model is the
specular lobe plus the ideal diffuse one (``kdd = 0``: the model the paper
modifies); ``--model both`` (default) fits both and reports each error, as the
paper compares them.

**Backends.** ``reference`` (default): ``scipy.optimize.least_squares``
(trust-region reflective, bounds) on the float64 NumPy reference evaluator,
lobe by lobe (:mod:`.lobes`). ``drjit``: the same solver on the Dr.Jit
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
from typing import Callable, Dict, Mapping, Optional, Sequence, Union

import numpy as np

from ..errors import ParameterError
from ..measured import IndexTable
from ..measured.measurements import Measurements
from ..schema import DD_DISTRIBUTIONS as DISTRIBUTIONS
from .backends import BACKENDS
from .diagnosis import Reciprocity, diagnose, reciprocity as reciprocity_of, regional_fit
from .identifiability import analyze
from .vector import ANISOTROPIC, PER_WAVELENGTH, ParameterVector, absent_parameters
from .options import assignments_by_model, check_arguments, with_index
from .objectives import OBJECTIVES, choose_objective, make_terms
from .lobes import LobeModel
from .result import FitProgress, FitResult
from .starts import WidthOrder, default_starts, start_points
from .subsample import START_ROWS, sample

__all__ = ["FitResult", "FitProgress", "fit_model", "fit_models"]

#: ``init`` / ``fix``: {name: value} or ``"name=value,..."``
Assignments = Union[None, str, Mapping[str, float]]


#: Residual evaluations between two progress reports within a start.
PROGRESS_EVERY = 25


class _Residuals:
    """The objective's residuals of every measured value at a parameter
    vector, and their Jacobian (the model's, times d residual / d model)."""

    def __init__(self, evaluator, terms, free):
        self.evaluator, self.terms, self.free = evaluator, terms, free

    def __call__(self, x):
        m = self.evaluator.observables(x)
        return np.concatenate([t.residuals(m[t.name][t.rows]) for t in self.terms])

    def jacobian(self, x):
        m = self.evaluator.observables(x)
        cols = self.evaluator.jacobian_columns(x)
        return np.stack([np.concatenate([t.derivative(m[t.name][t.rows]) * cols[p][t.name][t.rows]
                                         for t in self.terms]) for p in self.free], 1)


def _best_of_starts(residuals, order, points, tol, report):
    """The lowest-cost ``least_squares`` solution from each of *points* (in
    the natural vector); *report(start, evaluations, cost, best, finished)*."""
    from scipy.optimize import least_squares

    best = None
    for number, x_start in enumerate(points, 1):
        calls = [0]

        def counted(z):
            r = residuals(order.to_natural(z))
            calls[0] += 1
            if calls[0] % PROGRESS_EVERY == 0:
                report(number, calls[0], 0.5 * float(r @ r), best.cost if best else math.inf,
                       False)
            return r

        sol = least_squares(counted, order.to_internal(x_start),
                            jac=lambda z: order.jacobian(residuals.jacobian(order.to_natural(z)), z),
                            bounds=(order.lo, order.hi), method="trf", x_scale="jac",
                            ftol=tol, xtol=tol, gtol=tol, max_nfev=400)
        if best is None or sol.cost < best.cost:
            best = sol
        report(number, calls[0], float(sol.cost), float(best.cost), True)
    return best


def _residual_summary(data, final):
    """``(residuals, rms, relative rms, rms of ln(model/data) of m00)`` per quantity."""
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
    rms_ln = math.nan
    if "m00" in data.observed:
        y, m = data.observed["m00"], final["m00"]
        ok = np.isfinite(y) & (y > 0) & (m > 0)
        rms_ln = float(np.sqrt(np.mean(np.log(m[ok] / y[ok]) ** 2))) if ok.any() else math.nan
    return resid, rms, rel, rms_ln


def _uncertainties(data, terms, objective, evaluator, residuals, free, x_best, chi2, dof,
                   lo, hi, rel_uncertainty, abs_uncertainty):
    """``(formal, standard uncertainties of free, undetermined, correlated
    groups, covariance)`` at the optimum *x_best* (:mod:`.identifiability`)."""
    # assumed uncertainties (or a weighting objective): scaled up by the reduced
    # chi-square when the residuals are larger, never down (a fit to exact data
    # does not make the data exact)
    likelihood = OBJECTIVES[objective].likelihood
    formal = (not likelihood
              or any(t.name not in data.uncertainty for t in terms))
    chi2_scale = max(chi2 / max(dof, 1), 1.0) if formal else 1.0
    # a weighting objective's residuals are not in units of the noise: judge
    # the data with the linear ones (identifiability module)
    noise = residuals if likelihood else _Residuals(
        evaluator, make_terms(data, "linear", rel_uncertainty, abs_uncertainty), free)
    r_noise = noise(x_best)
    if not likelihood:
        chi2_scale = max(float(r_noise @ r_noise) / max(dof, 1), 1.0)
    sd, undetermined, groups, cov = analyze(
        noise.jacobian(x_best), free, x_best, chi2_scale, with_covariance=True,
        chi2=None if likelihood
        else lambda z: float(np.sum(noise(np.clip(z, lo, hi)) ** 2)))
    if not likelihood:
        # the weighting's own scatter (sandwich): never below the data's bound
        G = residuals.jacobian(x_best)
        m = evaluator.observables(x_best)
        w = np.concatenate([np.abs(t.derivative(m[t.name][t.rows])) * t.u for t in terms])
        A = np.linalg.pinv(G.T @ G, rcond=1e-12)
        sand = A @ (G.T * w ** 2) @ G @ A * chi2_scale
        sd = np.maximum(sd, np.sqrt(np.clip(np.diag(sand), 0.0, None)))
    return formal, sd, undetermined, groups, cov


def _stated(layout, order, z_best, x_best, values, sd, undetermined, cov, lo, hi, anisotropic):
    """``(errors, at_bound, anisotropy)`` of :class:`FitResult` from the
    standard uncertainties *sd* of the free parameters."""
    W = len(layout.wavelengths)
    errors = layout.place(sd, {**{p: np.full(W, np.nan) for p in PER_WAVELENGTH},
                               **{p: math.nan for p in layout.shared}})
    at_bound = [layout.label(n) for n, x, a, b in zip(layout.free, x_best, lo, hi)
                if x <= a * (1 + 1e-6) + 1e-12 or x >= b * (1 - 1e-6)]
    if order.at_bound(z_best):
        at_bound.append("sigma_dd = sigma (the lobes' order)")
    anisotropy = {}
    for base, (u, v) in ANISOTROPIC.items():
        if anisotropic and u in layout.free and v in layout.free:
            i, j = layout.free.index(u), layout.free.index(v)
            var = cov[i, i] + cov[j, j] - 2 * cov[i, j]
            split = (math.inf if u in undetermined or v in undetermined
                     else math.sqrt(max(float(var), 0.0)))
            anisotropy[base] = (values[u] - values[v], split)
    return errors, at_bound, anisotropy


def fit_model(data: Measurements, model: str = "three", backend: str = "reference",
              shadowing: str = "vgroove", dd_distribution: str = "beckmann",
              material: Optional[str] = None, init: Assignments = None, fix: Assignments = None,
              starts: Optional[int] = None, rel_uncertainty: float = 0.05,
              abs_uncertainty: float = 0.005, seed: int = 0, anisotropic: bool = False,
              distribution: str = "beckmann", objective: str = "auto",
              log_floor: Optional[float] = None, nk: Union[None, str, IndexTable] = None,
              progress: Optional[Callable[[FitProgress], None]] = None,
              start_rows: Optional[int] = START_ROWS,
              reciprocity: Union[bool, None, Reciprocity] = False) -> FitResult:
    """Least-squares fit of one model to measurements.

    Parameters
    ----------
    data : Measurements
        What to fit (:func:`mitsuba_pbrdf.measured.read`).
    model : str
        ``"three"`` or ``"two"`` (:data:`mitsuba_pbrdf.choices.MODELS`).
    backend : str
        ``"reference"`` (NumPy float64) or ``"drjit"`` (the plugin).
    shadowing, dd_distribution, distribution : str
        The model's shadowing and its lobes' distributions (``beckmann``, ``ggx``).
    material, nk : str or IndexTable, optional
        n, k at the data's wavelengths from a tabulated conductor (a name) or
        an index table (a file or an :class:`~mitsuba_pbrdf.measured.IndexTable`):
        the start of a polarized fit and **fixed** in a fit of unpolarized
        data (``m00`` alone cannot determine the index), unless ``init`` or
        ``fix`` name them.
    init, fix : dict or str, optional
        Starting and fixed values, {name: value} (``n``, ``k``, ``n@<nm>``,
        ``k@<nm>``, ``sigma``, ``ks``, ``kdd``, ``sigma_dd``, ``kid``) or
        ``"name=value,..."``.
    starts : int, optional
        The number of starting points (default: the initial values and the
        roughness grid of :mod:`.starts`); ``seed`` seeds the random ones.
    rel_uncertainty, abs_uncertainty : float
        The assumed uncertainties where the file gives none: ``rel |y| + abs max|y|``.
    anisotropic : bool
        Fit ``sigma_u`` and ``sigma_v`` instead of ``sigma`` (:mod:`.vector`);
        the result's ``anisotropy`` gives their difference and its uncertainty.
    objective : str
        The residual minimized (:data:`.objectives.OBJECTIVES`; ``"auto"``
        follows the data); ``log_floor`` its floor, 1/sr.
    progress : callable, optional
        Called with a :class:`FitProgress` as the fit goes.
    start_rows : int, optional
        Where the data hold more rows, the starts run on this many of them and
        the best is polished on all (:mod:`.subsample`; None: all rows).
    reciprocity : Reciprocity or None, optional
        The data's :func:`.diagnosis.reciprocity` where the caller has it
        (:func:`fit_models` computes it once for all its fits); False: compute it.

    Returns
    -------
    FitResult

    Raises
    ------
    ParameterError, ValueError
        A bad option, or more free parameters than measured values, before any work.

    Example
    -------
    >>> from mitsuba_pbrdf import fitting
    >>> data = fitting.synthetic_measurements({"sigma": 0.1, "n": 1.2, "k": 7.0})
    >>> r = fitting.fit_model(data, "two", material="Al", starts=1)
    >>> round(r.values["sigma"], 2)
    0.1
    """
    check_arguments(data, model, backend, starts, rel_uncertainty, abs_uncertainty,
                    start_rows)
    init, fix, notes = assignments_by_model((model,), init, fix)[model]
    objective, objective_reason = choose_objective(data, list(data.observed), objective)
    terms = make_terms(data, objective, rel_uncertainty, abs_uncertainty, log_floor)
    init, fix, index_note = with_index(data, init, fix, material, nk,
                                       absent_parameters(model, fix))
    wavelengths = data.wavelengths
    layout = ParameterVector(wavelengths, model, init, fix, anisotropic)
    n_obs = sum(len(t.y) for t in terms)
    if n_obs <= len(layout.free):
        raise ValueError(f"{n_obs} measured values cannot determine {len(layout.free)} "
                         f"free parameters")
    evaluator = BACKENDS[backend](data, layout, shadowing, dd_distribution, distribution)
    residuals = _Residuals(evaluator, terms, layout.free)

    lo, hi = layout.bounds()
    order = WidthOrder(layout, lo, hi)
    x0 = np.clip(layout.vector(), lo, hi)
    count = default_starts(layout, x0, lo, hi) if starts is None else int(starts)
    points = start_points(layout, x0, lo, hi, count, np.random.default_rng(seed))

    subsample = sample(data, terms, start_rows, seed)

    def report(start, evaluations, cost, best, finished, polish=False):
        if progress is not None:
            progress(FitProgress(model, distribution, start, len(points) + bool(subsample),
                                 evaluations, cost, best, finished, polish))

    t0 = time.perf_counter()
    tol = 1e-10 if backend == "reference" else 1e-7   # float32 residuals: looser tolerances
    evaluations = 0
    if subsample is None:
        best = _best_of_starts(residuals, order, points, tol, report)
    else:
        rows, sub_data, sub_terms = subsample
        sub_evaluator = BACKENDS[backend](sub_data, layout, shadowing, dd_distribution,
                                          distribution)
        chosen = _best_of_starts(_Residuals(sub_evaluator, sub_terms, layout.free), order,
                                 points, tol, report)
        evaluations = sub_evaluator.count
        best = _best_of_starts(residuals, order, [order.to_natural(chosen.x)], tol,
                               lambda s, *a: report(len(points) + 1, *a, polish=True))
    seconds = time.perf_counter() - t0

    x_best = order.to_natural(best.x)
    values = layout.unpack(x_best)
    chi2 = float(2 * best.cost)
    dof = n_obs - len(layout.free)
    formal, sd, undetermined, groups, cov = _uncertainties(
        data, terms, objective, evaluator, residuals, layout.free, x_best, chi2, dof, lo, hi,
        rel_uncertainty, abs_uncertainty)
    errors, at_bound, anisotropy = _stated(layout, order, best.x, x_best, values, sd,
                                           undetermined, cov, lo, hi, anisotropic)

    # the float64 lobes whatever the backend; for unpolarized data element 00
    # alone (the full Mueller form of 10^6 rows would take gigabytes)
    final = LobeModel(data, list(data.observed), shadowing, dd_distribution,
                      distribution).observables(values)
    resid, rms, rel, rms_ln = _residual_summary(data, final)
    result = FitResult(
        model=model, backend=backend, wavelengths=wavelengths, values=values, errors=errors,
        chi2=chi2, dof=dof, residuals=resid, rms=rms, relative_rms=rel, seconds=seconds,
        evaluations=evaluations + evaluator.count, success=bool(best.success),
        message=str(best.message), free=[layout.label(n) for n in layout.free],
        at_bound=at_bound, shadowing=shadowing, dd_distribution=dd_distribution,
        undetermined=[layout.label(n) for n in undetermined],
        correlated=[[layout.label(n) for n in g] for g in groups],
        fixed=[layout.label(n) for n in _all_names(len(wavelengths), layout.shared)
               if n not in layout.free],
        anisotropic=bool(anisotropic), distribution=distribution, anisotropy=anisotropy,
        objective=objective, objective_reason=objective_reason,
        objectives={t.name: t.objective for t in terms},
        log_floor=next((t.floor for t in terms if t.name == "m00"
                        and OBJECTIVES[t.objective].floored), None),
        index_note=index_note, starts=len(points), formal=formal,
        regions=regional_fit(data, final, terms), rms_ln=rms_ln,
        rel_uncertainty=rel_uncertainty, abs_uncertainty=abs_uncertainty,
        absent={p: why for p, why in layout.absent.items()
                if p in PER_WAVELENGTH or p in layout.shared},
        notes=notes, rows=len(data),
        start_rows=None if subsample is None else len(subsample[0]),
        reciprocity=reciprocity_of(data) if reciprocity is False else reciprocity)
    result.warnings = diagnose(result, data, material, result.reciprocity)
    return result


def _all_names(W, shared):
    return [f"{p}@{j}" for p in ("n", "k") for j in range(W)] + list(shared)


def fit_models(data: Measurements, models: Sequence[str] = ("three", "two"),
               distribution: str = "beckmann", dd_distribution: Optional[str] = None,
               **options) -> Dict[str, FitResult]:
    """:func:`fit_model` for each of ``models`` with the same options.

    Parameters
    ----------
    data : Measurements
        What to fit.
    models : sequence of str
        ``"three"`` and/or ``"two"``.
    distribution : str
        The specular lobe's: ``beckmann``, ``ggx`` or ``auto``, which fits each
        model with both and keeps the lower cost (the same objective, data and
        parameter count); the result's ``distribution_choice`` says what was compared.
    dd_distribution : str, optional
        The directional diffuse lobe's, by default the same as the specular lobe's.
    **options
        :func:`fit_model`'s other options.

    Returns
    -------
    dict
        Model name -> :class:`FitResult`, in the order of ``models``.

    Raises
    ------
    ParameterError, ValueError
        A bad option, before any work.

    Example
    -------
    >>> from mitsuba_pbrdf import fitting
    >>> data = fitting.synthetic_measurements({"sigma": 0.1, "n": 1.2, "k": 7.0})
    >>> sorted(fitting.fit_models(data, material="Al", starts=1))
    ['three', 'two']
    """
    candidates = DISTRIBUTIONS if distribution == "auto" else (distribution,)
    for d in candidates:
        if d not in DISTRIBUTIONS:
            raise ParameterError("distribution", f"must be auto or one of "
                                                 f"{', '.join(DISTRIBUTIONS)}, not {d!r}")
    shares = assignments_by_model(tuple(models), options.pop("init", None),
                                  options.pop("fix", None))
    out = {}
    options.setdefault("reciprocity", reciprocity_of(data))
    for m in models:
        init, fix, notes = shares[m]
        fits = [fit_model(data, model=m, distribution=d, init=init, fix=fix,
                          dd_distribution=d if dd_distribution is None else dd_distribution,
                          **options) for d in candidates]
        best = min(fits, key=lambda r: r.chi2)
        best.notes = notes + best.notes
        if len(fits) > 1:
            best.distribution_choice = (
                f"{best.distribution} kept: chi2 " + ", ".join(
                    f"{r.chi2:.4g} ({r.distribution})" for r in fits))
            best.seconds = sum(r.seconds for r in fits)
        out[m] = best
    return out
