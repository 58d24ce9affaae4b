"""What a fit minimizes: the residual of each measured value, by objective.

Reflectance of metals spans decades (a near-mirror spike of hundreds per
steradian over a tail of thousandths), and which residual a fit minimizes
decides which part of that range it reproduces. The objectives apply to the
unpolarized BRDF ``m00``; the other Mueller elements and DoLP, signed or
bounded, keep linear residuals with their uncertainties in every objective.
``y`` is the measured value, ``m`` the model's, ``u`` the value's standard
uncertainty (given in the file, or assumed: ``rel |y| + abs max|y|``), ``s``
the relative uncertainty (``u / y`` where given, else ``rel``):

* ``linear``: ``(m - y) / u``. The likelihood of Gaussian noise of the
  measurement's own uncertainties; with assumed ones (a few per cent of the
  largest value) everything far below the peak counts for nothing.
* ``log``: ``ln((m + f) / (y + f)) / s``, with a stated floor ``f`` (default
  1 % of the median positive ``y``, or where the file's uncertainties stop
  being relative if higher, :func:`log_floor`; ``y < 0`` counts as 0; with
  given ones ``s = u / (|y| + f)``, the spread of ``ln(y + f)``). The likelihood
  of multiplicative (log-normal) noise: every decade weighs the same, so the
  spike and the tail are both fitted. BRDF fitting poses it this way when data
  span decades (e.g. Ngan, Durand and Matusik 2005, who found linear errors
  dominated by the peak; Löw et al. 2012).
* ``relative``: ``(m - y) / (s max(y, f))``, the first-order form of ``log``:
  symmetric only for small errors (a model too low by any factor costs at most
  ``1/s``, too high costs without bound), so it biases a fit low.
* ``cosine``: ``(m - y) cos(theta_i) / (abs max(y cos theta_i))``: uniform
  weights on the reflected radiance per unit irradiance, ``rho cos theta_i``,
  the quantity a renderer integrates (the cosine-weighted error of Ngan et al.
  2005). A weighting, not a noise model: its parameter uncertainties are formal.
* ``log-cosine``: ``[ln(1 + m cos theta_i) - ln(1 + y cos theta_i)] / s``
  (Löw, Kronander, Ynnerman and Unger 2012): logarithmic above
  ``rho cos theta_i ~ 1``, linear below it, so the peak is compressed and the
  tail of a metal (``rho << 1``) weighs little. Also a weighting: formal
  uncertainties.

``auto`` (the default) follows the data: ``linear`` when the file gives the
uncertainties of every fitted quantity, ``log`` when ``m00`` spans more than
two decades, else ``linear`` with assumed uncertainties.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Optional, Tuple

import numpy as np

from ..errors import ParameterError

__all__ = ["Objective", "OBJECTIVES", "Term", "make_terms", "choose_objective",
           "objective_of", "log_floor", "noise_crossover", "decades"]


@dataclass(frozen=True)
class Objective:
    """One objective of the module docstring: its *name* (``--objective``), a
    one-line *summary* for reports and ``--help``, the observables it shapes
    (*applies_to*; None: all, the others keep linear residuals), whether it is
    a noise model's *likelihood* (else a weighting, whose parameter
    uncertainties are formal), whether its residuals are *relative* (scaled
    by ``s``: a relative uncertainty is needed, and the plot's band is
    ``y exp(+-s)``), whether the fit reports its *floor*, and its
    *residual* and *derivative* (d residual / d model) of a :class:`Term` at
    model values ``m``."""
    name: str
    summary: str
    applies_to: Optional[Tuple[str, ...]]
    likelihood: bool
    relative: bool
    floored: bool
    residual: Callable[["Term", np.ndarray], np.ndarray]
    derivative: Callable[["Term", np.ndarray], np.ndarray]


def _positive(m):
    return np.maximum(m, 0.0)


#: Objective name -> :class:`Objective`, in the order ``--help`` lists them.
OBJECTIVES = {o.name: o for o in (
    Objective("linear", "(model - data) / uncertainty", None, True, False, False,
              lambda t, m: (m - t.y) / t.u,
              lambda t, m: 1.0 / t.u),
    Objective("log", "ln((model + f) / (data + f)) / relative uncertainty", ("m00",),
              True, True, True,
              lambda t, m: np.log((_positive(m) + t.floor) / (_positive(t.y) + t.floor)) / t.s,
              lambda t, m: np.where(m > 0, 1.0 / (_positive(m) + t.floor), 0.0) / t.s),
    Objective("relative", "(model - data) / (relative uncertainty x data)", ("m00",),
              True, True, True,
              lambda t, m: (m - t.y) / (t.s * np.maximum(t.y, t.floor)),
              lambda t, m: 1.0 / (t.s * np.maximum(t.y, t.floor))),
    Objective("cosine", "(model - data) cos(theta_i), uniform weights (Ngan et al. 2005)",
              ("m00",), False, False, False,
              lambda t, m: (m - t.y) * t.cos_i / t.scale,
              lambda t, m: t.cos_i / t.scale),
    Objective("log-cosine",
              "ln(1 + model cos(theta_i)) - ln(1 + data cos(theta_i)) (Löw et al. 2012)",
              ("m00",), False, True, False,
              lambda t, m: (np.log1p(_positive(m) * t.cos_i)
                            - np.log1p(_positive(t.y) * t.cos_i)) / t.s,
              lambda t, m: np.where(m > 0, t.cos_i / (1.0 + _positive(m) * t.cos_i), 0.0) / t.s),
)}


def objective_of(objective, quantity) -> str:
    """The objective that the residuals of *quantity* follow under *objective*."""
    applies = OBJECTIVES[objective].applies_to
    return objective if applies is None or quantity in applies else "linear"


#: m00 spanning more decades than this gets the ``log`` objective under ``auto``.
AUTO_DECADES = 2.0


#: The ``log`` objective's default floor, as a fraction of the median positive m00.
FLOOR_FRACTION = 0.01


def log_floor(y, floor: Optional[float] = None, u=None) -> float:
    """The ``log`` objective's floor f (1/sr): *floor* when given, else
    :data:`FLOOR_FRACTION` of the median positive value (1e-12 where none is),
    raised to :func:`noise_crossover` of the stated uncertainties *u* where
    the file gives them. A robust level, not the minimum: the smallest values
    of a campaign are its detector's noise, and a floor under them gave them
    the weight of the reflection itself (the fit then bends the model toward
    the noise)."""
    if floor is not None:
        return float(floor)
    positive = y[np.isfinite(y) & (y > 0)]
    f = FLOOR_FRACTION * float(np.median(positive)) if positive.size else 1e-12
    return max(f, noise_crossover(y, u)) if u is not None else f


def noise_crossover(y, u) -> float:
    """Where stated uncertainties *u* of values *y* stop being relative: b / a
    of the fit ``u ~ a |y| + b`` (a, b >= 0, least squares in u's relative
    error), 0 where either part is absent. ``ln(y + b/a) / a`` is the
    transform that gives such noise the same spread at every level, so with
    that floor the log objective is the likelihood of the stated noise at all
    values. A lower floor takes values whose noise is absolute (u a sizeable
    fraction of y) as log-normal: the log of a noisy value is biased low and
    u / y weighs the values that noise raised most, and a fit through data
    whose tail is mostly noise recovered the ideal diffuse weight 8 standard
    uncertainties off."""
    from scipy.optimize import nnls

    ok = np.isfinite(y) & np.isfinite(u) & (u > 0)
    if ok.sum() < 2:
        return 0.0
    A = np.column_stack([np.abs(y[ok]) / u[ok], 1.0 / u[ok]])
    (a, b), _ = nnls(A, np.ones(ok.sum()))
    return float(b / a) if a > 0 and b > 0 else 0.0


def decades(y) -> float:
    """How many decades the positive values of *y* span (0 if fewer than 2)."""
    positive = y[np.isfinite(y) & (y > 0)]
    return float(np.log10(positive.max() / positive.min())) if positive.size > 1 else 0.0


def choose_objective(data, names, requested="auto"):
    """``(objective, reason)`` for fitting the quantities *names* of *data*."""
    if requested != "auto":
        if requested not in OBJECTIVES:
            raise ValueError(f"objective must be auto or one of {', '.join(OBJECTIVES)}, "
                             f"not {requested!r}")
        if all(objective_of(requested, q) != requested for q in names):
            raise ParameterError("objective", (
                f"{requested} applies to {', '.join(OBJECTIVES[requested].applies_to)}, "
                f"which this fit does not measure ({', '.join(names)}: linear residuals); "
                f"give auto or linear"))
        return requested, "as requested"
    if "m00" not in names:
        return "linear", "no m00 is fitted (the other quantities are always linear)"
    if all(q in data.uncertainty for q in names):
        return "linear", "the file gives the uncertainty of every fitted value"
    span = decades(data.observed["m00"])
    if span > AUTO_DECADES:
        return "log", (f"m00 spans {span:.1f} decades and the file gives no uncertainties: "
                       f"a linear objective with assumed ones would weigh only the largest values")
    return "linear", (f"m00 spans {span:.1f} decades (at most {AUTO_DECADES:g}): linear with "
                      f"assumed uncertainties")


@dataclass
class Term:
    """The residuals of one measured quantity under an objective: the ``rows``
    of the data that measure it, values ``y``, uncertainties ``u``, relative
    uncertainties ``s``, the cosine of the incidence angle, and for ``m00`` the
    floor ``f`` of the logarithmic objectives."""
    name: str
    objective: str            # the objective this term follows ("linear" off m00)
    rows: np.ndarray
    y: np.ndarray
    u: np.ndarray
    s: np.ndarray
    cos_i: np.ndarray
    floor: float = 0.0
    scale: float = 1.0        # cosine: abs x max(y cos theta_i)

    def residuals(self, m):
        return OBJECTIVES[self.objective].residual(self, m)

    def derivative(self, m):
        """d residual / d model value, per value."""
        return OBJECTIVES[self.objective].derivative(self, m)


def make_terms(data, objective, rel, abs_, floor=None):
    """The :class:`Term` of each observed quantity of *data* under *objective*
    (``m00``; the others linear), with the assumed uncertainties ``rel |y| +
    abs max|y|`` where the file gives none (:func:`.backends.weights`)."""
    from .backends import weights

    if objective not in OBJECTIVES:
        raise ValueError(f"objective must be one of {', '.join(OBJECTIVES)}, not {objective!r}")
    if floor is not None and not (math.isfinite(floor) and floor > 0):
        raise ValueError(f"log_floor must be a finite number > 0 (1/sr), got {floor!r}")
    cos_i = np.cos(np.radians(data.theta_i))
    terms = []
    for q, y, u, rows in zip(*weights(data, rel, abs_)):
        kind = objective_of(objective, q)
        stated = q in data.uncertainty
        f = log_floor(y, floor, u if stated and kind == "log" else None) if q == "m00" else 0.0
        if stated:
            # the spread of ln(y + f) is u / (|y| + f); relative: u / max(|y|, f)
            s = (u / (np.abs(y) + f) if kind == "log"
                 else u / np.maximum(np.abs(y), max(f, 1e-300)))
        else:
            if OBJECTIVES[kind].relative and not rel > 0:
                raise ValueError(f"the {kind} objective needs a relative uncertainty > 0 "
                                 f"(rel_uncertainty, --rel-uncertainty) where the file gives none")
            s = np.full(len(y), float(rel))
        term = Term(q, kind, rows, y, u, s, cos_i[rows], f)
        if kind == "cosine":
            if not abs_ > 0:
                raise ValueError("the cosine objective needs an absolute uncertainty > 0 "
                                 "(abs_uncertainty, --abs-uncertainty)")
            term.scale = abs_ * float(np.max(np.abs(y) * term.cos_i))
        terms.append(term)
    return terms
