"""Pictures of a fit to a ``.pbsdf`` table: measured versus fitted slices.

Top row: M00 (log scale) and DoLP (unpolarized light) against the signed
reflection angle in the plane of incidence (positive on the specular side)
for incidence angles 20, 45 and 70 deg; the table's values (dots) are read
with the emulation of ``measured_polarized``'s interpolation
(:mod:`mitsuba_pbrdf.measured.lookup`), the models' are lines. Bottom row: the
hemisphere of viewing directions for light at 45 deg (seen from above, light
on the left): M00 and DoLP of the table and of the three-component fit. All at
the table's middle wavelength.
"""

from __future__ import annotations

import numpy as np

from .. import reference as ref
from ..choices import MODELS, preferred
from ..measured.lookup import lookup
from ..measured.pbsdf import PbsdfTable
from .vector import SHARED

__all__ = ["plot_table_fit"]

INCIDENCE = (20.0, 45.0, 70.0)


def _direction(theta, phi):
    theta, phi = np.broadcast_arrays(np.radians(theta), np.radians(phi))
    return np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], -1)


def _model(r, wavelength_index, theta_i, phi_i, theta_r, phi_r):
    v = r.values
    return ref.pbrdf(*(np.radians(a) for a in (theta_i, phi_i, theta_r, phi_r)),
                     v["n"][wavelength_index], v["k"][wavelength_index],
                     shadowing=r.shadowing, dd_distribution=r.dd_distribution,
                     distribution=r.distribution,
                     **{name: v[name] for name in SHARED if name in v})


def plot_table_fit(table: PbsdfTable, results, path, title=None):
    """Write the figure (see the module docstring) to *path* (PNG)."""
    import matplotlib
    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    # the middle of the fitted wavelengths (all the table's, or those chosen):
    # j indexes the fit's n, k; the table is looked up at that wavelength
    fitted = next(iter(results.values())).wavelengths
    j = fitted.size // 2
    wavelength = float(fitted[j])
    fig = Figure(figsize=(13, 8.5))
    axes = fig.subplots(2, 3)
    colors = matplotlib.colormaps["tab10"]
    signed = np.linspace(-85.0, 85.0, 171)
    for c, ti in enumerate(INCIDENCE):
        tr = np.abs(signed)
        pr = np.where(signed >= 0, 180.0, 0.0)
        M = lookup(table, _direction(ti, 0.0), _direction(tr, pr), wavelength)
        for ax, q in zip(axes[0, :2], ("m00", "dolp")):
            y = M[:, 0, 0] if q == "m00" else ref.dop_unpolarized(M)
            ax.plot(signed[::3], y[::3], "o", ms=3, color=colors(c), label=f"table, θi = {ti:g}°")
            for name, r in results.items():
                F = _model(r, j, ti, 0.0, tr, pr)
                f = F[:, 0, 0] if q == "m00" else ref.dop_unpolarized(F)
                ax.plot(signed, f, MODELS[name].line_style, color=colors(c), lw=1.1,
                        label=f"{name}-component" if c == 0 else None)
    for ax, q in zip(axes[0, :2], ("M00 (1/sr)", "DoLP")):
        ax.set_xlabel("reflection angle θr (deg, + = specular side)")
        ax.set_title(f"{q}, in plane, {wavelength:g} nm")
        ax.legend(fontsize=7)
    axes[0, 0].set_yscale("log")
    axes[0, 1].set_ylim(0, 1)
    ax = axes[0, 2]
    for name, r in results.items():
        ax.bar([f"{name}\n{q}" for q in ("m00 rel", "dolp")],
               [r.relative_rms.get("m00", np.nan), _dolp_rms(r, table, j, wavelength)],
               alpha=0.7)
    ax.set_title("RMS residual (M00 relative; DoLP absolute)")
    _hemisphere(axes[1], table, preferred(results), j, wavelength)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)  # the format of path's extension, as plot_fit's
    return path


def _dolp_rms(r, table, j, wavelength):
    rng = np.random.default_rng(0)
    ti = rng.uniform(0, 75, 400)
    tr = rng.uniform(0, 75, 400)
    pr = rng.uniform(0, 360, 400)
    M = lookup(table, _direction(ti, 0.0), _direction(tr, pr), wavelength)
    F = _model(r, j, ti, 0.0, tr, pr)
    ok = M[:, 0, 0] > 1e-3 * M[:, 0, 0].max()
    return float(np.sqrt(np.mean((ref.dop_unpolarized(M) - ref.dop_unpolarized(F))[ok] ** 2)))


def _hemisphere(axes, table, r, j, wavelength, theta_i=45.0, size=81):
    x, y = np.meshgrid(np.linspace(-1, 1, size), np.linspace(-1, 1, size))
    inside = x * x + y * y < 0.985
    z = np.sqrt(np.clip(1 - x * x - y * y, 0, 1))
    V = np.stack([x, y, z], -1)
    M = lookup(table, _direction(theta_i, 180.0), V, wavelength)
    theta_r = np.degrees(np.arccos(np.clip(z, 0, 1)))
    F = _model(r, j, theta_i, 180.0, theta_r, np.degrees(np.arctan2(y, x)))
    top = max(np.nanmax(M[..., 0, 0][inside]), 1e-12)
    for ax, (label, data) in zip(axes, (("table", M), (f"{r.model}-component fit", F))):
        img = np.where(inside, np.log10(np.maximum(data[..., 0, 0], top * 1e-4) / top), np.nan)
        ax.imshow(img, origin="lower", extent=(-1, 1, -1, 1), cmap="magma", vmin=-4, vmax=0)
        ax.set_title(f"log10 M00 / max, {label}, θi = {theta_i:g}°", fontsize=9)
        ax.set_axis_off()
    ax = axes[2]
    d = np.where(inside, ref.dop_unpolarized(M) - ref.dop_unpolarized(F), np.nan)
    im = ax.imshow(d, origin="lower", extent=(-1, 1, -1, 1), cmap="RdBu_r", vmin=-0.1, vmax=0.1)
    ax.set_title("DoLP table − fit", fontsize=9)
    ax.set_axis_off()
    ax.figure.colorbar(im, ax=ax, fraction=0.046)
