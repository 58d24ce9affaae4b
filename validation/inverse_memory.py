"""Memory and time of the gradient of a Stokes-image loss, by method and size.

    python validation/inverse_memory.py            # full study (~1 h on 2 cores)
    python validation/inverse_memory.py --quick    # 64 and 128 pixels, 16 and 64 spp
    python validation/inverse_memory.py --normalmap --methods primal,prb --sizes 512 \
        --spps 64 --reps 3 --section "Goal row: normal map and 7 parameters"

``--normalmap`` wraps the sphere's pbrdf in a ``polarized_normalmap`` whose
texels are differentiated too; ``--reps`` interleaves primal renders and
gradients in each process and reports medians; ``--section`` writes the rows
as a section of the report instead of rewriting it.

Writes ``validation/inverse_memory.md``. Scene: ``inverse.sphere_scene`` (a
pbrdf sphere on a diffuse floor, two area lights and a sky) with ``path`` at
``max_depth`` 4 inside ``stokes``, loss = squared error of S0, S1, S2 against a
target rendered with other BSDF parameters, gradient with respect to the
sphere's 7 BSDF parameters. Each configuration runs in its own process, which
reports its peak resident memory (``ru_maxrss``, the whole process: Python,
LLVM, Mitsuba and the scene included) and Dr.Jit's allocation watermark
during the gradient. Rows (``mitsuba_pbrdf.inverse.loss_and_gradient``):

* ``primal render``: a process that renders the image only (no gradient),
  the reference for the memory and time ratios;
* ``stokes_prb``: polarized path replay (``method="prb"``, the default
  ``"auto"`` for this scene): primal render + one replay of all samples;
* ``path AD``: reverse mode through ``path`` in one pass, run only where its
  predicted memory fits the machine;
* ``reverse, P passes``: the samples split into P passes with gradient
  accumulation, P chosen for a 4 GiB Dr.Jit budget (``reverse_passes``);
* ``forward``: one forward-mode render per parameter with symbolic loops
  (memory of a primal render); run up to 64 spp (its time grows linearly
  with the samples and the number of parameters).

Times are wall-clock seconds on a shared 2-core machine; ratios are taken
within one process (gradient / primal render of the same process), which
cancels most of the machine's drift.
"""

import argparse
import json
import math
import os
import resource
import statistics
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
#: forward mode is run up to this many samples per pixel
MAX_FORWARD_SPP = 64
#: texels per side of the normal map of --normalmap
TEXELS = 64
#: the variant of the study (--variant, e.g. cuda_ad_spectral_polarized on a GPU)
VARIANT = "llvm_ad_spectral_polarized"


def child(config):
    """Run one configuration; print a JSON line."""
    import drjit as dr
    import mitsuba as mi
    import numpy as np

    import mitsuba_pbrdf
    mitsuba_pbrdf.use_variant(config.get("variant", VARIANT))
    from mitsuba_pbrdf import inverse

    size, spp = config["size"], config["spp"]
    normalmap = config.get("normalmap", False)
    scene = mi.load_dict(normalmap_sphere(size, spp) if normalmap
                         else inverse.sphere_scene(size, size, spp, DEPTH))
    params = mi.traverse(scene)
    keys = bsdf_keys(normalmap)
    prefix = "object.bsdf.nested_bsdf." if normalmap else "object.bsdf."
    passes = max(1, spp // 64)
    target = np.array(inverse.render(scene, spp=spp, seed=1000, passes=passes))
    params[prefix + "sigma.value"] = 0.18
    params[prefix + "eta.value"] = 1.6
    params.update()
    loss = inverse.stokes_loss(scene, target, (0, 1, 2))
    del target

    def primal(seed):
        dr.sync_thread()
        t0 = time.perf_counter()
        image = inverse.render(scene, spp=spp, seed=seed, passes=1)
        dr.eval(image)
        dr.sync_thread()
        return time.perf_counter() - t0

    def gradient(seed):
        value, grads, stats = inverse.loss_and_gradient(
            scene, params, keys, loss, spp=spp, seed=seed, method=config["method"],
            passes=config["passes"])
        return {"loss": value, "grads": [float(grads[k][0]) for k in keys],
                "seconds": stats.seconds, "drjit_peak": stats.drjit_peak_bytes,
                "renders": stats.renders}

    primal(1)  # compiles the primal kernel
    reps = config.get("reps")
    out, ratios = [], []
    if reps and config["method"] != "primal":
        # interleaved: a primal render, then a gradient, reps times (after
        # one gradient that compiles); medians of the times and ratios
        out.append(gradient(4))
        primals = []
        for r in range(reps):
            primals.append(primal(10 + r))
            out.append(gradient(5 + r))
            ratios.append(out[-1]["seconds"] / primals[-1])
        primal_seconds = statistics.median(primals)
    else:
        primal_seconds = (statistics.median([primal(10 + r) for r in range(reps)]) if reps
                          else min(primal(2), primal(3)))
        if config["method"] != "primal":
            for seed in config.get("seeds", [5, 6]):  # the first call includes JIT compilation
                out.append(gradient(seed))
    result = {"config": config, "primal_seconds": primal_seconds,
              "peak_rss": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024, "runs": out}
    if ratios:
        result["median_seconds"] = statistics.median(r["seconds"] for r in out[1:])
        result["median_ratio"] = statistics.median(ratios)
    print(json.dumps(result), flush=True)


def normalmap_sphere(size, spp):
    """The study's sphere scene dict with its pbrdf wrapped in a
    ``polarized_normalmap`` of :data:`TEXELS` x :data:`TEXELS` texels (the
    bumps of ``inverse.normals.scenes.true_normals``)."""
    from mitsuba_pbrdf import inverse
    from mitsuba_pbrdf.inverse.normals.scenes import true_normals
    from mitsuba_pbrdf.inverse.normals.texels import normalmap_texture

    pbrdf = {"type": "pbrdf", "eta": 2.0, "k": 4.0, "sigma": 0.12, "ks": 1.0,
             "kdd": 0.1, "sigma_dd": 0.5, "kid": 0.03}
    bsdf = {"type": "polarized_normalmap", "normalmap": normalmap_texture(true_normals(TEXELS)),
            "bsdf": pbrdf}
    return inverse.sphere_scene(size, size, spp, DEPTH, bsdf=bsdf)


def bsdf_keys(normalmap):
    """The differentiated parameters: the 7 of pbrdf (and the normal map's texels)."""
    if normalmap:
        return (["object.bsdf.nested_bsdf." + p + ".value" for p in PARAMS]
                + ["object.bsdf.normalmap.data"])
    return ["object.bsdf." + p + ".value" for p in PARAMS]


def run(config):
    proc = subprocess.run([sys.executable, os.path.abspath(__file__), "--child", json.dumps(config)],
                          capture_output=True, text=True, cwd=ROOT)
    lines = [line for line in proc.stdout.splitlines() if line.startswith("{")]
    if proc.returncode != 0 or not lines:
        raise RuntimeError(f"{config}: failed\n{proc.stderr[-3000:]}")
    result = json.loads(lines[-1])
    seconds = result["runs"][-1]["seconds"] if result["runs"] else result["primal_seconds"]
    print(f"  {config}: peak RSS {result['peak_rss'] / 2**30:.2f} GiB, {seconds:.1f} s",
          flush=True)
    return result


def predicted_reverse_bytes(size, spp):
    from mitsuba_pbrdf.inverse import REVERSE_BYTES_PER_SAMPLE_AND_DEPTH
    return REVERSE_BYTES_PER_SAMPLE_AND_DEPTH * DEPTH * size * size * spp


def plan(sizes, spps):
    """(size, spp, label, method, passes) of every configuration."""
    configs = []
    for size in sizes:
        for spp in spps:
            need = predicted_reverse_bytes(size, spp)
            configs.append((size, spp, "primal render", "primal", 1))
            configs.append((size, spp, "stokes_prb", "prb", 1))
            if need <= MAX_ONE_PASS:
                configs.append((size, spp, "path AD (1 pass)", "reverse", 1))
            passes = max(1, math.ceil(need / BUDGET))
            if passes > 1:
                configs.append((size, spp, f"path AD, {passes} passes", "reverse", passes))
            if spp <= MAX_FORWARD_SPP:
                configs.append((size, spp, "forward (symbolic loops)", "forward", 1))
    return configs


def table(rows):
    """Markdown cost table: each gradient row against the primal-render
    process of the same size and spp."""
    primal = {(s, spp): r for s, spp, label, r in rows if label == "primal render"}
    rows = [r for r in rows if r[:2] in primal]
    lines = ["| pixels | spp | method | peak RSS | RSS / primal process | Dr.Jit peak | "
             "gradient time, first / next | next / primal render | renders |",
             "|---|---|---|---|---|---|---|---|---|"]
    for size, spp, label, r in rows:
        p = primal[(size, spp)]
        if label == "primal render":
            lines.append(f"| {size}x{size} | {spp} | primal render | "
                         f"{r['peak_rss'] / 2**30:.2f} GiB | 1 | | {r['primal_seconds']:.1f} s | 1 "
                         f"| 1 |")
            continue
        first, second = r["runs"][0], r["runs"][-1]
        seconds = r.get("median_seconds", second["seconds"])
        ratio = r.get("median_ratio", second["seconds"] / r["primal_seconds"])
        lines.append(
            f"| {size}x{size} | {spp} | {label} | {r['peak_rss'] / 2**30:.2f} GiB | "
            f"{r['peak_rss'] / p['peak_rss']:.2f} | "
            f"{max(x['drjit_peak'] for x in r['runs']) / 2**30:.2f} GiB | "
            f"{first['seconds']:.1f} s / {seconds:.1f} s | "
            f"{ratio:.2f} | {first['renders']} |")
    return lines


def main(argv=None):
    args = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    args.add_argument("--quick", action="store_true")
    args.add_argument("--child")
    args.add_argument("--out", default=os.path.join(HERE, "inverse_memory.md"))
    args.add_argument("--cache", help="JSON file of finished configurations (reused)")
    args.add_argument("--methods", help="run only these (comma-separated: primal, prb, reverse, "
                      "forward); rows of others found in --cache are still reported")
    args.add_argument("--sizes", help="image sizes to run (comma-separated; default 128,256,512)")
    args.add_argument("--spps", help="samples per pixel to run (comma-separated; default "
                      "16,64,256)")
    args.add_argument("--normalmap", action="store_true",
                      help=f"wrap the sphere's pbrdf in a polarized_normalmap ({TEXELS}x{TEXELS} "
                      "texels) and differentiate its texels too")
    args.add_argument("--reps", type=int,
                      help="interleave this many primal renders and gradients in each process "
                      "and report medians (default: one primal-render pair, then two gradients)")
    args.add_argument("--section",
                      help="write the rows as a section of this title in --out, replacing a "
                      "section of the same title, instead of rewriting the whole report")
    args.add_argument("--variant", default=VARIANT,
                      help=f"Mitsuba variant (default {VARIANT}; cuda_ad_spectral_polarized on a GPU)")
    args = args.parse_args(argv)
    if args.child:
        child(json.loads(args.child))
        return 0

    sizes, spps = ((64, 128), (16, 64)) if args.quick else ((128, 256, 512), (16, 64, 256))
    if args.sizes:
        sizes = tuple(int(v) for v in args.sizes.split(","))
    if args.spps:
        spps = tuple(int(v) for v in args.spps.split(","))
    configs = plan(sizes, spps)
    # The goal's row first, then replay and primal everywhere, then the rest:
    # the report is rewritten after every configuration.
    goal = (max(sizes), 64)
    configs.sort(key=lambda c: (c[:2] != goal, c[3] not in ("primal", "prb")))
    cache = {}
    if args.cache and os.path.exists(args.cache):
        with open(args.cache) as f:
            cache = {tuple(json.loads(k)): v for k, v in json.load(f).items()}
    done = []
    for size, spp, label, method, passes in configs:
        key = (size, spp, method, passes)
        if key not in cache and args.methods and method not in args.methods.split(","):
            continue
        if key not in cache:
            config = {"size": size, "spp": spp, "method": method, "passes": passes}
            if args.variant != VARIANT:
                config["variant"] = args.variant
            if args.normalmap:
                config["normalmap"] = True
            if args.reps:
                config["reps"] = args.reps
            cache[key] = run(config)
            if args.cache:
                with open(args.cache, "w") as f:
                    json.dump({json.dumps(list(k)): v for k, v in cache.items()}, f)
        done.append((size, spp, label, cache[key]))
        order = {c[:3]: i for i, c in enumerate(plan(sizes, spps))}
        rows = sorted(done, key=lambda r: order[r[:3]])
        present = {r[:3] for r in rows}
        write(args, rows, [c[:3] for c in plan(sizes, spps) if c[:3] not in present])
    print(f"wrote {args.out}")
    return 0


def command_line(args):
    """The command that reproduces the rows of ``--section``."""
    words = ["python validation/inverse_memory.py"]
    for name in ("methods", "sizes", "spps", "reps", "variant"):
        value = getattr(args, name)
        if value and not (name == "variant" and value == VARIANT):
            words.append(f"--{name} {value}")
    if args.normalmap:
        words.append("--normalmap")
    words.append(f'--section "{args.section}"')
    return " ".join(words)


def write_section(args, rows):
    """Replace (or append) the section ``## {args.section}`` of ``args.out``."""
    what = (f"the sphere's pbrdf inside a polarized_normalmap, gradient with respect to the 7 "
            f"pbrdf parameters and the {TEXELS}x{TEXELS}x3 normal-map texels"
            if args.normalmap else "gradient with respect to the 7 BSDF parameters")
    timing = (f"medians of {args.reps} interleaved primal renders and gradients in each process"
              if args.reps else "one primal render and a second gradient call per process")
    body = [f"## {args.section}", "",
            f"`{command_line(args)}`: {what}, `{args.variant}`, {timing}.", ""]
    body += table(rows)
    text = open(args.out).read() if os.path.exists(args.out) else ""
    head = f"## {args.section}\n"
    start = text.find(head)
    if start < 0:
        text = text.rstrip("\n") + "\n\n" + "\n".join(body) + "\n"
    else:
        end = text.find("\n## ", start + len(head))
        tail = "" if end < 0 else text[end:]
        text = text[:start] + "\n".join(body) + "\n" + tail
    with open(args.out, "w") as f:
        f.write(text)


def write(args, rows, missing=()):
    if args.section:
        write_section(args, rows)
        return
    lines = ["# Memory and time of Stokes-loss gradients",
             "",
             f"`python validation/inverse_memory.py{' --quick' if args.quick else ''}` (this "
             "file). Sphere scene of `mitsuba_pbrdf.inverse.sphere_scene`, `path` with max_depth "
             f"4 inside `stokes`, `{args.variant}`, "
             + ("2 CPU cores shared with other work (times are indicative; the ratios are taken "
                "within one process), " if args.variant.startswith("llvm") else "")
             + "gradient of a "
             "squared-error loss on S0, S1, S2 with respect to 7 BSDF parameters.",
             "",
             "* peak RSS: the whole process (Python, LLVM, scene); RSS / primal process: against "
             "a process of the same size that renders the primal image only;",
             "* Dr.Jit peak: its allocation watermark during the gradient (bytes allocated, some "
             "never touched, so it can exceed the resident peak);",
             "* gradient time: loss and gradient (primal render, loss, backward), first call "
             "(with JIT compilation) / second call (kernels cached, as in every later iteration "
             "of an optimization); next / primal render: the second call over one primal render "
             "of the same process;",
             "* renders: primal renders + derivative renders (or replays).",
             "",
             f"Prediction for one path AD pass: "
             f"{__import__('mitsuba_pbrdf.inverse', fromlist=['x']).REVERSE_BYTES_PER_SAMPLE_AND_DEPTH}"
             " B x max_depth x pixels x spp; forward mode is run up to "
             f"{MAX_FORWARD_SPP} spp (its time grows with spp x parameters).",
             ""]
    lines += table(rows)
    if missing:
        lines += ["", "Not run in this pass (`--methods`): " + "; ".join(
            f"{size}x{size} {spp} spp {label}" for size, spp, label in missing) + "."]
    lines += ["", "Gradient values of the methods at the same seed are compared in "
              "validation/path_replay_gradients.md (path AD in Mitsuba 3.9 is wrong in S1, S2 "
              "where the sampled direction depends on a parameter, as here: its rows are a "
              "cost reference only)."]
    with open(args.out, "w") as f:
        f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    sys.exit(main())
