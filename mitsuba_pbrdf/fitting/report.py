"""The fit's report (text, Markdown tables) and its plot (data with error
bars against each model's curves)."""

from __future__ import annotations

from typing import Dict, Optional

import numpy as np

from ..measured.measurements import Measurements
from .backends import weights
from .layout import MODELS, SHARED, TWO_COMPONENT_FIXED
from .observables import model_observables
from .solver import FitResult

__all__ = ["report", "plot_fit", "undetermined_warning"]


def _fmt(v, e):
    if np.isinf(e):
        return f"{v:.5g} (undetermined)"
    if not np.isfinite(e):
        return f"{v:.5g} (fixed)"
    return f"{v:.5g} +/- {e:.2g}"


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
    lines = [f"# pBRDF fit of {data.source}",
             f"{len(data)} measurements, {data.count()} values "
             f"({', '.join(f'{q}: {np.isfinite(y).sum()}' for q, y in data.observed.items())}); "
             f"wavelengths {', '.join(f'{w:g}' for w in data.wavelengths)} nm; "
             f"uncertainties {'given' if data.uncertainty else 'assumed'}"]
    if data.ignored_columns:
        lines.append(f"ignored columns: {', '.join(data.ignored_columns)}")
    for name, r in results.items():
        lines += ["", f"## {MODELS[r.model]}",
                  f"backend {r.backend}, shadowing {r.shadowing}, directional diffuse "
                  f"{r.dd_distribution}; {r.evaluations} model evaluations, {r.seconds:.2f} s; "
                  f"{'converged' if r.success else 'NOT converged'} ({r.message})"]
        header = "| parameter | fitted | " + ("true |" if truth else "")
        lines += ["", header, "|---|---|" + ("---|" if truth else "")]
        for p in ("n", "k"):
            for j, w in enumerate(r.wavelengths):
                t = ""
                if truth:
                    tv = np.broadcast_to(truth[p], r.wavelengths.shape)[j]
                    t = f" {tv:.5g} |"
                lines.append(f"| {p} ({w:g} nm) | {_fmt(r.values[p][j], r.errors[p][j])} |{t}")
        for p in SHARED:
            if r.model == "two" and p in TWO_COMPONENT_FIXED:
                continue
            t = f" {truth[p]:.5g} |" if truth else ""
            lines.append(f"| {p} | {_fmt(r.values[p], r.errors[p])} |{t}")
        if r.undetermined:
            lines.append("\n" + undetermined_warning(r))
        if r.at_bound:
            lines.append(f"\nat a bound (uncertainty not meaningful): {', '.join(r.at_bound)}")
        lines += ["", f"chi2 = {r.chi2:.4g} for {r.dof} degrees of freedom "
                      f"(reduced {r.reduced_chi2:.3g})"]
        for q in data.observed:
            rel = (f", relative RMS {100 * r.relative_rms[q]:.2f} %"
                   if q == "m00" and np.isfinite(r.relative_rms[q]) else "")
            lines.append(f"* {q}: RMS residual {r.rms[q]:.4g}{rel}")
    if len(results) > 1:
        lines += ["", "## Model comparison", "",
                  "| model | reduced chi2 | " + " | ".join(
                      f"RMS {q}" + (" (relative)" if q == "m00" else "") for q in data.observed)
                  + " |", "|---|---|" + "---|" * len(data.observed)]
        for r in results.values():
            cells = [(f"{100 * r.relative_rms[q]:.2f} %" if q == "m00" else f"{r.rms[q]:.4g}")
                     for q in data.observed]
            lines.append(f"| {r.model}-component | {r.reduced_chi2:.3g} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def _series(data):
    """Groups of rows to draw as curves: (label, rows, x, in-plane?)."""
    ti, pi_, tr, pr = data.theta_i, data.phi_i, data.theta_r, data.phi_r
    dphi = np.radians(pr - pi_)
    in_plane = np.abs(np.sin(dphi)) < 1e-6
    signed = np.where(np.cos(dphi) < 0, tr, -tr)     # + on the specular side
    groups = []
    for w in data.wavelengths:
        for t in np.unique(ti):
            rows = np.flatnonzero((data.wavelength == w) & (ti == t) & in_plane)
            if rows.size:
                rows = rows[np.argsort(signed[rows])]
                groups.append((f"{t:g} deg, {w:g} nm", rows, signed[rows], True))
    rest = np.flatnonzero(~in_plane)
    if rest.size:
        groups.append(("out of plane", rest, None, False))
    return groups


def plot_fit(data: Measurements, results: Dict[str, FitResult], path, title=None):
    """Data (with error bars) and each model's fit, one panel per quantity:
    in-plane measurements against the signed detector angle (positive on the
    specular side), one curve per incidence angle and wavelength;
    out-of-plane ones in a panel of model against data."""
    import matplotlib
    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    quantities = list(data.observed)
    groups = _series(data)
    has_oop = any(not g[3] for g in groups)
    panels = len(quantities) + (1 if has_oop else 0)
    ncols = min(panels, 6)                 # all 16 elements: rows of 6, not one strip
    nrows = -(-panels // ncols)
    fig = Figure(figsize=(5.0 * ncols, 4.2 * nrows))
    axes = fig.subplots(nrows, ncols, squeeze=False).ravel()
    for ax in axes[panels:]:
        ax.set_visible(False)
    names, _, unc, index = weights(data, 0.05, 0.005)
    unc_full = {}
    for q, u, i in zip(names, unc, index):
        full = np.full(len(data), np.nan)
        full[i] = u
        unc_full[q] = full
    styles = {"three": "-", "two": "--"}
    colors = matplotlib.colormaps["tab10"]
    for ax, q in zip(axes, quantities):
        for g, (label, rows, x, in_plane) in enumerate(g for g in groups if g[3]):
            y = data.observed[q][rows]
            ok = np.isfinite(y)
            ax.errorbar(x[ok], y[ok], yerr=unc_full[q][rows][ok], fmt="o", ms=3,
                        color=colors(g % 10), label=f"data {label}", alpha=0.8)
            for m, r in results.items():
                fit = model_observables(data, r.values, r.shadowing, r.dd_distribution, [q])[q][rows]
                ax.plot(x, fit, styles.get(r.model, "-"), color=colors(g % 10), lw=1.2,
                        label=f"{r.model}-component" if g == 0 else None)
        ax.set_xlabel("detector angle theta_r (deg, + = specular side)")
        ax.set_ylabel(q + (" (1/sr)" if q != "dolp" else ""))
        if q == "m00":
            ax.set_yscale("log")
        ax.set_title(q)
        ax.legend(fontsize=6)
    if has_oop:
        ax = axes[panels - 1]
        rows = next(g[1] for g in groups if not g[3])
        for m, r in results.items():
            for q in quantities:
                fit = model_observables(data, r.values, r.shadowing, r.dd_distribution, [q])[q][rows]
                y = data.observed[q][rows]
                scale = np.nanmax(np.abs(y)) or 1.0
                ax.plot(y / scale, fit / scale, "o" if r.model == "three" else "x", ms=3,
                        label=f"{q}, {r.model}-component")
        ax.plot([0, 1], [0, 1], "k:", lw=0.8)
        ax.set_xlabel("data / max")
        ax.set_ylabel("model / max")
        ax.set_title("out-of-plane measurements")
        ax.legend(fontsize=6)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    return path
