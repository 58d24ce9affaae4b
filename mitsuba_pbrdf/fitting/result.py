"""What a fit gives: :class:`FitResult` (its JSON: :meth:`FitResult.as_dict`)
and the :class:`FitProgress` it reports as it goes (:mod:`.solver`)."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Dict, List, Optional

import numpy as np

__all__ = ["FitResult", "FitProgress"]


@dataclass
class FitResult:
    """Outcome of :func:`.solver.fit_model`. ``values`` / ``errors``: ``n``, ``k``
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
    objective: str = "linear"
    objective_reason: str = ""
    objectives: Dict[str, str] = field(default_factory=dict)   # quantity -> its residuals' objective
    log_floor: Optional[float] = None     # 1/sr, the log and relative objectives' floor
    index_note: str = ""                  # why n, k are fixed, where they are
    starts: int = 1
    formal: bool = True                   # uncertainties scaled by the reduced chi-square
    regions: List = field(default_factory=list)     # :class:`.diagnosis.Region` rows
    warnings: List[str] = field(default_factory=list)
    distribution_choice: str = ""          # distribution="auto": what was compared
    rms_ln: float = math.nan              # RMS of ln(model / data) of m00 where both > 0
    rel_uncertainty: float = 0.05         # the assumed uncertainties (where the file gives none)
    abs_uncertainty: float = 0.005
    #: parameters the model lacks -> why (:func:`.layout.absent_parameters`): not reported
    absent: Dict[str, str] = field(default_factory=dict)
    notes: List[str] = field(default_factory=list)      # init/fix values not used, and why
    rows: int = 0                         # rows of the data
    start_rows: Optional[int] = None      # rows the starts ran on (:mod:`.subsample`); None: all
    reciprocity: Optional[object] = None  # the data's :class:`.diagnosis.Reciprocity`, if pairs

    @property
    def start_note(self) -> str:
        """Where the starts ran, e.g. "7 starts on 20,000 of 200,000 rows, the best polished on all"."""
        if self.start_rows is None:
            return f"{self.starts} starts on all {self.rows:,} rows"
        return (f"{self.starts} starts on {self.start_rows:,} of {self.rows:,} rows, "
                f"the best polished on all")

    @property
    def reduced_chi2(self):
        return self.chi2 / max(self.dof, 1)

    def error_reason(self, label, error) -> str:
        """Why the parameter *label* (``kid``, ``n(633 nm)``) has no uncertainty
        to state ("fixed", "undetermined", "at a bound"), or "" where it has one.
        At a bound the curvature's +/- is not meaningful: the optimum is a
        corner, not a minimum (the lobes' order at its bound, sigma_dd = sigma,
        puts sigma_dd there)."""
        if not np.isfinite(error):
            return "undetermined" if np.isinf(error) else "fixed"
        order = label == "sigma_dd" and any(b.startswith("sigma_dd = sigma") for b in self.at_bound)
        return "at a bound" if label in self.at_bound or order else ""

    def _labelled_errors(self):
        """(label, key, index or None, error) of every parameter."""
        for p, e in self.errors.items():
            if isinstance(e, np.ndarray):
                for j, w in enumerate(self.wavelengths):
                    yield f"{p}({w:g} nm)", p, j, float(e[j])
            else:
                yield p, p, None, float(e)

    def as_dict(self) -> Dict:
        """JSON-ready, by :func:`dataclasses.asdict`: the fields but those of
        :data:`_NOT_SAVED`, two renamed (:data:`_SAVED_AS`), the derived
        ``reduced_chi2`` and ``start_note``; a number that is not finite is
        ``None`` (null). An error that is not stated (undetermined, fixed, at a
        bound) is null, its reason in ``error_reasons`` by label."""
        out = {_SAVED_AS.get(k, k): _jsonable(v) for k, v in asdict(self).items()
               if k not in _NOT_SAVED}
        reasons = {}
        for label, key, j, e in self._labelled_errors():
            reasons[label] = self.error_reason(label, e)
            if reasons[label] == "at a bound":
                if j is None:
                    out["errors"][key] = None
                else:
                    out["errors"][key][j] = None
        out["error_reasons"] = {k: v for k, v in reasons.items() if v}
        out["reduced_chi2"], out["start_note"] = self.reduced_chi2, self.start_note
        out["anisotropy"] = {base: {"difference": d, "uncertainty": _jsonable(float(sd))}
                             for base, (d, sd) in self.anisotropy.items()}
        out["reciprocity"] = self.reciprocity.as_dict() if self.reciprocity else None
        out["regions"] = [r.as_dict() for r in self.regions]
        return out


#: :class:`FitResult` fields the JSON leaves out: the per-row residuals (the
#: data's size), the free labels (``fixed`` and ``values`` tell them) and the
#: assumed uncertainties (the command's options)
_NOT_SAVED = ("residuals", "free", "rel_uncertainty", "abs_uncertainty")
#: fields saved under a name that says more
_SAVED_AS = {"formal": "formal_uncertainties", "rms_ln": "rms_ln_m00"}


def _jsonable(v):
    """*v* with arrays as lists and numbers that are not finite as None."""
    if isinstance(v, np.ndarray):
        return [_jsonable(float(a)) for a in v]
    if isinstance(v, dict):
        return {k: _jsonable(a) for k, a in v.items()}
    if isinstance(v, (list, tuple)):
        return [_jsonable(a) for a in v]
    return None if isinstance(v, float) and not math.isfinite(v) else v


@dataclass
class FitProgress:
    """What :func:`.solver.fit_model` reports to its ``progress`` callback: after each
    start (``finished`` True) and every :data:`.solver.PROGRESS_EVERY` residual
    evaluations within one. ``cost`` is half the sum of squared residuals."""
    model: str
    distribution: str
    start: int            # 1-based
    starts: int
    evaluations: int      # residual evaluations of this start
    cost: float
    best: float           # lowest cost of the finished starts (inf before the first)
    finished: bool
    polish: bool = False  # the best start's polish on all rows (:mod:`.subsample`)
