"""The report of validation/sfp_accuracy.py: a table of the stored runs
(validation/sfp_accuracy/NAME.npz) and a figure (noise floor, learning-rate
schedules, the per-view losses of multi-view aluminium, the best map's errors)."""

from __future__ import annotations

import os

import numpy as np


def load_runs(store, names):
    """The stored runs, in *names* order (missing ones skipped): dicts of arrays."""
    runs = []
    for name in names:
        path = os.path.join(store, f"{name}.npz")
        if os.path.isfile(path):
            with np.load(path, allow_pickle=False) as z:
                runs.append({k: z[k] for k in z.files})
    return runs


def _options(run):
    import ast

    return ast.literal_eval(str(run["options"]))


def table(runs, experiments):
    lines = ["| experiment | what | command | start | iterations x spp | targets | median | "
             "90th pct | loss at 1024 spp: fit / truth | time |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in runs:
        o = _options(r)
        sched = (f"lr {o['lr']} x {o['lr_decay']}^it" if o["lr_decay"] is not None
                 else f"lr {o['lr']} to {o['lr'] * o['lr_end']:.3g}")
        lines.append(
            f"| {r['name']} | {experiments[str(r['name'])][0]}; {o['metal']}, {o['views']} view"
            f"{'s' * (o['views'] > 1)}, {o['observables']}, {o['parametrization']}"
            f"{', smoothness %g' % o['smoothness'] if o['smoothness'] else ''}, {sched}, "
            f"{o['size']} px | `{r['command']}` | {o['start']} ({float(r['start_median']):.2f}) | "
            f"{o['iterations']} x {o['spp']} | {o['target_spp']} spp | {float(r['median']):.2f} | "
            f"{float(r['p90']):.2f} | {float(r['fit_loss']):.5f} / {float(r['truth_loss']):.5f} "
            f"({float(r['fit_loss']) / float(r['truth_loss']):.3f}) | {float(r['seconds']):.0f} s |")
    return lines


def figure(runs, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from mitsuba_pbrdf.visualization.png import save_png

    by = {str(r["name"]): r for r in runs}
    fig, axes = plt.subplots(2, 3, figsize=(15, 9))
    ax = axes[0, 0]
    for r in runs:
        if _options(r)["start"] == "truth" and _options(r)["views"] == 1:
            ax.plot(r["loss"], lw=1, label=f"{r['name']}: {float(r['median']):.2f}°")
    ax.set_title("(a) start at the truth: data loss per iteration")
    ax.set_xlabel("iteration")
    ax.set_ylabel("loss (noisy, at the fit's spp)")
    ax.set_yscale("log")
    ax.legend(fontsize=6)
    ax = axes[0, 1]
    for r in runs:
        o = _options(r)
        if o["start"] == "flat" and o["views"] == 1 and o["metal"] == "Cu":
            ax.semilogy(r["rates"], lw=1, label=f"{r['name']}: {float(r['median']):.2f}°")
    ax.set_title("(b) learning rate per iteration (final median error)")
    ax.set_xlabel("iteration")
    ax.legend(fontsize=6)
    ax = axes[0, 2]
    names = [str(r["name"]) for r in runs if _options(r)["metal"] == "Cu"]
    ratio = [float(by[n]["fit_loss"]) / float(by[n]["truth_loss"]) for n in names]
    med = [float(by[n]["median"]) for n in names]
    ax.scatter(ratio, med, s=12)
    for n, x, y in zip(names, ratio, med):
        ax.annotate(n, (x, y), fontsize=5)
    ax.axvline(1.0, color="k", lw=0.5)
    ax.set_xlabel("loss at 1024 spp of the fit / of the truth")
    ax.set_ylabel("median angular error (deg)")
    ax.set_xscale("log")
    ax.set_title("(c) error vs loss of the fit / the truth's (<= 1: at the floor)")
    ax = axes[1, 0]
    for n in ("al3-truth-40x16", "al3-truth-fixed-40x16"):
        if n in by:
            vl = np.atleast_2d(by[n]["view_loss"])
            for v in range(vl.shape[1]):
                ax.plot(vl[:, v] / vl[0, v], lw=1, label=f"{n}, view {v}")
    ax.set_title("(d) aluminium: each view's loss / its first")
    ax.set_xlabel("iteration")
    ax.legend(fontsize=6)
    best = by.get("t4096-200x128")
    for ax, r, title in ((axes[1, 1], best, "one view, Stokes, flat start"),
                         (axes[1, 2], by.get("truth-128spp"), "start at truth, 128 spp")):
        if r is None:
            ax.axis("off")
            continue
        err = np.where(r["visible"], r["error"], np.nan)
        im = ax.imshow(err, origin="upper", vmin=0, vmax=15, cmap="magma")
        ax.set_title(f"{title} ({r['name']}):\nerror per texel, median {float(r['median']):.2f}°")
        fig.colorbar(im, ax=ax, label="deg", shrink=0.8)
    fig.tight_layout()
    save_png(fig, path, dpi=100)
    plt.close(fig)


def write_report(store, report, figure_path, experiments, preamble=(), reading=()):
    """Write the table and figure of the runs stored under *store*
    (*experiments*: name -> (description, options), in the table's order)."""
    from mitsuba_pbrdf.outputs import write_text

    runs = load_runs(store, list(experiments))
    lines = ["# What limits shape from polarization's accuracy", "",
             "`python validation/sfp_accuracy.py report` (this file) from the runs below, each "
             "made by its command (`llvm_ad_spectral_polarized`, 2 cores shared with other "
             "jobs, under `nice`); see the script's docstring for the plate and the options "
             "every experiment shares.", "", *preamble, "", *table(runs, experiments), "",
             f"![experiments](figures/{os.path.basename(figure_path)})", ""]
    coverage = os.path.join(store, "coverage.md")
    if os.path.isfile(coverage):
        with open(coverage) as f:
            lines += ["## Where the errors sit", "",
                      "`python validation/sfp_accuracy.py coverage`.", "",
                      *f.read().splitlines(), ""]
    views = os.path.join(store, "views.md")
    if os.path.isfile(views):
        with open(views) as f:
            lines += ["## Each view's gradient at the flat start", "",
                      "`python validation/sfp_accuracy.py views` (proof/sfp_view_gradients.py): "
                      "three views, flat map, Stokes loss against 256-spp targets. g . d: the "
                      "view's stokes_prb gradient (256 spp) along d, the unit direction of minus "
                      "the sum of the three; FD along d: central difference of the view's loss, "
                      "step 2e-3, the same random numbers; then the norm of the view's gradient "
                      "at 1024 spp and the RMS norm of (16-spp gradient - it) over 8 seeds.", "",
                      *f.read().splitlines(), ""]
    lines += [*reading, ""]
    write_text(report, "\n".join(lines))
    figure(runs, figure_path)
    print(f"wrote {report} and {figure_path}")


def texel_coverage(texels=16, size=48, supersample=8):
    """(texels, texels) pixels of view 0 of the plate (proof/sfp_study.py's
    scene) whose footprint falls in each texel: camera rays on a grid of
    ``supersample`` x ``supersample`` per pixel, hits binned by uv. A variant
    must be set."""
    import mitsuba as mi

    from mitsuba_pbrdf.inverse.normals import scenes as ns

    scene = mi.load_dict(ns.plate_scene(ns.true_normals(texels), size=size))
    n = size * supersample
    y, x = np.meshgrid((np.arange(n) + 0.5) / n, (np.arange(n) + 0.5) / n, indexing="ij")
    ray, _ = scene.sensors()[0].sample_ray(0.0, 0.5, mi.Point2f(x.ravel(), y.ravel()),
                                           mi.Point2f(0.5, 0.5))
    si = scene.ray_intersect(ray)
    valid = np.array(si.is_valid())
    uv = np.array(si.uv)[:, valid]
    rows = np.clip((uv[1] * texels).astype(int), 0, texels - 1)
    cols = np.clip((uv[0] * texels).astype(int), 0, texels - 1)
    count = np.zeros((texels, texels))
    np.add.at(count, (rows, cols), 1.0 / supersample ** 2)
    return count


def coverage_lines(store, names, coverage):
    """Table rows: where the errors of the runs *names* sit (few or many
    pixels per texel, border or interior, steep or gentle true normals)."""
    from mitsuba_pbrdf.inverse.normals import scenes as ns

    tilt = np.degrees(np.arccos(ns.true_normals(coverage.shape[0])[..., 2]))
    border = np.zeros(coverage.shape, bool)
    border[[0, -1], :] = border[:, [0, -1]] = True
    few = coverage < np.median(coverage)
    lines = [f"Pixels of view 0 per texel: {coverage.min():.1f} to {coverage.max():.1f}, "
             f"median {np.median(coverage):.1f} (48 x 48 pixels, 16 x 16 texels). Median error "
             "(degrees) of the visible texels by group:", "",
             "| experiment | fewer pixels than the median | more | border | interior | "
             "true tilt > 15° | true tilt < 8° |", "|---|---|---|---|---|---|---|"]
    for r in load_runs(store, names):
        e, vis = r["error"], r["visible"]
        cells = [np.median(e[vis & m]) for m in (few, ~few, border, ~border, tilt > 15, tilt < 8)]
        lines.append(f"| {r['name']} | " + " | ".join(f"{c:.2f}" for c in cells) + " |")
    return lines
