"""Study 2: physics checks, each on the float64 reference and on the plugin.

    python validation/physics.py [--pairs 100000]   (-> physics.md, figures/physics_fresnel.png)

1. Fresnel reflectance at normal incidence against ((n-1)^2 + k^2) / ((n+1)^2 + k^2)
   from the conductor's tabulated n, k.
2. Pseudo-Brewster angle (minimum of R_p) of Al and Cu against the minimum of the
   closed-form (real-arithmetic, Born & Wolf) Fresnel R_p, and the Brewster angle
   arctan(n) of a dielectric.
3. Unpolarized light reflected into the mirror direction is s-polarized (S1 > 0 in
   the s/p frame) and its degree of polarization rises up to the pseudo-Brewster
   angle.
4. Reciprocity: M00(wi, wr) = M00(wr, wi), and the whole matrix obeys
   M(r -> i) = Q M(i -> r)^T Q, Q = diag(1, 1, -1, 1).
5. Realizability: the eigenvalues of Cloude's coherency matrix are >= 0 and the
   degree of polarization of the output is <= 1 for every input Stokes vector.

The checks are ``proof.mirror_fresnel`` (1-3) and
``mitsuba_pbrdf.diagnostics.physics`` (4, 5), whose docstrings say how the plugin is
measured; this script runs them at the study's sizes and writes the report. The
directional-hemispherical albedo (white furnace) is ``furnace.py``. The
tolerances and their reasons are in ``tests/diagnostics/test_physics.py``, which runs the same
functions with fewer samples.
"""

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from validation import common  # noqa: E402
from mitsuba_pbrdf import reference  # noqa: E402
from mitsuba_pbrdf.diagnostics import physics  # noqa: E402
from proof import mirror_fresnel  # noqa: E402


# ---------------------------------------------------------------------------
# Figure and report
# ---------------------------------------------------------------------------

def figure_fresnel(plugin=True, wavelength=632.8):
    plt = common.pyplot()
    theta_deg = np.linspace(0.25, 89.75, 359)
    theta = np.radians(theta_deg)
    fig, axes = plt.subplots(2, 2, figsize=(10, 6.5), sharex=True)
    for col, metal in enumerate(("Al", "Cu")):
        n, k = (float(x) for x in reference.conductor_ior(metal, wavelength))
        rs, rp = mirror_fresnel.closed_form_reflectances(theta, n, k)
        pb = np.degrees(mirror_fresnel.closed_form_pseudo_brewster(n, k))
        ax = axes[0, col]
        ax.plot(theta_deg, rs, color="tab:blue", label="R_s closed form")
        ax.plot(theta_deg, rp, color="tab:red", label="R_p closed form")
        ax.plot(theta_deg, 0.5 * (rs + rp), color="k", lw=0.8, label="R (unpolarized)")
        marks = np.arange(2.5, 89.0, 5.0)
        if plugin:
            bsdf = mirror_fresnel.load_plugin(material=metal, sigma=mirror_fresnel.SIGMA)
            to_viewer, to_light = mirror_fresnel.in_plane_pair(np.radians(marks))
            M = mirror_fresnel.mueller_global(bsdf, to_viewer, to_light, [wavelength])[:, 0]
            scale = 4 * np.pi * mirror_fresnel.ALPHA**2 * np.cos(np.radians(marks)) ** 2
            ax.plot(marks, (M[:, 0, 0] + M[:, 0, 1]) * scale, "o", mfc="none", ms=4,
                    color="tab:blue", label="R_s plugin")
            ax.plot(marks, (M[:, 0, 0] - M[:, 0, 1]) * scale, "s", mfc="none", ms=4,
                    color="tab:red", label="R_p plugin")
        ax.axvline(pb, color="0.5", ls=":")
        ax.text(pb, rp.min(), f" θpB = {pb:.2f}°", va="top",
                ha="right", fontsize=8)
        ax.set_title(f"{metal} at {wavelength} nm (n = {n:.3f}, k = {k:.3f})")
        ax.set_ylabel("reflectance")
        ax.legend(loc="lower left")

        ax = axes[1, col]
        for three, style in ((False, "-"), (True, "--")):
            result = mirror_fresnel.mirror_polarization(metal, wavelength, theta_deg, plugin=False,
                                                 three_lobes=three)
            label = "3 lobes (kdd 0.2, kid 0.05)" if three else "specular only"
            ax.plot(theta_deg, mirror_fresnel.dop(result["reference"]), style, color="k", label=label)
            ax.plot(theta_deg, result["reference"][:, 1], style, color="tab:green", lw=0.8,
                    label=f"S1/S0, {label}")
            if plugin:
                pr = mirror_fresnel.mirror_polarization(metal, wavelength, marks, plugin=True,
                                                 three_lobes=three)["plugin"]
                ax.plot(marks, mirror_fresnel.dop(pr), "o" if not three else "^", mfc="none", ms=4,
                        color="k", label=f"DOP plugin, {label}")
        ax.axvline(pb, color="0.5", ls=":")
        ax.set_xlabel("incidence angle = mirror reflection angle (deg)")
        ax.set_ylabel("DOP of reflected light (unpolarized in)")
        ax.legend(loc="upper left", fontsize=7)
    fig.suptitle("Fresnel reflectance from the plugin's mirror-direction Mueller matrix vs the "
                 "closed form, and the polarization of reflected light", fontsize=9)
    fig.tight_layout()
    return common.save_figure(fig, "physics_fresnel")


def report(pairs=100_000, plugin=True):
    start = time.perf_counter()
    sections = []

    rows = mirror_fresnel.normal_incidence(plugin=plugin)
    worst_ref = max(abs(r[5] / r[4] - 1) for r in rows)
    worst_plugin = max(abs(r[6] / r[4] - 1) for r in rows) if plugin else np.nan
    sections.append(
        "## 1. Fresnel reflectance at normal incidence\n\n"
        "R = ((n−1)² + k²)/((n+1)² + k²) from Mitsuba's tabulated n, k, against R recovered "
        f"from the BRDF at exact normal incidence and exit (σ = {mirror_fresnel.SIGMA}: R = 4πα² M00). "
        f"Worst relative error: reference **{worst_ref:.1e}**, plugin **{worst_plugin:.1e}**.\n\n"
        + common.table(["metal", "λ (nm)", "n", "k", "R closed form", "R reference",
                        "R plugin", "plugin rel. error"],
                       [r + (abs(r[6] / r[4] - 1),) for r in rows], digits=6))

    rows = mirror_fresnel.pseudo_brewster(plugin=plugin)
    worst_ref = max(abs(r[5] - r[4]) for r in rows)
    worst_plugin = max(abs(r[6] - r[4]) for r in rows) if plugin else np.nan
    sections.append(
        "## 2. Pseudo-Brewster angle\n\n"
        "Angle of minimum R_p: closed form = minimum of the real-arithmetic Fresnel R_p "
        "(Born & Wolf; arctan n for the dielectric) by bisection on its slope; reference = "
        "golden-section minimum of R_p from its mirror-direction Mueller matrix; plugin = "
        "parabola through the three lowest points of a 0.01° grid. Resolution: how far float32 "
        "rounding of R_p (2e-6 relative) can move a minimum this flat. Worst difference: "
        f"reference **{worst_ref:.1e}°**, plugin **{worst_plugin:.1e}°**.\n\n"
        + common.table(["case", "λ (nm)", "n", "k", "θpB closed form (°)", "reference − closed (°)",
                        "plugin − closed (°)", "plugin resolution (°)", "R_p min"],
                       [(r[0], r[1], r[2], r[3], r[4], r[5] - r[4], r[6] - r[4], r[7], r[8])
                        for r in rows], digits=4))

    rows = mirror_fresnel.s_polarization(plugin=plugin)
    sections.append(
        "## 3. Reflected light is s-polarized; DOP rises toward the pseudo-Brewster angle\n\n"
        "Unpolarized light reflected into the mirror direction, incidence 1°–89.5° (step "
        "0.25°): S1/S0 > 0 (s-polarized, S1 = I_s − I_p) at every angle, S2 = S3 = 0, and the "
        "DOP increases monotonically up to θpB; it peaks a little beyond θpB, at the angle "
        "where |r_p/r_s| is smallest.\n\n"
        + common.table(["metal", "λ (nm)", "lobes", "engine", "min S1/S0", "max |S2|,|S3| / S0",
                        "DOP rising to θpB", "θpB (°)", "DOP at θpB", "θ of max DOP (°)",
                        "max DOP"], rows, digits=4))

    rows = physics.reciprocity(pairs=pairs, plugin=plugin)
    sections.append(
        "## 4. Reciprocity\n\n"
        f"{pairs:,} random direction pairs × 4 wavelengths per row (half near the specular "
        "direction), wi and wr swapped: worst |M00(i,r) − M00(r,i)| / M00 and worst element "
        "of |M(r,i) − Q M(i,r)ᵀ Q| / M00, Q = diag(1, 1, −1, 1) (Mueller reciprocity theorem in "
        "the global s/p frames).\n\n"
        + common.table(["configuration", "engine", "M00 rel. asymmetry", "Q Mᵀ Q, rel. to M00"],
                       rows))

    rows = physics.realizability(pairs=pairs, plugin=plugin)
    sections.append(
        "## 5. Realizability\n\n"
        f"{pairs:,} random pairs (cos θ ≥ 1e-3) plus normal, retro-reflection, mirror and "
        "grazing pairs × 4 wavelengths per row: the smallest eigenvalue of Cloude's coherency "
        "matrix relative to M00 (≥ 0 for a physical Mueller matrix; specular-only matrices are "
        "pure, so three eigenvalues are 0 and rounding shows as ±ε), and the largest excess of "
        "output DOP over 1 for 69 input Stokes vectors, (|S1..3| − S0)/M00.\n\n"
        + common.table(["configuration", "engine", "matrices", "min eigenvalue / M00",
                        "max DOP excess / M00", "min M00 checked"], rows)
        + "\n\nMatrices counted: M00 above 1e-290 (reference) or 1e-30 (plugin); below, D "
        "underflows to denormal numbers whose few significant bits make any matrix look "
        "unphysical (the far tail of the σ = 0.02 lobe).")

    figure = figure_fresnel(plugin=plugin)
    text = (f"# Study 2: physics checks\n\n`python validation/physics.py --pairs {pairs}` "
            f"({time.perf_counter() - start:.0f} s). Each check on the float64 reference "
            "evaluator and on the plugin (float32, through `frames.eval_global`), by the "
            "functions of `proof/mirror_fresnel.py` (1–3) and "
            "`mitsuba_pbrdf/diagnostics/physics.py` (4, 5). The same functions run with fewer "
            "samples in `tests/diagnostics/test_physics.py`, whose docstrings justify each tolerance. "
            "The white-furnace (albedo) study is "
            "[`furnace.md`](furnace.md).\n\n"
            f"![Fresnel and DOP]({figure})\n\n" + "\n\n".join(sections))
    common.write_markdown("physics", text)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pairs", type=int, default=100_000)
    args = parser.parse_args(argv)
    common.use_variant()
    report(args.pairs)


if __name__ == "__main__":
    main()
