"""Speed and accuracy of the pbrdf plugin: time versus error, and ratios.

    python benchmarks/benchmark.py            # full run (several minutes on 2 cores)
    python benchmarks/benchmark.py --quick    # smoke test (CI): tiny images, few spp

Writes ``benchmarks/results.md`` (or ``--out DIR``) and, for the error-versus-time
study, one PNG per scene. Every ratio is measured within one run, A and B
interleaved, median of the repetitions.

Sections:

1. Render time of pbrdf against Mitsuba's built-in equivalent where the model
   reduces to one (specular only = ``roughconductor``; ideal diffuse only =
   ``diffuse``; specular + ideal diffuse = ``blendbsdf`` of the two), and of the
   polarized against the unpolarized variant; JIT compile time apart.
2. BSDF evaluation throughput of the Dr.Jit kernel against the NumPy float64
   reference on the same direction pairs, and the float32 error.
3. Error versus time: RMSE of S0 and of DoLP against a high-spp reference, at
   1, 2, 4, ... spp, for full mixture sampling, cosine-only sampling, the
   built-in equivalent (where there is one) and the unpolarized variant (S0).
4. Peak memory (resident set) of one render of each scene.
"""

import argparse
import math
import os
import subprocess
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
POLARIZED, UNPOLARIZED = "llvm_ad_spectral_polarized", "llvm_ad_spectral"
ALPHA = 0.2  # Beckmann width of the reduced configurations (sigma = alpha / sqrt 2)


def set_variant(name):
    """``mitsuba_pbrdf.use_variant(name)``; returns the ``mitsuba`` module."""
    import mitsuba as mi

    import mitsuba_pbrdf

    mitsuba_pbrdf.use_variant(name)
    return mi


# --------------------------------------------------------------------- scenes

def pbrdf_spec_kid(**extra):
    return dict({"type": "pbrdf", "material": "Cu", "sigma": ALPHA / math.sqrt(2),
                 "shadowing": "smith", "kid": 0.1}, **extra)


def builtin_spec_kid():
    """ks * roughconductor + kid * Lambert as blendbsdf(weight 1/2) of a doubled
    roughconductor and a diffuse of reflectance 2 kid."""
    return {"type": "blendbsdf", "weight": 0.5,
            "bsdf_0": {"type": "roughconductor", "material": "Cu", "alpha": ALPHA,
                       "specular_reflectance": 2.0},
            "bsdf_1": {"type": "diffuse", "reflectance": 0.2}}


def environment_map(mi, width=64):
    """A small procedural sky: blue gradient, bright sun, dark ground."""
    h = width // 2
    theta = (np.arange(h) + 0.5) / h * np.pi
    phi = (np.arange(width) + 0.5) / width * 2 * np.pi
    t, p = np.meshgrid(theta, phi, indexing="ij")
    sky = np.where(t[..., None] < np.pi / 2, [0.25, 0.35, 0.6], [0.05, 0.045, 0.04]).astype(np.float32)
    sun = np.exp(-((t - 0.7) ** 2 + (p - 2.0) ** 2) / 0.01)[..., None] * 60
    return mi.Bitmap((sky + sun).astype(np.float32))


def scene_dict(mi, name, bsdf, res, polarized=True):
    path = {"type": "path", "max_depth": 4}
    integrator = {"type": "stokes", "integrator": path} if polarized else path
    film = {"type": "hdrfilm", "width": res, "height": res * 3 // 4, "pixel_format": "rgb"}

    def sensor(origin, target):
        return {"type": "perspective", "fov": 35, "film": film, "sampler": {"type": "independent"},
                "to_world": mi.ScalarTransform4f().look_at(origin=origin, target=target, up=[0, 1, 0])}

    if name == "plane_small_light":
        return {"type": "scene", "integrator": integrator,
                "sensor": sensor([0, 2.0, 4.0], [0, 0, 0]),
                "plane": {"type": "rectangle", "bsdf": bsdf,
                          "to_world": mi.ScalarTransform4f().rotate([1, 0, 0], -90).scale(3)},
                "light": {"type": "sphere", "center": [0, 2.0, -2.5], "radius": 0.1,
                          "emitter": {"type": "area", "radiance": 400.0}}}
    if name == "sphere_environment":
        return {"type": "scene", "integrator": integrator,
                "sensor": sensor([0, 0.5, 3.5], [0, 0, 0]),
                "sphere": {"type": "sphere", "bsdf": dict(bsdf)},
                "env": {"type": "envmap", "bitmap": environment_map(mi)}}
    raise ValueError(name)


def load_default_scene(mi, res, sampling="mixture", polarized=True):
    """scenes/default.xml at ``res`` pixels wide, its pbrdf BSDFs set to
    ``sampling``; without the `stokes` wrapper for unpolarized variants."""
    with open(os.path.join(ROOT, "scenes", "default.xml")) as f:
        xml = f.read()
    xml = xml.replace('<bsdf type="pbrdf">',
                      f'<bsdf type="pbrdf"><string name="sampling" value="{sampling}"/>')
    if not polarized:
        xml = xml.replace('<integrator type="stokes">', "", 1)
        head, sep, tail = xml.partition("</integrator>")
        xml = head + sep + tail.replace("</integrator>", "", 1)
    return mi.load_string(xml, width=str(res), height=str(res * 3 // 4))


# --------------------------------------------------------------------- helpers

def timed_render(mi, scene, spp, seed=0):
    import drjit as dr

    start = time.perf_counter()
    image = mi.render(scene, spp=spp, seed=seed)
    dr.eval(image)
    dr.sync_thread()
    return time.perf_counter() - start, np.array(image, dtype=np.float64)


def stokes_luminance(image, polarized=True):
    """(H, W, 15) Stokes channels -> (H, W, 4) Stokes of the luminance
    (Rec. 709 weights; the unpolarized variant gives S0 only)."""
    w = np.array([0.2126, 0.7152, 0.0722])
    if not polarized:
        return np.concatenate([image[..., :3] @ w[:, None], np.zeros(image.shape[:2] + (3,))], -1)
    s = image[..., 3:15].reshape(image.shape[:2] + (4, 3))
    return s @ w


def errors(estimate, reference, polarized=True):
    s0_ref = reference[..., 0]
    mask = s0_ref > 1e-3 * s0_ref.max()
    rmse_s0 = math.sqrt(np.mean((estimate[..., 0] - s0_ref)[mask] ** 2)) / s0_ref[mask].mean()
    if not polarized:
        return rmse_s0, float("nan")

    def dolp(s):
        return np.hypot(s[..., 1], s[..., 2]) / np.maximum(s[..., 0], 1e-12)

    rmse_dolp = math.sqrt(np.mean((dolp(estimate) - dolp(reference))[mask] ** 2))
    return rmse_s0, rmse_dolp


def cpu_render_time(mi, scene, spp, seed=0):
    """CPU seconds (all of this process's threads) of one render: less
    sensitive than wall time to other processes sharing the cores."""
    start = time.process_time()
    timed_render(mi, scene, spp, seed)
    return time.process_time() - start


def median_ratio(mi, scene_a, scene_b, spp, reps):
    for s in (scene_a, scene_b):  # compile both first
        timed_render(mi, s, spp)
    ta, tb = [], []
    for rep in range(reps):
        ta.append(cpu_render_time(mi, scene_a, spp, seed=rep))
        tb.append(cpu_render_time(mi, scene_b, spp, seed=rep))
    return float(np.median(ta)), float(np.median(tb))


# --------------------------------------------------------------------- 1. render time

def render_time_ratios(res, spp, reps):
    mi = set_variant(POLARIZED)
    pairs = [
        ("specular only vs roughconductor",
         {"type": "roughconductor", "material": "Cu", "alpha": ALPHA},
         {"type": "pbrdf", "material": "Cu", "sigma": ALPHA / math.sqrt(2), "shadowing": "smith"}),
        ("ideal diffuse only vs diffuse",
         {"type": "diffuse", "reflectance": 0.5}, {"type": "pbrdf", "ks": 0.0, "kid": 0.5}),
        ("specular + ideal diffuse vs blendbsdf", builtin_spec_kid(), pbrdf_spec_kid()),
    ]
    rows = []
    for label, builtin, plugin in pairs:
        for scene_name in ("plane_small_light", "sphere_environment"):
            a = mi.load_dict(scene_dict(mi, scene_name, builtin, res))
            b = mi.load_dict(scene_dict(mi, scene_name, plugin, res))
            ta, tb = median_ratio(mi, a, b, spp, reps)
            rows.append((f"{label} ({scene_name})", ta, tb, tb / ta))

    # Polarized vs unpolarized variant, full three-lobe model, default scene.
    times = {}
    for variant in (POLARIZED, UNPOLARIZED, POLARIZED, UNPOLARIZED):
        mi = set_variant(variant)
        scene = load_default_scene(mi, res, polarized=variant == POLARIZED)
        timed_render(mi, scene, spp)
        times.setdefault(variant, []).extend(cpu_render_time(mi, scene, spp, seed=r) for r in range(reps))
    tp, tu = float(np.median(times[POLARIZED])), float(np.median(times[UNPOLARIZED]))
    rows.append(("default scene: polarized / unpolarized variant", tu, tp, tp / tu))
    return rows


def compile_times(res):
    """First render minus second render (4 spp), each BSDF in a fresh process
    whose HOME is empty, so Dr.Jit's on-disk kernel cache (~/.drjit) is cold:
    tracing + LLVM compilation of the megakernel."""
    import tempfile

    rows = []
    for label, bsdf in (("pbrdf (3 lobes)", dict(pbrdf_spec_kid(), kdd=0.2)),
                        ("roughconductor", {"type": "roughconductor", "material": "Cu", "alpha": ALPHA})):
        code = (
            "import sys; sys.path.insert(0, %r); import benchmark as b; "
            "mi = b.set_variant(b.POLARIZED); "
            "s = mi.load_dict(b.scene_dict(mi, 'sphere_environment', %r, %d)); "
            "print(b.timed_render(mi, s, 4)[0], b.timed_render(mi, s, 4)[0])"
        ) % (HERE, bsdf, res)
        with tempfile.TemporaryDirectory() as home:
            env = dict(os.environ, HOME=home)
            out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                                 check=True, env=env)
        first, second = map(float, out.stdout.split()[-2:])
        rows.append((label, first, second, first - second))
    return rows


# --------------------------------------------------------------------- 2. eval throughput

def eval_throughput(n, reps):
    mi = set_variant(POLARIZED)
    import drjit as dr

    from mitsuba_pbrdf import frames, reference

    wavelengths = (450.0, 520.0, 600.0, 690.0)
    config = dict(material="Cu", sigma=0.15, kdd=0.2, sigma_dd=0.5, kid=0.05)
    bsdf = mi.load_dict(dict({"type": "pbrdf"}, **config))
    rng = np.random.default_rng(0)
    wi_hat, wo_hat = frames.random_directions(n, rng)

    si = dr.zeros(mi.SurfaceInteraction3f, n)
    si.wi = mi.Vector3f(*wi_hat.T.astype(np.float32))
    si.wavelengths = mi.UnpolarizedSpectrum(*wavelengths)
    wo = mi.Vector3f(*wo_hat.T.astype(np.float32))
    ctx = mi.BSDFContext()
    times = []
    for _ in range(reps + 1):
        start = time.perf_counter()
        value = bsdf.eval(ctx, si, wo)
        dr.eval(value)
        dr.sync_thread()
        times.append(time.perf_counter() - start)
    t_drjit = float(np.median(times[1:]))  # the first call compiles

    n_ref, k_ref = reference.conductor_ior("Cu", wavelengths)
    ti, pi_ = frames.to_angles(wo_hat)
    tr, pr = frames.to_angles(wi_hat)
    c = {k: v for k, v in config.items() if k != "material"}
    start = time.perf_counter()
    R = reference.pbrdf(ti[:, None], pi_[:, None], tr[:, None], pr[:, None], n_ref, k_ref, **c)
    t_numpy = time.perf_counter() - start

    M = frames.eval_global(bsdf, wi_hat, wo_hat, wavelengths, "radiance")
    m00 = R[..., :1, :1]
    resolved = m00 > 1e-7 * m00.max()
    rel = np.where(resolved, np.abs(M - R) / np.maximum(m00, 1e-300), 0).max()
    evaluations = n * len(wavelengths)
    return {"pairs": n, "t_drjit": t_drjit, "t_numpy": t_numpy,
            "drjit_per_s": evaluations / t_drjit, "numpy_per_s": evaluations / t_numpy,
            "speedup": t_numpy / t_drjit, "max_err_over_m00": float(rel)}


# --------------------------------------------------------------------- 3. error vs time

def method_scenes(mi, scene_name, res, variant):
    """{method: scene} for one benchmark scene in the active variant."""
    polarized = variant == POLARIZED
    if scene_name == "default":
        if polarized:
            return {"mixture": load_default_scene(mi, res),
                    "cosine": load_default_scene(mi, res, "cosine")}
        return {"unpolarized variant": load_default_scene(mi, res, polarized=False)}
    if polarized:
        return {"mixture": mi.load_dict(scene_dict(mi, scene_name, pbrdf_spec_kid(), res)),
                "cosine": mi.load_dict(scene_dict(mi, scene_name, pbrdf_spec_kid(sampling="cosine"), res)),
                "built-in blend": mi.load_dict(scene_dict(mi, scene_name, builtin_spec_kid(), res))}
    return {"unpolarized variant": mi.load_dict(scene_dict(mi, scene_name, pbrdf_spec_kid(), res,
                                                           polarized=False))}


def error_vs_time(scene_names, res, spp_list, reference_spp):
    curves = {}
    for scene_name in scene_names:
        mi = set_variant(POLARIZED)
        scenes = method_scenes(mi, scene_name, res, POLARIZED)
        reference_image = stokes_luminance(timed_render(mi, scenes["mixture"], reference_spp, seed=999)[1])
        curves[scene_name] = {}
        for variant in (POLARIZED, UNPOLARIZED):
            mi = set_variant(variant)
            scenes = method_scenes(mi, scene_name, res, variant)
            for method, scene in scenes.items():
                points = []
                for spp in spp_list:
                    timed_render(mi, scene, spp, seed=1)  # compile for this spp
                    seconds, image = timed_render(mi, scene, spp, seed=2)
                    estimate = stokes_luminance(image, variant == POLARIZED)
                    points.append((spp, seconds) + errors(estimate, reference_image, variant == POLARIZED))
                curves[scene_name][method] = points
    return curves


def crossings(points_a, points_b, column):
    """Times at which curve b's error first drops below curve a's (interpolated
    on log-log axes between measured points), or None."""
    ta, ea = np.log([p[1] for p in points_a]), np.log([p[column] for p in points_a])
    tb, eb = np.log([p[1] for p in points_b]), np.log([p[column] for p in points_b])
    t = np.linspace(max(ta.min(), tb.min()), min(ta.max(), tb.max()), 200)
    if t.size == 0 or not (np.all(np.isfinite(ea)) and np.all(np.isfinite(eb))):
        return None
    diff = np.interp(t, tb, eb) - np.interp(t, ta, ea)
    change = np.nonzero(np.diff(np.sign(diff)))[0]
    return float(np.exp(t[change[0]])) if change.size else None


def plot_curves(curves, out_dir):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    paths = []
    for scene_name, methods in curves.items():
        fig, axes = plt.subplots(1, 2, figsize=(9, 3.6), dpi=110)
        for method, points in methods.items():
            t = [p[1] for p in points]
            axes[0].loglog(t, [p[2] for p in points], "o-", label=method)
            if not np.isnan(points[0][3]):
                axes[1].loglog(t, [p[3] for p in points], "o-", label=method)
        axes[0].set(title=f"{scene_name}: relative RMSE of S0", xlabel="render time (s)")
        axes[1].set(title="RMSE of DoLP", xlabel="render time (s)")
        for ax in axes:
            ax.grid(True, which="both", alpha=0.3)
            ax.legend(fontsize=8)
        fig.tight_layout()
        path = os.path.join(out_dir, f"error_vs_time_{scene_name}.png")
        fig.savefig(path)
        plt.close(fig)
        paths.append(path)
    return paths


# --------------------------------------------------------------------- 4. memory

def peak_memory(scene_name, res, spp):
    """Peak resident set (MiB) of a fresh process rendering one scene once:
    VmHWM of /proc (getrusage's ru_maxrss would carry the parent's peak over
    the exec)."""
    code = (
        "import sys; sys.path.insert(0, %r); import benchmark as b; "
        "mi = b.set_variant(b.POLARIZED); "
        "s = b.load_default_scene(mi, %d) if %r == 'default' else "
        "mi.load_dict(b.scene_dict(mi, %r, b.pbrdf_spec_kid(), %d)); "
        "b.timed_render(mi, s, %d); "
        "print([l.split()[1] for l in open('/proc/self/status') if l.startswith('VmHWM')][0])"
    ) % (HERE, res, scene_name, scene_name, res, spp)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return int(out.stdout.strip().splitlines()[-1]) / 1024.0


# --------------------------------------------------------------------- report

def report(args, ratios, compiles, throughput, curves, memory, figures, seconds, load=None):
    lines = ["# Benchmarks", "",
             f"`python benchmarks/benchmark.py{' --quick' if args.quick else ''}` "
             f"({seconds:.0f} s on {os.cpu_count()} cores, Mitsuba variant `{POLARIZED}`, "
             "path tracer depth 4 inside `stokes`). Medians of interleaved repetitions."
             + (f" Load average {load[0]:.1f} before, {load[1]:.1f} after (other work on the "
                "machine inflates the absolute times; the ratios compare interleaved runs)."
                if load else ""), "",
             f"## Render time at equal spp ({args.ratio_spp} spp, {args.res} px wide)", "",
             "CPU time of the rendering process (all its threads), median of interleaved runs.", "",
             "| comparison | built-in / baseline (CPU s) | pbrdf (CPU s) | ratio |", "|---|---|---|---|"]
    lines += [f"| {label} | {ta:.3f} | {tb:.3f} | {r:.3f} |" for label, ta, tb, r in ratios]
    lines += ["", "## JIT compile (cold kernel cache: first render minus second, 4 spp)", "",
              "| BSDF | first render (s) | second (s) | compile + trace (s) |", "|---|---|---|---|"]
    lines += [f"| {label} | {a:.2f} | {b:.2f} | {c:.2f} |" for label, a, b, c in compiles]
    t = throughput
    lines += ["", "## BSDF evaluation throughput", "",
              f"{t['pairs']} direction pairs x 4 wavelengths, full three-lobe Cu configuration, "
              "full 4x4 Mueller matrix.", "",
              "| engine | time (s) | evaluations / s |", "|---|---|---|",
              f"| Dr.Jit kernel (float32, LLVM, 2 cores) | {t['t_drjit']:.3f} | {t['drjit_per_s']:.3g} |",
              f"| NumPy reference (float64) | {t['t_numpy']:.3f} | {t['numpy_per_s']:.3g} |",
              "", f"Speed-up {t['speedup']:.1f}x; float32 vs float64 worst error "
              f"{t['max_err_over_m00']:.2g} of M00 (where M00 > 1e-7 of its maximum).", "",
              "## Error versus time", "",
              "Relative RMSE of S0 and RMSE of DoLP (luminance channel) against a "
              f"{args.reference_spp}-spp render with mixture sampling, at spp {args.spp_list}.", ""]
    for scene_name, methods in curves.items():
        lines += [f"### {scene_name}", "", "| method | spp | time (s) | RMSE S0 | RMSE DoLP |",
                  "|---|---|---|---|---|"]
        for method, points in methods.items():
            lines += [f"| {method} | {p[0]} | {p[1]:.3f} | {p[2]:.3g} | {p[3]:.3g} |" for p in points]
        mix = methods.get("mixture")
        for other in methods:
            if other != "mixture" and mix:
                for column, what in ((2, "S0"), (3, "DoLP")):
                    x = crossings(mix, methods[other], column)
                    lines.append(f"- {other} vs mixture ({what}): "
                                 + (f"curves cross at {x:.3g} s" if x else "curves do not cross "
                                    "in the measured range"))
        lines += ["", f"![{scene_name}](figures/{os.path.basename(figures[scene_name])})", ""]
    lines += ["## Peak memory (one render in a fresh process)", "", "| scene | peak RSS (MiB) |",
              "|---|---|"]
    lines += [f"| {name} | {mib:.0f} |" for name, mib in memory.items()]
    return "\n".join(lines) + "\n"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="tiny smoke-test configuration")
    parser.add_argument("--out", default=HERE, help="folder for results.md and figures/")
    args = parser.parse_args(argv)
    if args.quick:
        args.res, args.ratio_spp, args.reps, args.pairs = 48, 8, 2, 20_000
        args.spp_list, args.reference_spp, args.scenes = [1, 2, 4], 32, ["plane_small_light"]
    else:
        args.res, args.ratio_spp, args.reps, args.pairs = 192, 64, 7, 1_000_000
        args.spp_list = [1, 2, 4, 8, 16, 32, 64, 128]
        args.reference_spp, args.scenes = 4096, ["default", "plane_small_light", "sphere_environment"]
    os.makedirs(os.path.join(args.out, "figures"), exist_ok=True)

    start = time.perf_counter()
    load = [os.getloadavg()[0]]
    ratios = render_time_ratios(args.res, args.ratio_spp, args.reps)
    compiles = compile_times(args.res)
    throughput = eval_throughput(args.pairs, args.reps)
    curves = error_vs_time(args.scenes, args.res // 2 if not args.quick else args.res,
                           args.spp_list, args.reference_spp)
    figures = dict(zip(curves, plot_curves(curves, os.path.join(args.out, "figures"))))
    memory = {name: peak_memory(name, args.res, args.ratio_spp) for name in args.scenes}
    load.append(os.getloadavg()[0])
    text = report(args, ratios, compiles, throughput, curves, memory, figures,
                  time.perf_counter() - start, load)
    with open(os.path.join(args.out, "results.md"), "w") as f:
        f.write(text)
    sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
