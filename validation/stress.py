"""Study 4: numerical stability stress test of the ``pbrdf`` plugin.

    python validation/stress.py [--samples 1000000] [--seed 0]   (-> stress.md)

A seeded generator draws random configurations and, for each, a batch of
direction pairs from several regions; every ``eval``, ``pdf``, ``eval_pdf`` and
``sample`` result, in both transport modes, is checked to be

* finite (no NaN, no Inf), with pdf >= 0, M00 >= 0 and sample weight M00 >= 0;
* physically realizable: the smallest eigenvalue of Cloude's coherency matrix
  >= -REALIZABILITY_TOL x M00 (also for the sample weights);
* zero below the horizon (value and pdf; sample weight when wi is below);
* consistent: ``eval`` and ``pdf`` equal ``eval_pdf``'s value and pdf, and
  ``sample``'s pdf and weight equal ``eval_pdf``'s pdf and value / pdf at the
  direction it returns;

and its value (rotated into the global s/p frames, cosine divided out) is
compared with the float64 reference evaluator: the worst error relative to M00,
max_ij |M_ij - R_ij| / R00, per region of directions.

Parameters (all float32-exact, so both evaluators see the same numbers):
n log-uniform in [0.05, 10] (n < 1 included); k = 0 (dielectric, 25 %),
k = 100 (10 %) or log-uniform in [1e-3, 100]; sigma log-uniform in [1e-4, 2],
sigma_dd in [1e-3, 5]; each weight ks, kdd, kid = 0 (20 %), 1e3 (15 %) or
uniform in [0, 1]. In 60 % of the configurations every one of these is a
64 x 64 bitmap texture of independent draws and each lane reads a random texel,
so each lane has its own parameters (including all three weights 0); the rest
use scalars - a named conductor (Al, Cu, Au, Ag, Cr, W) or scalar n, k - where
a weight of exactly 0 drops its lobe (in 30 % of them all but one lobe).
Per configuration: shadowing vgroove or
smith, directional diffuse Beckmann or GGX, ``sampling="cosine"`` in 10 %, 4
wavelengths uniform in Mitsuba's spectral range [360, 830] nm.

Regions of direction pairs (wi = towards the viewer, wo = towards the light):

* ``generic``: cos theta of each uniform in [1e-3, 1];
* ``grazing``: one or both with cos theta log-uniform in [1e-7, 1e-3];
* ``normal``: exact normal incidence and/or exit (0, 0, 1);
* ``retro``: wo = wi exactly (collinear: the facet's plane of incidence is
  undefined, the Mueller-rotation singularity), any angle down to grazing;
* ``mirror``: wo the exact mirror direction of wi; ``near-mirror``: within
  1e-6 .. 1e-2 rad of it (narrow lobes);
* ``opposite``: both grazing and nearly opposite (wi + wo almost horizontal:
  cos(beta) -> 0, where float rounding can make it <= 0);
* ``below``: wi or wo at or below the horizon (z = 0, -0, -1e-7, generic).

Float32 accuracy is a property of the conditioning: near grazing, for nearly
opposite directions or with narrow lobes (sigma 1e-4: D varies by e^-1 over
1e-4 rad of the half vector) the float32 representation of the inputs alone
changes the float64 reference by far more than 2^-24. The study therefore
measures the reference's own sensitivity kappa to perturbations the size of
that representation (``sensitivity``) and reports each error also in units of
u (1 + kappa), u = 2^-24: the number of float32 roundings it amounts to once the
problem's conditioning is accounted for.
"""

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from validation import common  # noqa: E402
from mitsuba_pbrdf import reference  # noqa: E402

U32 = 2.0 ** -24
#: Realizability tolerance relative to M00. The plugin assembles its matrix
#: from realizable factors (a non-negative scale, the Jones-derived facet
#: matrix built from two complex amplitudes, orthogonal frame rotations,
#: depolarizers with non-negative weights); only the rounding of its 16
#: entries (a few float32 operations each, |dM_ij| <= 4 u M00) can make it
#: unphysical, and that moves the coherency eigenvalues by at most
#: ||dH||_2 <= ||dM||_F / 2 <= 8 u M00 (H = sum M_ij B_ij / 4 with orthogonal
#: B_ij of Frobenius norm 2). Allow 16 u.
REALIZABILITY_TOL = 16 * U32
#: Accuracy bound, in units of u (1 + kappa): the plugin's evaluation chain
#: (normalizing the half vector, D with its exponential, G, the complex Fresnel
#: amplitudes, two frame rotations with their trigonometry, the cosine) has on
#: the order of 100 float32 operations, each adding at most u of relative
#: error on top of what the inputs' conditioning (1 + kappa) already implies.
ACCURACY_UNITS = 128
#: Below this M00 (1/sr) float32 values are near the denormal range (1.2e-38)
#: and carry no relative precision: not used for relative checks.
M00_FLOOR = 1e-30
MATERIALS = ("Al", "Cu", "Au", "Ag", "Cr", "W")      # tables cover 360-830 nm
REGIONS = ("generic", "grazing", "normal", "retro", "mirror", "near-mirror", "opposite", "below")
#: Share of each batch per region.
SHARES = dict(generic=0.30, grazing=0.20, normal=0.08, retro=0.08, mirror=0.08,
              **{"near-mirror": 0.12}, opposite=0.06, below=0.08)


def f32(x):
    return float(np.float32(x))


# ---------------------------------------------------------------------------
# Generators
# ---------------------------------------------------------------------------

TEXELS = 64                                           # textured parameters: 64 x 64 texels
TEXTURED = ("eta", "k", "sigma", "sigma_dd", "ks", "kdd", "kid")


def _draw_eta(rng, size=None):
    return np.exp(rng.uniform(np.log(0.05), np.log(10.0), size))


def _draw_k(rng, size=None):
    r = rng.random(size)
    k = np.exp(rng.uniform(np.log(1e-3), np.log(100.0), size))
    return np.where(r < 0.25, 0.0, np.where(r < 0.35, 100.0, k))


def _draw_sigma(rng, size=None, high=2.0, low=1e-4):
    return np.exp(rng.uniform(np.log(low), np.log(high), size))


def _draw_weight(rng, size=None):
    r = rng.random(size)
    return np.where(r < 0.2, 0.0, np.where(r < 0.35, 1e3, rng.random(size)))


#: The first configurations of every run: each single-lobe code path, the
#: cosine sampling option and a BSDF without lobes (all weights 0), so that a
#: short run covers them for sure.
FORCED = ({"single": "kid"}, {"single": "kdd"}, {"single": "ks"}, {"sampling": "cosine"},
          {"single": "none"})


def draw_config(rng, force=None):
    """(plugin parameters, 4 wavelengths). All numbers float32-exact.

    Kinds: "textured" (60 %): every numeric parameter a 64 x 64 bitmap
    (nearest filter) of independent draws, so each lane sees its own n, k,
    sigma, sigma_dd and weights (including all three weights 0); "named"
    (20 %): a tabulated conductor with scalar parameters; "scalar" (20 %):
    scalar n, k. Scalar weights of exactly 0 drop their lobe."""
    import mitsuba as mi

    c = {}
    force = force or {}
    r = 0.7 if "single" in force else rng.random()
    if r < 0.6:
        draws = {"eta": _draw_eta, "k": _draw_k, "sigma": _draw_sigma,
                 "sigma_dd": lambda g, size: _draw_sigma(g, size, 5.0, 1e-3),
                 "ks": _draw_weight, "kdd": _draw_weight, "kid": _draw_weight}
        for name, draw in draws.items():
            texels = draw(rng, (TEXELS, TEXELS, 1)).astype(np.float32)
            c[name] = {"type": "bitmap", "bitmap": mi.Bitmap(texels), "filter_type": "nearest",
                       "raw": True}
    else:
        if r < 0.8:
            c["material"] = str(rng.choice(MATERIALS))
        else:
            c["eta"], c["k"] = f32(_draw_eta(rng)), f32(_draw_k(rng))
        c["sigma"] = f32(_draw_sigma(rng))
        c["sigma_dd"] = f32(_draw_sigma(rng, None, 5.0, 1e-3))
        c["ks"], c["kdd"], c["kid"] = (f32(_draw_weight(rng)) for _ in range(3))
        if "single" in force or rng.random() < 0.3:      # a single lobe (its own code path)
            keep = force.get("single") or str(rng.choice(["ks", "kdd", "kid"]))
            for w in ("ks", "kdd", "kid"):                # "none": no lobe at all
                c[w] = (c[w] or 0.5) if w == keep else 0.0
    c["shadowing"] = str(rng.choice(["vgroove", "smith"]))
    c["dd_distribution"] = str(rng.choice(["beckmann", "ggx"]))
    if rng.random() < 0.1 or "sampling" in force:
        c["sampling"] = "cosine"
    wavelengths = tuple(f32(w) for w in np.sort(rng.uniform(360.0, 830.0, 4)))
    return c, wavelengths


def _hemisphere(n, rng, cos_lo, cos_hi, log=False):
    cos = (np.exp(rng.uniform(np.log(cos_lo), np.log(cos_hi), n)) if log
           else rng.uniform(cos_lo, cos_hi, n))
    sin = np.sqrt(1.0 - cos * cos)
    phi = rng.uniform(0.0, 2.0 * np.pi, n)
    return np.stack([sin * np.cos(phi), sin * np.sin(phi), cos], axis=1)


def _f32_vectors(v):
    """Unit vectors rounded to float32, as float64 (exactly what Mitsuba gets)."""
    return v.astype(np.float32).astype(np.float64)


def draw_directions(n, rng):
    """(wi, wo, region index) arrays: wi towards the viewer, wo towards the light."""
    counts = {r: int(round(SHARES[r] * n)) for r in REGIONS}
    counts["generic"] += n - sum(counts.values())
    wi_parts, wo_parts, labels = [], [], []
    for index, region in enumerate(REGIONS):
        m = counts[region]
        if m == 0:
            continue
        if region == "generic":
            wi, wo = _hemisphere(m, rng, 1e-3, 1.0), _hemisphere(m, rng, 1e-3, 1.0)
        elif region == "grazing":
            wi, wo = _hemisphere(m, rng, 1e-7, 1e-3, log=True), _hemisphere(m, rng, 1e-3, 1.0)
            both = rng.random(m) < 0.3
            wo[both] = _hemisphere(int(both.sum()), rng, 1e-7, 1e-3, log=True)
            swap = rng.random(m) < 0.5
            wi[swap], wo[swap] = wo[swap].copy(), wi[swap].copy()
        elif region == "normal":
            wi, wo = _hemisphere(m, rng, 1e-7, 1.0), _hemisphere(m, rng, 1e-7, 1.0)
            which = rng.integers(0, 3, m)
            wi[which != 1] = [0.0, 0.0, 1.0]
            wo[which != 0] = [0.0, 0.0, 1.0]
        elif region == "retro":
            wi = np.vstack([_hemisphere(m // 2, rng, 1e-3, 1.0),
                            _hemisphere(m - m // 2, rng, 1e-7, 1e-3, log=True)])
            wo = wi.copy()
        elif region == "mirror":
            wi = np.vstack([_hemisphere(m // 2, rng, 1e-3, 1.0),
                            _hemisphere(m - m // 2, rng, 1e-7, 1e-3, log=True)])
            wo = wi * [-1.0, -1.0, 1.0]
        elif region == "near-mirror":
            wi = _hemisphere(m, rng, 1e-3, 1.0)
            mirror = wi * [-1.0, -1.0, 1.0]
            axis = np.cross(mirror, rng.normal(size=(m, 3)))
            axis /= np.linalg.norm(axis, axis=1, keepdims=True)
            angle = np.exp(rng.uniform(np.log(1e-6), np.log(1e-2), m))[:, None]
            wo = mirror * np.cos(angle) + np.cross(axis, mirror) * np.sin(angle)
            wo[:, 2] = np.abs(wo[:, 2])
        elif region == "opposite":
            wi = _hemisphere(m, rng, 1e-7, 1e-2, log=True)
            wo = -wi + rng.normal(scale=1e-3, size=(m, 3))
            wo[:, 2] = np.exp(rng.uniform(np.log(1e-7), np.log(1e-2), m))
        else:                                             # below the horizon
            wi, wo = _hemisphere(m, rng, 1e-7, 1.0), _hemisphere(m, rng, 1e-7, 1.0)
            z = rng.choice(np.array([0.0, -0.0, -1e-7, -0.5]), m)
            side = rng.integers(0, 3, m)                  # 0: wi, 1: wo, 2: both below
            for v, mask in ((wi, side != 1), (wo, side != 0)):
                v[mask, 2] = np.where(z[mask] == -0.5, -np.abs(v[mask, 2]), z[mask])
        wi /= np.linalg.norm(wi, axis=1, keepdims=True)
        wo /= np.linalg.norm(wo, axis=1, keepdims=True)
        wi_parts.append(wi)
        wo_parts.append(wo)
        labels.append(np.full(m, index))
    return (_f32_vectors(np.vstack(wi_parts)), _f32_vectors(np.vstack(wo_parts)),
            np.concatenate(labels))


# ---------------------------------------------------------------------------
# The plugin, raw and in the reference's frames
# ---------------------------------------------------------------------------

def _global_basis(d):
    import drjit as dr
    import mitsuba as mi

    s = dr.cross(mi.Vector3f(0, 0, 1), d)
    return dr.select(dr.squared_norm(s) == 0, mi.Vector3f(1, 0, 0), dr.normalize(s))


def _mueller(value, n):
    """(n, 4 wavelengths, 4, 4) from a Dr.Jit Mueller matrix; a result of width 1
    (e.g. the zero weight of a BSDF without lobes) is broadcast to n lanes."""
    a = np.asarray(value, dtype=np.float64)
    a = a.reshape(4, 4, 4, -1)
    return np.transpose(np.broadcast_to(a, (4, 4, 4, n)), (3, 2, 0, 1))


def _lanes(value, n):
    """A Dr.Jit Float as (n,) float64 (width 1 broadcast)."""
    return np.broadcast_to(np.asarray(value, dtype=np.float64).reshape(-1), (n,))


def evaluate_plugin(bsdf, wi, wo, wavelengths, mode, rng, textures=None, uv=None):
    """Everything the plugin returns for these pairs in one transport mode.

    ``wi``/``wo`` are the *physical* directions (viewer, light); in Importance
    mode Mitsuba's si.wi is the light and its wo argument the viewer. ``uv``
    (2, n) selects each lane's texel of textured parameters."""
    import drjit as dr
    import mitsuba as mi

    n = len(wi)
    radiance = mode == "radiance"
    si_wi, wo_arg = (wi, wo) if radiance else (wo, wi)
    si = dr.zeros(mi.SurfaceInteraction3f, n)
    si.wi = mi.Vector3f(*[mi.Float(np.ascontiguousarray(si_wi[:, j])) for j in range(3)])
    si.n = mi.Normal3f(0, 0, 1)
    si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
    if uv is not None:
        si.uv = mi.Point2f(*np.asarray(uv, dtype=np.float32))
    si.wavelengths = mi.UnpolarizedSpectrum(*wavelengths)
    w = mi.Vector3f(*[mi.Float(np.ascontiguousarray(wo_arg[:, j])) for j in range(3)])
    ctx = mi.BSDFContext(mi.TransportMode.Radiance if radiance else mi.TransportMode.Importance)

    value_ep, pdf_ep = bsdf.eval_pdf(ctx, si, w)
    value = bsdf.eval(ctx, si, w)
    pdf = bsdf.pdf(ctx, si, w)
    bs, weight = bsdf.sample(ctx, si, mi.Float(rng.random(n, dtype=np.float32)),
                             mi.Point2f(*rng.random((2, n), dtype=np.float32)))
    value_bs, pdf_bs = bsdf.eval_pdf(ctx, si, bs.wo)          # at the sampled direction

    # into the reference's global s/p frames (light arrives along -wo_hat, leaves along wi_hat)
    wo_h, wi_h = (w, si.wi) if radiance else (si.wi, w)
    rotated = mi.mueller.rotate_mueller_basis(
        value_ep, -wo_h, mi.mueller.stokes_basis(-wo_h), _global_basis(-wo_h),
        wi_h, mi.mueller.stokes_basis(wi_h), _global_basis(wi_h))
    cos_wo = np.abs(wo_arg[:, 2])
    with np.errstate(divide="ignore", invalid="ignore"):
        brdf = np.where(cos_wo[:, None, None, None] > 0,
                        _mueller(rotated, n) / cos_wo[:, None, None, None], 0.0)
    lanes = {}                             # per-lane values of textured parameters
    for name, texture in (textures or {}).items():
        lanes[name] = np.asarray(texture.eval(si), dtype=np.float64).reshape(4, n).T
    bs_wo = np.asarray(bs.wo, dtype=np.float64).reshape(3, -1).T
    return dict(value=_mueller(value, n), value_ep=_mueller(value_ep, n),
                pdf=_lanes(pdf, n), pdf_ep=_lanes(pdf_ep, n),
                weight=_mueller(weight, n), bs_pdf=_lanes(bs.pdf, n),
                bs_wo=np.broadcast_to(bs_wo, (n, 3)), brdf=brdf, lanes=lanes,
                value_bs=_mueller(value_bs, n), pdf_bs=_lanes(pdf_bs, n))


# ---------------------------------------------------------------------------
# The reference at the same inputs
# ---------------------------------------------------------------------------

def lane_parameters(config, wavelengths, lanes, n):
    """Per-lane parameter arrays: n, k, ks, kdd, kid of shape (n, 4); sigma,
    sigma_dd of shape (n, 1). ``lanes`` holds what the textured parameters
    evaluated to (evaluate_plugin)."""
    p = {}
    for name in TEXTURED:
        if name in lanes:
            p[name] = lanes[name] if name not in ("sigma", "sigma_dd") else lanes[name][:, :1]
        elif name in config:
            p[name] = np.full((n, 1), float(config[name]))
    if "material" in config:
        p["eta"], p["k"] = (np.broadcast_to(x, (n, 4)) for x in
                            reference.conductor_ior(config["material"], wavelengths))
    return p


def reference_brdf(config, p, wi, wo, sigma_scale=1.0, angles=None):
    """Float64 reference (n, 4, 4, 4) at the plugin's (float32) inputs with the
    per-lane parameters ``p`` (lane_parameters). For Smith shadowing on
    Beckmann lobes Mitsuba's approximate G1 replaces the exact one (the plugin
    evaluates it, like roughconductor), so that the comparison measures float32
    arithmetic only."""
    from mitsuba_pbrdf.frames import mitsuba_beckmann_G1, to_angles

    if angles is None:
        angles = to_angles(wo) + to_angles(wi)
    ti, pi_, tr, pr = angles
    angles = (ti[:, None], pi_[:, None], tr[:, None], pr[:, None])
    shadowing = config["shadowing"]
    sigma, sigma_dd = p["sigma"] * sigma_scale, p["sigma_dd"] * sigma_scale

    def smith_correction(sig, distribution):
        if shadowing != "smith" or distribution != "beckmann":
            return 1.0
        alpha = np.sqrt(2) * sig[:, 0]
        ci, cr = np.cos(ti), np.cos(tr)
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = (mitsuba_beckmann_G1(ci, alpha) * mitsuba_beckmann_G1(cr, alpha)
                     / (reference.smith_G1(ci, alpha) * reference.smith_G1(cr, alpha)))
        return np.where(np.isfinite(ratio), ratio, 1.0)[:, None]

    F = np.zeros((len(ti), 4, 4, 4))
    ks, kdd, kid = (np.broadcast_to(p[w], (len(ti), 4)) for w in ("ks", "kdd", "kid"))
    if np.any(ks != 0):
        Fs = reference.specular(*angles, p["eta"], p["k"], sigma, shadowing)
        F += (ks * smith_correction(sigma, "beckmann"))[..., None, None] * Fs
    if np.any(kdd != 0):
        fdd = reference.directional_diffuse(*angles, sigma_dd, shadowing, config["dd_distribution"])
        F[..., 0, 0] += kdd * fdd * smith_correction(sigma_dd, config["dd_distribution"])
    if np.any(kid != 0):
        F[..., 0, 0] += kid * reference.ideal_diffuse(*angles[0::2])
    return F


def _rotate_towards(v, other, angle):
    """Rotate unit vectors ``v`` by ``angle`` in the plane of ``v`` and ``other``
    (unchanged where they are parallel)."""
    t = other - np.sum(other * v, axis=-1, keepdims=True) * v
    norm = np.linalg.norm(t, axis=-1, keepdims=True)
    t = np.where(norm > 0, t / np.where(norm > 0, norm, 1.0), 0.0)
    return v * np.cos(angle)[:, None] + t * np.sin(angle)[:, None]


def sensitivity(config, p, wi, wo, R, rng, trials=4):
    """kappa (n, 4): the largest change of R, relative to R00 and in units of
    u = 2^-24, under perturbations the size of the float32 representation of
    the inputs, random signs, ``trials`` draws:

    * each direction's azimuth by +-u rad and its cos(theta) by a relative +-u
      (the rounding of its x, y and z components);
    * each direction turned by +-u tan(beta) in the plane of wi and wo: Mitsuba
      passes float32 vectors whose length is 1 only to within ~u, and a length
      error e of one of them tilts the half vector by e sin(beta) / (2 cos beta),
      the same as turning that direction by e tan(beta) (beta: half the angle
      between wi and wo; large for nearly opposite directions);
    * sigma and sigma_dd by a relative +-u;

    and, deterministically, the two unit-vector pairs that share the half
    vector normalize(wi + wo) of the float32 vectors as given (one direction
    normalized, the other its mirror image about that half vector): the
    geometry the plugin actually evaluates."""
    from mitsuba_pbrdf.frames import to_angles

    m00 = np.maximum(R[..., 0, 0], 1e-300)
    kappa = np.zeros(R.shape[:2])
    ui = wi / np.linalg.norm(wi, axis=-1, keepdims=True)
    uo = wo / np.linalg.norm(wo, axis=-1, keepdims=True)
    h = wi + wo
    h_norm = np.linalg.norm(h, axis=-1, keepdims=True)
    h = np.where(h_norm > 0, h / np.where(h_norm > 0, h_norm, 1.0), 0.0)

    def reflect(v):
        return 2 * np.sum(v * h, axis=-1, keepdims=True) * h - v

    for a, b in ((ui, reflect(ui)), (reflect(uo), uo)):
        valid = (a[:, 2] > 0) & (b[:, 2] > 0) & (h_norm[:, 0] > 0)
        P = reference_brdf(config, p, a, b, angles=to_angles(b) + to_angles(a))
        with np.errstate(over="ignore", invalid="ignore"):
            change = np.max(np.abs(P - R), axis=(-1, -2)) / m00 / U32
        kappa = np.maximum(kappa, np.where(valid[:, None], change, 0.0))
    cos2b = np.clip(np.sum(ui * uo, axis=-1), -1.0, 1.0)
    tan_b = np.sqrt(np.maximum(1 - cos2b, 0) / np.maximum(1 + cos2b, 1e-300))
    tilt = U32 * np.minimum(tan_b, 1e7)
    for _ in range(trials):
        sign = rng.choice([-1.0, 1.0], (7, len(wi)))
        ti, pi_ = to_angles(_rotate_towards(uo, ui, sign[5] * tilt))
        tr, pr = to_angles(_rotate_towards(ui, uo, sign[6] * tilt))
        ti = np.arccos(np.clip(np.cos(ti) * (1 + U32 * sign[0]), -1, 1))
        tr = np.arccos(np.clip(np.cos(tr) * (1 + U32 * sign[2]), -1, 1))
        angles = (ti, pi_ + U32 * sign[1], tr, pr + U32 * sign[3])
        P = reference_brdf(config, p, wi, wo, 1 + U32 * sign[4][:, None], angles)
        with np.errstate(over="ignore", invalid="ignore"):
            kappa = np.maximum(kappa, np.max(np.abs(P - R), axis=(-1, -2)) / m00 / U32)
    return kappa


# ---------------------------------------------------------------------------
# Checks
# ---------------------------------------------------------------------------

def load(config):
    """(plugin, {name: texture} of its textured parameters, loaded on their own
    to read the per-lane values the plugin sees)."""
    import mitsuba as mi

    bsdf = mi.load_dict(dict({"type": "pbrdf"}, **config))
    textures = {name: mi.load_dict(value) for name, value in config.items()
                if isinstance(value, dict)}
    return bsdf, textures


def describe(config):
    """A config as a short string (bitmaps abbreviated)."""
    return "{" + ", ".join(f"{k}: {'bitmap' if isinstance(v, dict) else repr(v)}"
                           for k, v in config.items()) + "}"


class Tally:
    """Failure counts per check and worst errors per region."""

    def __init__(self):
        self.samples = 0
        self.evaluations = 0
        self.failures = {}
        self.examples = {}
        self.worst = {r: 0.0 for r in REGIONS if r != "below"}
        self.worst_units = {r: 0.0 for r in REGIONS if r != "below"}
        self.errors = {r: [] for r in REGIONS if r != "below"}
        self.worst_units_case = {}
        self.compared = {r: 0 for r in REGIONS if r != "below"}
        self.min_eigen = 1.0
        self.configs = 0
        self.worst_case = {}
        self.consistency_lanes = 0
        self.failing_configs = {}

    def check(self, name, ok, config, detail=""):
        ok = np.asarray(ok)
        bad = int(np.size(ok) - np.count_nonzero(ok))
        self.failures[name] = self.failures.get(name, 0) + bad
        if bad and name not in self.examples:
            self.examples[name] = f"{describe(config)} {detail}"
        if bad:
            self.failing_configs.setdefault(name, set()).add(describe(config))


def check_config(config, wavelengths, n, rng, tally, accuracy=True):
    bsdf, textures = load(config)
    wi, wo, region = draw_directions(n, rng)
    uv = (rng.integers(0, TEXELS, (2, n)) + 0.5) / TEXELS      # a random texel per lane
    below = (wi[:, 2] <= 0) | (wo[:, 2] <= 0)
    R = kappa = p = None
    tally.configs += 1
    tally.samples += n
    for mode in ("radiance", "importance"):
        out = evaluate_plugin(bsdf, wi, wo, wavelengths, mode, rng, textures, uv)
        tally.evaluations += 4 * n
        label = f"mode={mode}"
        for key in ("value", "value_ep", "pdf", "pdf_ep", "weight", "bs_pdf", "brdf"):
            tally.check(f"finite {key}", np.isfinite(out[key]).reshape(n, -1).all(axis=1),
                        config, label)
        value, weight = out["value_ep"], out["weight"]
        tally.check("pdf >= 0", (out["pdf_ep"] >= 0) & (out["pdf"] >= 0), config, label)
        tally.check("M00 >= 0", (value[..., 0, 0] >= 0).all(axis=1), config, label)
        tally.check("weight M00 >= 0", (weight[..., 0, 0] >= 0).all(axis=1), config, label)
        tally.check("sample pdf >= 0", out["bs_pdf"] >= 0, config, label)
        tally.check("abs(M_ij) <= M00", (np.abs(value) <= value[..., :1, :1] * (1 + REALIZABILITY_TOL)
                                      + 1e-37).all(axis=(1, 2, 3)), config, label)
        tally.check("eval == eval_pdf", np.all(np.abs(out["value"] - value)
                                               <= 1e-6 * np.abs(value[..., :1, :1]) + 1e-37,
                                               axis=(1, 2, 3)), config, label)
        tally.check("pdf == eval_pdf", np.abs(out["pdf"] - out["pdf_ep"])
                    <= 1e-6 * out["pdf_ep"] + 1e-37, config, label)
        tally.check("zero below horizon", (np.all(value[below] == 0, axis=(1, 2, 3))
                                           & (out["pdf_ep"][below] == 0)
                                           & (out["pdf"][below] == 0)), config, label)
        viewer_below = (wi if mode == "radiance" else wo)[:, 2] <= 0
        tally.check("sample zero below horizon",
                    np.all(weight[viewer_below] == 0, axis=(1, 2, 3))
                    & (out["bs_pdf"][viewer_below] == 0), config, label)
        if p is None:
            p = lane_parameters(config, wavelengths, out["lanes"], n)
        # sample() agrees with eval_pdf at the direction it returns: pdf equal and
        # weight = value / pdf, up to the float32 conditioning of that comparison.
        # sample() works from the sampled facet normal m, eval_pdf recomputes
        # h = normalize(wi + wo) from the rounded wo: they differ by ~2u / cos(beta)
        # rad. That changes D by a relative 2 sqrt(x) (2u / cos(beta)) / alpha,
        # x = tan^2(theta_h) / alpha^2 (for each microfacet lobe present), and
        # cos(beta) itself - a dot product of float32 vectors of length 1 +- u -
        # by ~u / cos^2(beta), which V-groove's G and the Fresnel factor inherit.
        # Tolerance: 1e-3 + 4 x those; lanes where they exceed 0.1 are not
        # compared (ill-conditioned, not inconsistent).
        si_wi = wi if mode == "radiance" else wo
        half = out["bs_wo"] + si_wi
        cos_beta = np.linalg.norm(half, axis=1) / 2
        with np.errstate(divide="ignore", invalid="ignore"):
            cos_h = half[:, 2] / np.linalg.norm(half, axis=1)
            tan2 = np.maximum(1 - cos_h**2, 0) / cos_h**2
            tilt = 2 * U32 / cos_beta
            sens = 4 * U32 / cos_beta**2
            for weight_name, sigma_name in (("ks", "sigma"), ("kdd", "sigma_dd")):
                alpha = np.sqrt(2) * p[sigma_name][:, 0]
                present = np.max(p[weight_name], axis=1) > 0
                sens = sens + np.where(present, 2 * np.sqrt(tan2) / alpha * tilt / alpha, 0.0)
        tolerance = 1e-3 + 4 * sens
        sampled = ((out["bs_pdf"] > 0) & (out["pdf_bs"] > 0) & (cos_h > 0)
                   & np.isfinite(tolerance) & (tolerance < 0.1))
        tally.consistency_lanes += int(sampled.sum())
        with np.errstate(divide="ignore", invalid="ignore"):
            expected_weight = out["value_bs"] / out["pdf_bs"][:, None, None, None]
        scale = np.abs(expected_weight[..., :1, :1]) + 1e-30
        tol = np.where(sampled, tolerance, 0.0)
        tally.check("sample weight == eval / pdf",
                    np.all(np.abs(weight - expected_weight) <= tol[:, None, None, None] * scale,
                           axis=(1, 2, 3)) | ~sampled, config, label)
        tally.check("sample pdf == pdf(sampled wo)",
                    (np.abs(out["bs_pdf"] - out["pdf_bs"]) <= tol * out["pdf_bs"]) | ~sampled,
                    config, label)
        sampled_below = out["bs_wo"][:, 2] <= 0
        tally.check("sampled below horizon has zero weight",
                    np.all(weight[sampled_below] == 0, axis=(1, 2, 3)), config, label)
        for name, M in (("realizable value", value), ("realizable weight", weight)):
            m00 = M[..., 0, 0]
            ok = m00 > M00_FLOOR
            lam = np.ones(m00.shape)
            if ok.any():       # normalized first: squares of tiny entries would underflow
                lam[ok] = common.coherency_eigenvalues(M[ok] / m00[ok][..., None, None])[..., 0]
            tally.min_eigen = min(tally.min_eigen, float(lam.min()))
            tally.check(name, (lam >= -REALIZABILITY_TOL).all(axis=1), config, label)

        if accuracy:
            if R is None:
                R = reference_brdf(config, p, wi, wo)
                kappa = sensitivity(config, p, wi, wo, R, rng)
            m00 = R[..., 0, 0]
            resolved = m00 > 1e-10
            with np.errstate(over="ignore", invalid="ignore"):
                err = np.max(np.abs(out["brdf"] - R), axis=(-1, -2)) / np.maximum(m00, 1e-300)
                units = err / (U32 * (1.0 + kappa))
            for index, name in enumerate(REGIONS):
                if name == "below":
                    continue
                sel = (region == index)[:, None] & resolved
                if sel.any():
                    tally.compared[name] += int(sel.sum())
                    if err[sel].max() > tally.worst[name]:
                        i = np.unravel_index(np.argmax(np.where(sel, err, -1)), err.shape)
                        tally.worst_case[name] = dict(
                            error=float(err[i]), kappa=float(kappa[i]), mode=mode,
                            config=describe(config), wavelength=wavelengths[i[1]],
                            wi=wi[i[0]].tolist(), wo=wo[i[0]].tolist(),
                            plugin_m00=float(out["brdf"][i][0, 0]), reference_m00=float(m00[i]),
                            params={k: float(np.broadcast_to(v, (n, 4))[i]) for k, v in p.items()})
                    if units[sel].max() > tally.worst_units[name]:
                        i = np.unravel_index(np.argmax(np.where(sel, units, -1)), units.shape)
                        tally.worst_units_case[name] = dict(
                            units=float(units[i]), error=float(err[i]), kappa=float(kappa[i]),
                            mode=mode, config=describe(config), wi=wi[i[0]].tolist(),
                            wo=wo[i[0]].tolist())
                    tally.worst[name] = max(tally.worst[name], float(err[sel].max()))
                    tally.worst_units[name] = max(tally.worst_units[name], float(units[sel].max()))
                    tally.errors[name].append(err[sel].astype(np.float32))
            tally.check("zero reference -> zero plugin", np.all(
                (R[..., 0, 0] != 0) | (np.abs(out["brdf"][..., 0, 0]) == 0), axis=1)
                | below, config, label)


def run(samples=100_000, seed=0, lanes=TEXELS * TEXELS, accuracy=True, progress=False):
    """Draw configurations until ``samples`` direction pairs have been checked."""
    rng = np.random.default_rng(seed)
    tally = Tally()
    start = time.perf_counter()
    while tally.samples < samples:
        config, wavelengths = draw_config(rng, FORCED[tally.configs] if tally.configs < len(FORCED)
                                          else None)
        n = min(lanes, samples - tally.samples)
        check_config(config, wavelengths, max(n, 64), rng, tally, accuracy)
        if progress and tally.configs % 50 == 0:
            print(f"  {tally.samples:,} samples, {tally.configs} configurations, "
                  f"{time.perf_counter() - start:.0f} s", flush=True)
    tally.seconds = time.perf_counter() - start
    return tally


def report(samples=1_000_000, seed=0):
    tally = run(samples, seed, progress=True)
    checks = common.table(["check", "failures"],
                          sorted(tally.failures.items()))
    def percentile(name, q):
        return (float(np.percentile(np.concatenate(tally.errors[name]), q))
                if tally.errors[name] else np.nan)

    rows = [(name, tally.compared[name], percentile(name, 50), percentile(name, 99.9),
             tally.worst[name], tally.worst_units[name]) for name in tally.worst]
    accuracy = common.table(["region", "values compared", "median ΔM / M00",
                             "99.9th percentile", "worst", "worst in units of u (1 + κ)"], rows)
    cases = "\n".join(
        f"* {name}: error {c['error']:.2e}, κ {c['kappa']:.3g}, {c['mode']}, λ {c['wavelength']:.1f} "
        f"nm, wi {np.round(c['wi'], 8).tolist()}, wo {np.round(c['wo'], 8).tolist()}, "
        f"parameters {{{', '.join(f'{k}: {v:.4g}' for k, v in c['params'].items())}}}, "
        f"{c['config'].split('shadowing')[1].strip(' :')}"
        for name, c in tally.worst_case.items())
    cases_units = "\n".join(
        f"* {name}: {c['units']:.3g} u (1 + κ), error {c['error']:.2e}, κ {c['kappa']:.3g}, "
        f"{c['mode']}, wi {np.round(c['wi'], 8).tolist()}, wo {np.round(c['wo'], 8).tolist()}, "
        f"{c['config']}" for name, c in tally.worst_units_case.items())
    text = f"""# Study 4: stability stress test

`python validation/stress.py --samples {samples} --seed {seed}` ({tally.seconds:.0f} s):
{tally.samples:,} direction pairs over {tally.configs} random configurations, each evaluated
in both transport modes with `eval`, `pdf`, `eval_pdf` and `sample` ({tally.evaluations:,}
calls' lanes; × 4 wavelengths). The generator, the parameter ranges and the regions are
described in `stress.py`'s docstring; `tests/test_fuzz.py` runs the same code on 10⁵ pairs.

**Checks** (number of failing lanes; every check must be 0):

{checks}

Smallest coherency eigenvalue seen: {tally.min_eigen:.2e} × M00 (tolerance
−{REALIZABILITY_TOL:.1e}, i.e. 16 float32 roundings).

**Accuracy against the float64 reference** per region (both modes, 4 wavelengths per pair,
reference M00 > 1e-10 1/sr; reference evaluated at the plugin's float32 inputs, with Mitsuba's
approximate Beckmann G1 for Smith shadowing as the plugin uses). u = 2⁻²⁴; κ is the reference's
own sensitivity to perturbations the size of the float32 representation of the inputs (see the
docstring). Large relative errors occur only where κ is large, i.e. where the problem itself is
ill-conditioned: narrow lobes near grazing, and nearly opposite grazing directions, where the
half vector is the normalized sum of two almost cancelling float32 vectors. Bound asserted in
`tests/test_fuzz.py`: {ACCURACY_UNITS} u (1 + κ).

{accuracy}

Largest error per region (ΔM / M00 = max_ij |M_ij − R_ij| / R00):

{cases}

Largest error in units of u (1 + κ) per region:

{cases_units}
"""
    if tally.examples:
        text += "\n**First failure per check:**\n\n" + "\n".join(
            f"* {k}: `{v}`" for k, v in tally.examples.items()) + "\n"
    common.write_markdown("stress", text)
    return tally


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=1_000_000)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    common.use_variant()
    report(args.samples, args.seed)


if __name__ == "__main__":
    main()
