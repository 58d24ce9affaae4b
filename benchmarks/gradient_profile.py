"""Per-kernel profile of a ``stokes_prb`` gradient against a primal render.

    nice python benchmarks/gradient_profile.py                      # 256^2, 64 spp, CPU
    nice python benchmarks/gradient_profile.py --normalmap --reps 5
    python benchmarks/gradient_profile.py --backend cuda --size 512  # on a GPU
    python benchmarks/gradient_profile.py --cold --sizes 256,128     # compile time

Scene: ``inverse.sphere_scene`` at depth 4 (validation/inverse_memory.py's,
``--normalmap``: its pbrdf inside a 64 x 64 ``polarized_normalmap`` whose
texels are differentiated too), gradient of the Stokes loss with respect to
the 7 pbrdf parameters by ``inverse.loss_and_gradient(method="prb")``.

Dr.Jit's kernel history (``dr.JitFlag.KernelHistory``) is read at the edge
of each phase, so every kernel launch lands in one of:

* ``primal render``: the reference, ``stokes`` around ``path`` (C++);
* ``primal pass``: the gradient's own image (``stokes_prb.render``), the
  loss and its image gradient;
* ``adjoint pass``: ``render_backward`` (film adjoint, then one kernel that
  traces the paths again storing their vertices and replays them).

Per phase (medians over ``--reps`` interleaved repetitions, after one warm-up
gradient): wall seconds, distinct JIT kernels, launches (JIT kernels, reductions, copies),
kernel execution seconds, and the generated IR of the phase's largest
kernel: Dr.Jit's operation count and, from its LLVM IR or PTX text, the
lines and the call sites of gathers, scatters, scatter-adds (the adjoint's
accumulation into the parameters), the callables (virtual-call targets:
BSDFs, emitters, shapes) and the local arrays (LLVM) or local-memory
accesses (PTX). ``gradient / primal`` is the
ratio of ``loss_and_gradient``'s own timing to the primal render that
precedes it, pair by pair (the figure of validation/inverse_memory.py).

``--cold`` runs each of ``--sizes`` in a fresh process, all with
``DRJIT_CACHE_DIR`` (where Dr.Jit keeps compiled kernels, ``~/.drjit`` by
default) pointing at one temporary folder that starts empty, and reports
the first and the next gradient of each: the kernels compiled (found neither
in memory nor on disk), their operation counts, code-generation and compile
seconds, and the kernels loaded from disk. The default ``256,256,128``:
cold, then warm from the disk cache, then another size.

``--mitsuba-prb BSDF`` times Mitsuba's own ``prb`` instead (unpolarized,
``{backend}_ad_rgb``, the same scene with ``roughconductor`` or ``pbrdf``
on the sphere) against a ``path`` render: the reference ratio.
"""

import argparse
import os
import re
import statistics
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
for _path in (ROOT, os.path.join(ROOT, "validation")):
    if _path not in sys.path:
        sys.path.insert(0, _path)

#: IR text patterns counted in a kernel, per backend (LLVM IR, PTX)
IR_PATTERNS = {
    "llvm": {"gathers": r"call [^\n]*@(?:llvm\.masked\.gather|gather_)",
             "scatters": r"call [^\n]*@(?:llvm\.masked\.scatter|scatter_)",
             "atomics": r"call [^\n]*@reduce_|atomicrmw", "calls": r"define [^\n]*@func_",
             "local": r"\balloca\b"},
    "cuda": {"gathers": r"\bld\.global", "scatters": r"\bst\.global",
             "atomics": r"\b(?:red|atom)\.", "calls": r"^\.func", "local": r"\b(?:ld|st)\.local"},
}


def ir_counts(entry, backend):
    """Counts of :data:`IR_PATTERNS` in a kernel-history entry's IR text."""
    ir = entry.get("ir")
    text = ir.getvalue() if hasattr(ir, "getvalue") else (ir or "")
    counts = {name: len(re.findall(pattern, text, re.MULTILINE))
              for name, pattern in IR_PATTERNS[backend].items()}
    counts["lines"] = text.count("\n")
    return counts


class Phases:
    """Reads Dr.Jit's kernel history at phase edges: ``mark(name)`` closes the
    phase open so far (its launches and wall time) and opens ``name``."""

    def __init__(self, dr):
        self.dr = dr
        self.open, self.t0, self.cpu0, self.done = None, None, None, []

    def mark(self, name):
        dr = self.dr
        dr.sync_thread()
        history = dr.kernel_history()
        now, cpu = time.perf_counter(), time.process_time()
        if self.open is not None:
            self.done.append((self.open, now - self.t0, cpu - self.cpu0, history))
        self.open, self.t0, self.cpu0 = name, now, cpu

    def take(self):
        self.mark(None)
        done, self.done = self.done, []
        return done


def summarize(history, backend):
    """Figures of one phase's kernel launches (dict)."""
    jit = [h for h in history if "execution_time" in h]
    kernels = [h for h in jit if "hash" in h]
    largest = max(jit, key=lambda h: h.get("operation_count", 0), default=None)
    out = {"kernels": len({h["hash"] for h in kernels}), "launches": len(jit),
           "exec_s": sum(h["execution_time"] for h in jit) / 1e3,
           "ops": largest.get("operation_count", 0) if largest else 0}
    out.update(ir_counts(largest, backend) if largest else {})
    return out


def kernel_lines(phase, history):
    """One line per launch: phase, hash, size, operations, times."""
    for h in history:
        if "execution_time" in h:
            name = h.get("hash", str(h.get("type")).split(".")[-1])[:10]
            yield (f"  {phase:<14} {name:<10} size {h.get('size', 0):>9} "
                   f"ops {h.get('operation_count', 0):>6} in {h.get('input_count', 0):>3} "
                   f"out {h.get('output_count', 0):>3} exec {h['execution_time']:9.2f} ms "
                   f"codegen {h.get('codegen_time', 0):7.1f} ms compile "
                   f"{h.get('backend_time', 0):8.1f} ms"
                   f"{' (cached)' if h.get('cache_hit') else ''}"
                   f"{' (disk)' if h.get('cache_disk') else ''}")


COLUMNS = [("wall s", "wall", "{:.3f}"), ("CPU s", "cpu", "{:.3f}"),
           ("kernels", "kernels", "{:.0f}"),
           ("launches", "launches", "{:.0f}"), ("kernel exec s", "exec_s", "{:.3f}"),
           ("largest: ops", "ops", "{:.0f}"), ("IR lines", "lines", "{:.0f}"),
           ("gathers", "gathers", "{:.0f}"), ("scatters", "scatters", "{:.0f}"),
           ("scatter-adds", "atomics", "{:.0f}"), ("callables", "calls", "{:.0f}"),
           ("local arrays", "local", "{:.0f}")]


def table(rows):
    """Markdown rows; the last two columns: wall and CPU seconds over those of
    the primal render."""
    primal = dict(rows)["primal render"]
    lines = ["| phase | " + " | ".join(c[0] for c in COLUMNS) + " | wall / primal | CPU / primal |",
             "|---|" + "---|" * (len(COLUMNS) + 2)]
    for name, figures in rows:
        cells = [fmt.format(figures.get(key, 0)) for _, key, fmt in COLUMNS]
        lines.append(f"| {name} | " + " | ".join(cells)
                     + f" | {figures['wall'] / primal['wall']:.2f} "
                     f"| {figures['cpu'] / primal['cpu']:.2f} |")
    return lines


def setup(args):
    """(mi, dr, scene, params, keys, loss, primal(seed), gradient(seed), phases)."""
    import drjit as dr
    import mitsuba as mi
    import numpy as np

    import mitsuba_pbrdf
    mitsuba_pbrdf.use_variant(args.variant)
    from inverse_memory import DEPTH, bsdf_keys, normalmap_sphere
    from mitsuba_pbrdf import inverse
    from mitsuba_pbrdf.inverse import gradients

    phases = Phases(dr)

    def make(size):
        scene = mi.load_dict(normalmap_sphere(size, args.spp) if args.normalmap
                             else inverse.sphere_scene(size, size, args.spp, DEPTH))
        params = mi.traverse(scene)
        keys = bsdf_keys(args.normalmap)
        prefix = "object.bsdf.nested_bsdf." if args.normalmap else "object.bsdf."
        target = np.array(inverse.render(scene, spp=args.spp, seed=1000))
        params[prefix + "sigma.value"] = 0.18
        params[prefix + "eta.value"] = 1.6
        params.update()
        return scene, params, keys, inverse.stokes_loss(scene, target, (0, 1, 2))

    baseline = load_baseline(args.baseline) if getattr(args, "baseline", None) else None
    which = {"code": "this checkout"}

    class Phased:
        """The replay integrator, marking the phase edges; with ``--baseline``,
        runs the baseline's ``render``/``render_backward`` on it instead when
        ``which["code"]`` says so."""

        def __init__(self, inner):
            self.inner = inner

        def _method(self, name):
            if which["code"] == "baseline":
                return getattr(baseline.StokesPRBIntegrator, name).__get__(self.inner)
            return getattr(self.inner, name)

        def render(self, *a, **k):
            phases.mark("primal pass")
            return self._method("render")(*a, **k)

        def render_backward(self, *a, **k):
            phases.mark("adjoint pass")
            return self._method("render_backward")(*a, **k)

    replay_integrator = gradients._replay_integrator
    gradients._replay_integrator = lambda scene: Phased(replay_integrator(scene))

    def primal(scene, seed):
        phases.mark("primal render")
        dr.eval(inverse.render(scene, spp=args.spp, seed=seed))
        phases.mark("between")
        return phases.done[-1][1:3]

    def gradient(scene, params, keys, loss, seed, code="this checkout"):
        which["code"] = code
        phases.mark("between")
        cpu = time.process_time()
        _, grads, stats = inverse.loss_and_gradient(scene, params, keys, loss, spp=args.spp,
                                                    seed=seed, method="prb")
        cpu = time.process_time() - cpu
        phases.mark("between")
        return stats.seconds, cpu, grads

    return dr, make, primal, gradient, phases


def load_baseline(root):
    """The ``stokes_prb`` module of another checkout ``root`` (e.g. ``git worktree
    add /tmp/base HEAD~1``), with its own ``replay`` module, under new names in
    this package (so that its relative imports of the rest resolve here)."""
    import importlib.util

    loaded = None
    for name in ("replay", "stokes_prb"):
        path = os.path.join(root, "mitsuba_pbrdf", "integrators", name + ".py")
        with open(path, encoding="utf-8") as f:
            source = f.read().replace("from .replay import", "from .baseline_replay import")
        module_name = "mitsuba_pbrdf.integrators.baseline_" + name
        spec = importlib.util.spec_from_loader(module_name, loader=None, origin=path)
        loaded = importlib.util.module_from_spec(spec)
        loaded.__file__ = path
        sys.modules[module_name] = loaded
        exec(compile(source, path, "exec"), loaded.__dict__)
    if not hasattr(loaded, "StokesPRBIntegrator"):  # plugin modules build their class per variant
        loaded.StokesPRBIntegrator = loaded.build_class()
    return loaded


def profile(args):
    dr, make, primal, gradient, phases = setup(args)
    backend = args.variant.split("_")[0]
    codes = ["this checkout"] + (["baseline"] if args.baseline else [])
    dr.set_flag(dr.JitFlag.KernelHistory, True)
    scene, params, keys, loss = make(args.size)
    primal(scene, 1)
    first = {code: gradient(scene, params, keys, loss, 4, code)[2]  # compiles
             for code in codes}
    phases.take()
    per_phase, ratios, cpu_ratios, primals, grads_s = {}, {}, {}, [], {}
    for rep in range(args.reps):
        p, p_cpu = primal(scene, 10 + rep)
        primals.append(p)
        # the order of the codes alternates, A B, B A, ...
        for code in (codes if rep % 2 == 0 else codes[::-1]):
            g, g_cpu, _ = gradient(scene, params, keys, loss, 5 + rep, code)
            grads_s.setdefault(code, []).append(g)
            ratios.setdefault(code, []).append(g / p)
            cpu_ratios.setdefault(code, []).append(g_cpu / p_cpu)
            for name, wall, cpu, history in phases.take():
                if name == "between":
                    continue
                if name != "primal render" and len(codes) > 1:
                    name = f"{name} ({code})"
                figures = summarize(history, backend)
                figures["wall"], figures["cpu"] = wall, cpu
                per_phase.setdefault(name, []).append(figures)
                if args.kernels and rep == 0:
                    print("\n".join(kernel_lines(name, history)))
    rows = [(name, {key: statistics.median(f[key] for f in runs) for key in runs[0]})
            for name, runs in sorted(per_phase.items(),
                                     key=lambda item: item[0] != "primal render")]
    print(f"\n`{command_line()}` ({args.variant}, {args.size}x{args.size}, {args.spp} spp, "
          f"depth 4, {'normal map, ' if args.normalmap else ''}medians of {args.reps} "
          f"interleaved repetitions in one process)\n")
    print("\n".join(table(rows)))
    print()
    for code in codes:
        r, c = ratios[code], cpu_ratios[code]
        print(f"* gradient ({code}) / primal render: wall time, median {statistics.median(r):.2f} "
              f"(min {min(r):.2f}, max {max(r):.2f}); CPU time, median {statistics.median(c):.2f} "
              f"(min {min(c):.2f}, max {max(c):.2f}); gradient "
              f"{statistics.median(grads_s[code]):.3f} s, primal render "
              f"{statistics.median(primals):.3f} s (wall)")
    if args.baseline:
        print(f"* gradients of the two codes with the same seed: largest difference "
              f"{gradient_difference(first[codes[0]], first[codes[1]]):.1e} of each "
              f"parameter's largest magnitude")


def gradient_difference(a, b):
    """The largest ``|a - b|`` over the entries of each parameter, relative to
    that parameter's largest ``|a|`` (parameters whose gradient is 0 left out):
    0.0 when two codes give the same gradients bit for bit."""
    import numpy as np

    worst = 0.0
    for key in a:
        x, y = np.ravel(np.asarray(a[key], float)), np.ravel(np.asarray(b[key], float))
        scale = np.max(np.abs(x)) if x.size else 0.0
        if scale > 0:
            worst = max(worst, float(np.max(np.abs(x - y)) / scale))
    return worst


COLD_HEADER = ["| process | size | gradient | seconds | kernels compiled | their operations "
               "| code generation s | compile s | kernels from disk |",
               "|---|---|---|---|---|---|---|---|---|"]


def cold(args):
    """Each of ``args.sizes`` in a fresh process, in order, all sharing one
    kernel cache folder that starts empty."""
    import subprocess

    print(f"\n`{command_line()}` ({args.variant}, {args.spp} spp, depth 4"
          f"{', normal map' if args.normalmap else ''}; a fresh process per row pair, "
          f"DRJIT_CACHE_DIR an empty temporary folder at the start)\n")
    print("\n".join(COLD_HEADER))
    with tempfile.TemporaryDirectory(prefix="drjit-cache-") as cache:
        for n, size in enumerate(args.sizes, 1):
            command = [sys.executable, os.path.abspath(__file__), "--cold-child", str(n),
                       "--size", str(size), "--spp", str(args.spp), "--variant", args.variant]
            command += ["--normalmap"] if args.normalmap else []
            command += ["--kernels"] if args.kernels else []
            proc = subprocess.run(command, env=dict(os.environ, DRJIT_CACHE_DIR=cache),
                                  capture_output=True, text=True)
            if proc.returncode:
                sys.exit(f"gradient_profile.py --cold: the process for size {size} failed:\n"
                         f"{proc.stderr[-3000:]}")
            print(proc.stdout.rstrip())


def cold_child(args):
    """One row pair of :func:`cold`: the first and the next gradient."""
    dr, make, primal, gradient, phases = setup(args)
    dr.set_flag(dr.JitFlag.KernelHistory, True)
    size = args.size
    scene, params, keys, loss = make(size)
    primal(scene, 1)
    phases.take()
    for which, seed in (("first", 4), ("next", 5)):
        seconds, _, _ = gradient(scene, params, keys, loss, seed)
        history = [h for *_, hist in phases.take() for h in hist if "hash" in h]
        new = [h for h in history if not h.get("cache_hit") and not h.get("cache_disk")]
        if args.kernels:
            print("\n".join(kernel_lines(f"{size} {which}", new)))
        print(f"| {args.cold_child} | {size}x{size} | {which} | {seconds:.2f} | {len(new)} | "
              f"{'+'.join(str(h.get('operation_count', 0)) for h in new) or '0'} | "
              f"{sum(h.get('codegen_time', 0) for h in new) / 1e3:.2f} | "
              f"{sum(h.get('backend_time', 0) for h in new) / 1e3:.2f} | "
              f"{sum(1 for h in history if h.get('cache_disk'))} |")


def mitsuba_prb(args):
    """Mitsuba's own ``prb`` (unpolarized, ``{backend}_ad_rgb``) on the same
    scene, the reference of the issue: gradient of a squared error with
    respect to the sphere BSDF's float parameters, against a ``path`` render
    of the same scene; ``args.mitsuba_prb`` names the sphere's BSDF."""
    import drjit as dr
    import mitsuba as mi

    import mitsuba_pbrdf
    mitsuba_pbrdf.use_variant(f"{args.backend}_ad_rgb")
    from inverse_memory import DEPTH
    from mitsuba_pbrdf import inverse

    bsdf = ({"type": "roughconductor", "material": "Cu", "alpha": 0.17}
            if args.mitsuba_prb == "roughconductor" else None)
    scenes = {}
    for name in ("path", "prb"):
        d = inverse.sphere_scene(args.size, args.size, args.spp, DEPTH, bsdf=bsdf)
        d["integrator"] = {"type": name, "max_depth": DEPTH}
        scenes[name] = mi.load_dict(d)
    params = mi.traverse(scenes["prb"])
    keys = [k for k in params.keys() if k.startswith("object.bsdf.")
            and isinstance(params[k], mi.Float)]
    target = mi.render(scenes["path"], spp=args.spp, seed=1000)
    dr.eval(target)

    def primal(seed):
        dr.sync_thread()
        t0 = time.perf_counter()
        dr.eval(mi.render(scenes["path"], spp=args.spp, seed=seed))
        dr.sync_thread()
        return time.perf_counter() - t0

    def gradient(seed):
        dr.sync_thread()
        t0 = time.perf_counter()
        for k in keys:
            dr.enable_grad(params[k])
        params.update()
        image = mi.render(scenes["prb"], params, spp=args.spp, seed=seed, seed_grad=seed + 1)
        dr.backward(dr.mean(dr.square(image - target), axis=None))
        dr.eval([dr.grad(params[k]) for k in keys])
        dr.sync_thread()
        seconds = time.perf_counter() - t0
        for k in keys:
            dr.disable_grad(params[k])
        params.update()
        return seconds

    primal(1)
    gradient(2)
    ratios = []
    for rep in range(args.reps):
        ratios.append(gradient(20 + rep) / primal(10 + rep))
    print(f"Mitsuba's prb ({args.backend}_ad_rgb, sphere BSDF {args.mitsuba_prb}, {len(keys)} "
          f"parameters, {args.size}x{args.size}, {args.spp} spp, depth {DEPTH}) / path render: "
          f"median {statistics.median(ratios):.2f} (min {min(ratios):.2f}, max {max(ratios):.2f}) "
          f"over {args.reps} interleaved pairs")


def command_line():
    return "python benchmarks/gradient_profile.py " + " ".join(sys.argv[1:])


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--spp", type=int, default=64)
    parser.add_argument("--reps", type=int, default=3)
    parser.add_argument("--normalmap", action="store_true")
    parser.add_argument("--backend", choices=("llvm", "cuda"), default="llvm",
                        help="variant prefix (default llvm: llvm_ad_spectral_polarized)")
    parser.add_argument("--variant", help="the Mitsuba variant (overrides --backend)")
    parser.add_argument("--kernels", action="store_true", help="also print every launch")
    parser.add_argument("--baseline", metavar="DIR",
                        help="another checkout (e.g. git worktree add DIR HEAD~1): its stokes_prb "
                        "and replay code interleaved with this checkout's, A B B A ...")
    parser.add_argument("--cold", action="store_true",
                        help="compile time: empty kernel cache, first and next gradient per size")
    parser.add_argument("--mitsuba-prb", choices=("roughconductor", "pbrdf"),
                        help="instead: Mitsuba's own prb, unpolarized, with this sphere BSDF")
    parser.add_argument("--sizes", default="256,256,128",
                        help="--cold: image sizes, one fresh process each, in this order "
                        "(comma-separated; default: cold, then warm from the disk cache, then "
                        "another size)")
    parser.add_argument("--cold-child", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    args.variant = args.variant or f"{args.backend}_ad_spectral_polarized"
    try:
        args.sizes = [int(s) for s in args.sizes.split(",")]
    except ValueError:
        parser.error(f"--sizes: comma-separated integers expected, got {args.sizes!r}")
    if args.mitsuba_prb:
        mitsuba_prb(args)
    elif args.cold_child:
        cold_child(args)
    elif args.cold:
        cold(args)
    else:
        profile(args)


if __name__ == "__main__":
    main()
