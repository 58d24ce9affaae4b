"""Numerical stability stress test of the ``pbrdf`` plugin: checks and tallies.

:func:`run` draws random configurations and, for each, a batch of direction
pairs from several regions (:mod:`proof.fuzz_inputs`); every
``eval``, ``pdf``, ``eval_pdf`` and ``sample`` result, in both transport modes
(:mod:`mitsuba_pbrdf.diagnostics.bsdf_outputs`), is checked to be

* finite (no NaN, no Inf), with pdf >= 0, M00 >= 0 and sample weight M00 >= 0;
* physically realizable: the smallest eigenvalue of Cloude's coherency matrix
  >= -REALIZABILITY_TOL x M00 (also for the sample weights);
* zero below the horizon (value and pdf; sample weight when wi is below);
* consistent: ``eval`` and ``pdf`` equal ``eval_pdf``'s value and pdf, and
  ``sample``'s pdf and weight equal ``eval_pdf``'s pdf and value / pdf at the
  direction it returns;

and its value (rotated into the global s/p frames, cosine divided out, 1/sr)
is compared with the float64 reference evaluator: the worst error relative to
M00, max_ij |M_ij - R_ij| / R00, per region of directions, also in units of
u (1 + kappa) (:mod:`proof.conditioning`). :func:`check_outputs`
applies the checks of the first three kinds to the outputs of any BSDF.
"""

import time

import numpy as np

from mitsuba_pbrdf.diagnostics.bsdf_outputs import bsdf_outputs
from .conditioning import lane_parameters, reference_brdf, sensitivity
from .fuzz_inputs import FORCED, REGIONS, TEXELS, draw_config, draw_directions
from mitsuba_pbrdf.diagnostics.realizability import REALIZABILITY_TOL, U32, coherency_eigenvalues

__all__ = ["ACCURACY_UNITS", "M00_FLOOR", "REALIZABILITY_TOL", "TIGHT_BOUND", "Tally", "check_config",
           "check_outputs", "consistency_tolerance", "run"]

#: Accuracy bound, in units of u (1 + kappa): the plugin's evaluation chain
#: (normalizing the half vector, D with its exponential, G, the complex Fresnel
#: amplitudes, two frame rotations with their trigonometry, the cosine) has on
#: the order of 100 float32 operations, each adding at most u of relative
#: error on top of what the inputs' conditioning (1 + kappa) already implies.
ACCURACY_UNITS = 128
#: A lane's accuracy bound ACCURACY_UNITS u (1 + kappa), relative to M00, is
#: *tight* below this: there the comparison can catch a 0.1 % error.
TIGHT_BOUND = 1e-3
#: Below this M00 (1/sr) float32 values are near the denormal range (1.2e-38)
#: and carry no relative precision: not used for relative checks.
M00_FLOOR = 1e-30


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
        #: Per region: lanes whose bound is tight (< TIGHT_BOUND), and a sample
        #: of the effective bounds ACCURACY_UNITS u (1 + kappa) for the report.
        self.tight = {r: 0 for r in REGIONS if r != "below"}
        self.bounds = {r: [] for r in REGIONS if r != "below"}
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


def consistency_tolerance(out, wi, wo, mode, p):
    """Relative tolerance (n,) of sample() against eval_pdf at the direction it
    returns; NaN or inf where the comparison is meaningless.

    sample() works from the sampled facet normal m, eval_pdf recomputes
    h = normalize(wi + wo) from the rounded wo: they differ by ~2u / cos(beta)
    rad. That changes D by a relative 2 sqrt(x) (2u / cos(beta)) / alpha,
    x = tan^2(theta_h) / alpha^2 (for each microfacet lobe present), and
    cos(beta) itself - a dot product of float32 vectors of length 1 +- u -
    by ~u / cos^2(beta), which V-groove's G and the Fresnel factor inherit.
    Tolerance: 1e-3 + 4 x those. ``p``: per-lane parameters (lane_parameters)."""
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
    return np.where(cos_h > 0, tolerance, np.nan)


def check_outputs(out, wi, wo, mode, tally, config, tolerance):
    """Tally the finiteness, sign, horizon, consistency and realizability checks
    of one :func:`~mitsuba_pbrdf.diagnostics.bsdf_outputs.bsdf_outputs` result.
    ``tolerance`` (n,): relative tolerance of the sample() consistency checks
    (:func:`consistency_tolerance`); lanes where it is not below 0.1 are not
    compared (ill-conditioned, not inconsistent)."""
    n = len(wi)
    below = (wi[:, 2] <= 0) | (wo[:, 2] <= 0)
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
    # sample() agrees with eval_pdf at the direction it returns: pdf equal and
    # weight = value / pdf, up to the float32 conditioning of that comparison.
    sampled = ((out["bs_pdf"] > 0) & (out["pdf_bs"] > 0) & np.isfinite(tolerance)
               & (tolerance < 0.1))
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
            lam[ok] = coherency_eigenvalues(M[ok] / m00[ok][..., None, None])[..., 0]
        tally.min_eigen = min(tally.min_eigen, float(lam.min()))
        tally.check(name, (lam >= -REALIZABILITY_TOL).all(axis=1), config, label)


def _tally_accuracy(tally, out, R, kappa, wi, wo, region, p, config, wavelengths, mode):
    """Worst error against the reference R per region (raw and in u (1 + kappa))."""
    n = len(wi)
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
            bound = ACCURACY_UNITS * U32 * (1.0 + kappa[sel])
            tally.tight[name] += int(np.count_nonzero(bound < TIGHT_BOUND))
            tally.bounds[name].append(bound.astype(np.float32))
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


def check_config(config, wavelengths, n, rng, tally, accuracy=True):
    """Draw ``n`` direction pairs, run every check of one configuration in both
    transport modes and, with ``accuracy``, compare with the reference."""
    bsdf, textures = load(config)
    wi, wo, region = draw_directions(n, rng)
    uv = (rng.integers(0, TEXELS, (2, n)) + 0.5) / TEXELS      # a random texel per lane
    below = (wi[:, 2] <= 0) | (wo[:, 2] <= 0)
    R = kappa = p = None
    tally.configs += 1
    tally.samples += n
    for mode in ("radiance", "importance"):
        out = bsdf_outputs(bsdf, wi, wo, wavelengths, mode, rng, textures, uv)
        tally.evaluations += 4 * n
        if p is None:
            p = lane_parameters(config, wavelengths, out["lanes"], n)
        check_outputs(out, wi, wo, mode, tally, config,
                      consistency_tolerance(out, wi, wo, mode, p))
        if accuracy:
            if R is None:
                R = reference_brdf(config, p, wi, wo)
                kappa = sensitivity(config, p, wi, wo, R, rng)
            _tally_accuracy(tally, out, R, kappa, wi, wo, region, p, config, wavelengths, mode)
            tally.check("zero reference -> zero plugin", np.all(
                (R[..., 0, 0] != 0) | (np.abs(out["brdf"][..., 0, 0]) == 0), axis=1)
                | below, config, f"mode={mode}")


def run(samples=100_000, seed=0, lanes=TEXELS * TEXELS, accuracy=True, progress=False):
    """Draw configurations until ``samples`` direction pairs have been checked;
    returns the :class:`Tally` (``seconds``: its run time)."""
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
