"""Study 3: rendered Stokes images of aluminium and copper checked against physics.

    python validation/rendered_stokes.py [--spp 256] [--passes 8]
        (-> rendered_stokes.md, figures/rendered_<scene>_<metal>.png)

Scenes (``llvm_ad_spectral_polarized``, ``stokes`` + ``direct`` integrators,
box pixel filter): a plate and a sphere of ``pbrdf`` with the metal's tabulated
n, k (``material="Al"`` / ``"Cu"``, three lobes), lit by an unpolarized
directional light whose spectrum is a narrow band (628-638 nm) so that every
wavelength carried by a pixel sees nearly the same n + ik.

Checks per pixel:

* **Angle of linear polarization from geometry alone.** Unpolarized light
  reflected by the specular lobe from wi to wr is reflected by the facets with
  normal h = normalize(wi + wr); it leaves s-polarized with respect to that
  facet's plane of incidence (R_s >= R_p for every metal), i.e. polarized along
  ``wi x wr``, perpendicular to the plane containing the incident and the
  reflected ray. The depolarized lobes do not change the angle. So the expected
  AoLP of every pixel is the angle of ``wi x wr`` in the camera's Stokes frame
  (x = cross(ray direction, camera up)) - for the pixels whose ray lies in the
  plane of incidence (the plate's middle column), the direction perpendicular to
  the plane of incidence. No BRDF evaluation is involved.
* **Degree of linear polarization against the reference evaluator**: the
  footprint average (8 x 8 rays per pixel) of the reference's Stokes vector for
  unpolarized light, integrated over the light's band with the sensor's
  response (``band_weights``), rotated into the camera frame.

Noise: ``passes`` independent renders with different seeds; per pixel the
standard error of the mean DoLP (AoLP) over passes. Pixels compared: every ray
of the footprint hits the object, the light is more than ~3 deg above the local
horizon for the whole footprint (the terminator is a discontinuity the
footprint quadrature cannot resolve) and, for AoLP, the reference DoLP is at
least 10 standard errors (where the angle is defined).
"""

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from validation import common  # noqa: E402
from mitsuba_pbrdf import reference  # noqa: E402

BAND = (628.0, 638.0)                        # nm, the light's spectrum (plus 1 nm ramps)
BAND_NODES = np.linspace(BAND[0], BAND[1], 6)   # the reference's wavelengths in the band
LOBES = dict(kdd=0.15, sigma_dd=0.5, kid=0.03)
SIGMA = {"Al": 0.12, "Cu": 0.18}
SUBPIXELS = 8

SCENES = {
    # The plate of scenes/analytic_plane.xml, the light in the x-z plane so that
    # the middle column (odd width) sees the plane of incidence.
    "plate": dict(width=65, height=48, fov=40.0, origin=(2.4, 0.0, 1.2), target=(0.2, 0.0, 0.0),
                  up=(0.0, 0.0, 1.0), light=(0.85, 0.0, -0.45)),
    # A unit sphere seen from +z, lit from the right, slightly behind (phase angle ~96 deg).
    "sphere": dict(width=64, height=64, fov=34.0, origin=(0.0, 0.0, 4.0), target=(0.0, 0.0, 0.0),
                   up=(0.0, 1.0, 0.0), light=(-0.95, -0.25, 0.1)),
}


def light_spectrum():
    """A 10 nm wide band (linear ramps of 1 nm at the edges)."""
    lo, hi = BAND
    return {"type": "irregular", "wavelengths": f"{lo - 1}, {lo}, {hi}, {hi + 1}",
            "values": "0, 1, 1, 0"}


def band_weights():
    """Quadrature weights of BAND_NODES for what a pixel records: the integral
    over wavelength of S(lambda) E(lambda) (r + g + b)(lambda), with E the
    light's spectrum and r, g, b Mitsuba's linear sRGB responses (CIE 1931 XYZ
    -> sRGB); S is interpolated linearly between the nodes and held constant
    over the 1 nm ramps. Normalized to sum 1 (a common factor cancels in DoLP
    and AoLP and is fitted for S0)."""
    import mitsuba as mi

    lam = np.linspace(BAND[0] - 1.0, BAND[1] + 1.0, 2401)
    emission = np.interp(lam, [BAND[0] - 1, BAND[0], BAND[1], BAND[1] + 1], [0.0, 1.0, 1.0, 0.0])
    xyz = mi.cie1931_xyz(mi.Float(lam.astype(np.float32)))
    rgb = np.asarray(mi.xyz_to_srgb(mi.Color3f(xyz)), dtype=np.float64)
    response = emission * rgb.sum(axis=0)
    hats = np.stack([np.interp(lam, BAND_NODES, np.eye(len(BAND_NODES))[j])
                     for j in range(len(BAND_NODES))])       # constant beyond the end nodes
    w = (hats * response).sum(axis=1)
    return w / w.sum()


def scene_dict(name, metal):
    import mitsuba as mi

    s = SCENES[name]
    bsdf = dict({"type": "pbrdf", "material": metal, "sigma": SIGMA[metal]}, **LOBES)
    if name == "plate":
        shape = {"type": "rectangle", "to_world": mi.ScalarTransform4f().scale(10), "bsdf": bsdf}
    else:
        shape = {"type": "sphere", "bsdf": bsdf}
    return {
        "type": "scene",
        "integrator": {"type": "stokes", "integrator": {"type": "direct"}},
        "sensor": {"type": "perspective", "fov": s["fov"],
                   "to_world": mi.ScalarTransform4f().look_at(origin=s["origin"], target=s["target"],
                                                              up=s["up"]),
                   "sampler": {"type": "independent"},
                   "film": {"type": "hdrfilm", "width": s["width"], "height": s["height"],
                            "pixel_format": "rgb", "rfilter": {"type": "box"}}},
        "light": {"type": "directional", "direction": s["light"],
                  "irradiance": light_spectrum()},
        "object": shape,
    }


def render(scene, spp, passes, seed=0):
    """(passes, H, W, 4) Stokes vectors, the colour channels summed (the light is
    narrowband: every channel carries the same Stokes vector up to a factor)."""
    import mitsuba as mi

    out = []
    for p in range(passes):
        img = np.array(mi.render(scene, spp=spp, seed=seed + 1000 * p), dtype=np.float64)
        out.append(img[..., 3:15].reshape(img.shape[:-1] + (4, 3)).sum(axis=-1))
    return np.stack(out)


# ---------------------------------------------------------------------------
# Expected values
# ---------------------------------------------------------------------------

def _normalize(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def hit(name, origin, direction):
    """(hit mask, surface normal) per ray for the scene's object."""
    if name == "plate":
        t = -origin[..., 2] / direction[..., 2]
        p = origin + t[..., None] * direction
        mask = (t > 0) & (np.abs(p[..., 0]) < 10) & (np.abs(p[..., 1]) < 10)
        return mask, np.broadcast_to([0.0, 0.0, 1.0], origin.shape)
    b = np.sum(origin * direction, axis=-1)
    c = np.sum(origin * origin, axis=-1) - 1.0
    disc = b * b - c
    t = -b - np.sqrt(np.maximum(disc, 0.0))
    mask = (disc > 0) & (t > 0)
    return mask, _normalize(origin + t[..., None] * direction)


def angle_in_camera_frame(vector, direction, up):
    """Angle (rad) of a transverse ``vector`` from the camera's Stokes x axis
    cross(direction, up) (``direction``: the camera ray's), measured towards
    its y axis w x x_axis, where w = -direction is the direction in which the
    light propagates (right-handed (x, y, w), as Mitsuba's stokes_basis)."""
    x_axis = _normalize(np.cross(direction, up))
    y_axis = np.cross(-direction, x_axis)
    return np.arctan2(np.sum(vector * y_axis, -1), np.sum(vector * x_axis, -1))


def rotator_to_camera(forward, current, target):
    """Mueller rotator from Stokes basis ``current`` to ``target`` about
    ``forward`` (mitsuba.mueller.rotate_stokes_basis)."""
    theta = np.arccos(np.clip(np.sum(current * target, axis=-1), -1.0, 1.0))
    theta = np.where(np.sum(forward * np.cross(current, target), axis=-1) < 0, -theta, theta)
    return reference.rotator(theta)


def expected(name, metal, scene):
    """Per pixel: (valid mask, reference Stokes (H, W, 4) in the camera frame
    for unit irradiance, expected AoLP from geometry (H, W), and the same
    Stokes with 4 x 4 rays per pixel for the footprint-quadrature error)."""
    from mitsuba_pbrdf import frames

    origin, direction, up = frames.pixel_rays(scene.sensors()[0], SUBPIXELS)
    mask, normal = hit(name, origin, direction)
    w_i = _normalize(-np.asarray(SCENES[name]["light"], dtype=np.float64))   # towards the light
    w_r = -direction                                                         # towards the camera
    cos_i = np.sum(normal * w_i, -1)
    cos_r = np.sum(normal * w_r, -1)

    # Local frame per ray: z = normal, x = any tangent.
    helper = np.where(np.abs(normal[..., :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
    e1 = _normalize(np.cross(helper, normal))
    e2 = np.cross(normal, e1)

    def angles(w):
        return (np.arccos(np.clip(np.sum(w * normal, -1), -1, 1)),
                np.arctan2(np.sum(w * e2, -1), np.sum(w * e1, -1)))

    ti, pi_ = angles(np.broadcast_to(w_i, w_r.shape))
    tr, pr = angles(w_r)
    n, k = reference.conductor_ior(metal, BAND_NODES)
    weights = band_weights()
    stokes = np.zeros(ti.shape + (4,))
    for row in range(ti.shape[0]):                   # one image row at a time: lean memory
        F = reference.pbrdf(ti[row, ..., None], pi_[row, ..., None], tr[row, ..., None],
                            pr[row, ..., None], n, k, SIGMA[metal], **LOBES)
        stokes[row] = np.einsum("...w,...wi->...i", np.broadcast_to(weights, F.shape[:-2]),
                                F[..., :, 0])
    stokes *= np.maximum(cos_i, 0)[..., None]
    stokes = np.where(mask[..., None], stokes, 0.0)
    # reference output frame: s = normalize(n x w_r) (surface x axis at normal exit)
    s_out = np.cross(normal, w_r)
    s_norm = np.linalg.norm(s_out, axis=-1, keepdims=True)
    s_out = np.where(s_norm > 1e-12, s_out / np.maximum(s_norm, 1e-300), e1)
    camera_x = _normalize(np.cross(direction, up))
    stokes = np.einsum("...ij,...j->...i", rotator_to_camera(w_r, s_out, camera_x), stokes)

    valid = np.all(mask, axis=-1) & np.all(cos_i > 0.05, axis=-1) & np.all(cos_r > 0.05, axis=-1)
    pixel = stokes.mean(axis=2)
    coarse = stokes.reshape(stokes.shape[:2] + (SUBPIXELS // 2, 2, SUBPIXELS // 2, 2, 4))
    coarse = coarse[:, :, :, 0, :, 0].reshape(stokes.shape[:2] + (-1, 4)).mean(axis=2)

    # geometry only: polarization along w_i x w_r (the pixel's mean ray direction)
    d = _normalize(direction.mean(axis=2))
    perpendicular = np.cross(np.broadcast_to(w_i, d.shape), -d)
    aolp_geometry = angle_in_camera_frame(perpendicular, d, up)
    return valid, pixel, aolp_geometry, coarse


def dolp(stokes):
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.hypot(stokes[..., 1], stokes[..., 2]) / stokes[..., 0]


def aolp(stokes):
    return 0.5 * np.arctan2(stokes[..., 2], stokes[..., 1])


def wrap_half_pi(a):
    """Angle difference modulo pi, in [-pi/2, pi/2)."""
    return (a + 0.5 * np.pi) % np.pi - 0.5 * np.pi


# ---------------------------------------------------------------------------
# Study
# ---------------------------------------------------------------------------

def measure(name, metal, spp=256, passes=8):
    """Render and compare; returns a dict of figures of merit and images."""
    import mitsuba as mi

    scene = mi.load_dict(scene_dict(name, metal))
    start = time.perf_counter()
    images = render(scene, spp, passes)
    seconds = time.perf_counter() - start
    valid, ref, aolp_geo, coarse = expected(name, metal, scene)

    valid &= np.all(images[..., 0] > 0, axis=0)     # every pass saw light (narrow band)
    mean = images.mean(axis=0)
    # scale: least squares of rendered S0 on reference S0 over valid pixels
    # (irradiance x band x colour response: one constant per image)
    scale = np.sum(mean[..., 0] * ref[..., 0] * valid) / np.sum(ref[..., 0] ** 2 * valid)

    dolp_passes = dolp(images)
    dolp_mean = dolp(mean)
    dolp_se = dolp_passes.std(axis=0, ddof=1) / np.sqrt(passes)
    dolp_ref = dolp(ref)
    footprint = np.abs(dolp(coarse) - dolp_ref)          # 4x4 vs 8x8 rays: quadrature error
    d_dolp = dolp_mean - dolp_ref

    aolp_mean = aolp(mean)
    aolp_se = np.sqrt(np.mean(wrap_half_pi(aolp(images) - aolp_mean) ** 2, axis=0)
                      * passes / (passes - 1)) / np.sqrt(passes)
    polarized = valid & (dolp_ref > 10 * np.maximum(dolp_se, 1e-12))
    d_aolp_geo = wrap_half_pi(aolp_mean - aolp_geo)
    d_aolp_ref_geo = wrap_half_pi(aolp(ref) - aolp_geo)

    middle = np.zeros_like(valid)
    if name == "plate":
        middle[:, SCENES[name]["width"] // 2] = True      # rays in the plane of incidence
    in_plane = polarized & middle

    z = np.abs(d_dolp[valid]) / np.maximum(dolp_se[valid] + footprint[valid], 1e-12)
    z_aolp = np.abs(d_aolp_geo[polarized]) / np.maximum(aolp_se[polarized], 1e-12)
    # Aggregates robust to the heavy tails of per-pixel standard errors from
    # few passes: the image mean of the difference against its standard error
    # (a systematic error shows as a bias), and the RMS difference against the
    # RMS standard error (for pure noise they are equal in expectation).
    geometry_error = np.abs(d_aolp_ref_geo[polarized])    # single ray vs footprint average
    d_aolp_ref = wrap_half_pi(aolp_mean - aolp(ref))      # rendered vs reference evaluator
    aolp_footprint = np.abs(wrap_half_pi(aolp(coarse) - aolp(ref)))
    return {
        "scene": name, "metal": metal, "spp": spp, "passes": passes, "seconds": seconds,
        "pixels": int(valid.sum()), "polarized_pixels": int(polarized.sum()),
        "in_plane_pixels": int(in_plane.sum()),
        "scale": scale,
        "dolp_ref_max": float(dolp_ref[valid].max()),
        "dolp_mean_abs_error": float(np.abs(d_dolp[valid]).mean()),
        "dolp_max_abs_error": float(np.abs(d_dolp[valid]).max()),
        "dolp_bias": float(d_dolp[valid].mean()),
        "dolp_bias_se": float(np.sqrt(np.sum(dolp_se[valid] ** 2)) / valid.sum()),
        "dolp_median_se": float(np.median(dolp_se[valid])),
        "dolp_max_z": float(z.max()),
        "dolp_frac_3se": float(np.mean(np.abs(d_dolp[valid]) <= 3 * dolp_se[valid]
                                       + footprint[valid])),
        "footprint_max": float(footprint[valid].max()),
        "aolp_max_error_deg": float(np.degrees(np.abs(d_aolp_geo[polarized]).max())),
        "aolp_rms_error_deg": float(np.degrees(np.sqrt(np.mean(d_aolp_geo[polarized] ** 2)))),
        "aolp_median_se_deg": float(np.degrees(np.median(aolp_se[polarized]))),
        "aolp_max_z": float(z_aolp.max()),
        "aolp_ref_vs_geometry_deg": float(np.degrees(
            np.abs(d_aolp_ref_geo[valid & (dolp_ref > 1e-4)]).max())),
        "aolp_in_plane_max_deg": (float(np.degrees(np.abs(d_aolp_geo[in_plane]).max()))
                                  if in_plane.any() else np.nan),
        "aolp_in_plane_mean_deg": (float(np.degrees(d_aolp_geo[in_plane].mean()))
                                   if in_plane.any() else np.nan),
        "aolp_in_plane_mean_se_deg": (float(np.degrees(np.sqrt(np.sum(aolp_se[in_plane] ** 2))
                                                       / in_plane.sum()))
                                      if in_plane.any() else np.nan),
        "dolp_rms_error": float(np.sqrt(np.mean(d_dolp[valid] ** 2))),
        "dolp_rms_se": float(np.sqrt(np.mean(dolp_se[valid] ** 2))),
        "footprint_rms": float(np.sqrt(np.mean(footprint[valid] ** 2))),
        "aolp_mean_error_deg": float(np.degrees(d_aolp_geo[polarized].mean())),
        "aolp_mean_se_deg": float(np.degrees(np.sqrt(np.sum(aolp_se[polarized] ** 2))
                                             / max(polarized.sum(), 1))),
        "aolp_rms_se_deg": float(np.degrees(np.sqrt(np.mean(aolp_se[polarized] ** 2)))),
        "aolp_geometry_rms_deg": float(np.degrees(np.sqrt(np.mean(geometry_error ** 2)))),
        "aolp_ref_mean_error_deg": float(np.degrees(d_aolp_ref[polarized].mean())),
        "aolp_ref_rms_error_deg": float(np.degrees(np.sqrt(np.mean(d_aolp_ref[polarized] ** 2)))),
        "aolp_ref_max_error_deg": float(np.degrees(np.abs(d_aolp_ref[polarized]).max())),
        "aolp_footprint_rms_deg": float(np.degrees(np.sqrt(np.mean(aolp_footprint[polarized] ** 2)))),
        "images": dict(mean=mean, valid=valid, dolp=dolp_mean, dolp_ref=dolp_ref, d_dolp=d_dolp,
                       dolp_se=dolp_se, aolp=aolp_mean, aolp_geo=aolp_geo, polarized=polarized),
    }


def figure(result):
    plt = common.pyplot()
    im = result["images"]
    valid = im["valid"]
    fig, axes = plt.subplots(1, 5, figsize=(15, 3.1))

    def show(ax, data, title, cmap, vmin=None, vmax=None, mask=None):
        d = np.where(mask if mask is not None else np.ones_like(valid), data, np.nan)
        h = ax.imshow(d, cmap=cmap, vmin=vmin, vmax=vmax, interpolation="nearest")
        ax.set_title(title)
        ax.set_xticks([])
        ax.set_yticks([])
        fig.colorbar(h, ax=ax, fraction=0.046, pad=0.03)

    s0 = im["mean"][..., 0]
    show(axes[0], s0 / np.percentile(s0[valid], 99.5), "S0 (rendered)", "gray", 0, 1)
    vmax = float(np.percentile(im["dolp_ref"][valid], 99.5))
    show(axes[1], im["dolp"], "DoLP rendered", "viridis", 0, vmax, valid)
    show(axes[2], im["dolp_ref"], "DoLP reference", "viridis", 0, vmax, valid)
    lim = float(np.percentile(np.abs(im["d_dolp"][valid]), 99.5))
    show(axes[3], im["d_dolp"], "DoLP rendered − reference", "RdBu", -lim, lim, valid)
    d_aolp = np.degrees(wrap_half_pi(im["aolp"] - im["aolp_geo"]))
    lim = max(float(np.percentile(np.abs(d_aolp[im["polarized"]]), 99.5)), 1e-3)
    show(axes[4], d_aolp, "AoLP rendered − geometry (°)", "RdBu", -lim, lim, im["polarized"])
    # AoLP as line segments on the intensity image
    ys, xs = np.nonzero(im["polarized"])
    step = max(1, len(xs) // 150)
    for y, x in zip(ys[::step], xs[::step]):
        a = im["aolp_geo"][y, x]
        dx, dy = 0.9 * np.cos(a), -0.9 * np.sin(a)   # image rows grow downward
        axes[0].plot([x - dx, x + dx], [y - dy, y + dy], color="tab:red", lw=0.6)
    height, width = valid.shape
    axes[0].set_xlim(-0.5, width - 0.5)
    axes[0].set_ylim(height - 0.5, -0.5)
    fig.suptitle(f"{result['scene']}, {result['metal']} ({result['spp']} spp × "
                 f"{result['passes']} passes): red ticks = polarization direction expected from "
                 "geometry (wi × wr)", fontsize=9)
    fig.tight_layout()
    return common.save_figure(fig, f"rendered_{result['scene']}_{result['metal']}")


def report(spp=256, passes=8):
    start = time.perf_counter()
    results = []
    for name in SCENES:
        for metal in ("Al", "Cu"):
            r = measure(name, metal, spp, passes)
            r["figure"] = figure(r)
            results.append(r)
    rows = [(r["scene"], r["metal"], r["pixels"], r["dolp_ref_max"],
             f"{r['dolp_bias']:.1e} ± {r['dolp_bias_se']:.1e}", r["dolp_rms_error"],
             r["dolp_rms_se"], r["dolp_max_abs_error"], r["footprint_rms"] / 3) for r in results]
    dolp_table = common.table(
        ["scene", "metal", "pixels", "max DoLP", "mean ΔDoLP ± s.e.", "RMS ΔDoLP",
         "RMS s.e.", "max |ΔDoLP|", "footprint error (RMS)"], rows)
    rows = [(r["scene"], r["metal"], r["polarized_pixels"], r["aolp_rms_error_deg"],
             r["aolp_max_error_deg"], r["aolp_geometry_rms_deg"], r["aolp_ref_vs_geometry_deg"],
             f"{r['aolp_ref_mean_error_deg']:.1e} ± {r['aolp_mean_se_deg']:.1e}",
             r["aolp_ref_rms_error_deg"], r["aolp_rms_se_deg"],
             (f"{r['in_plane_pixels']}: {r['aolp_in_plane_mean_deg']:.1e} ± "
              f"{r['aolp_in_plane_mean_se_deg']:.1e}, max {r['aolp_in_plane_max_deg']:.3f}")
             if r["in_plane_pixels"] else "–") for r in results]
    aolp_table = common.table(
        ["scene", "metal", "pixels", "vs geometry: RMS Δ (°)", "max |Δ| (°)",
         "rule's own error: RMS (°)", "max (°)", "vs reference: mean Δ ± s.e. (°)", "RMS Δ (°)",
         "RMS s.e. (°)", "in-plane pixels: mean Δ ± s.e., max |Δ| (°)"], rows)
    figures = "\n\n".join(f"![{r['scene']} {r['metal']}]({r['figure']})" for r in results)
    render_seconds = sum(r["seconds"] for r in results)
    text = f"""# Study 3: rendered Stokes images against physics

`python validation/rendered_stokes.py --spp {spp} --passes {passes}`
({time.perf_counter() - start:.0f} s, of which {render_seconds:.0f} s rendering).
`llvm_ad_spectral_polarized`, `stokes` + `direct` integrators, box filter; a plate and a unit
sphere of `pbrdf` (`material` Al or Cu, σ {SIGMA['Al']} (Al), {SIGMA['Cu']} (Cu),
kdd {LOBES['kdd']}, σdd {LOBES['sigma_dd']}, kid {LOBES['kid']}), unpolarized directional light with a {BAND[0]:g}–{BAND[1]:g} nm band
spectrum. Each image: {passes} independent renders of {spp} spp (seeds differ), i.e.
{spp * passes} spp in all; Δ = value of the mean image − expected; standard errors (s.e.) from
the spread over the passes. Pixels: footprint fully on the object, light and camera more than
3° above the local horizon, light seen in every pass; AoLP only where the reference DoLP exceeds
10 s.e. Expected values: the reference evaluator averaged over 8×8 rays per pixel and over the
band with the sensor's response (footprint error: a third of the 8×8 − 4×4 difference,
Richardson's estimate for the midpoint rule).

**Angle of linear polarization.** The geometric rule: the reflected light is polarized along
wi × wr, perpendicular to the plane containing the incident and the reflected ray; for the
plate's middle column, whose rays lie in the plane of incidence, perpendicular to the plane of
incidence. "Rule's own error" is the reference evaluator against the rule (evaluated on the
pixel's central ray, whereas the pixel averages its footprint). The rendered AoLP is also
compared with the reference evaluator's.

{aolp_table}

**Degree of linear polarization** against the reference evaluator:

{dolp_table}

Both are at the Monte Carlo noise: the mean differences are within a few standard errors of 0
and the RMS differences equal the RMS standard errors.

{figures}
"""
    common.write_markdown("rendered_stokes", text)
    return results


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--spp", type=int, default=256)
    parser.add_argument("--passes", type=int, default=8)
    args = parser.parse_args(argv)
    common.use_variant()
    report(args.spp, args.passes)


if __name__ == "__main__":
    main()
