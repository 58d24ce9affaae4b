"""Spatially varying recovery: a roughness map and a kdd map of a metal sphere
from Stokes images, with S0 only and with S0, S1, S2.

    python validation/svbrdf_recovery.py            # 60 iterations each (~10 min on 2 cores)
    python validation/svbrdf_recovery.py --quick    # 20 iterations

Writes ``validation/svbrdf_recovery.md`` and
``validation/figures/svbrdf_recovery.png`` (loss curves, maps before/after,
error maps). The fit is mitsuba_pbrdf.inverse.svbrdf (examples/svbrdf_recovery.py
runs it): three views, two area lights and a sky, ``stokes_prb`` at depth 2,
64 x 64 pixels, 16 spp per iteration and view, targets at 128 spp, Adam on the 2 x 64 texels from
uniform maps (sigma 0.2, kdd 0.2). Error: RMS over the texels that received
a gradient (seen by a camera), for each map.
"""

import argparse
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

FIGURE = os.path.join(HERE, "figures", "svbrdf_recovery.png")
RUNS = {"S0 only": (0,), "S0, S1, S2": (0, 1, 2)}


def figure(results, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    names = ("sigma", "kdd")
    fig, axes = plt.subplots(3, 5, figsize=(15, 9))
    ax = axes[0, 0]
    for label, r in results.items():
        ax.semilogy(np.array(r["loss"]) / r["loss"][0], label=label)
    ax.set_xlabel("iteration")
    ax.set_ylabel("loss / initial loss")
    ax.legend()
    ax.set_title("loss (each on its own components)")
    for j in range(1, 5):
        axes[0, j].axis("off")
    any_r = next(iter(results.values()))
    for i, name in enumerate(names):
        truth = any_r["truth"][name]
        vmax = float(truth.max()) * 1.2
        panels = [("truth", truth), ("start", any_r["start"][name])]
        panels += [(label, r["recovered"][name]) for label, r in results.items()]
        for j, (title, data) in enumerate(panels):
            a = axes[i + 1, j]
            im = a.imshow(data, vmin=0, vmax=vmax, cmap="viridis")
            a.set_title(f"{name}: {title}")
            a.axis("off")
        fig.colorbar(im, ax=axes[i + 1, :4].tolist(), shrink=0.8)
        a = axes[i + 1, 4]
        err = {label: np.abs(r["recovered"][name] - truth) * r["visible"][name]
               for label, r in results.items()}
        a.imshow(np.concatenate(list(err.values()), axis=1), vmin=0, vmax=vmax / 3, cmap="magma")
        a.set_title(f"|error|: {' | '.join(err)}")
        a.axis("off")
    fig.savefig(path, dpi=80)
    plt.close(fig)


def main(argv=None):
    args = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    args.add_argument("--quick", action="store_true")
    args.add_argument("--out", default=os.path.join(HERE, "svbrdf_recovery.md"))
    args = args.parse_args(argv)
    import mitsuba_pbrdf

    mitsuba_pbrdf.use_variant("llvm_ad_spectral_polarized")
    from mitsuba_pbrdf.inverse.svbrdf import map_errors, recover

    iterations = 20 if args.quick else 60
    results, errors = {}, {}
    for label, components in RUNS.items():
        print(label, flush=True)
        results[label] = recover(components, iterations=iterations)
        errors[label] = map_errors(results[label])
    os.makedirs(os.path.dirname(FIGURE), exist_ok=True)
    figure(results, FIGURE)

    lines = ["# Spatially varying recovery: sigma and kdd maps from Stokes images", "",
             f"`python validation/svbrdf_recovery.py{' --quick' if args.quick else ''}` (this "
             "file). `mitsuba_pbrdf/inverse/svbrdf.py`: a `pbrdf` sphere (n = 1.5, k = 3.5, ks = 1, "
             "sigma_dd = 0.5) whose `sigma` and `kdd` are 8 x 8 single-channel bitmaps (bilinear), "
             "seen by three cameras (64 x 64) under two area lights and a sky; `stokes_prb` at "
             "depth 2 (`mi.render` + `dr.backward`), 16 spp per view and iteration, targets at "
             "128 spp; Adam (learning rate 0.02, x 0.97 per iteration) on the 128 texels for "
             f"{iterations} iterations from "
             "uniform maps (sigma 0.2, kdd 0.2), the loss of `inverse.stokes_loss` summed over "
             "the views on S0 only or on S0, S1, S2.", "",
             "RMS error of each map against the truth over the texels seen by a camera "
             "(that received a gradient):", "",
             "| loss on | sigma: start | sigma: recovered | kdd: start | kdd: recovered | "
             "seconds |", "|---|---|---|---|---|---|"]
    for label, e in errors.items():
        lines.append(f"| {label} | {e['sigma']['start']:.4f} | {e['sigma']['recovered']:.4f} | "
                     f"{e['kdd']['start']:.4f} | {e['kdd']['recovered']:.4f} | "
                     f"{results[label]['seconds']:.0f} |")
    n_vis = {name: int(results["S0, S1, S2"]["visible"][name].sum()) for name in ("sigma", "kdd")}
    lines += ["", f"Texels seen: sigma {n_vis['sigma']}, kdd {n_vis['kdd']} of 64 each.", "",
              "![loss curves, maps and errors](figures/svbrdf_recovery.png)", ""]
    with open(args.out, "w") as f:
        f.write("\n".join(lines) + "\n")
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
