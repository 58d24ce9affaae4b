"""The float64 reference at the plugin's float32 inputs, and the conditioning
of that comparison.

Float32 accuracy is a property of the conditioning: near grazing, for nearly
opposite directions or with narrow lobes (sigma 1e-4: D varies by e^-1 over
1e-4 rad of the half vector) the float32 representation of the inputs alone
changes the float64 reference by far more than 2^-24. :func:`sensitivity`
measures the reference's own sensitivity kappa to perturbations the size of
that representation; an error is then expressed in units of u (1 + kappa),
u = 2^-24: the number of float32 roundings it amounts to once the problem's
conditioning is accounted for.

Units and frames: BRDF Mueller matrices in 1/sr (no cosine) in the reference's
global s/p frames, shape (n lanes, 4 wavelengths, 4, 4); directions wi (towards
the viewer) and wo (towards the light) as unit vectors (n, 3) in the surface's
local frame.
"""

import numpy as np

from mitsuba_pbrdf import reference
from .fuzz_inputs import TEXTURED
from mitsuba_pbrdf.diagnostics.realizability import U32


def lane_parameters(config, wavelengths, lanes, n):
    """Per-lane parameter arrays: n, k, ks, kdd, kid of shape (n, 4); sigma,
    sigma_dd of shape (n, 1). ``lanes`` holds what the textured parameters
    evaluated to (the ``lanes`` of
    :func:`~mitsuba_pbrdf.diagnostics.bsdf_outputs.bsdf_outputs`)."""
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
    from mitsuba_pbrdf.frames import to_angles
    from proof.mitsuba_g1 import mitsuba_beckmann_G1

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
