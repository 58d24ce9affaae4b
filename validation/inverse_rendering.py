"""Inverse rendering example: recover a metal sphere's pBRDF parameters from
target Stokes images with ``mi.ad.Adam``, from S0 alone and from S0, S1, S2.

    python validation/inverse_rendering.py [--size 64] [--iterations 400] [--spp 16] [--lr-decay 0.99]

Writes ``validation/inverse_rendering.md`` and
``validation/figures/inverse_rendering_{loss,parameters,images}.png``.

Scene: ``mitsuba_pbrdf.inverse.sphere_scene`` (sphere n = 2, k = 4,
sigma = 0.12, ks = 1, kdd = 0.1, sigma_dd = 0.5, kid = 0.03; a soft box near
the camera gives highlights near normal incidence, one behind on the right
highlights at 60-70 degrees, plus a dim sky), ``direct`` integrator in
``stokes``. Target rendered at 512 spp. Fitted: n, k, sigma, ks, kdd, kid
(sigma_dd held) from two starting points, Adam on log-parameters,
``--spp`` samples per iteration, learning rate 0.05 decaying by
``--lr-decay`` per iteration. Also the Cramer-Rao bounds of the parameters from the Jacobian
images (forward-mode derivative renders) with 1 % pixel noise, for S0 and for
S0..S2.
"""

import argparse
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
FIGURES = os.path.join(HERE, "figures")
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

NAMES = ("eta", "k", "sigma", "ks", "kdd", "kid")
LABELS = {"eta": "n", "k": "k", "sigma": "sigma", "ks": "ks", "kdd": "kdd", "kid": "kid"}
STARTS = {"A": dict(eta=1.5, k=5.0, sigma=0.18, ks=0.75, kdd=0.2, kid=0.05),
          "B": dict(eta=3.0, k=3.0, sigma=0.08, ks=1.3, kdd=0.05, kid=0.015)}
COMPONENTS = {"S0": (0,), "S0..S2": (0, 1, 2)}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--size", type=int, default=64)
    p.add_argument("--iterations", type=int, default=400)
    p.add_argument("--lr", type=float, default=0.05)
    p.add_argument("--lr-decay", type=float, default=0.99)
    p.add_argument("--starts", default="A,B")
    p.add_argument("--spp", type=int, default=16)
    p.add_argument("--out", default=os.path.join(HERE, "inverse_rendering.md"))
    args = p.parse_args(argv)

    import mitsuba as mi

    import mitsuba_pbrdf
    mitsuba_pbrdf.use_variant("llvm_ad_spectral_polarized")
    from mitsuba_pbrdf import inverse
    from mitsuba_pbrdf.stokes import image as stokes_io

    scene = mi.load_dict(inverse.sphere_scene(args.size, args.size, args.spp,
                                              integrator="direct"))
    params = mi.traverse(scene)
    keys = ["object.bsdf." + n + ".value" for n in NAMES]
    truth = {k: float(np.array(params[k])[0]) for k in keys}
    film = scene.sensors()[0].film()
    target = np.array(inverse.render(scene, spp=512, seed=4242, passes=8))

    # Identifiability at the truth: Jacobian images and Cramer-Rao bounds
    t0 = time.perf_counter()
    jac = inverse.jacobian(scene, params, keys, spp=128, seed=99)
    jac_seconds = time.perf_counter() - t0
    s0 = inverse.stokes_indices(scene, (0,))[0]
    noise = 0.01 * float(target[..., s0].mean())
    values = np.array([truth[k] for k in keys])
    crb, corr = {}, {}
    for name, comps in COMPONENTS.items():
        F = inverse.fisher_information(jac, sum(inverse.stokes_indices(scene, comps), []), noise)
        C = np.linalg.inv(F)
        crb[name] = np.sqrt(np.diag(C)) / values
        corr[name] = C[0, 1] / np.sqrt(C[0, 0] * C[1, 1])

    # Fits
    full_loss = inverse.stokes_loss(scene, target, (0, 1, 2))
    fits = {}
    for start_name, start in STARTS.items():
        if start_name not in args.starts.split(","):
            continue
        for comp_name, comps in COMPONENTS.items():
            init = {"object.bsdf." + n + ".value": v for n, v in start.items()}
            curve = []

            def record(it, value, current):
                # every 20 iterations: the S0..S2 loss of the current parameters with
                # less render noise (256 spp, the same seed each time)
                if it % 20 == 0 or it == args.iterations - 1:
                    for k, v in current.items():
                        params[k] = v
                    params.update()
                    curve.append((it, float(full_loss(inverse.render(scene, spp=256, seed=5,
                                                                      passes=4))[0])))

            result = inverse.fit_parameters(scene, keys, target, comps, initial=init,
                                            iterations=args.iterations, lr=args.lr,
                                            lr_decay=args.lr_decay, spp=args.spp, seed=1,
                                            method="reverse", callback=record)
            result.curve = curve
            fitted = np.array(inverse.render(scene, spp=256, seed=77, passes=4))
            fits[(start_name, comp_name)] = (result, fitted)
            err = {LABELS[k.split(".")[2]]: f"{100 * (result.final[k] / truth[k] - 1):+.1f}%"
                   for k in keys}
            print(f"start {start_name}, {comp_name}: {err} ({result.seconds:.0f} s)", flush=True)
    # initial image of start A
    for k, v in STARTS["A"].items():
        params["object.bsdf." + k + ".value"] = v
    params.update()
    initial = np.array(inverse.render(scene, spp=256, seed=77, passes=4))

    _figures(fits, truth, keys, target, initial, film, stokes_io)

    # Report
    L = ["# Inverse rendering: a metal sphere from its Stokes images", "",
         f"`python validation/inverse_rendering.py` (this file; {args.size}x{args.size} pixels, "
         f"{args.iterations} Adam iterations of {args.spp} spp, `direct` integrator, "
         "`llvm_ad_spectral_polarized`). Target rendered at 512 spp with the true parameters; "
         "each fit starts from one of two guesses and uses the loss on S0 alone or on S0, S1, "
         "S2 (squared error, `inverse.stokes_loss`). Parameters are fitted on a log scale with "
         f"`mi.ad.Adam` (learning rate {args.lr}, x{args.lr_decay} per iteration); gradients by reverse-mode "
         "AD of `direct` (`inverse.loss_and_gradient`).", "",
         "## Recovered versus true", "",
         "| parameter | true | start A | A: S0 | A: S0..S2 | start B | B: S0 | B: S0..S2 |",
         "|---|---|---|---|---|---|---|---|"]
    for k in keys:
        n = k.split(".")[2]
        cells = [f"{truth[k]:.4g}"]
        for s in STARTS:
            cells.append(f"{STARTS[s][n]:.4g}")
            for c in COMPONENTS:
                v = fits[(s, c)][0].final[k]
                cells.append(f"{v:.4g} ({100 * (v / truth[k] - 1):+.1f} %)")
        L.append(f"| {LABELS[n]} | " + " | ".join(cells) + " |")
    secs = [r.seconds for r, _ in fits.values()]
    peaks = [r.peak_drjit_bytes for r, _ in fits.values()]
    L += ["", f"Time per fit {min(secs):.0f}-{max(secs):.0f} s on 2 cores; Dr.Jit peak memory "
              f"{max(peaks) / 2**20:.0f} MiB.", "",
          "## Which parameters polarization makes identifiable", "",
          "Cramer-Rao bound (relative standard deviation of an unbiased estimate) of each "
          f"parameter at the truth, for Gaussian pixel noise of 1 % of the mean S0 in every "
          f"channel used, from the Jacobian images (forward-mode renders, 128 spp, "
          f"{jac_seconds:.0f} s):", "",
          "| parameter | S0 | S0..S2 | ratio |", "|---|---|---|---|"]
    for i, k in enumerate(keys):
        n = LABELS[k.split(".")[2]]
        L.append(f"| {n} | {100 * crb['S0'][i]:.3g} % | {100 * crb['S0..S2'][i]:.3g} % | "
                 f"{crb['S0'][i] / crb['S0..S2'][i]:.1f} |")
    L += ["", f"Correlation of the n and k estimates: {corr['S0']:+.3f} (S0), "
              f"{corr['S0..S2']:+.3f} (S0..S2).", "",
          "From S0 the complex index enters only through the unpolarized reflectance "
          "ks (R_s + R_p)/2 at the few incidence angles the highlights sample: ks, n and k "
          "trade off along a valley (the n-k correlation above), and Adam ends wherever its "
          "noisy steps leave it on that valley, different for the two starts. S1 and S2 add "
          "(R_s - R_p)/(R_s + R_p), which ks does not scale: the bounds of n, k and ks shrink "
          "by an order of magnitude or more, and the fits from S0..S2 move to the true n, k, ks. "
          "sigma is set by the shape of the highlights either way. The small diffuse weights "
          "kdd and kid change the image little at this resolution and render noise: Adam "
          "trades them against n and k only slowly (see the trajectories: from the farther "
          "start B they are still drifting after the last iteration, n and k with them). A "
          "second-order step using the Jacobian images (`inverse.jacobian`) would converge "
          "faster; Adam is what the issue asked to demonstrate.", "",
          "![loss](figures/inverse_rendering_loss.png)", "",
          "![parameters](figures/inverse_rendering_parameters.png)", "",
          "![images](figures/inverse_rendering_images.png)"]
    with open(args.out, "w") as f:
        f.write("\n".join(L) + "\n")
    print(f"wrote {args.out}")
    return 0


def _figures(fits, truth, keys, target, initial, film, stokes_io):
    import matplotlib
    matplotlib.use("Agg")
    from matplotlib.figure import Figure
    from mitsuba_pbrdf.visualization import panels as visualize

    os.makedirs(FIGURES, exist_ok=True)
    styles = {"S0": "--", "S0..S2": "-"}
    colors = {"A": "tab:blue", "B": "tab:orange"}

    fig = Figure(figsize=(11, 4))
    ax1, ax2 = fig.subplots(1, 2)
    for (s, c), (r, _) in fits.items():
        loss = np.array(r.loss)
        smooth = np.convolve(loss, np.ones(10) / 10, mode="valid")
        ax1.plot(np.arange(len(smooth)) + 9, smooth, styles[c], color=colors[s],
                 label=f"start {s}, fitted on {c}")
        it, value = np.array(r.curve).T
        ax2.plot(it, value, styles[c] + "o", ms=3, color=colors[s],
                 label=f"start {s}, fitted on {c}")
    ax1.set_yscale("log")
    ax1.set_xlabel("iteration")
    ax1.set_ylabel("optimized loss (16 spp, 10-iteration mean)")
    ax1.set_title("loss seen by Adam (floor: render noise)", fontsize=9)
    ax2.set_yscale("log")
    ax2.set_xlabel("iteration")
    ax2.set_ylabel("S0..S2 loss at 256 spp")
    ax2.set_title("S0, S1, S2 loss of the current parameters", fontsize=9)
    ax1.legend(fontsize=7)
    ax2.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(FIGURES, "inverse_rendering_loss.png"), dpi=120)

    fig = Figure(figsize=(12, 6))
    axes = fig.subplots(2, 3).ravel()
    for ax, k in zip(axes, keys):
        for (s, c), (r, _) in fits.items():
            ax.plot([t[k] for t in r.trajectory] + [r.final[k]], styles[c], color=colors[s],
                    label=f"{s}, {c}")
        ax.axhline(truth[k], color="k", lw=0.8)
        ax.set_title(LABELS[k.split(".")[2]])
        ax.set_xlabel("iteration")
    axes[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(FIGURES, "inverse_rendering_parameters.png"), dpi=120)

    images = [("target", target), ("initial (start A)", initial),
              ("fitted from S0 (A)", fits[("A", "S0")][1]),
              ("fitted from S0..S2 (A)", fits[("A", "S0..S2")][1])]
    fig = Figure(figsize=(3.2 * len(images), 6.2))
    axes = fig.subplots(2, len(images))
    exposure = visualize.auto_exposure(stokes_io.from_mitsuba(target, film).rgb)
    for j, (title, img) in enumerate(images):
        si = stokes_io.from_mitsuba(img, film)
        visualize.plot_intensity(axes[0, j], si, exposure=exposure, title=title)
        visualize.plot_dolp(axes[1, j], si)
    fig.tight_layout()
    fig.savefig(os.path.join(FIGURES, "inverse_rendering_images.png"), dpi=110)


if __name__ == "__main__":
    sys.exit(main())
