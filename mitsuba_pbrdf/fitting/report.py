"""The fit's text report (parameters, chi-square, regions, warnings, Markdown
tables); its picture is :mod:`.plots`."""

from __future__ import annotations

from typing import Dict, List, Optional

import numpy as np

from ..measured.measurements import Measurements
from ..choices import MODELS
from .vector import ANISOTROPIC, SHARED
from .objectives import OBJECTIVES
from .result import FitResult

__all__ = ["report", "undetermined_warning", "anisotropy_line"]


def _fmt(r, label, v, e):
    """The value of parameter *label* of fit *r*, with its +/- where it has one."""
    reason = r.error_reason(label, e)
    if reason:
        return f"{v:.5g} ({reason}{': no uncertainty' if reason == 'at a bound' else ''})"
    return f"{v:.5g} +/- {e:.2g}"


def _num(v, spec=".3g"):
    return format(v, spec) if np.isfinite(v) else "–"


def undetermined_warning(r: FitResult) -> str:
    """The warning for parameters the data leave undetermined (empty if none)."""
    if not r.undetermined:
        return ""
    groups = "; ".join("{" + ", ".join(g) + "}" for g in r.correlated)
    return (f"warning: {r.model}-component fit: the data leave {', '.join(r.undetermined)} "
            f"undetermined (no uncertainty given); parameters that move together: {groups}")


def report(data: Measurements, results: Dict[str, FitResult], truth: Optional[Dict] = None) -> str:
    """Text report: the data, then per model the parameters with standard
    uncertainties, chi-square and the RMS residual of each quantity, then the
    comparison of the models' errors."""
    lines = _data_lines(data, results)
    for r in results.values():
        lines += (_fit_lines(r) + _parameter_table(r, truth) + _verdict_lines(r)
                  + _residual_lines(data, r))
    if len(results) > 1:
        lines += _comparison(data, results)
    return "\n".join(lines) + "\n"


def _data_lines(data, results) -> List[str]:
    """The report's head: what was measured, and the reciprocity of its swapped pairs."""
    lines = [f"# pBRDF fit of {data.source}",
             f"{len(data)} measurements, {data.count()} values "
             f"({', '.join(f'{q}: {np.isfinite(y).sum()}' for q, y in data.observed.items())}); "
             f"wavelengths {', '.join(f'{w:g}' for w in data.wavelengths)} nm; "
             f"uncertainties {'given' if data.uncertainty else 'assumed'}"]
    if data.ignored_columns:
        lines.append(f"ignored columns: {', '.join(data.ignored_columns)}")
    swapped = next((r.reciprocity for r in results.values() if r.reciprocity), None)
    if swapped is not None:
        lines.append(swapped.line())
    return lines


def _fit_lines(r: FitResult) -> List[str]:
    """A fit's heading (its model's title), how it ran, its objective and its notes."""
    floor = f" (floor f = {r.log_floor:.3g} 1/sr)" if r.log_floor is not None else ""
    lines = ["", f"## {MODELS[r.model].title}",
             f"backend {r.backend}, shadowing {r.shadowing}, specular {r.distribution}"
             f"{' (anisotropic)' if r.anisotropic else ''}, directional diffuse "
             f"{r.dd_distribution}; {r.start_note}; {r.evaluations} model evaluations, "
             f"{r.seconds:.2f} s; {'converged' if r.success else 'NOT converged'} "
             f"({r.message})",
             f"objective: {r.objective}{floor}, {OBJECTIVES[r.objective].summary}: "
             f"{r.objective_reason}; per observable: "
             + ", ".join(f"{q} {o}" for q, o in r.objectives.items())]
    if r.distribution_choice:
        lines.append(f"distribution: {r.distribution_choice}")
    if r.index_note:
        lines.append(r.index_note)
    lines += r.notes
    off = {}
    for p, why in r.absent.items():          # what the model itself fixes: its title says
        if p not in MODELS[r.model].fixed:
            off.setdefault(why, []).append(p)
    return lines + [f"not in this model: {', '.join(ps)} ({why})" for why, ps in off.items()]


def _parameter_table(r: FitResult, truth: Optional[Dict]) -> List[str]:
    """The fitted parameters with their uncertainties (and the true values, given *truth*)."""
    header = "| parameter | fitted | " + ("true |" if truth else "")
    lines = ["", header, "|---|---|" + ("---|" if truth else "")]
    for p in ("n", "k"):
        for j, w in enumerate(r.wavelengths if p not in r.absent else ()):
            t = ""
            if truth:
                tv = np.broadcast_to(truth[p], r.wavelengths.shape)[j]
                t = f" {tv:.5g} |"
            lines.append(f"| {p} ({w:g} nm) | "
                         f"{_fmt(r, f'{p}({w:g} nm)', r.values[p][j], r.errors[p][j])} |{t}")
    for p in SHARED:
        if p not in r.values or p in r.absent:
            continue
        t = f" {truth[p]:.5g} |" if truth else ""
        lines.append(f"| {p} | {_fmt(r, p, r.values[p], r.errors[p])} |{t}")
    return lines


def _verdict_lines(r: FitResult) -> List[str]:
    """What the data resolve: anisotropy, undetermined parameters, parameters at a bound."""
    lines = ["\n" + anisotropy_line(base, difference, sd)
             for base, (difference, sd) in r.anisotropy.items()]
    if r.undetermined:
        lines.append("\n" + undetermined_warning(r))
    if r.at_bound:
        lines.append(f"\nat a bound (uncertainty not meaningful): {', '.join(r.at_bound)}")
    return lines


def _residual_lines(data, r: FitResult) -> List[str]:
    """Chi-square, the RMS residual per quantity, the regions' table and the warnings."""
    lines = ["", f"chi2 = {r.chi2:.4g} for {r.dof} degrees of freedom "
                 f"(reduced {r.reduced_chi2:.3g}; {r.objective} objective)"]
    for q in data.observed:
        rel = (f", relative RMS {100 * r.relative_rms[q]:.2f} %"
               if q == "m00" and np.isfinite(r.relative_rms[q]) else "")
        ln = (f", RMS ln(model/data) {r.rms_ln:.3g}"
              if q == "m00" and np.isfinite(r.rms_ln) else "")
        lines.append(f"* {q}: RMS residual {r.rms[q]:.4g}{rel}{ln}")
    if r.regions:
        lines += ["", "| region (exclusive: each value in the first that applies, in this "
                      "order) | values | RMS ln(model/data) m00 | mean ln(model/data) m00 "
                      "| chi2 per value |", "|---|---|---|---|---|"]
        for g in r.regions:
            lines.append(f"| {g.label} | {g.values} | {_num(g.rms_ln)} | "
                         f"{_num(g.mean_ln, '+.3g')} | {_num(g.chi2_per_value)} |")
    return lines + ["\n" + w for w in r.warnings]


def _comparison(data, results) -> List[str]:
    """The models' reduced chi-square and RMS residuals side by side."""
    ln = "m00" in data.observed
    lines = ["", "## Model comparison", "",
             "| model | reduced chi2 | " + ("RMS ln(model/data) m00 | " if ln else "")
             + " | ".join(f"RMS {q}" + (" (relative)" if q == "m00" else "")
                          for q in data.observed)
             + " |", "|---|---|" + ("---|" if ln else "") + "---|" * len(data.observed)]
    for r in results.values():
        cells = [(f"{100 * r.relative_rms[q]:.2f} %" if q == "m00" else f"{r.rms[q]:.4g}")
                 for q in data.observed]
        lines.append(f"| {r.model}-component | {r.reduced_chi2:.3g} | "
                     + (f"{_num(r.rms_ln)} | " if ln else "") + " | ".join(cells) + " |")
    return lines


def anisotropy_line(base, difference, sd):
    """What an anisotropic fit says of the split of *base* into its
    refinements: their difference with its standard uncertainty, and whether
    the data resolve it (more than 3 standard uncertainties from 0)."""
    u, v = ANISOTROPIC[base]
    if not np.isfinite(sd):
        return (f"anisotropy: {u} - {v} = {difference:.4g}, undetermined: the measurements' "
                f"azimuths do not resolve {u} and {v}")
    verdict = ("resolved: the surface is anisotropic" if abs(difference) > 3 * sd else
               "not resolved: consistent with an isotropic surface")
    return (f"anisotropy: {u} - {v} = {difference:.4g} +/- {sd:.2g} "
            f"({abs(difference) / sd:.1f} standard uncertainties), {verdict}")
