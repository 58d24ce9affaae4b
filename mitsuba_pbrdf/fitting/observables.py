"""The model's observables (Mueller elements, DoLP) on the geometry of a set of
measurements, with the float64 reference evaluator, and synthetic
measurements of the model."""

from __future__ import annotations

from typing import Dict

import numpy as np

from .. import reference as ref
from ..measured.measurements import Measurements
from .vector import SHARED

__all__ = ["model_observables", "observables_from_mueller", "linear_ratios", "synthetic_measurements"]


def _per_point(data, per_wavelength):
    """Per-measurement values of a per-wavelength array."""
    index = np.searchsorted(data.wavelengths, data.wavelength)
    return np.asarray(per_wavelength, dtype=np.float64)[index]


def linear_ratios(M):
    """``(q, u, ok)``: the normalized linear Stokes ratios ``M10 / M00`` and
    ``M20 / M00`` of unpolarized light reflected by Mueller matrices ``M``
    (N, 4, 4), 0 where ``ok`` (``M00 > 0``) is False. DoLP is ``hypot(q, u)``.
    Ratios first: a lobe far from its peak underflows (M00 ~ 1e-318 at a
    narrow width) and a square or product of such values is 0, a ratio is not."""
    m00 = M[:, 0, 0]
    ok = m00 > 0
    safe = np.where(ok, m00, 1.0)
    return np.where(ok, M[:, 1, 0] / safe, 0.0), np.where(ok, M[:, 2, 0] / safe, 0.0), ok


def observables_from_mueller(M, names):
    """{name: value at every measurement} from Mueller matrices ``M`` (N, 4, 4)."""
    out = {}
    for name in names:
        if name == "dolp":
            q, u, _ = linear_ratios(M)
            out[name] = np.hypot(q, u)
        else:
            out[name] = M[:, int(name[1]), int(name[2])]
    return out


def model_observables(data: Measurements, values: Dict, shadowing="vgroove",
                      dd_distribution="beckmann", names=None, distribution="beckmann"):
    """The model's value of each observed quantity (or ``names``) at every
    measurement, with the float64 reference. ``values``: ``n``, ``k`` (one per
    distinct wavelength, or scalars) and the shared parameters (those of
    :data:`.layout.SHARED` it holds: ``sigma``, or ``sigma_u`` and ``sigma_v``)."""
    names = list(data.observed) if names is None else list(names)
    n = np.broadcast_to(values["n"], data.wavelengths.shape)
    k = np.broadcast_to(values["k"], data.wavelengths.shape)
    M = ref.pbrdf(*data.radians(), _per_point(data, n), _per_point(data, k),
                  shadowing=shadowing, dd_distribution=dd_distribution, distribution=distribution,
                  **{name: values[name] for name in SHARED if name in values})
    return observables_from_mueller(M, names)


def synthetic_measurements(values, theta_i=(20.0, 45.0, 70.0), theta_r=None, wavelengths=(633.0,),
                           quantities=("m00", "dolp"), noise=0.02, noise_floor=1e-4, seed=0,
                           shadowing="vgroove", dd_distribution="beckmann", out_of_plane=True,
                           phi_i=(0.0,), distribution="beckmann"):
    """Measurements of the model with parameters ``values`` (see
    :func:`model_observables`) on a goniometer grid (in plane, detector from
    -80 to 80 deg in 2-deg steps, plus an out-of-plane ring at 30 and 90 deg
    azimuth), with Gaussian noise of standard deviation ``noise * |value| +
    noise_floor * max|m00|`` (DoLP: ``max|dolp|``; given as the uncertainty).
    ``phi_i``: the light's azimuths (deg; the grid turns with it), several to
    resolve anisotropy."""
    rng = np.random.default_rng(seed)
    theta_r = np.arange(-80.0, 80.1, 2.0) if theta_r is None else np.asarray(theta_r, float)
    rows = []
    for wl in wavelengths:
        for pi_ in phi_i:
            for ti in theta_i:
                for tr in theta_r:
                    rows.append((ti, pi_, abs(tr), pi_ + (180.0 if tr >= 0 else 0.0), wl))
                if out_of_plane:
                    for tr in (20.0, 40.0, 60.0):
                        for dphi in (150.0, 120.0, 90.0):
                            rows.append((ti, pi_, tr, pi_ + dphi, wl))
    a = np.array(rows)
    data = Measurements(a[:, 0], a[:, 1], a[:, 2], a[:, 3], a[:, 4], {}, {}, "<synthetic>")
    wl = data.wavelengths
    vals = dict(values)
    if "material" in vals:
        vals["n"], vals["k"] = ref.conductor_ior(vals.pop("material"), wl)
    names = list(dict.fromkeys(("m00",) + tuple(quantities)))
    clean = model_observables(data, vals, shadowing, dd_distribution, names, distribution)
    for q in quantities:
        y = clean[q]
        # a polarimeter's floor is a fraction of the intensity it measures (M00),
        # not of the element's own largest value: an element that vanishes by
        # symmetry (m03 ~ 1e-21, round-off) would get uncertainties of 1e-26
        level = clean["dolp" if q == "dolp" else "m00"]
        u = noise * np.abs(y) + noise_floor * np.abs(level).max()
        obs = y + rng.normal(size=y.shape) * u
        if q == "dolp":
            obs = np.clip(obs, 0.0, 1.0)
        elif q == "m00":
            obs = np.abs(obs)
        data.observed[q] = obs
        data.uncertainty[q] = u
    return data
