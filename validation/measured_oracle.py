"""Study: Mitsuba's own ``measured_polarized`` as an independent oracle.

    python validation/measured_oracle.py [--size 96] [--spp 256] [--grids coarse,default,kaist]
                                         [--quick]
        (-> measured_oracle.md, figures/measured_oracle_<grid>.png)

The model (flat n = 0.9, k = 2.4, sigma = 0.15, kdd = 0.1, sigma_dd = 0.5,
kid = 0.02: spectrally flat, so the table's 5 bands and the clamping outside
450-650 nm play no part) is exported with ``pbrdf export`` on several grids and
rendered with Mitsuba's C++ ``measured_polarized``; the model itself renders
with ``pbrdf`` in the same scenes (``llvm_ad_spectral_polarized``).

1. **BSDF level**: ``measured_polarized``'s ``eval`` (scalar variant) against
   the NumPy emulation of its lookup at random direction pairs: does the
   emulation read Mitsuba's conventions right?
2. **Predicted interpolation error**: emulation against the float64 model at
   random pairs (both directions within 84 deg of the normal).
3. **Direct lighting**: a sphere under a directional light, orthographic
   camera (``proof/measured_oracle.py``): per-pixel S0 (relative), DoLP
   and AoLP (deg) of ``measured_polarized`` minus ``pbrdf``, against the
   per-pixel bound predicted before rendering (largest sub-pixel difference of
   the emulated table and the model, plus float32 floors of 1e-4, 1e-4,
   0.01 deg). Both renders draw the same sub-pixel positions.
4. **Path tracing** (default grid): the sphere on a floor of the same
   material, directional light plus a constant environment, ``path`` with
   ``max_depth`` 4, different BSDF sampling in the two plugins (so
   independent Monte Carlo noise): per-pixel differences in units of their
   standard error (from ``passes`` independent renders), and the image means.
"""

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from validation import common  # noqa: E402

MODEL = dict(eta=0.9, k=2.4, sigma=0.15, kdd=0.1, sigma_dd=0.5, kid=0.02)
GRIDS = {"coarse": "25x40x40", "default": "default", "kaist": "kaist"}
FLOORS = dict(s0=1e-4, dolp=1e-4, aolp=0.01)


def params():
    from mitsuba_pbrdf.reference.params import PBRDFParams
    return PBRDFParams(**MODEL).validate()


def plugin():
    return dict(type="pbrdf", **MODEL)


def export_table(grid_name, folder):
    from mitsuba_pbrdf.measured.export import export_pbsdf, parse_grid
    path = os.path.join(folder, f"oracle_{grid_name}.pbsdf")
    grid = parse_grid(GRIDS[grid_name])
    t0 = time.perf_counter()
    if not os.path.exists(path):
        export_pbsdf(path, params(), grid)
    return path, grid, time.perf_counter() - t0


def bsdf_level(path, n):
    """measured_polarized (scalar variant) vs the emulation: largest
    |difference| / M00 per element over n pairs, and the median."""
    import mitsuba as mi

    from mitsuba_pbrdf import frames, use_variant
    from mitsuba_pbrdf.measured import lookup, pbsdf
    use_variant("scalar_spectral_polarized")
    try:
        bsdf = mi.load_dict({"type": "measured_polarized", "filename": path})
        wi_hat, wo_hat = frames.random_directions(n, np.random.default_rng(5), min_cos=0.1)
        wl = np.array([470.0, 520.0, 580.0, 630.0])
        M = frames.eval_global(bsdf, wi_hat, wo_hat, wl)
    finally:
        use_variant(common.VARIANT)
    E = lookup.lookup(pbsdf.read_pbsdf(path), wo_hat[:, None], wi_hat[:, None], wl[None, :])
    rel = np.abs(M - E) / E[..., :1, :1]
    return float(np.median(rel)), float(np.percentile(rel, 99.9)), float(rel.max())


def interpolation_error(path, n):
    """Emulated table vs the model at n random pairs (cos >= 0.1)."""
    from mitsuba_pbrdf import frames
    from mitsuba_pbrdf.measured import lookup, pbsdf, rusinkiewicz
    from mitsuba_pbrdf.reference import dop_unpolarized
    wi_hat, wo_hat = frames.random_directions(n, np.random.default_rng(6), min_cos=0.1)
    E = lookup.lookup(pbsdf.read_pbsdf(path), wo_hat, wi_hat, 550.0)
    R = params().evaluate(*rusinkiewicz.angles(wo_hat, wi_hat), [550.0])[:, 0]
    big = R[:, 0, 0] > 1e-3 * R[:, 0, 0].max()
    rel = np.abs(E[:, 0, 0] - R[:, 0, 0])[big] / R[big, 0, 0]
    dd = np.abs(dop_unpolarized(E) - dop_unpolarized(R))[big]
    return [float(np.median(rel)), float(np.percentile(rel, 99)), float(np.median(dd)),
            float(np.percentile(dd, 99))]


def compare_direct(path, size, spp):
    from mitsuba_pbrdf.measured import pbsdf
    from proof import measured_oracle as oracle
    scene = lambda b: oracle.sphere_scene(b, size, spp)
    t0 = time.perf_counter()
    model = oracle.render_stokes(scene(plugin()), seed=3)
    t_model = time.perf_counter() - t0
    t0 = time.perf_counter()
    table = oracle.render_stokes(scene({"type": "measured_polarized", "filename": path,
                                        "alpha_sample": 0.2}), seed=3)
    t_table = time.perf_counter() - t0
    pred = oracle.predict_direct(pbsdf.read_pbsdf(path), params(), scene(plugin()), size)
    qm, qt = oracle.quantities(model), oracle.quantities(table)
    v = pred["valid"] & (qm[0] > 1e-3 * qm[0].max())
    pol = v & (qm[1] > 0.02)
    with np.errstate(invalid="ignore", divide="ignore"):
        d = {"s0": np.abs(qt[0] - qm[0]) / qm[0], "dolp": np.abs(qt[1] - qm[1]),
             "aolp": np.abs(oracle.angle_difference(qt[2], qm[2]))}
    bounds = {"s0": pred["bound_s0"], "dolp": pred["bound_dolp"], "aolp": pred["bound_aolp"]}
    masks = {"s0": v, "dolp": v, "aolp": pol}
    stats = {}
    for q in ("s0", "dolp", "aolp"):
        m = masks[q]
        stats[q] = dict(median=float(np.median(d[q][m])), p99=float(np.percentile(d[q][m], 99)),
                        max=float(d[q][m].max()), bound_median=float(np.median(bounds[q][m])),
                        bound_max=float(bounds[q][m].max()),
                        excess=float((d[q] / (bounds[q] + FLOORS[q]))[m].max()))
    return dict(stats=stats, pixels=int(v.sum()), polarized=int(pol.sum()), model=qm, diff=d,
                bounds=bounds, valid=v, pol=pol, seconds=(t_model, t_table))


def compare_path(path, size, spp, passes):
    """Path-traced sphere on a floor: per-pixel z-scores of the difference."""
    from proof import measured_oracle as oracle

    def scene(bsdf):
        import mitsuba as mi
        s = oracle.sphere_scene(bsdf, size, spp, integrator="path", max_depth=4,
                                environment=0.15)
        s["floor"] = {"type": "rectangle", "bsdf": bsdf,
                      "to_world": mi.ScalarTransform4f().translate([0, 0, -1]).scale(3.0)}
        return s

    runs = {}
    for name, bsdf in (("model", plugin()), ("table", {"type": "measured_polarized",
                                                       "filename": path, "alpha_sample": 0.2})):
        runs[name] = np.stack([oracle.render_stokes(scene(bsdf), seed=100 + i)
                               for i in range(passes)])
    mean = {k: v.mean(0) for k, v in runs.items()}
    se = {k: v.std(0, ddof=1) / np.sqrt(passes) for k, v in runs.items()}
    sigma = np.sqrt(se["model"] ** 2 + se["table"] ** 2)
    with np.errstate(invalid="ignore", divide="ignore"):
        z = (mean["table"] - mean["model"]) / sigma
    lit = mean["model"][..., 0] > 1e-3 * mean["model"][..., 0].max()
    zs = {c: z[..., i][lit & (sigma[..., i] > 0)] for i, c in enumerate(("S0", "S1", "S2"))}
    image = {c: (mean["table"][..., i].sum() - mean["model"][..., i].sum())
             / mean["model"][..., 0].sum() for i, c in enumerate(("S0", "S1", "S2"))}
    image_se = {c: np.sqrt((sigma[..., i] ** 2).sum()) / mean["model"][..., 0].sum()
                for i, c in enumerate(("S0", "S1", "S2"))}
    return zs, image, image_se, int(lit.sum())


def figure(name, r):
    plt = common.pyplot()
    fig, axes = plt.subplots(3, 3, figsize=(10, 9.5))
    v = r["valid"]
    shows = [("S0 (pbrdf)", r["model"][0], "magma", None),
             ("DoLP (pbrdf)", r["model"][1], "viridis", (0, max(r["model"][1][v].max(), 1e-3))),
             ("AoLP deg (pbrdf)", np.where(r["pol"], r["model"][2], np.nan), "twilight", (-90, 90))]
    for ax, (title, img, cmap, lim) in zip(axes[0], shows):
        im = ax.imshow(np.where(v, img, np.nan), cmap=cmap, clim=lim)
        ax.set_title(title)
        fig.colorbar(im, ax=ax, fraction=0.046)
    for row, what in ((1, "diff"), (2, "bounds")):
        for ax, q in zip(axes[row], ("s0", "dolp", "aolp")):
            m = r["pol"] if q == "aolp" else v
            img = np.where(m, np.maximum(r[what][q], 1e-7), np.nan)
            im = ax.imshow(np.log10(img), cmap="inferno", clim=(-6, 0))
            ax.set_title(("|measured_polarized - pbrdf| " if row == 1 else "predicted bound ")
                         + {"s0": "S0 (rel.)", "dolp": "DoLP", "aolp": "AoLP (deg)"}[q]
                         + ", log10", fontsize=8)
            fig.colorbar(im, ax=ax, fraction=0.046)
    for ax in axes.ravel():
        ax.set_axis_off()
    fig.suptitle(f"measured_polarized vs pbrdf, {name} table grid")
    return common.save_figure(fig, f"measured_oracle_{name}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=96)
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--passes", type=int, default=8)
    ap.add_argument("--grids", default="coarse,default,kaist")
    ap.add_argument("--folder", default=os.path.join(common.ROOT, "out", "measured_oracle"))
    ap.add_argument("--quick", action="store_true", help="small images, no KAIST grid")
    args = ap.parse_args(argv)
    if args.quick:
        args.size, args.spp, args.passes, args.grids = 48, 64, 4, "coarse,default"
    common.use_variant()
    os.makedirs(args.folder, exist_ok=True)
    rows_bsdf, rows_interp, rows_render, figures = [], [], [], []
    for name in args.grids.split(","):
        path, grid, t_export = export_table(name, args.folder)
        mb = os.path.getsize(path) / 2**20
        med, p999, mx = bsdf_level(path, 400 if args.quick else 3000)
        rows_bsdf.append([f"{name} ({grid})", med, p999, mx])
        rows_interp.append([f"{name} ({grid}, {mb:.0f} MiB)"] + interpolation_error(
            path, 5000 if args.quick else 40000))
        r = compare_direct(path, args.size, args.spp)
        s = r["stats"]
        rows_render.append([f"{name} ({grid})", r["pixels"], s["s0"]["median"], s["s0"]["p99"],
                            s["s0"]["max"], s["s0"]["bound_max"], s["dolp"]["median"],
                            s["dolp"]["max"], s["dolp"]["bound_max"], s["aolp"]["median"],
                            s["aolp"]["max"], s["aolp"]["bound_max"],
                            max(s[q]["excess"] for q in s) <= 1])
        figures.append((name, figure(name, r)))
        print(f"{name}: exported in {t_export:.0f} s, rendered in {r['seconds'][0]:.1f} s (pbrdf), "
              f"{r['seconds'][1]:.1f} s (measured_polarized, incl. kernel compilation)", flush=True)
    path, _, _ = export_table("default", args.folder)
    zs, image, image_se, lit = compare_path(path, args.size // 2 if not args.quick else 32,
                                            args.spp // 2, args.passes)
    from scipy.stats import t as student
    dof = 2 * (args.passes - 1)       # two standard errors, each from `passes` renders
    expected = 2 * student.sf(3.0, dof)
    rows_path = [[c, lit, float(np.median(np.abs(zs[c]))), float(np.mean(np.abs(zs[c]) > 3)),
                  expected, float(np.abs(zs[c]).max()), image[c], image_se[c]] for c in zs]

    text = [
        "# Mitsuba's measured_polarized as an independent oracle",
        "",
        f"Generated by `python validation/measured_oracle.py{' --quick' if args.quick else ''}` "
        f"({args.size}x{args.size} pixels, {args.spp} spp, `{common.VARIANT}`). Model: "
        f"flat n = {MODEL['eta']}, k = {MODEL['k']}, sigma = {MODEL['sigma']}, kdd = {MODEL['kdd']}, "
        f"sigma_dd = {MODEL['sigma_dd']}, kid = {MODEL['kid']}, V-groove shadowing; tables "
        "written by `pbrdf export` (grids phi_d x theta_d x theta_h; `default` has a "
        "square-spaced theta_h, `kaist` is the database's uniform 1-degree grid).",
        "",
        "## 1. Mitsuba's lookup read right",
        "",
        "`measured_polarized`'s `eval` (scalar variant) against the NumPy emulation "
        "(`mitsuba_pbrdf.measured.lookup`) at random pairs (both directions within 84 deg), "
        "4 wavelengths, 16 elements: |difference| / M00.",
        "",
        common.table(["table", "median", "99.9 %", "max"], rows_bsdf),
        "",
        "The tails come from float32 angles near the specular peak (tests/measured/test_pbsdf.py "
        "bounds them); a convention read wrongly would differ at order 1.",
        "",
        "## 2. Predicted interpolation error",
        "",
        "The emulated table against the float64 model at random pairs (M00 at least 1e-3 of "
        "the largest), 550 nm.",
        "",
        common.table(["table", "M00 rel. median", "M00 rel. 99 %", "DoLP median", "DoLP 99 %"],
                     rows_interp),
        "",
        "## 3. Direct lighting: per-pixel agreement",
        "",
        "Per pixel |measured_polarized - pbrdf| for S0 (relative), DoLP and AoLP (deg, where "
        "DoLP > 0.02); `bound max` is the largest per-pixel bound predicted before rendering; "
        f"`within` says whether every pixel stays within its bound plus the float32 floors "
        f"({FLOORS['s0']:g}, {FLOORS['dolp']:g}, {FLOORS['aolp']:g} deg).",
        "",
        common.table(["table", "pixels", "S0 median", "S0 99 %", "S0 max", "S0 bound max",
                      "DoLP median", "DoLP max", "DoLP bound max", "AoLP median", "AoLP max",
                      "AoLP bound max", "within"], rows_render),
        "",
    ]
    for name, fig in figures:
        text += [f"![{name}]({fig})", ""]
    text += [
        "## 4. Path tracing",
        "",
        "The sphere on a floor of the same material, directional light plus a constant "
        f"environment, `path` (max_depth 4), {args.passes} passes of {args.spp // 2} spp each, "
        "default table. The two plugins sample differently, so their noise is independent: "
        "z = difference / its standard error (from the passes) per lit pixel, and the "
        "difference of the image sums relative to the sum of S0 (with its standard error).",
        "",
        common.table(["Stokes", "pixels", "median |z|", "share |z| > 3",
                      f"expected share (Student t, {dof} dof)", "max |z|",
                      "image difference / sum S0", "standard error"], rows_path),
        "",
        "The standard errors are themselves estimated from the passes, so z follows "
        "Student's t rather than a Gaussian (median |z| about 0.7); an interpolation error "
        "larger than the noise would show up as a larger share and a significant image "
        "difference.",
    ]
    common.write_markdown("measured_oracle", "\n".join(text))


if __name__ == "__main__":
    main()
