"""Reciprocity and realizability of a pBRDF, on the float64 reference and on
the ``pbrdf`` plugin (or any Mitsuba BSDF), over random direction pairs.

Frames and units: every matrix here is a BRDF Mueller matrix in 1/sr (cosine
divided out) in the reference's global s/p frames
(:mod:`mitsuba_pbrdf.frames`); directions are unit vectors (n, 3) in the
surface's local frame (z = normal), ``to_viewer`` (the reference's wr) and
``to_light`` (its wi); wavelengths in nm.

* Reciprocity: M00(wi, wr) = M00(wr, wi), and the whole matrix obeys
  M(r -> i) = Q M(i -> r)^T Q, Q = diag(1, 1, -1, 1) (Mueller reciprocity in the
  global s/p frames).
* Realizability: the eigenvalues of Cloude's coherency matrix are >= 0 and the
  degree of polarization of the output is <= 1 for every input Stokes vector
  (:mod:`mitsuba_pbrdf.diagnostics.realizability`).

:func:`reciprocity_errors` and :func:`mueller_global` take any Mitsuba BSDF;
:func:`reciprocity` and :func:`realizability` run the plugin configurations of
:data:`CONFIGS` against the reference. The Fresnel checks are in
:mod:`proof.mirror_fresnel`.
"""

import numpy as np

from .. import reference
from . import realizability as _realizability

Q = np.diag([1.0, 1.0, -1.0, 1.0])

#: Plugin parameters of the reciprocity and realizability runs (the reference gets the same).
CONFIGS = {
    "Al, 3 lobes, vgroove": dict(material="Al", sigma=0.15, kdd=0.2, sigma_dd=0.5, kid=0.05),
    "Cu, 3 lobes, smith, ggx": dict(material="Cu", sigma=0.3, kdd=0.3, sigma_dd=0.8, kid=0.1,
                                    shadowing="smith", dd_distribution="ggx"),
    "Au, specular, sigma 0.02": dict(material="Au", sigma=0.02),
    "dielectric n 1.5, k 0": dict(eta=1.5, k=0.0, sigma=0.2, kid=0.05),
    "n 0.5, k 0 (total reflection)": dict(eta=0.5, k=0.0, sigma=0.3, shadowing="smith"),
}
#: Wavelengths (nm) of the CONFIGS runs.
CONFIG_WAVELENGTHS = (450.0, 520.0, 600.0, 690.0)

#: Smallest M00 (1/sr) whose matrix is checked for realizability: far enough above
#: the smallest normal number (float64 2.2e-308, float32 1.2e-38) that every
#: element larger than 1e-16 M00 (float64) or 1e-8 M00 (float32) is a normal
#: number with full relative precision; smaller elements are below the rounding
#: of M00 anyway. In the far tail of a narrow lobe D underflows to denormals,
#: whose few significant bits make any matrix look unphysical.
NORMAL_FLOOR = {"reference": 1e-290, "plugin": 1e-30}


# ---------------------------------------------------------------------------
# Evaluation in the global s/p frames
# ---------------------------------------------------------------------------

def mueller_global(bsdf, to_viewer, to_light, wavelengths, mode="radiance"):
    """:func:`mitsuba_pbrdf.frames.eval_global` of any Mitsuba BSDF over any
    number of wavelengths (nm; 4 per call): (n, len(wavelengths), 4, 4), 1/sr."""
    from .. import frames

    wavelengths = list(wavelengths)
    out = []
    for start in range(0, len(wavelengths), 4):
        block = wavelengths[start:start + 4]
        padded = block + [block[-1]] * (4 - len(block))
        out.append(frames.eval_global(bsdf, to_viewer, to_light, padded, mode)[:, :len(block)])
    return np.concatenate(out, axis=1)


def load_plugin(**params):
    """``mi.load_dict`` of a ``pbrdf`` with these parameters (a variant must be set)."""
    import mitsuba as mi

    return mi.load_dict(dict({"type": "pbrdf"}, **params))


def reference_config(config, wavelengths):
    """reference.pbrdf keyword arguments (n, k of shape (w,)) for plugin
    parameters ``config`` (a :data:`CONFIGS` entry)."""
    c = dict(dict(ks=1.0, kdd=0.0, sigma_dd=0.5, kid=0.0, shadowing="vgroove",
                  dd_distribution="beckmann"), **config)
    if "material" in c:
        n, k = reference.conductor_ior(c.pop("material"), wavelengths)
    else:
        n, k = np.full(len(wavelengths), c.pop("eta")), np.full(len(wavelengths), c.pop("k"))
    return dict(c, n=n, k=k)


def reference_global(config, to_viewer, to_light, wavelengths):
    """The reference's BRDF (n, len(wavelengths), 4, 4) for plugin parameters ``config``."""
    from .. import frames

    ti, pi_ = frames.to_angles(to_light)
    tr, pr = frames.to_angles(to_viewer)
    return reference.pbrdf(ti[:, None], pi_[:, None], tr[:, None], pr[:, None],
                           **reference_config(config, wavelengths))


# ---------------------------------------------------------------------------
# Reciprocity
# ---------------------------------------------------------------------------

def reciprocity_errors(evaluate, to_viewer, to_light, floor=1e-7):
    """(max |M00(i,r) − M00(r,i)| / M00, max_ij |M(r,i) − Q M(i,r)^T Q| / M00)
    for ``evaluate(to_viewer, to_light) -> (n, w, 4, 4)`` (e.g. a
    :func:`mueller_global` of any BSDF), where M00 > ``floor`` max M00 (below,
    a float32 lobe's far tail underflows)."""
    A = evaluate(to_viewer, to_light)
    B = evaluate(to_light, to_viewer)
    m00 = A[..., 0, 0]
    ok = m00 > floor * m00.max()
    rel00 = np.abs(B[..., 0, 0] - m00)[ok] / m00[ok]
    full = np.max(np.abs(B - Q @ np.swapaxes(A, -1, -2) @ Q), axis=(-1, -2))[ok] / m00[ok]
    return float(rel00.max()), float(full.max())


def reciprocity(configs=CONFIGS, pairs=100_000, plugin=True, seed=1):
    """Rows: (config, engine, max |M00(i,r) - M00(r,i)| / M00,
    max_ij |M(r,i) - Q M(i,r)^T Q| / M00), over ``pairs`` random direction
    pairs (half near the specular direction, cos theta >= 0.02) x 4 wavelengths,
    where M00 > 1e-7 max M00 (below, float32 D underflows in the far tail)."""
    from .. import frames

    rng = np.random.default_rng(seed)
    rows = []
    for name, config in configs.items():
        to_viewer, to_light = frames.random_directions(pairs, rng)
        engines = {"reference": lambda v, l: reference_global(config, v, l, CONFIG_WAVELENGTHS)}
        if plugin:
            bsdf = load_plugin(**config)
            engines["plugin"] = lambda v, l: mueller_global(bsdf, v, l, CONFIG_WAVELENGTHS)
        for engine, evaluate in engines.items():
            rows.append((name, engine) + reciprocity_errors(evaluate, to_viewer, to_light))
    return rows


# ---------------------------------------------------------------------------
# Realizability
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


def realizability(configs=CONFIGS, pairs=100_000, plugin=True, seed=2):
    """Rows: (config, engine, matrices checked (M00 above NORMAL_FLOOR), min
    eigenvalue / M00, max (DOP_out - 1) over 69 input Stokes vectors
    (unpolarized, the six pure states, 62 random fully polarized), min M00).
    Where the output intensity vanishes (p light at
    Brewster's angle) the DOP is measured as (|S_out,1..3| - S_out,0) / M00."""
    from .. import frames

    rng = np.random.default_rng(seed)
    inputs = _realizability.poincare_inputs()
    rows = []
    for name, config in configs.items():
        to_viewer, to_light = frames.random_directions(pairs, rng, min_cos=1e-3)
        sv, sl = special_pairs()
        to_viewer, to_light = np.vstack([to_viewer, sv]), np.vstack([to_light, sl])
        engines = {"reference": reference_global(config, to_viewer, to_light, CONFIG_WAVELENGTHS)}
        if plugin:
            engines["plugin"] = mueller_global(load_plugin(**config), to_viewer, to_light,
                                               CONFIG_WAVELENGTHS)
        for engine, M in engines.items():
            rows.append((name, engine) + _realizability.realizability(
                M, floor=NORMAL_FLOOR[engine], inputs=inputs))
    return rows
