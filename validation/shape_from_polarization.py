"""Shape from polarization on metals: the normal map of a bumpy copper and
aluminium plate recovered from intensity, Stokes and polarization-camera
images, from one and three views.

    python validation/shape_from_polarization.py            # the report's size
    python validation/shape_from_polarization.py --quick    # fewer cases and iterations
    python validation/shape_from_polarization.py --long 200 # + copper, one view, 200 x 128
                                                            #   spp, targets at 4096 spp

Writes ``validation/shape_from_polarization.md`` and
``validation/figures/shape_from_polarization.png``. Section 1 checks the
texel gradients (proof/normal_map_gradients.py): ``stokes_prb`` against
``path`` AD with cosine sampling, per sample, and against central finite
differences, for ``polarized_normalmap`` and ``polarized_bumpmap``. Section 2
runs proof/sfp_study.py's cases: the plate (mitsuba_pbrdf.inverse.normals.scenes)
under an environment map and an area light, targets at high spp, a flat
start, Adam on the unit normals with ``stokes_prb``, the learning rate
decaying geometrically to a tenth; error = angle between recovered and true
normals over the texels that received a gradient. ``--long`` adds the fits
that reach the 2-degree goal and their noise floor (the same fits started at
the true map); validation/sfp_accuracy.py holds the experiments behind them.
"""

import argparse
import os
import platform
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

REPORT = os.path.join(HERE, "shape_from_polarization.md")
FIGURE = os.path.join(HERE, "figures", "shape_from_polarization.png")
OBSERVABLES = ("intensity", "stokes", "polcam-bright", "polcam-dim")


def cases(args):
    from proof.sfp_study import Case

    size = dict(texels=args.texels, size=args.size, iterations=args.iterations, spp=args.spp,
                target_spp=args.target_spp)
    out = [Case(metal=m, observables=o, views=1, **size)
           for m in ("Cu", "Al") for o in (("intensity", "stokes") if args.quick else OBSERVABLES)]
    if not args.quick:
        out += [Case(metal=m, observables=o, views=3, **size)
                for m in ("Cu", "Al") for o in ("intensity", "stokes")]
    if args.long:
        # the noise floor of validation/sfp_accuracy.md: targets 16 x cleaner, 8 x the spp
        long = dict(size, iterations=args.long, spp=8 * args.spp, target_spp=16 * args.target_spp)
        out += [Case(metal="Cu", observables=o, views=1, start=start, **long)
                for start in ("flat", "truth") for o in ("intensity", "stokes")]
    return out


def gradient_rows():
    from proof.normal_map_gradients import WRAPPERS, compare, relative_differences

    rows = []
    for wrapper in WRAPPERS:
        t0 = time.perf_counter()
        r = compare(wrapper)
        d = relative_differences(r)
        rows.append(f"| {wrapper} | {r['prb'].size} | {d['prb vs path AD']:.2g} | "
                    f"{d['prb vs FD']:.2g} | {abs(r['prb']).max():.3g} | "
                    f"{time.perf_counter() - t0:.0f} s |")
    return rows


def figure(runs, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from mitsuba_pbrdf.visualization.png import save_png

    shown = [r for r in runs if r["case"].views == 1 and r["case"].observables in
             ("stokes", "intensity") and r["case"].iterations == runs[0]["case"].iterations]
    fig, axes = plt.subplots(2, 1 + len(shown), figsize=(3.2 * (1 + len(shown)), 6.6))
    axes = np.atleast_2d(axes)
    enc = lambda n: np.clip((n + 1.0) / 2.0, 0, 1)  # noqa: E731
    axes[0, 0].imshow(enc(runs[0]["truth"]), origin="upper")
    axes[0, 0].set_title("true normals\n(n + 1) / 2")
    vmax = 20.0
    for j, r in enumerate(shown):
        c = r["case"]
        ax_n, ax_e = axes[0, 1 + j], axes[1, 1 + j]
        ax_n.imshow(enc(r["result"].normals), origin="upper")
        ax_n.set_title(f"recovered: {c.metal}, {c.observables}\n1 view, {c.iterations} x {c.spp}"
                       f" spp, targets {c.target_spp}")
        err = np.where(r["result"].visible, r["result"].angular_error, np.nan)
        im = ax_e.imshow(err, origin="upper", vmin=0, vmax=vmax, cmap="magma")
        ax_e.set_title(f"error, median {r['error']['median']:.1f}°")
    fig.colorbar(im, ax=axes[1, 1:].tolist(), label="angular error (deg)", shrink=0.8)
    ax = axes[1, 0]
    for r in runs:
        ax.semilogy(np.array(r["result"].loss) / r["result"].loss[0], lw=1,
                    label=f"{r['case'].label}, {r['case'].iterations} x {r['case'].spp}")
    ax.set_xlabel("iteration")
    ax.set_ylabel("loss / first loss")
    ax.legend(fontsize=5)
    for a in axes.ravel()[1:]:
        if a is not ax:
            a.set_xticks([])
            a.set_yticks([])
    save_png(fig, path, dpi=110)
    plt.close(fig)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--quick", action="store_true", help="one view, intensity and stokes only")
    p.add_argument("--texels", type=int, default=16)
    p.add_argument("--size", type=int, default=48)
    p.add_argument("--iterations", type=int, default=40)
    p.add_argument("--spp", type=int, default=16)
    p.add_argument("--target-spp", type=int, default=256)
    p.add_argument("--skip-gradients", action="store_true")
    p.add_argument("--long", type=int, default=0, metavar="N",
                   help="also copper, one view, intensity and stokes with N iterations at 8 x "
                        "the spp against targets at 16 x the target spp, from a flat start and "
                        "from the truth (the noise floor)")
    p.add_argument("--variant", default="llvm_ad_spectral_polarized")
    args = p.parse_args(argv)
    if args.quick:
        args.iterations = min(args.iterations, 20)

    import mitsuba_pbrdf
    mitsuba_pbrdf.use_variant(args.variant)
    from proof.sfp_study import EXPOSURES, FULL_WELL, READ_NOISE, run_case

    from mitsuba_pbrdf.outputs import write_text

    t_start = time.perf_counter()
    grad = [] if args.skip_gradients else gradient_rows()
    runs = []
    for case in cases(args):
        r = run_case(case)
        print(f"{case.label}: start {r['start']['median']:.2f}°, median {r['error']['median']:.2f}°"
              f", p90 {r['error']['p90']:.2f}°, {r['seconds']:.0f} s", flush=True)
        runs.append(r)

    c0 = runs[0]["case"]
    lines = ["# Shape from polarization on metals", "",
             f"`python validation/shape_from_polarization.py"
             f"{''.join(' ' + a for a in (sys.argv[1:] if argv is None else argv))}` (this file), `{args.variant}`, "
             f"{platform.machine()}, {os.cpu_count()} cores shared with other jobs; "
             f"total {time.perf_counter() - t_start:.0f} s.", ""]
    if grad:
        lines += ["## 1. Texel gradients", "",
                  "A random linear functional of all 15 channels of an 8 x 8 render of a plate "
                  "under one directional light (gold pbrdf, sigma 0.2, cosine sampling, depth 2, "
                  "4 spp), differentiated with respect to every texel of a random 3 x 3 normal "
                  "map (27 values) or height map (9 values). The light is reached by emitter "
                  "sampling only, so `path` AD differentiates the estimator `stokes_prb` replays, "
                  "sample for sample. FD: central differences, step 2e-3 in texel value, the "
                  "same random numbers. Difference = max |a - b| / max |b|.", "",
                  "| wrapper | texel values | stokes_prb vs path AD | stokes_prb vs FD | "
                  "largest |gradient| | time |", "|---|---|---|---|---|---|", *grad, ""]
    lines += ["## 2. Recovery", "",
              f"Plate [-1, 1]^2 with a {c0.texels} x {c0.texels} normal map of a height field "
              "(four Gaussian bumps and dents and a ripple, steepest normal 24° from the plate's "
              "normal); pbrdf with the metal's tabulated n + ik, sigma 0.15 (known); a lat-long "
              "sky (bright gradient with azimuthal bands, dim ground) and a rectangular area "
              f"light; cameras 55° from the normal, {c0.size} x {c0.size} pixels, view 0 at "
              "azimuth -90°, views 1 and 2 at 30° and 150°. Targets at "
              f"{c0.target_spp} spp; fit: {c0.iterations} Adam iterations from a flat map, "
              f"{c0.spp} spp per view, learning rate {c0.schedule} (geometric decay to a tenth "
              "by the last iteration), no smoothness term, stokes_prb depth 3. Rows 'from the "
              "truth' start at the true map: how far the fit drifts from it is its noise floor "
              "([validation/sfp_accuracy.md](sfp_accuracy.md)). polcam: the mono IMX250MZR mosaic of "
              f"the luminance Stokes vector, 16-bit ADC, full well {FULL_WELL:.0f} e-, read "
              f"noise {READ_NOISE} e-, Poisson shot noise, in the targets only; exposure "
              + ", ".join(f"{k}: full well at {v:g} x the brightest pixel"
                          for k, v in EXPOSURES.items()) + ".", "",
              "Angular error over the texels that received a gradient (degrees); memory: "
              "peak resident memory of the whole process during the fit (all cases run in one "
              "process, so it includes Mitsuba, the scenes and Dr.Jit's caches) and, after the "
              "+, its growth during this fit (Dr.Jit reuses memory it already holds, so a case "
              "after a larger one adds nothing).", "",
              "| metal | views | observables | start | iterations x spp | targets | start median "
              "| median | 90th pct | time | peak memory |",
              "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in runs:
        c = r["case"]
        lines.append(f"| {c.metal} | {c.views} | {c.observables} | {c.start} | "
                     f"{c.iterations} x {c.spp} | {c.target_spp} spp | "
                     f"{r['start']['median']:.2f} | "
                     f"{r['error']['median']:.2f} | {r['error']['p90']:.2f} | "
                     f"{r['seconds']:.0f} s | {r['peak_rss'] / 2**20:.0f} MiB "
                     f"+{r['peak_bytes'] / 2**20:.0f} |")
    lines += ["", "Median DoLP of the view-0 target over the plate's pixels (luminance Stokes "
              "vector; the sky seen directly is unpolarized): "
              + ", ".join(sorted({f"{r['case'].metal} {r['dolp']:.3f}" for r in runs})) + ".",
              "", f"![true and recovered normals, errors, losses](figures/{os.path.basename(FIGURE)})",
              "", "## Reading", "", "The physical reading of these figures (why metals polarize little, what AoLP adds to S0, where the errors sit) is in [docs/inverse-rendering.md](../docs/inverse-rendering.md#shape-from-polarization-normal-maps).", ""]
    write_text(REPORT, "\n".join(lines))
    figure(runs, FIGURE)
    print(f"wrote {REPORT} and {FIGURE}")


if __name__ == "__main__":
    main()
