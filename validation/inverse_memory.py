"""Memory and time of the gradient of a Stokes-image loss, by method and size.

    python validation/inverse_memory.py            # full study (~30 min on 2 cores)
    python validation/inverse_memory.py --quick    # 64 and 128 pixels only

Writes ``validation/inverse_memory.md``. Scene: ``inverse.sphere_scene`` (a
pbrdf sphere on a diffuse floor, two area lights and a sky) with ``path`` at
``max_depth`` 4 inside ``stokes``, loss = squared error of S0, S1, S2 against a
target rendered with other BSDF parameters, gradient with respect to the
sphere's 7 BSDF parameters. Each configuration runs in its own process, which
reports its peak resident memory (``ru_maxrss``, the whole process: Python,
LLVM, Mitsuba and the scene included) and Dr.Jit's allocation watermark
during the gradient. Methods (``mitsuba_pbrdf.inverse.loss_and_gradient``):

* ``path AD``: reverse mode in one pass, exactly what ``mi.render`` +
  ``dr.backward`` computes (tests/test_inverse.py); run only where its
  predicted memory fits the machine, else the prediction is given;
* ``reverse, P passes``: the samples split into P passes with gradient
  accumulation, P chosen for a 4 GiB Dr.Jit budget (``reverse_passes``);
* ``forward``: one forward-mode render per parameter with symbolic loops
  (memory of a primal render).

Gradients "equal within Monte Carlo noise": at 128 x 128, 64 spp, the
gradient of each method over 4 seeds, mean and standard deviation.
"""

import argparse
import json
import os
import resource
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

DEPTH = 4
PARAMS = ("eta", "k", "sigma", "ks", "kdd", "sigma_dd", "kid")
BUDGET = 4 * 1024**3
#: largest predicted reverse-mode memory we run in one pass on this machine
MAX_ONE_PASS = 6 * 1024**3


CHOICE = ("**Choice.** Reverse mode with passes is the default (`method=\"reverse\"`, "
          "`passes=\"auto\"` for a memory budget): its cost is about one AD render of all the "
          "samples whatever the number of parameters, and its memory is set by the budget (here "
          "4 GiB of Dr.Jit memory: 4.5 GiB for the whole process at 512x512, 64 spp). Forward "
          "mode needs only the memory of a primal render (0.27 GiB) but one render per parameter "
          "(3x slower here with 7 parameters): for tight memory or a few parameters. A "
          "polarization-aware path-replay integrator was not written: path replay recovers each "
          "vertex's incident radiance by dividing by the path throughput, which for Mueller "
          "matrices means inverting them, and depolarizing lobes (the diffuse ones, and "
          "Mitsuba's `diffuse`) make them singular; forward mode gives the constant memory "
          "without that.")


def child(config):
    """Run one configuration; print a JSON line."""
    import mitsuba as mi
    import numpy as np

    import mitsuba_pbrdf
    mitsuba_pbrdf.use_variant("llvm_ad_spectral_polarized")
    from mitsuba_pbrdf import inverse

    size, spp = config["size"], config["spp"]
    scene = mi.load_dict(inverse.sphere_scene(size, size, spp, DEPTH))
    params = mi.traverse(scene)
    keys = ["object.bsdf." + p + ".value" for p in PARAMS]
    passes = max(1, spp // 16)
    target = np.array(inverse.render(scene, spp=spp, seed=1000, passes=passes))
    params["object.bsdf.sigma.value"] = 0.18
    params["object.bsdf.eta.value"] = 1.6
    params.update()
    loss = inverse.stokes_loss(scene, target, (0, 1, 2))
    inverse.render(scene, spp=spp, seed=1, passes=passes)  # compiles the primal kernel
    t0 = time.perf_counter()
    inverse.render(scene, spp=spp, seed=2, passes=passes)
    primal_seconds = time.perf_counter() - t0
    rss_before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    out = []
    for seed in config.get("seeds", [5, 6]):  # the first call includes JIT compilation
        value, grads, stats = inverse.loss_and_gradient(
            scene, params, keys, loss, spp=spp, seed=seed, method=config["method"],
            passes=config["passes"])
        out.append({"loss": value, "grads": [float(grads[k][0]) for k in keys],
                    "seconds": stats.seconds, "drjit_peak": stats.drjit_peak_bytes,
                    "renders": stats.renders})
    print(json.dumps({"config": config, "primal_seconds": primal_seconds,
                      "rss_before": rss_before * 1024,
                      "peak_rss": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024,
                      "runs": out}), flush=True)


def run(config):
    proc = subprocess.run([sys.executable, os.path.abspath(__file__), "--child", json.dumps(config)],
                          capture_output=True, text=True, cwd=ROOT)
    lines = [line for line in proc.stdout.splitlines() if line.startswith("{")]
    if proc.returncode != 0 or not lines:
        raise RuntimeError(f"{config}: failed\n{proc.stderr[-3000:]}")
    result = json.loads(lines[-1])
    print(f"  {config}: peak RSS {result['peak_rss'] / 2**30:.2f} GiB, "
          f"{result['runs'][0]['seconds']:.1f} s", flush=True)
    return result


def predicted_reverse_bytes(size, spp):
    from mitsuba_pbrdf.inverse import REVERSE_BYTES_PER_SAMPLE_AND_DEPTH
    return REVERSE_BYTES_PER_SAMPLE_AND_DEPTH * DEPTH * size * size * spp


def main(argv=None):
    import math

    import numpy as np

    args = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    args.add_argument("--quick", action="store_true")
    args.add_argument("--child")
    args.add_argument("--out", default=os.path.join(HERE, "inverse_memory.md"))
    args = args.parse_args(argv)
    if args.child:
        child(json.loads(args.child))
        return 0

    sizes = (64, 128) if args.quick else (128, 256, 512)
    rows = []
    for size in sizes:
        for spp in (16, 64):
            need = predicted_reverse_bytes(size, spp)
            configs = []
            if need <= MAX_ONE_PASS:
                configs.append(("path AD (reverse, 1 pass)", "reverse", 1))
            passes = max(1, math.ceil(need / BUDGET))
            if passes > 1:
                configs.append((f"reverse, {passes} passes", "reverse", passes))
            configs.append(("forward (symbolic loops)", "forward", 1))
            for label, method, p in configs:
                r = run({"size": size, "spp": spp, "method": method, "passes": p})
                rows.append((size, spp, label, need, r))

    # Monte Carlo agreement at 128 x 128, 64 spp, 4 seeds
    seeds = [11, 12, 13, 14]
    noise = {}
    for label, method, p in (("path AD (1 pass)", "reverse", 1), ("reverse, 4 passes", "reverse", 4),
                             ("forward", "forward", 1)):
        r = run({"size": 128 if not args.quick else 64, "spp": 64, "method": method, "passes": p,
                 "seeds": seeds})
        g = np.array([run_["grads"] for run_ in r["runs"]])
        noise[label] = (g.mean(0), g.std(0, ddof=1) / math.sqrt(len(seeds)))

    lines = ["# Memory and time of Stokes-loss gradients",
             "",
             "`python validation/inverse_memory.py` (this file). Sphere scene of "
             "`mitsuba_pbrdf.inverse.sphere_scene`, `path` with max_depth 4 inside `stokes`, "
             "`llvm_ad_spectral_polarized`, 2 CPU cores (shared with other work: times are "
             "indicative), gradient of a squared-error loss on S0, S1, S2 with respect to 7 BSDF "
             "parameters. Peak RSS: the whole process (Python, LLVM, scene: ~0.2 GiB before "
             "rendering). Dr.Jit peak: its allocation watermark during the gradient (bytes "
             "allocated, some never touched, so it can exceed the resident peak). "
             "Prediction for one reverse pass: "
             f"{__import__('mitsuba_pbrdf.inverse', fromlist=['x']).REVERSE_BYTES_PER_SAMPLE_AND_DEPTH}"
             " B x max_depth x pixels x spp.",
             "",
             "Gradient time: first call (with JIT compilation of the kernels) / second call "
             "(kernels cached, as in every later iteration of an optimization). Primal: one "
             "render without derivatives, for scale.",
             "",
             "| pixels | spp | method | predicted 1-pass reverse | peak RSS | Dr.Jit peak | "
             "gradient time, first / next | renders | primal render |",
             "|---|---|---|---|---|---|---|---|---|"]
    for size, spp, label, need, r in rows:
        first, second = r["runs"][0], r["runs"][-1]
        lines.append(f"| {size}x{size} | {spp} | {label} | {need / 2**30:.1f} GiB | "
                     f"{r['peak_rss'] / 2**30:.2f} GiB | "
                     f"{max(x['drjit_peak'] for x in r['runs']) / 2**30:.2f} GiB | "
                     f"{first['seconds']:.1f} s / {second['seconds']:.1f} s | {first['renders']} | "
                     f"{r['primal_seconds']:.1f} s |")
    big = [(s, spp) for s, spp, *_ in rows if s == max(sizes) and spp == 64]
    if big:
        lines += ["", f"The goal, {max(sizes)}x{max(sizes)} at 64 spp and depth 4: path AD in one "
                  f"pass would need ~{predicted_reverse_bytes(max(sizes), 64) / 2**30:.0f} GiB; the "
                  "rows above give the peak memory of the passes and of forward mode.", "",
                  CHOICE, ""]
    # agreement of methods at the big size (same seed 5)
    for size in sizes:
        for spp in (16, 64):
            rs = [(label, r) for s, sp, label, _, r in rows if s == size and sp == spp]
            if len(rs) > 1:
                ref_label, ref = rs[0]
                g0 = np.array(ref["runs"][0]["grads"])
                for label, r in rs[1:]:
                    g = np.array(r["runs"][0]["grads"])
                    lines.append(f"* {size}x{size}, {spp} spp: {label} vs {ref_label}: largest "
                                 f"difference {np.abs(g - g0).max() / np.abs(g0).max():.2e} of the "
                                 "largest component")
    lines += ["", "## Equal within Monte Carlo noise",
              "",
              f"{128 if not args.quick else 64}x{128 if not args.quick else 64}, 64 spp, seeds "
              f"{seeds}: mean gradient +/- standard error of the mean over the seeds.",
              "",
              "| parameter | " + " | ".join(noise) + " |", "|---|" + "---|" * len(noise)]
    for i, p in enumerate(PARAMS):
        lines.append(f"| {p} | " + " | ".join(f"{m[i]:.4g} +/- {e[i]:.2g}"
                                              for m, e in noise.values()) + " |")
    ref_mean, ref_err = noise["path AD (1 pass)"]
    for label, (m, e) in noise.items():
        if label.startswith("path"):
            continue
        z = np.abs(m - ref_mean) / np.sqrt(e**2 + ref_err**2)
        lines.append(f"\n{label} vs path AD: largest |difference| / combined standard error "
                     f"= {z.max():.2f}")
    with open(args.out, "w") as f:
        f.write("\n".join(lines) + "\n")
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
