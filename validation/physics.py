"""Study 2: physics checks, each on the float64 reference and on the plugin.

    python validation/physics.py [--pairs 100000]   (-> physics.md, figures/physics_fresnel.png)

1. Fresnel reflectance at normal incidence against ((n-1)^2 + k^2) / ((n+1)^2 + k^2)
   from the conductor's tabulated n, k.
2. Pseudo-Brewster angle (minimum of R_p) of Al and Cu against the minimum of the
   closed-form (real-arithmetic, Born & Wolf) Fresnel R_p, and the Brewster angle
   arctan(n) of a dielectric.
3. Unpolarized light reflected into the mirror direction is s-polarized (S1 > 0 in
   the s/p frame) and its degree of polarization rises up to the pseudo-Brewster
   angle.
4. Reciprocity: M00(wi, wr) = M00(wr, wi), and the whole matrix obeys
   M(r -> i) = Q M(i -> r)^T Q, Q = diag(1, 1, -1, 1).
5. Realizability: the eigenvalues of Cloude's coherency matrix are >= 0 and the
   degree of polarization of the output is <= 1 for every input Stokes vector.

The directional-hemispherical albedo (white furnace) is ``furnace.py``. The
tolerances and their reasons are in ``tests/test_physics.py``, which runs the same
functions with fewer samples.

How the plugin is measured: ``frames.eval_global`` returns its BRDF (cosine
divided out) in the reference's global s/p frames. In the mirror direction of a
flat-on-average surface the half vector is the normal, so D(h) = 1 / (pi alpha^2),
V-groove G = 1 and the specular lobe is D F(theta) / (4 cos^2 theta): the facet's
Fresnel Mueller matrix F at the incidence angle is 4 pi alpha^2 cos^2(theta) M.
"""

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from validation import common  # noqa: E402
from mitsuba_pbrdf import reference  # noqa: E402

METALS = ("Al", "Cu", "Au", "Ag")
WAVELENGTHS = (400.0, 450.0, 500.0, 550.0, 600.0, 650.0, 700.0, 800.0)
SIGMA = 0.1                         # RMS slope of the specular lobe in checks 1-3
ALPHA = np.sqrt(2.0) * SIGMA
Q = np.diag([1.0, 1.0, -1.0, 1.0])

#: Configurations of checks 4 and 5 (plugin parameters; the reference gets the same).
CONFIGS = {
    "Al, 3 lobes, vgroove": dict(material="Al", sigma=0.15, kdd=0.2, sigma_dd=0.5, kid=0.05),
    "Cu, 3 lobes, smith, ggx": dict(material="Cu", sigma=0.3, kdd=0.3, sigma_dd=0.8, kid=0.1,
                                    shadowing="smith", dd_distribution="ggx"),
    "Au, specular, sigma 0.02": dict(material="Au", sigma=0.02),
    "dielectric n 1.5, k 0": dict(eta=1.5, k=0.0, sigma=0.2, kid=0.05),
    "n 0.5, k 0 (total reflection)": dict(eta=0.5, k=0.0, sigma=0.3, shadowing="smith"),
}
CONFIG_WAVELENGTHS = (450.0, 520.0, 600.0, 690.0)


# ---------------------------------------------------------------------------
# Evaluation helpers
# ---------------------------------------------------------------------------

def _in_plane_pair(theta):
    """(to_viewer, to_light) unit vectors in the x-z plane: light at +x,
    viewer in the mirror direction."""
    theta = np.atleast_1d(np.asarray(theta, dtype=np.float64))
    to_light = np.stack([np.sin(theta), np.zeros_like(theta), np.cos(theta)], axis=1)
    return to_light * [-1.0, 1.0, 1.0], to_light


def plugin_global(bsdf, to_viewer, to_light, wavelengths, mode="radiance"):
    """frames.eval_global over any number of wavelengths (4 per call):
    (n, len(wavelengths), 4, 4)."""
    from mitsuba_pbrdf import frames

    wavelengths = list(wavelengths)
    out = []
    for start in range(0, len(wavelengths), 4):
        block = wavelengths[start:start + 4]
        padded = block + [block[-1]] * (4 - len(block))
        out.append(frames.eval_global(bsdf, to_viewer, to_light, padded, mode)[:, :len(block)])
    return np.concatenate(out, axis=1)


def load_plugin(**params):
    import mitsuba as mi

    return mi.load_dict(dict({"type": "pbrdf"}, **params))


def reference_config(config, wavelengths):
    """reference.pbrdf keyword arguments (n, k of shape (w,)) for a CONFIGS entry."""
    c = dict(dict(ks=1.0, kdd=0.0, sigma_dd=0.5, kid=0.0, shadowing="vgroove",
                  dd_distribution="beckmann"), **config)
    if "material" in c:
        n, k = reference.conductor_ior(c.pop("material"), wavelengths)
    else:
        n, k = np.full(len(wavelengths), c.pop("eta")), np.full(len(wavelengths), c.pop("k"))
    return dict(c, n=n, k=k)


def reference_global(config, to_viewer, to_light, wavelengths):
    from mitsuba_pbrdf import frames

    ti, pi_ = frames.to_angles(to_light)
    tr, pr = frames.to_angles(to_viewer)
    return reference.pbrdf(ti[:, None], pi_[:, None], tr[:, None], pr[:, None],
                           **reference_config(config, wavelengths))


# ---------------------------------------------------------------------------
# 1. Fresnel reflectance at normal incidence
# ---------------------------------------------------------------------------

def normal_incidence(metals=METALS, wavelengths=WAVELENGTHS, plugin=True):
    """Rows (metal, wavelength, n, k, R closed form, R reference, R plugin)."""
    rows = []
    up = np.array([[0.0, 0.0, 1.0]])
    for metal in metals:
        n, k = reference.conductor_ior(metal, wavelengths)
        closed = ((n - 1) ** 2 + k**2) / ((n + 1) ** 2 + k**2)
        # normal incidence and exit: h = z, D = 1/(pi alpha^2), G = 1, f = D R / 4
        f_ref = reference.pbrdf(0.0, 0.0, 0.0, 0.0, n, k, SIGMA)[..., 0, 0]
        r_ref = 4 * np.pi * ALPHA**2 * f_ref
        r_plugin = np.full(len(wavelengths), np.nan)
        if plugin:
            M = plugin_global(load_plugin(material=metal, sigma=SIGMA), up, up, wavelengths)
            r_plugin = 4 * np.pi * ALPHA**2 * M[0, :, 0, 0]
        for i, wl in enumerate(wavelengths):
            rows.append((metal, wl, n[i], k[i], closed[i], r_ref[i], r_plugin[i]))
    return rows


# ---------------------------------------------------------------------------
# 2. Pseudo-Brewster angle
# ---------------------------------------------------------------------------

def closed_form_reflectances(theta, n, k):
    """R_s, R_p in real arithmetic (Born & Wolf 14.4; the form of Mitsuba's
    fresnel_conductor): an implementation independent of the complex one."""
    c = np.cos(theta)
    c2, s2 = c * c, 1 - c * c
    t1 = n * n - k * k - s2
    a2pb2 = np.sqrt(t1 * t1 + 4 * n * n * k * k)
    a = np.sqrt(np.maximum(0.5 * (a2pb2 + t1), 0.0))
    term1, term2 = a2pb2 + c2, 2 * c * a
    rs = (term1 - term2) / (term1 + term2)
    term3, term4 = a2pb2 * c2 + s2 * s2, term2 * s2
    return rs, rs * (term3 - term4) / (term3 + term4)


def closed_form_pseudo_brewster(n, k):
    """The angle minimizing the closed-form R_p: bisection on the sign of its
    central-difference slope (step 1e-6 rad) down to 1e-12 rad. For k = 0 it is
    Brewster's arctan(n)."""
    def slope(t, h=1e-6):
        return (closed_form_reflectances(t + h, n, k)[1]
                - closed_form_reflectances(t - h, n, k)[1])

    lo, hi = 1e-3, 0.5 * np.pi - 1e-5
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if slope(mid) < 0 else (lo, mid)
    return 0.5 * (lo + hi)


def _golden_min(f, lo, hi, tol=1e-10):
    g = (np.sqrt(5) - 1) / 2
    a, b = lo, hi
    c, d = b - g * (b - a), a + g * (b - a)
    while b - a > tol:
        if f(c) < f(d):
            b, d = d, c
            c = b - g * (b - a)
        else:
            a, c = c, d
            d = a + g * (b - a)
    return 0.5 * (a + b)


def rp_reference(theta, n, k):
    """R_p from the reference BRDF in the mirror direction: a p-polarized input
    (S = [1, -1, 0, 0]) gives S0 = M00 - M01 = D R_p / (4 cos^2)."""
    M = reference.pbrdf(theta, 0.0, theta, np.pi, n, k, SIGMA)
    return (M[..., 0, 0] - M[..., 0, 1]) * 4 * np.pi * ALPHA**2 * np.cos(theta) ** 2


def rp_plugin(bsdf, theta, wavelength):
    to_viewer, to_light = _in_plane_pair(theta)
    M = plugin_global(bsdf, to_viewer, to_light, [wavelength])[:, 0]
    return (M[:, 0, 0] - M[:, 0, 1]) * 4 * np.pi * ALPHA**2 * np.cos(theta) ** 2


def plugin_argmin(values, theta):
    """Minimum of sampled values: the vertex of the parabola through the
    lowest grid point and its two neighbours."""
    i = int(np.argmin(values))
    i = min(max(i, 1), len(values) - 2)
    y0, y1, y2 = values[i - 1:i + 2]
    step = theta[1] - theta[0]
    return theta[i] + 0.5 * step * (y0 - y2) / (y0 - 2 * y1 + y2)


PSEUDO_BREWSTER_CASES = [("Al", 450.0), ("Al", 632.8), ("Cu", 450.0), ("Cu", 632.8),
                         ("Au", 550.0), ("Ag", 550.0), ("dielectric n 1.5", 550.0)]


def pseudo_brewster(cases=PSEUDO_BREWSTER_CASES, plugin=True, step_deg=0.01):
    """Rows: (case, wavelength, n, k, closed form deg, reference deg, plugin deg,
    plugin resolution deg, min R_p). The plugin's minimum is found on a grid of
    ``step_deg`` with a parabola through the three lowest points; its
    resolution is the angle over which float32 rounding can move the minimum:
    R_p = (M00 - M01) x scale carries an error of ~2e-6 (2^-24 relative per
    operation, ~30 operations) of M00 ~ (R_s + R_p) / 2, which moves the
    minimum of R_p,min + R_p'' d^2 / 2 by up to sqrt(2 x 2e-6 (R_s + R_p) / 2 / R_p'')
    (R_p'' from the closed form)."""
    rows = []
    for name, wl in cases:
        if name.startswith("dielectric"):
            n, k = 1.5, 0.0
            params = dict(eta=1.5, k=0.0, sigma=SIGMA)
        else:
            n, k = (float(x) for x in reference.conductor_ior(name, wl))
            params = dict(material=name, sigma=SIGMA)
        closed = closed_form_pseudo_brewster(n, k)
        ref_min = _golden_min(lambda t: float(rp_reference(t, n, k)), closed - 0.05, closed + 0.05)
        rs_pb, rp_min = (float(x) for x in closed_form_reflectances(closed, n, k))
        h = 1e-3
        curvature = float((closed_form_reflectances(closed + h, n, k)[1] - 2 * rp_min
                           + closed_form_reflectances(closed - h, n, k)[1]) / h**2)
        # R_p = (M00 - M01) x scale: its float32 error is ~2e-6 of M00 ~ (R_s + R_p) / 2
        resolution = np.sqrt(2 * 2e-6 * 0.5 * (rs_pb + rp_min) / curvature)
        plugin_min = np.nan
        if plugin:
            theta = np.radians(np.arange(30.0, 89.9, step_deg))
            plugin_min = plugin_argmin(rp_plugin(load_plugin(**params), theta, wl), theta)
        rows.append((name, wl, n, k, np.degrees(closed), np.degrees(ref_min),
                     np.degrees(plugin_min), np.degrees(resolution), rp_min))
    return rows


# ---------------------------------------------------------------------------
# 3. s-polarization and degree of polarization in the mirror direction
# ---------------------------------------------------------------------------

def mirror_polarization(metal, wavelength, theta_deg, plugin=True, three_lobes=False):
    """Stokes vector (normalized by S0) of unpolarized light reflected into the
    mirror direction, reference and plugin: ({"reference": (m, 4), "plugin": (m, 4)})."""
    theta = np.radians(np.asarray(theta_deg, dtype=np.float64))
    lobes = dict(kdd=0.2, sigma_dd=0.5, kid=0.05) if three_lobes else {}
    n, k = reference.conductor_ior(metal, wavelength)
    M = reference.pbrdf(theta, 0.0, theta, np.pi, n, k, SIGMA, **lobes)
    out = {"reference": M[:, :, 0] / M[:, :1, 0]}
    if plugin:
        to_viewer, to_light = _in_plane_pair(theta)
        P = plugin_global(load_plugin(material=metal, sigma=SIGMA, **lobes), to_viewer,
                          to_light, [wavelength])[:, 0]
        out["plugin"] = P[:, :, 0] / P[:, :1, 0]
    return out


def dop(stokes):
    return np.sqrt(np.sum(stokes[..., 1:] ** 2, axis=-1)) / stokes[..., 0]


def s_polarization(metals=("Al", "Cu"), wavelengths=(450.0, 632.8), plugin=True):
    """Rows: (metal, wavelength, lobes, engine, min S1/S0 over 1..89.5 deg,
    max |S2|, |S3| / S0, DOP rises monotonically up to theta_pB, theta_pB,
    DOP at theta_pB, angle of max DOP, max DOP)."""
    theta_deg = np.arange(1.0, 89.51, 0.25)
    rows = []
    for metal in metals:
        for wl in wavelengths:
            n, k = (float(x) for x in reference.conductor_ior(metal, wl))
            pb = np.degrees(closed_form_pseudo_brewster(n, k))
            for three in (False, True):
                result = mirror_polarization(metal, wl, theta_deg, plugin, three)
                for engine, S in result.items():
                    d = dop(S)
                    rising = bool(np.all(np.diff(d[theta_deg <= pb]) > 0))
                    i = int(np.argmax(d))
                    rows.append((metal, wl, "3 lobes" if three else "specular", engine,
                                 float(S[:, 1].min()), float(np.abs(S[:, 2:]).max()), rising,
                                 pb, float(np.interp(pb, theta_deg, d)), theta_deg[i], d[i]))
    return rows


# ---------------------------------------------------------------------------
# 4. Reciprocity
# ---------------------------------------------------------------------------

def reciprocity(configs=CONFIGS, pairs=100_000, plugin=True, seed=1):
    """Rows: (config, engine, max |M00(i,r) - M00(r,i)| / M00,
    max_ij |M(r,i) - Q M(i,r)^T Q| / M00), over ``pairs`` random direction
    pairs (half near the specular direction, cos theta >= 0.02) x 4 wavelengths,
    where M00 > 1e-7 max M00 (below, float32 D underflows in the far tail)."""
    from mitsuba_pbrdf import frames

    rng = np.random.default_rng(seed)
    rows = []
    for name, config in configs.items():
        to_viewer, to_light = frames.random_directions(pairs, rng)
        engines = {"reference": lambda v, l: reference_global(config, v, l, CONFIG_WAVELENGTHS)}
        if plugin:
            bsdf = load_plugin(**config)
            engines["plugin"] = lambda v, l: plugin_global(bsdf, v, l, CONFIG_WAVELENGTHS)
        for engine, evaluate in engines.items():
            A = evaluate(to_viewer, to_light)
            B = evaluate(to_light, to_viewer)
            m00 = A[..., 0, 0]
            ok = m00 > 1e-7 * m00.max()
            rel00 = np.abs(B[..., 0, 0] - m00)[ok] / m00[ok]
            full = np.max(np.abs(B - Q @ np.swapaxes(A, -1, -2) @ Q), axis=(-1, -2))[ok] / m00[ok]
            rows.append((name, engine, float(rel00.max()), float(full.max())))
    return rows


# ---------------------------------------------------------------------------
# 5. Realizability
# ---------------------------------------------------------------------------

def special_pairs():
    """Normal incidence/exit, retro-reflection, exact mirror and grazing pairs
    (to_viewer, to_light)."""
    t = np.radians([0.0, 10.0, 45.0, 80.0, 89.0, 89.9])
    light = np.stack([np.sin(t), np.zeros_like(t), np.cos(t)], 1)
    up = np.tile([0.0, 0.0, 1.0], (len(t), 1))
    mirror = light * [-1, 1, 1]
    tilted = np.stack([np.sin(t) * np.cos(1.0), np.sin(t) * np.sin(1.0), np.cos(t)], 1)
    viewers = np.vstack([up, light, mirror, tilted, mirror])
    lights = np.vstack([light, light, light, light, up])
    return viewers, lights


#: Smallest M00 whose matrix is checked for realizability: far enough above the
#: smallest normal number (float64 2.2e-308, float32 1.2e-38) that every element
#: larger than 1e-16 M00 (float64) or 1e-8 M00 (float32) is a normal number with
#: full relative precision; smaller elements are below the rounding of M00
#: anyway. In the far tail of a narrow lobe D underflows to denormals, whose few
#: significant bits make any matrix look unphysical.
NORMAL_FLOOR = {"reference": 1e-290, "plugin": 1e-30}


def realizability(configs=CONFIGS, pairs=100_000, plugin=True, seed=2):
    """Rows: (config, engine, matrices checked (M00 above NORMAL_FLOOR), min
    eigenvalue / M00, max (DOP_out - 1) over 69 input Stokes vectors
    (unpolarized, the six pure states, 62 random fully polarized), min M00).
    Where the output intensity vanishes (p light at
    Brewster's angle) the DOP is measured as (|S_out,1..3| - S_out,0) / M00."""
    from mitsuba_pbrdf import frames

    rng = np.random.default_rng(seed)
    inputs = common.poincare_inputs()
    rows = []
    for name, config in configs.items():
        to_viewer, to_light = frames.random_directions(pairs, rng, min_cos=1e-3)
        sv, sl = special_pairs()
        to_viewer, to_light = np.vstack([to_viewer, sv]), np.vstack([to_light, sl])
        engines = {"reference": reference_global(config, to_viewer, to_light, CONFIG_WAVELENGTHS)}
        if plugin:
            engines["plugin"] = plugin_global(load_plugin(**config), to_viewer, to_light,
                                              CONFIG_WAVELENGTHS)
        for engine, M in engines.items():
            m00 = M[..., 0, 0]
            ok = m00 > NORMAL_FLOOR[engine]
            # normalized first: squares of entries ~1e-160 would underflow
            normalized = M[ok] / m00[ok][..., None, None]
            lam = common.coherency_eigenvalues(normalized)[..., 0]
            s0, pol = common.output_dop(normalized, inputs)
            excess = np.max(pol - s0, axis=-1)
            rows.append((name, engine, int(ok.sum()), float(lam.min()), float(excess.max()),
                         float(m00[ok].min())))
    return rows


# ---------------------------------------------------------------------------
# Figure and report
# ---------------------------------------------------------------------------

def figure_fresnel(plugin=True, wavelength=632.8):
    plt = common.pyplot()
    theta_deg = np.linspace(0.25, 89.75, 359)
    theta = np.radians(theta_deg)
    fig, axes = plt.subplots(2, 2, figsize=(10, 6.5), sharex=True)
    for col, metal in enumerate(("Al", "Cu")):
        n, k = (float(x) for x in reference.conductor_ior(metal, wavelength))
        rs, rp = closed_form_reflectances(theta, n, k)
        pb = np.degrees(closed_form_pseudo_brewster(n, k))
        ax = axes[0, col]
        ax.plot(theta_deg, rs, color="tab:blue", label="R_s closed form")
        ax.plot(theta_deg, rp, color="tab:red", label="R_p closed form")
        ax.plot(theta_deg, 0.5 * (rs + rp), color="k", lw=0.8, label="R (unpolarized)")
        marks = np.arange(2.5, 89.0, 5.0)
        if plugin:
            bsdf = load_plugin(material=metal, sigma=SIGMA)
            to_viewer, to_light = _in_plane_pair(np.radians(marks))
            M = plugin_global(bsdf, to_viewer, to_light, [wavelength])[:, 0]
            scale = 4 * np.pi * ALPHA**2 * np.cos(np.radians(marks)) ** 2
            ax.plot(marks, (M[:, 0, 0] + M[:, 0, 1]) * scale, "o", mfc="none", ms=4,
                    color="tab:blue", label="R_s plugin")
            ax.plot(marks, (M[:, 0, 0] - M[:, 0, 1]) * scale, "s", mfc="none", ms=4,
                    color="tab:red", label="R_p plugin")
        ax.axvline(pb, color="0.5", ls=":")
        ax.text(pb, rp.min(), f" θpB = {pb:.2f}°", va="top",
                ha="right", fontsize=8)
        ax.set_title(f"{metal} at {wavelength} nm (n = {n:.3f}, k = {k:.3f})")
        ax.set_ylabel("reflectance")
        ax.legend(loc="lower left")

        ax = axes[1, col]
        for three, style in ((False, "-"), (True, "--")):
            result = mirror_polarization(metal, wavelength, theta_deg, plugin=False,
                                         three_lobes=three)
            label = "3 lobes (kdd 0.2, kid 0.05)" if three else "specular only"
            ax.plot(theta_deg, dop(result["reference"]), style, color="k", label=label)
            ax.plot(theta_deg, result["reference"][:, 1], style, color="tab:green", lw=0.8,
                    label=f"S1/S0, {label}")
            if plugin:
                pr = mirror_polarization(metal, wavelength, marks, plugin=True,
                                         three_lobes=three)["plugin"]
                ax.plot(marks, dop(pr), "o" if not three else "^", mfc="none", ms=4, color="k",
                        label=f"DOP plugin, {label}")
        ax.axvline(pb, color="0.5", ls=":")
        ax.set_xlabel("incidence angle = mirror reflection angle (deg)")
        ax.set_ylabel("DOP of reflected light (unpolarized in)")
        ax.legend(loc="upper left", fontsize=7)
    fig.suptitle("Fresnel reflectance from the plugin's mirror-direction Mueller matrix vs the "
                 "closed form, and the polarization of reflected light", fontsize=9)
    fig.tight_layout()
    return common.save_figure(fig, "physics_fresnel")


def report(pairs=100_000, plugin=True):
    start = time.perf_counter()
    sections = []

    rows = normal_incidence(plugin=plugin)
    worst_ref = max(abs(r[5] / r[4] - 1) for r in rows)
    worst_plugin = max(abs(r[6] / r[4] - 1) for r in rows) if plugin else np.nan
    sections.append(
        "## 1. Fresnel reflectance at normal incidence\n\n"
        "R = ((n−1)² + k²)/((n+1)² + k²) from Mitsuba's tabulated n, k, against R recovered "
        f"from the BRDF at exact normal incidence and exit (σ = {SIGMA}: R = 4πα² M00). "
        f"Worst relative error: reference **{worst_ref:.1e}**, plugin **{worst_plugin:.1e}**.\n\n"
        + common.table(["metal", "λ (nm)", "n", "k", "R closed form", "R reference",
                        "R plugin", "plugin rel. error"],
                       [r + (abs(r[6] / r[4] - 1),) for r in rows], digits=6))

    rows = pseudo_brewster(plugin=plugin)
    worst_ref = max(abs(r[5] - r[4]) for r in rows)
    worst_plugin = max(abs(r[6] - r[4]) for r in rows) if plugin else np.nan
    sections.append(
        "## 2. Pseudo-Brewster angle\n\n"
        "Angle of minimum R_p: closed form = minimum of the real-arithmetic Fresnel R_p "
        "(Born & Wolf; arctan n for the dielectric) by bisection on its slope; reference = "
        "golden-section minimum of R_p from its mirror-direction Mueller matrix; plugin = "
        "parabola through the three lowest points of a 0.01° grid. Resolution: how far float32 "
        "rounding of R_p (2e-6 relative) can move a minimum this flat. Worst difference: "
        f"reference **{worst_ref:.1e}°**, plugin **{worst_plugin:.1e}°**.\n\n"
        + common.table(["case", "λ (nm)", "n", "k", "θpB closed form (°)", "reference − closed (°)",
                        "plugin − closed (°)", "plugin resolution (°)", "R_p min"],
                       [(r[0], r[1], r[2], r[3], r[4], r[5] - r[4], r[6] - r[4], r[7], r[8])
                        for r in rows], digits=4))

    rows = s_polarization(plugin=plugin)
    sections.append(
        "## 3. Reflected light is s-polarized; DOP rises toward the pseudo-Brewster angle\n\n"
        "Unpolarized light reflected into the mirror direction, incidence 1°–89.5° (step "
        "0.25°): S1/S0 > 0 (s-polarized, S1 = I_s − I_p) at every angle, S2 = S3 = 0, and the "
        "DOP increases monotonically up to θpB; it peaks a little beyond θpB, at the angle "
        "where |r_p/r_s| is smallest.\n\n"
        + common.table(["metal", "λ (nm)", "lobes", "engine", "min S1/S0", "max |S2|,|S3| / S0",
                        "DOP rising to θpB", "θpB (°)", "DOP at θpB", "θ of max DOP (°)",
                        "max DOP"], rows, digits=4))

    rows = reciprocity(pairs=pairs, plugin=plugin)
    sections.append(
        "## 4. Reciprocity\n\n"
        f"{pairs:,} random direction pairs × 4 wavelengths per row (half near the specular "
        "direction), wi and wr swapped: worst |M00(i,r) − M00(r,i)| / M00 and worst element "
        "of |M(r,i) − Q M(i,r)ᵀ Q| / M00, Q = diag(1, 1, −1, 1) (Mueller reciprocity theorem in "
        "the global s/p frames).\n\n"
        + common.table(["configuration", "engine", "M00 rel. asymmetry", "Q Mᵀ Q, rel. to M00"],
                       rows))

    rows = realizability(pairs=pairs, plugin=plugin)
    sections.append(
        "## 5. Realizability\n\n"
        f"{pairs:,} random pairs (cos θ ≥ 1e-3) plus normal, retro-reflection, mirror and "
        "grazing pairs × 4 wavelengths per row: the smallest eigenvalue of Cloude's coherency "
        "matrix relative to M00 (≥ 0 for a physical Mueller matrix; specular-only matrices are "
        "pure, so three eigenvalues are 0 and rounding shows as ±ε), and the largest excess of "
        "output DOP over 1 for 69 input Stokes vectors, (|S1..3| − S0)/M00.\n\n"
        + common.table(["configuration", "engine", "matrices", "min eigenvalue / M00",
                        "max DOP excess / M00", "min M00 checked"], rows)
        + "\n\nMatrices counted: M00 above 1e-290 (reference) or 1e-30 (plugin); below, D "
        "underflows to denormal numbers whose few significant bits make any matrix look "
        "unphysical (the far tail of the σ = 0.02 lobe).")

    figure = figure_fresnel(plugin=plugin)
    text = (f"# Study 2: physics checks\n\n`python validation/physics.py --pairs {pairs}` "
            f"({time.perf_counter() - start:.0f} s). Each check on the float64 reference "
            "evaluator and on the plugin (float32, through `frames.eval_global`). The same "
            "functions run with fewer samples in `tests/test_physics.py`, whose docstrings "
            "justify each tolerance. The white-furnace (albedo) study is "
            "[`furnace.md`](furnace.md).\n\n"
            f"![Fresnel and DOP]({figure})\n\n" + "\n\n".join(sections))
    common.write_markdown("physics", text)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pairs", type=int, default=100_000)
    args = parser.parse_args(argv)
    common.use_variant()
    report(args.pairs)


if __name__ == "__main__":
    main()
