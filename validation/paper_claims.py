"""Study 1: the paper's claims as plots, three models side by side.

    python validation/paper_claims.py        (-> paper_claims.md, figures/paper_*.png)

In-plane pBRDF of aluminium and copper at 632.8 nm (n + ik from Mitsuba's
tables) versus the reflection angle, at incidence angles 20, 40 and 60 deg, for

* **Priest-Germer** (P-G): the specular microfacet lobe alone, no shadowing
  (``shadowing="none"`` in the reference evaluator);
* **two-component** (Hyde et al. 2009): the same specular lobe with V-groove
  shadowing plus a Lambertian lobe ``kd / pi``;
* **three-component** (this model, the paper's): specular + directional diffuse
  + ideal diffuse, V-groove shadowing.

The curves come from the float64 reference evaluator (``mitsuba_pbrdf.reference``);
the plugin is overlaid as markers for the models it implements (two- and
three-component) and the largest plugin-vs-reference difference is tabulated.

The model parameters below are illustrative (the paper's fitted values are not
in the text we have). The two-component model's Lambertian weight is chosen so
that its diffuse albedo equals the three-component model's total diffuse albedo
at normal incidence: both models reflect the same diffuse energy there and
differ only in how they distribute it.

Sign conventions: reflection angle theta_r > 0 on the forward (specular) side of
the normal, theta_r < 0 on the side of the source; Stokes vectors in the global
s/p frames (S1 = I_s - I_p), see ``reference.py``.
"""

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from validation import common  # noqa: E402
from mitsuba_pbrdf import reference  # noqa: E402

WAVELENGTH = 632.8                   # nm (HeNe line, a usual pBRDF measurement wavelength)
INCIDENCE = (20.0, 40.0, 60.0)       # deg
#: Illustrative three-component parameters per metal (RMS slopes, weights).
METALS = {
    "Al": dict(sigma=0.15, kdd=0.12, sigma_dd=0.45, kid=0.02),
    "Cu": dict(sigma=0.20, kdd=0.15, sigma_dd=0.55, kid=0.04),
}
MODELS = ("Priest-Germer", "two-component", "three-component")
COLORS = {"Priest-Germer": "tab:red", "two-component": "tab:blue", "three-component": "k"}
PLUGIN_MARKS = np.linspace(-85, 85, 34)    # deg, avoiding theta_r = 0 (see figure_in_plane)
STYLES = {"Priest-Germer": "--", "two-component": "-.", "three-component": "-"}


def ior(metal):
    n, k = reference.conductor_ior(metal, WAVELENGTH)
    return float(n), float(k)


def dd_albedo_normal(sigma_dd, shadowing="vgroove", m=400):
    """Directional-hemispherical albedo of the directional diffuse lobe at
    normal incidence, by Gauss-Legendre quadrature over (theta_r) (the lobe is
    rotationally symmetric there): int fdd cos dw = 2 pi int fdd cos sin dtheta."""
    x, w = np.polynomial.legendre.leggauss(m)
    theta = 0.25 * np.pi * (x + 1.0)              # [0, pi/2]
    f = reference.directional_diffuse(0.0, 0.0, theta, np.pi, sigma_dd, shadowing)
    return float(np.sum(2 * np.pi * f * np.cos(theta) * np.sin(theta) * w) * 0.25 * np.pi)


def model_parameters(metal, model):
    """Keyword arguments of ``reference.pbrdf`` for one of MODELS."""
    p = METALS[metal]
    n, k = ior(metal)
    base = dict(n=n, k=k, sigma=p["sigma"], ks=1.0, kdd=0.0, sigma_dd=p["sigma_dd"], kid=0.0)
    if model == "Priest-Germer":
        return dict(base, shadowing="none")
    if model == "two-component":
        kd = p["kid"] + p["kdd"] * dd_albedo_normal(p["sigma_dd"])
        return dict(base, kid=kd, shadowing="vgroove")
    return dict(base, kdd=p["kdd"], kid=p["kid"], shadowing="vgroove")


def in_plane(metal, model, theta_i_deg, theta_r_deg):
    """Reference Mueller BRDF (n, 4, 4), 1/sr, in the plane of incidence.
    A negative reflection angle is the source side (the reference maps a
    negative zenith angle to phi + pi)."""
    ti = np.radians(theta_i_deg)
    tr = np.radians(np.asarray(theta_r_deg, dtype=np.float64))
    return reference.pbrdf(ti, 0.0, tr, np.pi, **model_parameters(metal, model))


def plugin_in_plane(metal, model, theta_i_deg, theta_r_deg):
    """The same through the plugin (float32), in the reference's frames."""
    import mitsuba as mi
    from mitsuba_pbrdf import frames

    kw = model_parameters(metal, model)
    bsdf = mi.load_dict({"type": "pbrdf", "material": metal, "sigma": kw["sigma"],
                         "kdd": kw["kdd"], "sigma_dd": kw["sigma_dd"], "kid": kw["kid"],
                         "shadowing": kw["shadowing"]})
    ti = np.radians(theta_i_deg)
    tr = np.radians(np.asarray(theta_r_deg, dtype=np.float64))
    to_light = np.tile([np.sin(ti), 0.0, np.cos(ti)], (tr.size, 1))
    to_viewer = np.stack([-np.sin(tr), np.zeros_like(tr), np.cos(tr)], axis=1)
    return frames.eval_global(bsdf, to_viewer, to_light, (WAVELENGTH,) * 4)[:, 0]


def dop_unpolarized(M):
    return np.sqrt(np.sum(M[..., 1:, 0] ** 2, axis=-1)) / M[..., 0, 0]


# ---------------------------------------------------------------------------
# Measurements
# ---------------------------------------------------------------------------

def grazing_growth(metal, theta_i_deg=40.0, cos_r=(1e-1, 1e-2, 1e-3, 1e-4, 1e-6)):
    """M00 at the forward grazing end of the plane of incidence, per model:
    {model: array over cos_r}. P-G grows like 1/cos(theta_r); models with
    shadowing tend to a finite limit."""
    theta_r = np.degrees(np.arccos(np.asarray(cos_r)))
    return {model: in_plane(metal, model, theta_i_deg, theta_r)[:, 0, 0] for model in MODELS}


def peak_dop(metal, model, theta_i_deg):
    """DOP of unpolarized light reflected into the mirror direction."""
    return float(dop_unpolarized(in_plane(metal, model, theta_i_deg, [theta_i_deg]))[0])


def plugin_deviation(metal, theta_r_deg):
    """max over incidence angles and models (two-, three-component) of
    max_ij |plugin - reference| / M00: the plugin draws the same curves."""
    worst = 0.0
    for model in MODELS[1:]:
        for ti in INCIDENCE:
            R = in_plane(metal, model, ti, theta_r_deg)
            P = plugin_in_plane(metal, model, ti, theta_r_deg)
            worst = max(worst, float(np.max(np.abs(P - R) / R[:, :1, :1])))
    return worst


# ---------------------------------------------------------------------------
# Figures
# ---------------------------------------------------------------------------

def figure_in_plane(metal, plugin_points=True):
    plt = common.pyplot()
    # An even count keeps theta_r = 0 out: at exact normal exit the output s axis is by
    # convention the surface x axis, a 90 deg jump of the frame (S1, S2 change sign).
    theta_r = np.linspace(-89.95, 89.95, 1800)
    marks = PLUGIN_MARKS
    rows = ("M00 (1/sr)", "M01 / M00", "M22 / M00", "M33 / M00", "DOP (unpolarized in)")
    fig, axes = plt.subplots(len(rows), len(INCIDENCE), figsize=(11, 11.5), sharex=True)
    for col, ti in enumerate(INCIDENCE):
        for model in MODELS:
            M = in_plane(metal, model, ti, theta_r)
            curves = (M[:, 0, 0], M[:, 0, 1] / M[:, 0, 0], M[:, 2, 2] / M[:, 0, 0],
                      M[:, 3, 3] / M[:, 0, 0], dop_unpolarized(M))
            P = None
            if plugin_points and model != "Priest-Germer":
                P = plugin_in_plane(metal, model, ti, marks)
                points = (P[:, 0, 0], P[:, 0, 1] / P[:, 0, 0], P[:, 2, 2] / P[:, 0, 0],
                          P[:, 3, 3] / P[:, 0, 0], dop_unpolarized(P))
            for row, y in enumerate(curves):
                ax = axes[row, col]
                ax.plot(theta_r, y, STYLES[model], color=COLORS[model], lw=1.2, label=model)
                if P is not None:
                    ax.plot(marks, points[row], "o", ms=2.5, mfc="none", color=COLORS[model],
                            label=f"{model} (plugin)" if row == 0 else None)
        axes[0, col].set_yscale("log")
        axes[0, col].set_ylim(1e-3, 1e3)
        axes[0, col].set_title(f"{metal}, {WAVELENGTH} nm, incidence {ti:g}°")
        axes[-1, col].set_xlabel("reflection angle θr (deg; > 0: specular side)")
        axes[4, col].set_ylim(-0.02, 1.02)
        for row in range(1, 4):
            axes[row, col].set_ylim(-1.05, 1.05)
        for row in range(len(rows)):
            axes[row, col].axvline(ti, color="0.6", lw=0.6)
    for row, name in enumerate(rows):
        axes[row, 0].set_ylabel(name)
    axes[0, 0].legend(loc="upper left", ncol=1)
    p = METALS[metal]
    n, k = ior(metal)
    fig.suptitle(f"In-plane pBRDF of {metal} (n = {n:.3f}, k = {k:.3f}; σ = {p['sigma']}, "
                 f"kdd = {p['kdd']}, σdd = {p['sigma_dd']}, kid = {p['kid']}): lines = float64 "
                 "reference, circles = plugin", fontsize=9)
    fig.tight_layout()
    return common.save_figure(fig, f"paper_in_plane_{metal}")


def figure_grazing():
    plt = common.pyplot()
    cos_r = np.logspace(-7, 0, 300)
    theta_r = np.degrees(np.arccos(cos_r))
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
    for ax, metal in zip(axes, METALS):
        for model in MODELS:
            M = in_plane(metal, model, 40.0, theta_r)
            ax.loglog(cos_r, M[:, 0, 0], STYLES[model], color=COLORS[model], label=model)
        ax.loglog(cos_r, in_plane(metal, "Priest-Germer", 40.0, [89.0])[0, 0, 0]
                  * np.cos(np.radians(89.0)) / cos_r, ":", color="0.5", lw=0.8,
                  label="∝ 1 / cos θr")
        ax.set_xlabel("cos θr (forward side; grazing to the right)")
        ax.set_ylabel("M00 (1/sr)")
        ax.set_title(f"{metal}: incidence 40°, reflection towards grazing")
        ax.invert_xaxis()
        ax.legend()
    fig.tight_layout()
    return common.save_figure(fig, "paper_grazing")


# ---------------------------------------------------------------------------
# Report
# ---------------------------------------------------------------------------

def report(plugin_points=True):
    start = time.perf_counter()
    figures = [figure_in_plane(metal, plugin_points) for metal in METALS]
    figures.append(figure_grazing())

    cos_r = (1e-1, 1e-2, 1e-3, 1e-4, 1e-6)
    rows = []
    for metal in METALS:
        growth = grazing_growth(metal, 40.0, cos_r)
        for model in MODELS:
            rows.append([metal, model] + list(growth[model]))
    grazing = common.table(["metal", "model"] + [f"cos θr = {c:g}" for c in cos_r], rows)

    rows = []
    for metal in METALS:
        for model in MODELS:
            rows.append([metal, model] + [peak_dop(metal, model, ti) for ti in INCIDENCE])
    dop = common.table(["metal", "model"] + [f"θi = {ti:g}°" for ti in INCIDENCE], rows)

    marks = PLUGIN_MARKS
    deviation = ({metal: plugin_deviation(metal, marks) for metal in METALS}
                 if plugin_points else {})
    params = common.table(
        ["metal", "n", "k", "σ", "kdd", "σdd", "kid", "two-component kd"],
        [[m, *ior(m), p["sigma"], p["kdd"], p["sigma_dd"], p["kid"],
          model_parameters(m, "two-component")["kid"]] for m, p in METALS.items()], digits=4)

    text = f"""# Study 1: the paper's claims, three models side by side

`python validation/paper_claims.py` ({time.perf_counter() - start:.0f} s). In-plane pBRDF at
{WAVELENGTH} nm for Priest-Germer (specular microfacet lobe, no shadowing), the two-component
model of Hyde et al. 2009 (specular with V-groove shadowing + Lambertian) and this
three-component model (specular + directional diffuse + ideal diffuse, V-groove). Curves:
float64 reference evaluator; circles: the `pbrdf` plugin (two- and three-component models; it
has no unshadowed mode) at 34 reflection angles per incidence angle.

Parameters (illustrative; n, k from Mitsuba's tables; the two-component Lambertian weight kd
gives the same diffuse albedo at normal incidence as kdd·fdd + kid/π):

{params}

![Al](figures/paper_in_plane_Al.png)

![Cu](figures/paper_in_plane_Cu.png)

**Grazing blow-up.** M00 (1/sr) at incidence 40° as the reflection direction goes to grazing
on the forward side (cos θr → 0). Priest-Germer grows like 1/cos θr (a factor 10^5 between
cos θr = 0.1 and 1e-6); with shadowing the models tend to a finite limit (V-groove G ∝ cos θr
cancels the 1/cos θr). By reciprocity (checked in `physics.md`) the same holds for grazing
incidence.

{grazing}

![grazing](figures/paper_grazing.png)

**Degree of polarization in the mirror direction** (unpolarized incidence, θr = θi). The
diffuse lobes add unpolarized light: the two- and three-component models are less polarized
than Priest-Germer; all reflect s-polarized light (M10 > 0, see `physics.md`).

{dop}

Off the specular peak the three-component model's DOP falls off over the width of the
directional diffuse lobe, the two-component model's over the width of the specular lobe
(its Lambertian floor dominates sooner): the figures' bottom rows.
"""
    if deviation:
        text += ("\n**Plugin vs reference on these curves** (max over incidence angles, both "
                 "shadowed models, all elements, of |plugin − reference| / M00): " +
                 ", ".join(f"{m}: {v:.1e}" for m, v in deviation.items()) +
                 " (float32 rounding).\n")
    common.write_markdown("paper_claims", text)
    return {"grazing": {m: grazing_growth(m, 40.0, cos_r) for m in METALS},
            "deviation": deviation, "figures": figures}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--no-plugin", action="store_true", help="reference curves only")
    args = parser.parse_args(argv)
    if not args.no_plugin:
        common.use_variant()
    report(plugin_points=not args.no_plugin)


if __name__ == "__main__":
    main()
