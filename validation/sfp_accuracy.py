"""What limits shape from polarization's accuracy: the experiments behind
validation/shape_from_polarization.md's reading (issue 20).

    python validation/sfp_accuracy.py run NAME [NAME ...]   # one experiment each
    python validation/sfp_accuracy.py views                  # each view's gradient: FD, noise
    python validation/sfp_accuracy.py coverage               # where the errors sit
    python validation/sfp_accuracy.py report                 # the report from the stored runs
    python validation/sfp_accuracy.py list

Every experiment is a named set of options of proof/sfp_study.py's plate
(copper, one view, Stokes, 16 x 16 texels, 48 x 48 pixels, targets at 256
spp unless it says otherwise) and of recover_normals; its results (errors,
losses, the learning rates, the command that made it) go to
``validation/sfp_accuracy/NAME.npz``; ``report`` writes
``validation/sfp_accuracy.md`` and ``validation/figures/sfp_accuracy.png``.

Besides the angular error over the visible texels, each run reports the data
loss of the recovered map and of the true map, both rendered at 1024 spp with
the same seeds against the same targets ("loss at 1024 spp: fit / truth"): a
fit whose loss is above the truth's has not converged (an optimizer limit);
one whose loss equals or undercuts the truth's while its normals are off is
limited by what the images say (noise in the targets, ambiguity).
"""

import argparse
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

STORE = os.path.join(HERE, "sfp_accuracy")
REPORT = os.path.join(HERE, "sfp_accuracy.md")
FIGURE = os.path.join(HERE, "figures", "sfp_accuracy.png")
EVAL_SPP = 1024

BASE = dict(metal="Cu", views=1, observables="stokes", texels=16, size=48, iterations=200,
            spp=32, target_spp=256, lr=0.05, lr_end=0.1, lr_decay=None,
            parametrization="normals", smoothness=0.0, start="flat", seed=0)

#: name -> (what it tests, options that differ from BASE)
EXPERIMENTS = {
    # (a) noise floor: start at the truth
    "truth-16spp-old": ("noise floor: start at the truth, 16 spp, the 40-iteration rows' "
                        "schedule", dict(start="truth", iterations=100, spp=16, lr_decay=0.97)),
    "truth-32spp": ("noise floor: start at the truth, 32 spp, new schedule",
                    dict(start="truth", iterations=100)),
    "truth-128spp": ("noise floor: start at the truth, 128 spp, new schedule",
                     dict(start="truth", iterations=100, spp=128)),
    "truth-intensity": ("noise floor of intensity: start at the truth",
                        dict(start="truth", iterations=100, observables="intensity")),
    "truth-1024target": ("noise floor with targets at 1024 spp",
                         dict(start="truth", iterations=100, target_spp=1024)),
    "truth-4096target-128spp": ("noise floor with targets at 4096 spp, 128 spp",
                                dict(start="truth", iterations=100, spp=128, target_spp=4096)),
    # (b) schedules, from a flat start
    "old-200x32": ("the old --long row: lr 0.05 x 0.99^it", dict(lr_decay=0.99)),
    "old-200x32-097": ("lr 0.05 x 0.97^it: frozen after ~100 iterations", dict(lr_decay=0.97)),
    "end0.1-200x32": ("lr 0.05 down to 0.005 at the last iteration", dict()),
    "end0.1-40x16": ("the 40-iteration rows with the new schedule", dict(iterations=40, spp=16)),
    "old-40x16": ("the 40-iteration rows as they were", dict(iterations=40, spp=16,
                                                            lr_decay=0.97)),
    "t4096-200x128": ("targets at 4096 spp, 128 spp", dict(spp=128, target_spp=4096)),
    "intensity-t4096-200x128": ("intensity only, targets at 4096 spp, 128 spp",
                                dict(observables="intensity", spp=128, target_spp=4096)),
    # the same two fits with other seeds (targets' noise and the fits' samples)
    "t4096-200x128-seed1": ("t4096-200x128, seed 1", dict(spp=128, target_spp=4096, seed=1)),
    "t4096-200x128-seed2": ("t4096-200x128, seed 2", dict(spp=128, target_spp=4096, seed=2)),
    "intensity-t4096-200x128-seed1": ("intensity-t4096-200x128, seed 1",
                                      dict(observables="intensity", spp=128, target_spp=4096,
                                           seed=1)),
    "intensity-t4096-200x128-seed2": ("intensity-t4096-200x128, seed 2",
                                      dict(observables="intensity", spp=128, target_spp=4096,
                                           seed=2)),
    # raw polarization-camera frames (16 bits, shot and read noise) of 4096-spp renders
    "polcam-bright-t4096-200x128": ("polcam frames, brightest pixel at full well, of 4096-spp "
                                    "renders", dict(observables="polcam-bright", spp=128,
                                                    target_spp=4096)),
    "polcam-dim-t4096-200x128": ("polcam frames, 16x less light, of 4096-spp renders",
                                 dict(observables="polcam-dim", spp=128, target_spp=4096)),
    # (c) parametrization and smoothness
    "height-t4096-200x128": ("height field, targets at 4096 spp",
                             dict(parametrization="height", spp=128, target_spp=4096)),
    "height-lr0.2-t4096-200x128": ("height field, lr 0.2 to 0.02, targets at 4096 spp",
                                   dict(parametrization="height", spp=128, target_spp=4096,
                                        lr=0.2)),
    "height-lr0.5-t4096-200x128": ("height field, lr 0.5 to 0.05, targets at 4096 spp",
                                   dict(parametrization="height", spp=128, target_spp=4096,
                                        lr=0.5)),
    "smooth1e-3-t4096-200x128": ("smoothness 1e-3, targets at 4096 spp",
                                 dict(smoothness=1e-3, spp=128, target_spp=4096)),
    # (d) resolution
    "96px-t4096-200x32": ("96 x 96 pixels at 32 spp (the samples of 48 x 48 at 128), "
                          "targets at 4096 spp", dict(size=96, target_spp=4096)),
    # multi-view aluminium (the rising loss)
    "al3-old-40x16": ("Al, 3 views, the old 40-iteration row, BEFORE the multi-view gradient "
                      "fix (commit 7e179f0)", dict(metal="Al", views=3,
                                                                    iterations=40, spp=16,
                                                                    lr_decay=0.97)),
    "al1-old-40x16": ("Al, 1 view, the old 40-iteration row", dict(metal="Al", iterations=40,
                                                                   spp=16, lr_decay=0.97)),
    "cu3-truth-40x16": ("Cu, 3 views, start at the truth, BEFORE the fix", dict(views=3, iterations=40, spp=16,
                                                               lr_decay=0.97, start="truth")),
    "al1-truth-40x16": ("Al, 1 view, start at the truth", dict(metal="Al", iterations=40,
                                                              spp=16, lr_decay=0.97,
                                                              start="truth")),
    "al3-truth-40x16": ("Al, 3 views, start at the truth, BEFORE the fix", dict(metal="Al", views=3,
                                                               iterations=40, spp=16,
                                                               lr_decay=0.97, start="truth")),
    "al3-fixed-40x16": ("Al, 3 views, the old 40-iteration row, after the fix",
                        dict(metal="Al", views=3, iterations=40, spp=16, lr_decay=0.97)),
    "al3-truth-fixed-40x16": ("Al, 3 views, start at the truth, after the fix",
                              dict(metal="Al", views=3, iterations=40, spp=16, lr_decay=0.97,
                                   start="truth")),
}


#: Runs whose errors `coverage` splits by texel group.
COVERAGE_RUNS = ("t4096-200x128", "truth-4096target-128spp", "end0.1-200x32",
                 "intensity-t4096-200x128", "96px-t4096-200x32")

READING = [
    "## Reading", "",
    "* **Noise in the targets is the floor at 256 spp.** Started at the true map, a fit against "
    "256-spp targets drifts to a median of 3.76° (16 spp, the old schedule), 2.81° (32 spp) "
    "and 2.16° (128 spp), and in every case its loss at 1024 spp ends *below* the true map's: "
    "the free normals absorb the targets' Monte Carlo noise (a least-squares fit of 512 "
    "unknowns to noisy pixels), so the least-squares optimum is not the truth. From a flat "
    "start, 200 x 32 spp reaches 3.59° with a loss equal to the truth's (ratio 0.995): the "
    "fit is at that floor, and no schedule or iteration count takes it further. With "
    "targets at 4096 spp the floor from the truth is 1.26° (128 spp) and the flat start "
    "reaches 1.49° (p90 6.92°) in 200 x 128 spp, its loss still 1.4 x the truth's (not fully "
    "converged).",
    "* **Raw polarization-camera frames of clean renders.** The same fit from the 16-bit mono "
    "IMX250MZR mosaic (shot and read noise) of the 4096-spp renders: 4.25° (p90 12.04°) with "
    "the brightest pixel at full well, its loss 1.24 x the truth's; 7.70° (p90 20.61°) with "
    "16 x less light, its loss 0.66 x the truth's (the fit absorbs the sensor's noise: that is "
    "the floor). Against Stokes images' 1.49°: each pixel sees one polarizer angle, so a "
    "texel's polarization comes from a quarter of its pixels, and shot noise at a full well of "
    "10,500 electrons (1 % of the signal at the brightest pixel, 3 % at a tenth of it) on a "
    "polarized part of 0.14 of S0 (copper's median DoLP) leaves one pixel's AoLP uncertain by "
    "about 0.014 / (2 x 0.14) rad = 3° where bright and 9° at a tenth, against the 4096-spp "
    "images' Monte Carlo noise.",
    "* **Repeated with other seeds.** The same two flat-start fits against 4096-spp targets, "
    "with seeds 1 and 2 (other target noise, other samples in the fit): Stokes 1.43° and 1.50° "
    "(p90 7.39°, 7.85°) beside seed 0's 1.49°; intensity 5.73° and 5.91° beside 6.05°. Three "
    "runs each: the Stokes median stays under the 2° goal in all three and intensity stays "
    "about 4x worse; three runs give a range, not an uncertainty.",
    "* **Gradient noise sets the second floor.** Targets at 1024 spp, 32 spp per iteration: "
    "from the truth 2.60° with a loss 1.34 x the truth's, i.e. the random walk of Adam on "
    "16-32-spp gradients, not the targets, now limits it; 128 spp per iteration halves it.",
    "* **The schedule.** lr x 0.97^it is a twentieth of its start after 100 iterations: 200 "
    "iterations at 32 spp end at 4.01° with the loss still 1.10 x the truth's (frozen before "
    "the floor); lr x 0.99^it (3.51°) and the new default, a geometric decay to 0.1 x lr at "
    "the last iteration whatever the iteration count (3.59°), both reach the floor.",
    "* **Ambiguity: intensity alone cannot get there.** From the truth, an intensity-only fit "
    "drifts to 4.76° with a loss 0.86 x the truth's; with 4096-spp targets the flat start "
    "stops at 6.05° (p90 18.76°) with a loss only 1.11 x the truth's while Stokes reaches "
    "1.49°: S0 leaves directions of the normal free (tilt across the plane of incidence under "
    "a sky that changes mostly with elevation); AoLP pins the azimuth of the plane of "
    "incidence (its 180° ambiguity does not matter from a flat start with tilts under 25°).",
    "* **Multi-view fits fitted the last view only (a bug, fixed).** Started at the truth, "
    "aluminium from three views drifted to 7.32° with a loss at 1024 spp 26 x the truth's, "
    "view 0's loss rising from 0.10 to 0.35 while view 2's stayed flat; copper did the same "
    "(4.63°, 13 x). A loop of `dr.backward` through `mi.render` with `stokes_prb` leaves the "
    "texels holding the last view's gradient only (tests/inverse/test_normals.py asserts it); "
    "`summed_gradients` now reads and sums the views' gradients. With it, aluminium from "
    "three views at 40 x 16 spp reaches 3.03° (9.58° before; 8.40° from one view). Each "
    "view's gradient itself was right (the `views` table: it matches finite differences), "
    "and neither the loss summation nor Adam's state nor the learning rate was the cause.",
    "* **Parametrization, smoothness, resolution are not the limit.** A height field "
    "(integrable, half the unknowns) converges more slowly at the same schedule: 3.73° with a "
    "loss 5.7 x the truth's after 200 x 128 spp (the low-frequency heights need many small "
    "steps). Larger rates do not fix it: lr 0.2 gives 2.63° and lr 0.5 3.90°, both with the "
    "loss 5.2 x the truth's (the true map is exactly a height field on this grid, so this is "
    "convergence, not representation: a multi-scale or preconditioned height fit is left "
    "undone). A smoothness weight of 1e-3 gives 1.42° against 1.49° without (within one run's "
    "scatter). 96 x 96 pixels (about 15 per texel instead of 4) at the same samples per "
    "iteration gives 1.38°. The errors do not sit where few pixels see a texel, nor at the "
    "border (`coverage` table): they sit on the steep texels (true tilt above 15°), farthest "
    "from the flat start and reflecting the sky's dim lower part, and that excess vanishes "
    "from the truth (a convergence effect, not a floor).",
]


def run(name):
    import mitsuba as mi

    from mitsuba_pbrdf.inverse.normals import scenes as ns
    from mitsuba_pbrdf.inverse.normals.targets import observable_loss
    from mitsuba_pbrdf.inverse.normals import recover_normals

    what, overrides = EXPERIMENTS[name]
    o = dict(BASE, **overrides)
    truth = ns.true_normals(o["texels"])
    scene = mi.load_dict(ns.plate_scene(truth, metal=o["metal"], views=o["views"],
                                        size=o["size"]))
    targets = ns.render_targets(scene, spp=o["target_spp"], seed=10_000 + o["seed"])
    observables = o["observables"]
    if observables.startswith("polcam"):
        # the 16-bit mono mosaic with shot and read noise, as in the study
        from proof.sfp_study import EXPOSURES, polcam_frames

        targets = polcam_frames(targets, scene, EXPOSURES[observables.split("-")[1]],
                                seed=o["seed"])
        observables = "polcam"
    flat = np.zeros_like(truth)
    flat[..., 2] = 1.0
    start = truth if o["start"] == "truth" else flat
    t0 = time.perf_counter()
    result = recover_normals(ns.plate_scene(flat, metal=o["metal"], views=o["views"],
                                            size=o["size"]),
                             targets, observables=observables,
                             parametrization=o["parametrization"], smoothness=o["smoothness"],
                             iterations=o["iterations"], spp=o["spp"], lr=o["lr"],
                             lr_end=o["lr_end"], lr_decay=o["lr_decay"], truth=truth,
                             start=start if o["parametrization"] == "normals" else None,
                             seed=o["seed"])
    seconds = time.perf_counter() - t0
    if o["parametrization"] == "height" and o["start"] == "truth":
        raise SystemExit("height fits start flat here")

    def high_spp_loss(normals):
        s = mi.load_dict(ns.plate_scene(normals, metal=o["metal"], views=o["views"],
                                        size=o["size"]))
        total = 0.0
        for i, t in enumerate(targets):
            loss = observable_loss(s, t, observables, sensor=i)
            total += float(loss(mi.render(s, sensor=i, spp=EVAL_SPP, seed=77_000 + i))[0])
        return total

    fit_loss, truth_loss = high_spp_loss(result.normals), high_spp_loss(truth)
    err = result.angular_error[result.visible]
    os.makedirs(STORE, exist_ok=True)
    path = os.path.join(STORE, f"{name}.npz")
    np.savez_compressed(path, name=name, what=what, options=repr(o),
                        command=f"python validation/sfp_accuracy.py run {name}",
                        median=np.median(err), p90=np.percentile(err, 90),
                        start_median=np.median(result.start_error[result.visible]),
                        seconds=seconds, loss=np.array(result.loss),
                        view_loss=result.info["view_loss"],
                        view_grad=result.info["view_gradient_norm"], rates=result.info["learning_rates"],
                        fit_loss=fit_loss, truth_loss=truth_loss, normals=result.normals,
                        truth=truth, error=result.angular_error, visible=result.visible)
    print(f"{name}: median {np.median(err):.2f}°, p90 {np.percentile(err, 90):.2f}°, "
          f"loss at {EVAL_SPP} spp fit {fit_loss:.5g} / truth {truth_loss:.5g}, "
          f"{seconds:.0f} s", flush=True)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("action", nargs="?", default="report",
                   choices=("run", "views", "coverage", "report", "list"))
    p.add_argument("names", nargs="*")
    p.add_argument("--variant", default="llvm_ad_spectral_polarized")
    args = p.parse_args(argv)
    if args.action == "list":
        for k, (what, o) in EXPERIMENTS.items():
            print(f"{k}: {what} {o}")
        return
    if args.action == "report":
        from proof.sfp_accuracy_report import write_report
        write_report(STORE, REPORT, FIGURE, EXPERIMENTS, reading=READING)
        return
    import mitsuba_pbrdf
    mitsuba_pbrdf.use_variant(args.variant)
    if args.action == "coverage":
        from mitsuba_pbrdf.outputs import write_text
        from proof.sfp_accuracy_report import coverage_lines, texel_coverage

        lines = coverage_lines(STORE, COVERAGE_RUNS, texel_coverage())
        write_text(os.path.join(STORE, "coverage.md"), "\n".join(lines) + "\n")
        print("\n".join(lines))
        return
    if args.action == "views":
        from mitsuba_pbrdf.outputs import write_text
        from proof.sfp_view_gradients import gradient_noise, view_gradients

        lines = ["| metal | view | g . d | FD along d | abs(g) at 256 spp | abs(g) at 1024 spp "
                 "| noise at 16 spp |", "|---|---|---|---|---|---|---|"]
        for metal in ("Al", "Cu"):
            checks, noise = view_gradients(metal), gradient_noise(metal)
            for v in range(3):
                lines.append(f"| {metal} | {v} | {checks[v][0]:.4g} | {checks[v][1]:.4g} | "
                             f"{checks[v][2]:.4g} | {noise[v][0]:.4g} | {noise[v][1]:.4g} |")
                print(lines[-1], flush=True)
        write_text(os.path.join(STORE, "views.md"), "\n".join(lines) + "\n")
        return
    for name in args.names:
        if name not in EXPERIMENTS:
            raise SystemExit(f"unknown experiment {name!r}; see `list`")
    for name in args.names:
        run(name)


if __name__ == "__main__":
    main()
