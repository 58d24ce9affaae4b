"""Where the time of a ``stokes_prb`` gradient goes.

    nice -n 5 python validation/prb_profile.py --size 512 --spp 64 --reps 5

Scene: ``normalmap_sphere`` of validation/inverse_memory.py (``--normalmap``:
the study's sphere at depth 4 whose ``pbrdf`` is wrapped in a
``polarized_normalmap`` of 64 x 64 texels); differentiated: the 7 pbrdf
parameters and the normal map's texels. In one process, repeated ``--reps`` times in interleaved
order, it times (seconds, medians over the repetitions):

* ``primal render``: ``stokes`` around ``path`` (the loss's image);
* ``gradient``: :func:`inverse.loss_and_gradient` with ``method="prb"``
  (primal render by ``stokes_prb`` + loss + ``render_backward``);
* ``gradient, loss image by stokes + path``: the same with the loss's image
  rendered by the scene's ``stokes`` around ``path`` (as before it changed);
* ``gradient before``: that, with Mitsuba's Stokes-basis rotations in the
  pbrdf and the replay (``mi.mueller.rotate_mueller_basis``,
  ``si.to_world_mueller``) instead of ``mueller.py``: the code before
  both changes, interleaved with the code after;
* ``render_backward``: split into its kernels with ``dr.kernel_history()``
  (the film-adjoint kernel, and the trace + replay kernel);
* ``trace``: ``stokes_prb.render`` (the trace loop without storing vertices);
* ``--parts``: ``render_backward`` without Dr.Jit's ``ScatterReduceLocal``.
  (The replay-part rows of validation/prb_profile.md, builds of the replay
  with one part left out and wrong gradients on purpose, were measured with a
  profiling switch that the production replay no longer carries; to measure
  them again, check out commit 0d27115 and run ``--parts`` there.)

Prints a Markdown table with the command; ``--out`` also writes it.
"""

import argparse
import os
import statistics
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
for path in (ROOT, HERE):
    if path not in sys.path:
        sys.path.insert(0, path)

from inverse_memory import DEPTH, TEXELS, VARIANT, bsdf_keys, normalmap_sphere  # noqa: E402


def timed(fn):
    import drjit as dr

    dr.sync_thread()
    t0 = time.perf_counter()
    fn()
    dr.sync_thread()
    return time.perf_counter() - t0


def kernel_seconds(fn):
    """(wall seconds, [execution seconds of each kernel launched by fn])."""
    import drjit as dr

    dr.kernel_history()  # clear
    with dr.scoped_set_flag(dr.JitFlag.KernelHistory, True):
        seconds = timed(fn)
        history = dr.kernel_history()
    if os.environ.get("PRB_PROFILE_KERNELS"):
        for h in history:
            print({k: v for k, v in h.items() if k != "ir"})
    times = sorted(h["execution_time"] / 1000.0 for h in history if "execution_time" in h)
    # the trace + replay kernel (the largest); all other kernels (film adjoint,
    # reductions, memsets); the rest: Python tracing, code generation, waiting
    return seconds, [times[-1], sum(times[:-1]), seconds - sum(times)]


def main(argv=None):
    args = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    args.add_argument("--size", type=int, default=512)
    args.add_argument("--spp", type=int, default=64)
    args.add_argument("--reps", type=int, default=5)
    args.add_argument("--parts", action="store_true",
                      help="also time render_backward without ScatterReduceLocal")
    args.add_argument("--only", help="time only the primal render and the parts whose names "
                      "contain one of these comma-separated words")
    args.add_argument("--out")
    args = args.parse_args(argv)

    import drjit as dr
    import mitsuba as mi
    import numpy as np

    import mitsuba_pbrdf
    mitsuba_pbrdf.use_variant(VARIANT)
    from mitsuba_pbrdf import inverse
    from mitsuba_pbrdf.integrators import from_path
    from mitsuba_pbrdf.integrators import replay as replay_module

    scene = mi.load_dict(normalmap_sphere(args.size, args.spp))
    params = mi.traverse(scene)
    keys = bsdf_keys(True)
    target = np.array(inverse.render(scene, spp=args.spp, seed=1000))
    params["object.bsdf.nested_bsdf.sigma.value"] = 0.18
    params["object.bsdf.nested_bsdf.eta.value"] = 1.6
    params.update()
    loss = inverse.stokes_loss(scene, target, (0, 1, 2))
    prb = from_path(scene)
    sensor = scene.sensors()[0]

    def primal():
        dr.eval(inverse.render(scene, spp=args.spp, seed=2))

    grads = {}

    def gradient():
        _, g, _ = inverse.loss_and_gradient(scene, params, keys, loss, spp=args.spp, seed=5,
                                            method="prb")
        grads.update(g)

    from mitsuba_pbrdf.inverse import gradients as gradients_module

    def gradient_path_image():
        """``gradient`` with the loss's image rendered by the scene's ``stokes``
        around ``path`` (before: loss_and_gradient now renders it with
        ``stokes_prb``, the same image to float32 rounding)."""
        render = gradients_module.render
        gradients_module.render = lambda *a, integrator=None, **k: render(*a, **k)
        try:
            gradient()
        finally:
            gradients_module.render = render

    from mitsuba_pbrdf.bsdfs import fresnel as fresnel_module

    def gradient_before():
        """``gradient, loss image by stokes + path`` with Mitsuba's Stokes-basis
        rotations (``mi.mueller.rotate_mueller_basis`` for the facet's Fresnel
        matrix, ``si.to_world_mueller`` in the replay) instead of
        :mod:`mitsuba_pbrdf.mueller`: the code before both changes."""
        saved = fresnel_module.rotate_mueller_basis, replay_module.to_world_mueller
        fresnel_module.rotate_mueller_basis = mi.mueller.rotate_mueller_basis
        replay_module.to_world_mueller = lambda si, m, wo, wi: si.to_world_mueller(m, wo, wi)
        try:
            gradient_path_image()
        finally:
            fresnel_module.rotate_mueller_basis, replay_module.to_world_mueller = saved

    image = inverse.render(scene, spp=args.spp, seed=5)
    image = dr.detach(image)
    dr.enable_grad(image)
    dr.backward(loss(image))
    grad_image = dr.grad(image)
    dr.eval(grad_image)

    backward_grads = {}

    def backward(local_reduce=True, name="render_backward"):
        def run():
            with dr.scoped_set_flag(dr.JitFlag.ScatterReduceLocal, local_reduce):
                run_backward()

        def run_backward():
            for k in keys:
                dr.enable_grad(params[k])
            params.update()
            try:
                prb.render_backward(scene, params, grad_image, sensor, seed=6, spp=args.spp)
                backward_grads[name] = {k: np.array(dr.grad(params[k]), np.float64).ravel()
                                        for k in keys}
            finally:
                for k in keys:
                    dr.disable_grad(params[k])
                params.update()
        return run

    def trace():
        dr.eval(prb.render(scene, sensor, seed=6, spp=args.spp))

    jobs = {"primal render": primal, "gradient": gradient,
            "gradient, loss image by stokes + path": gradient_path_image,
            "gradient before (Mitsuba's rotations, loss image by stokes + path)":
                gradient_before,
            "trace (render)": trace,
            "render_backward": backward()}
    if args.parts:
        name = "render_backward without ScatterReduceLocal"
        jobs[name] = backward(local_reduce=False, name=name)
    if args.only:
        jobs = {name: fn for name, fn in jobs.items()
                if name == "primal render"
                or any(word in name for word in args.only.split(","))}
    for fn in jobs.values():  # compile every kernel once
        fn()
    times = {name: [] for name in jobs}
    kernels = {name: [] for name in jobs if name.startswith("render_backward")}
    for rep in range(args.reps):
        names = list(jobs) if rep % 2 == 0 else list(reversed(list(jobs)))
        for name in names:
            if name in kernels:
                seconds, ks = kernel_seconds(jobs[name])
                kernels[name].append(ks)
            else:
                seconds = timed(jobs[name])
            times[name].append(seconds)

    med = {name: statistics.median(v) for name, v in times.items()}
    p = med["primal render"]
    command = ("python validation/prb_profile.py --size {0} --spp {1} --reps {2}{3}{4}"
               .format(args.size, args.spp, args.reps, " --parts" if args.parts else "",
                       f" --only {args.only}" if args.only else ""))
    lines = [f"`{command}` ({args.size}x{args.size}, {args.spp} spp, depth {DEPTH}, "
             f"7 pbrdf parameters + {TEXELS}x{TEXELS} normal-map texels, {VARIANT}, "
             f"medians of {args.reps} interleaved repetitions in one process)", "",
             "| part | seconds | / primal render | trace + replay kernel + other kernels + "
             "rest (s) |", "|---|---|---|---|"]
    for name, value in med.items():
        ks = ""
        if name in kernels:
            per = np.median(np.array(kernels[name]), axis=0)
            ks = " + ".join(f"{s:.2f}" for s in per)
        lines.append(f"| {name} | {value:.2f} | {value / p:.2f} | {ks} |")
    lines += ["", "Gradients of `gradient` (seed 5):"] if grads else []
    lines += [] if not grads else [f"* {k}: {np.array2string(grads[k][:4], precision=7)}"
              + (f" (sum {grads[k].sum():.7g}, |.|_1 {np.abs(grads[k]).sum():.7g})"
                 if grads[k].size > 1 else "") for k in keys]
    exact = [n for n in backward_grads if n == "render_backward" or "ScatterReduceLocal" in n]
    if len(exact) > 1 and exact[0] == "render_backward":
        lines += ["", "Gradients of exact builds against `render_backward` (same seed): "
                  "largest |difference| / largest |gradient| per parameter:"]
        ref = backward_grads["render_backward"]
        for n in exact[1:]:
            rel = [np.abs(backward_grads[n][k] - ref[k]).max() / np.abs(ref[k]).max()
                   for k in keys]
            lines.append(f"* {n}: " + ", ".join(f"{r:.1e}" for r in rel))
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        with open(args.out, "w") as f:
            f.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
