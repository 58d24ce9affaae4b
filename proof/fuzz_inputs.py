"""The fuzz generator of the stress test: random ``pbrdf`` parameters and
hostile direction pairs.

Parameters (all float32-exact, so the plugin and the float64 reference see the
same numbers): n log-uniform in [0.05, 10] (n < 1 included); k = 0
(dielectric, 25 %), k = 100 (10 %) or log-uniform in [1e-3, 100]; sigma
log-uniform in [1e-4, 2], sigma_dd in [1e-3, 5]; each weight ks, kdd, kid = 0
(20 %), 1e3 (15 %) or uniform in [0, 1]. In 60 % of the configurations every one
of these is a 64 x 64 bitmap texture of independent draws and each lane reads a
random texel, so each lane has its own parameters (including all three weights
0); the rest use scalars - a named conductor (Al, Cu, Au, Ag, Cr, W) or scalar
n, k - where a weight of exactly 0 drops its lobe (in 30 % of them all but one
lobe). Per configuration: shadowing vgroove or smith, directional diffuse
Beckmann or GGX, ``sampling="cosine"`` in 10 %, 4 wavelengths uniform in
Mitsuba's spectral range [360, 830] nm.

Regions of direction pairs (unit vectors in the surface's local frame, z = the
normal; wi = towards the viewer, wo = towards the light), all rounded to float32:

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
"""

import numpy as np

MATERIALS = ("Al", "Cu", "Au", "Ag", "Cr", "W")      # tables cover 360-830 nm
REGIONS = ("generic", "grazing", "normal", "retro", "mirror", "near-mirror", "opposite", "below")
#: Share of each batch per region.
SHARES = dict(generic=0.30, grazing=0.20, normal=0.08, retro=0.08, mirror=0.08,
              **{"near-mirror": 0.12}, opposite=0.06, below=0.08)


def f32(x):
    """``x`` rounded to float32, as a Python float."""
    return float(np.float32(x))


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
