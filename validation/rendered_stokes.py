"""Study 3: rendered Stokes images of aluminium and copper checked against physics.

    python validation/rendered_stokes.py [--spp 256] [--passes 8]
        (-> rendered_stokes.md, figures/rendered_<scene>_<metal>.png)

The scenes (a plate and a sphere of ``pbrdf`` with Al and Cu, lit by an
unpolarized narrow-band directional light), the per-pixel checks (AoLP from
geometry alone, DoLP against the reference evaluator) and the noise model are
described in ``proof.rendered``, which :func:`report` runs at the
study's sizes; ``tests/diagnostics/test_physics.py`` runs the same measurement with fewer
samples and asserts on it.
"""

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from validation import common  # noqa: E402
from proof import rendered  # noqa: E402


def figure(result):
    plt = common.pyplot()
    im = result["images"]
    valid = im["valid"]
    fig, axes = plt.subplots(1, 5, figsize=(15, 3.1))

    def show(ax, data, title, cmap, vmin=None, vmax=None, mask=None):
        d = np.where(mask if mask is not None else np.ones_like(valid), data, np.nan)
        h = ax.imshow(d, cmap=cmap, vmin=vmin, vmax=vmax, interpolation="nearest")
        ax.set_title(title)
        ax.set_xticks([])
        ax.set_yticks([])
        fig.colorbar(h, ax=ax, fraction=0.046, pad=0.03)

    s0 = im["mean"][..., 0]
    show(axes[0], s0 / np.percentile(s0[valid], 99.5), "S0 (rendered)", "gray", 0, 1)
    vmax = float(np.percentile(im["dolp_ref"][valid], 99.5))
    show(axes[1], im["dolp"], "DoLP rendered", "viridis", 0, vmax, valid)
    show(axes[2], im["dolp_ref"], "DoLP reference", "viridis", 0, vmax, valid)
    lim = float(np.percentile(np.abs(im["d_dolp"][valid]), 99.5))
    show(axes[3], im["d_dolp"], "DoLP rendered − reference", "RdBu", -lim, lim, valid)
    d_aolp = np.degrees(rendered.wrap_half_pi(im["aolp"] - im["aolp_geo"]))
    lim = max(float(np.percentile(np.abs(d_aolp[im["polarized"]]), 99.5)), 1e-3)
    show(axes[4], d_aolp, "AoLP rendered − geometry (°)", "RdBu", -lim, lim, im["polarized"])
    # AoLP as line segments on the intensity image
    ys, xs = np.nonzero(im["polarized"])
    step = max(1, len(xs) // 150)
    for y, x in zip(ys[::step], xs[::step]):
        a = im["aolp_geo"][y, x]
        dx, dy = 0.9 * np.cos(a), -0.9 * np.sin(a)   # image rows grow downward
        axes[0].plot([x - dx, x + dx], [y - dy, y + dy], color="tab:red", lw=0.6)
    height, width = valid.shape
    axes[0].set_xlim(-0.5, width - 0.5)
    axes[0].set_ylim(height - 0.5, -0.5)
    fig.suptitle(f"{result['scene']}, {result['metal']} ({result['spp']} spp × "
                 f"{result['passes']} passes): red ticks = polarization direction expected from "
                 "geometry (wi × wr)", fontsize=9)
    fig.tight_layout()
    return common.save_figure(fig, f"rendered_{result['scene']}_{result['metal']}")


def report(spp=256, passes=8):
    start = time.perf_counter()
    results = []
    for name in rendered.SCENES:
        for metal in ("Al", "Cu"):
            r = rendered.measure(name, metal, spp, passes)
            r["figure"] = figure(r)
            results.append(r)
    rows = [(r["scene"], r["metal"], r["pixels"], r["dolp_ref_max"],
             f"{r['dolp_bias']:.1e} ± {r['dolp_bias_se']:.1e}", r["dolp_rms_error"],
             r["dolp_rms_se"], r["dolp_max_abs_error"], r["footprint_rms"] / 3) for r in results]
    dolp_table = common.table(
        ["scene", "metal", "pixels", "max DoLP", "mean ΔDoLP ± s.e.", "RMS ΔDoLP",
         "RMS s.e.", "max |ΔDoLP|", "footprint error (RMS)"], rows)
    rows = [(r["scene"], r["metal"], r["polarized_pixels"], r["aolp_rms_error_deg"],
             r["aolp_max_error_deg"], r["aolp_geometry_rms_deg"], r["aolp_ref_vs_geometry_deg"],
             f"{r['aolp_ref_mean_error_deg']:.1e} ± {r['aolp_mean_se_deg']:.1e}",
             r["aolp_ref_rms_error_deg"], r["aolp_rms_se_deg"],
             (f"{r['in_plane_pixels']}: {r['aolp_in_plane_mean_deg']:.1e} ± "
              f"{r['aolp_in_plane_mean_se_deg']:.1e}, max {r['aolp_in_plane_max_deg']:.3f}")
             if r["in_plane_pixels"] else "–") for r in results]
    aolp_table = common.table(
        ["scene", "metal", "pixels", "vs geometry: RMS Δ (°)", "max |Δ| (°)",
         "rule's own error: RMS (°)", "max (°)", "vs reference: mean Δ ± s.e. (°)", "RMS Δ (°)",
         "RMS s.e. (°)", "in-plane pixels: mean Δ ± s.e., max |Δ| (°)"], rows)
    figures = "\n\n".join(f"![{r['scene']} {r['metal']}]({r['figure']})" for r in results)
    render_seconds = sum(r["seconds"] for r in results)
    text = f"""# Study 3: rendered Stokes images against physics

`python validation/rendered_stokes.py --spp {spp} --passes {passes}`
({time.perf_counter() - start:.0f} s, of which {render_seconds:.0f} s rendering).
`llvm_ad_spectral_polarized`, `stokes` + `direct` integrators, box filter; a plate and a unit
sphere of `pbrdf` (`material` Al or Cu, σ {rendered.SIGMA['Al']} (Al), {rendered.SIGMA['Cu']} (Cu),
kdd {rendered.LOBES['kdd']}, σdd {rendered.LOBES['sigma_dd']}, kid {rendered.LOBES['kid']}), unpolarized directional light with a {rendered.BAND[0]:g}–{rendered.BAND[1]:g} nm band
spectrum. Each image: {passes} independent renders of {spp} spp (seeds differ), i.e.
{spp * passes} spp in all; Δ = value of the mean image − expected; standard errors (s.e.) from
the spread over the passes. Pixels: footprint fully on the object, light and camera more than
3° above the local horizon, light seen in every pass; AoLP only where the reference DoLP exceeds
10 s.e. Expected values: the reference evaluator averaged over 8×8 rays per pixel and over the
band with the sensor's response (footprint error: a third of the 8×8 − 4×4 difference,
Richardson's estimate for the midpoint rule).

**Angle of linear polarization.** The geometric rule: the reflected light is polarized along
wi × wr, perpendicular to the plane containing the incident and the reflected ray; for the
plate's middle column, whose rays lie in the plane of incidence, perpendicular to the plane of
incidence. "Rule's own error" is the reference evaluator against the rule (evaluated on the
pixel's central ray, whereas the pixel averages its footprint). The rendered AoLP is also
compared with the reference evaluator's.

{aolp_table}

**Degree of linear polarization** against the reference evaluator:

{dolp_table}

Both are at the Monte Carlo noise: the mean differences are within a few standard errors of 0
and the RMS differences equal the RMS standard errors.

{figures}
"""
    common.write_markdown("rendered_stokes", text)
    return results


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--spp", type=int, default=256)
    parser.add_argument("--passes", type=int, default=8)
    args = parser.parse_args(argv)
    common.use_variant()
    report(args.spp, args.passes)


if __name__ == "__main__":
    main()
