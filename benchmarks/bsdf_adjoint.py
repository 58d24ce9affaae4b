"""What one BSDF evaluation costs inside the replay, with and without its
adjoint: a ``pbrdf`` inside a ``polarized_normalmap`` of 64 x 64 texels (the
sphere of validation/inverse_memory.py ``--normalmap``), its Mueller matrix
rotated to world space and contracted with a Stokes vector and an adjoint, as
``stokes_prb``'s replay does, in a symbolic loop of 4 iterations over 4 M
lanes (16.8 M evaluations), 7 pbrdf parameters and the texels differentiated.

    python benchmarks/bsdf_adjoint.py            # writes benchmarks/bsdf_adjoint.md
    python benchmarks/bsdf_adjoint.py --lanes 1048576 --reps 3

Compared, interleaved in one process (medians of the kernels' execution
time, the first repetition left out: it compiles):

* Stokes-basis rotations: Mitsuba's (``mi.mueller.rotate_mueller_basis`` for
  the facet's Fresnel matrix, ``si.to_world_mueller``; an inverse sine and
  ``sincos`` each) or :mod:`mitsuba_pbrdf.mueller` (dot and cross
  products);
* forward only, or forward and adjoint (``dr.backward_from`` in the loop);
* the BSDF called directly, or through the surface's BSDF pointer (a
  symbolic call, as in the replay).
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time

import drjit as dr
import mitsuba as mi

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
for path in (ROOT, os.path.join(ROOT, "validation")):
    if path not in sys.path:
        sys.path.insert(0, path)

# the scene and parameters of the cost rows (validation/inverse_memory.py --normalmap)
from inverse_memory import TEXELS, VARIANT, bsdf_keys, normalmap_sphere  # noqa: E402

ITERATIONS = 4


def build(lanes):
    """The scene, its differentiated parameters, the normal-mapped BSDF and
    ``lanes`` surface interactions on the sphere (camera rays through the
    middle half of the image)."""
    scene = mi.load_dict(normalmap_sphere(64, 1))
    params = mi.traverse(scene)
    keys = bsdf_keys(True)
    for k in keys:
        dr.enable_grad(params[k])
    params.update()
    rng = mi.PCG32(lanes, dr.arange(mi.UInt64, lanes))
    with dr.suspend_grad():
        film = mi.Point2f(rng.next_float32(), rng.next_float32()) * 0.5 + 0.25
        ray, _ = scene.sensors()[0].sample_ray(0.0, 0.5, film, mi.Point2f(0.5))
        si = scene.ray_intersect(ray)
        dr.eval(si, ray)
    hit = dr.count(si.is_valid())
    if int(hit[0] if hasattr(hit, "__len__") else hit) != lanes:
        raise RuntimeError("some benchmark rays miss the sphere")
    return scene, params, keys, scene.shapes()[0].bsdf(), si, ray


def kernel(bsdf, si0, ray, lanes, ours, adjoint, symbolic_call):
    """A function running the benchmark loop once; returns its accumulator."""
    from mitsuba_pbrdf.integrators.replay import mueller_times, stokes_dot
    from mitsuba_pbrdf import mueller as rotators
    from mitsuba_pbrdf.bsdfs import fresnel

    @dr.syntax
    def run(mueller_times=mueller_times, stokes_dot=stokes_dot, rotators=rotators, bsdf=bsdf,
            si0=si0, ray=ray, lanes=lanes, ours=ours, adjoint=adjoint,
            symbolic_call=symbolic_call):
        # (closure variables as defaults: dr.syntax re-compiles the function)
        ctx = mi.BSDFContext()
        i = mi.UInt32(0)
        rng = mi.PCG32(lanes, dr.arange(mi.UInt64, lanes))
        acc = mi.Float(0.0)
        while i < ITERATIONS:
            i += 1
            wo = mi.warp.square_to_cosine_hemisphere(
                mi.Point2f(rng.next_float32(), rng.next_float32()))
            L = mi.SpectrumEntry(mi.UnpolarizedSpectrum(rng.next_float32()), 0.1, 0.2, 0.0)
            adj = mi.SpectrumEntry(1.0, mi.UnpolarizedSpectrum(rng.next_float32()), 0.3, 0.0)
            with dr.resume_grad():
                si = mi.SurfaceInteraction3f(si0)
                target = si.bsdf(ray) if dr.hint(symbolic_call, mode="scalar") else bsdf
                f = target.eval(ctx, si, wo, si.is_valid())
                if dr.hint(ours, mode="scalar"):
                    T = rotators.to_world_mueller(si, f, -wo, si.wi)
                else:
                    T = si.to_world_mueller(f, -wo, si.wi)
                value = stokes_dot(adj, mueller_times(T, L))
                if dr.hint(adjoint, mode="scalar"):
                    dr.backward_from(value)
                else:
                    acc += dr.detach(value[0])
            acc += wo.x
        return acc

    def once():
        # the facet's Fresnel matrix is rotated by fresnel.rotate_mueller_basis when traced
        saved = fresnel.rotate_mueller_basis
        fresnel.rotate_mueller_basis = (rotators.rotate_mueller_basis if ours
                                        else mi.mueller.rotate_mueller_basis)
        try:
            return run()
        finally:
            fresnel.rotate_mueller_basis = saved
    return once


def main(argv=None):
    args = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    args.add_argument("--lanes", type=int, default=1 << 22)
    args.add_argument("--reps", type=int, default=5)
    args.add_argument("--out", default=os.path.join(HERE, "bsdf_adjoint.md"))
    args = args.parse_args(argv)

    import mitsuba_pbrdf
    mitsuba_pbrdf.use_variant(VARIANT)
    scene, params, keys, bsdf, si, ray = build(args.lanes)

    configs = [(ours, adjoint, call) for call in (False, True) for adjoint in (False, True)
               for ours in (False, True)]
    runs = {c: kernel(bsdf, si, ray, args.lanes, *c) for c in configs}
    seconds = {c: [] for c in configs}
    for rep in range(args.reps):
        for c in (configs if rep % 2 == 0 else configs[::-1]):
            for k in keys:
                dr.clear_grad(params[k])
            dr.kernel_history()  # clear
            with dr.scoped_set_flag(dr.JitFlag.KernelHistory, True):
                dr.eval(runs[c](), [dr.grad(params[k]) for k in keys])
                dr.sync_thread()
                history = dr.kernel_history()
            if rep > 0:
                seconds[c].append(sum(h.get("execution_time", 0.0) for h in history) / 1000)
    med = {c: statistics.median(v) for c, v in seconds.items()}

    command = "python benchmarks/bsdf_adjoint.py" + (
        f" --lanes {args.lanes}" if args.lanes != 1 << 22 else "") + (
        f" --reps {args.reps}" if args.reps != 5 else "")
    n = args.lanes * ITERATIONS
    lines = ["# One BSDF evaluation in the replay, with and without its adjoint", "",
             f"`{command}`: {n / 1e6:.1f} M evaluations of a pbrdf inside a "
             f"polarized_normalmap ({TEXELS}x{TEXELS} texels; 7 parameters and the texels "
             f"differentiated), {VARIANT}, {os.cpu_count()} CPU threads, medians of "
             f"{args.reps - 1} interleaved repetitions of the kernels' execution time.", "",
             "| BSDF called | evaluation | Mitsuba's rotations (s) | rotators.py (s) | "
             "ratio |", "|---|---|---|---|---|"]
    for call in (False, True):
        for adjoint in (False, True):
            theirs, ours = med[(False, adjoint, call)], med[(True, adjoint, call)]
            lines.append(f"| {'through the BSDF pointer' if call else 'directly'} | "
                         f"{'forward and adjoint' if adjoint else 'forward'} | {theirs:.3f} | "
                         f"{ours:.3f} | {ours / theirs:.2f} |")
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        with open(args.out, "w") as f:
            f.write(text)


if __name__ == "__main__":
    main()
