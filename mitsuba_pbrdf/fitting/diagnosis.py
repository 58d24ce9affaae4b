"""Saying when the model does not fit: the goodness of fit by region of the
reflection, and the warnings a fit's report gives.

**Regions** (by geometry, the same for every sample; the first that applies):

* ``grazing``: the light or the detector 75° or more from the normal;
* ``specular peak``: the detector within 2° of the mirror direction;
* ``near-specular``: 2° to 10° from it;
* ``off-specular``: beyond 10°.

Per region: the number of measured values, the RMS and the mean of
``ln(model / data)`` of ``m00`` (where both are positive; a mean above 0 is a
model too high), and the objective's chi-square per value there.

**Warnings** (one line each):

* the reduced chi-square far above 1 (> :data:`MODEL_LIMITED`): the model, not
  the measurement noise, limits the fit, and the uncertainties are formal;
* a fitted index that no real material has (n < 1 with k < 1: a dielectric has
  n > 1, a metal k > 1 in the visible) or far from the named material's
  tabulated one (more than a factor 2 off): effective values, with the remedies;
* unpolarized data with n, k left free: no material named to take them from;
* a log objective's floor set below where the file's m00 uncertainties stop
  being relative (:func:`.objectives.noise_crossover`): the values below it
  are mostly noise, whose log is biased, and the fit's values with them.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

__all__ = ["REGIONS", "MODEL_LIMITED", "Region", "region_labels", "regional_fit", "diagnose"]

#: Region name -> its rule, in the order they are tried.
REGIONS = {"grazing": "light or detector >= 75 deg from the normal",
           "specular peak": "detector within 2 deg of the mirror direction",
           "near-specular": "2-10 deg from the mirror direction",
           "off-specular": "beyond 10 deg from the mirror direction"}
GRAZING_DEG, PEAK_DEG, NEAR_DEG = 75.0, 2.0, 10.0
#: Reduced chi-square above which a fit is limited by its model.
MODEL_LIMITED = 3.0


@dataclass
class Region:
    """Goodness of fit of one region of the reflection."""
    name: str
    rule: str
    values: int            # measured values (all quantities) in the region
    rms_ln: float          # RMS of ln(model / data) of m00 (NaN without m00)
    mean_ln: float         # mean of ln(model / data) of m00 (> 0: model too high)
    chi2_per_value: float  # the objective's chi-square per value

    def as_dict(self):
        return {k: (None if isinstance(v, float) and not math.isfinite(v) else v)
                for k, v in asdict(self).items()}


def _direction(theta, phi):
    t, p = np.radians(theta), np.radians(phi)
    return np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1)


def region_labels(data) -> np.ndarray:
    """The region of each measurement (see the module docstring)."""
    wi, wr = _direction(data.theta_i, data.phi_i), _direction(data.theta_r, data.phi_r)
    mirror = wi * np.array([-1.0, -1.0, 1.0])
    off = np.degrees(np.arccos(np.clip(np.sum(mirror * wr, -1), -1.0, 1.0)))
    labels = np.where(off < PEAK_DEG, "specular peak",
                      np.where(off < NEAR_DEG, "near-specular", "off-specular")).astype(object)
    labels[np.maximum(data.theta_i, data.theta_r) >= GRAZING_DEG] = "grazing"
    return labels


def regional_fit(data, model, terms):
    """:class:`Region` rows for the fitted *model* ({quantity: values}) under
    the objective's *terms*; regions without measurements are left out."""
    labels = region_labels(data)
    chi2 = np.zeros(len(data))
    count = np.zeros(len(data), dtype=int)
    for t in terms:
        r = t.residuals(model[t.name][t.rows])
        np.add.at(chi2, t.rows, r * r)
        np.add.at(count, t.rows, 1)
    ln = np.full(len(data), np.nan)
    if "m00" in data.observed:
        y, m = data.observed["m00"], model["m00"]
        ok = np.isfinite(y) & (y > 0) & (m > 0)
        ln[ok] = np.log(m[ok] / y[ok])
    rows = []
    for name, rule in REGIONS.items():
        inside = labels == name
        n = int(count[inside].sum())
        if not n:
            continue
        l = ln[inside & np.isfinite(ln)]
        rows.append(Region(name, rule, n,
                           float(np.sqrt(np.mean(l * l))) if l.size else math.nan,
                           float(np.mean(l)) if l.size else math.nan,
                           float(chi2[inside].sum() / n)))
    return rows


def _index_warnings(result, material):
    from .. import reference as ref

    label = f"{result.model}-component fit"
    tabulated = None
    if material is not None:
        try:
            tabulated = ref.conductor_ior(material, result.wavelengths)
        except ValueError:
            tabulated = None
    remedy = ("try --init n=1.35,k=0 (a dielectric) or --fix n=...,k=... with the sample's "
              "index, the two-component model (--model two), or fit without the elements that "
              "pull the index (--observables m00,dolp)")
    lines = []
    for j, w in enumerate(result.wavelengths):
        if f"n({w:g} nm)" not in result.free and f"k({w:g} nm)" not in result.free:
            continue
        n, k = float(result.values["n"][j]), float(result.values["k"][j])
        if n < 1 and k < 1:
            lines.append(f"warning: {label}: n = {n:.3g}, k = {k:.3g} at {w:g} nm is no real "
                         f"material's index (a dielectric has n > 1, a metal k > 1): effective "
                         f"values that buy a better fit of the polarization, not the sample's; "
                         f"{remedy}")
        elif tabulated is not None:
            nt, kt = float(tabulated[0][j]), float(tabulated[1][j])
            far = abs(math.log(n / nt)) > math.log(2) or (
                kt > 0.5 and (k <= 0 or abs(math.log(k / kt)) > math.log(2)))
            if far:
                lines.append(f"warning: {label}: n = {n:.3g}, k = {k:.3g} at {w:g} nm is far "
                             f"from {material}'s tabulated {nt:.3g} + {kt:.3g}i: effective "
                             f"values; {remedy}")
    return lines


def diagnose(result, data, material=None):
    """The warnings of a fit (one line each; see the module docstring)."""
    label = f"{result.model}-component fit"
    lines = []
    chi2 = result.reduced_chi2
    if chi2 > MODEL_LIMITED:
        scaled = (f"the uncertainties are formal (scaled by sqrt({chi2:.3g}))" if result.formal
                  else "the uncertainties assume the model is right")
        lines.append(f"warning: {label}: reduced chi-square {chi2:.3g} is far above 1: the model, "
                     f"not the measurement noise, limits this fit; {scaled}")
    lines += _index_warnings(result, material)
    polarized = any(q != "m00" for q in data.observed)
    if not polarized and any(f.startswith(("n(", "k(")) for f in result.free):
        lines.append(f"warning: {label}: unpolarized data (m00 alone) cannot determine n and k; "
                     f"name the material (--material) or give its index (--nk FILE) to fix them")
    if result.objectives.get("m00") == "log" and "m00" in data.uncertainty:
        from .objectives import noise_crossover

        crossover = noise_crossover(data.observed["m00"], data.uncertainty["m00"])
        if result.log_floor is not None and result.log_floor < crossover:
            lines.append(f"warning: {label}: the log floor {result.log_floor:.3g} 1/sr is below "
                         f"{crossover:.3g} 1/sr, where the file's m00 uncertainties stop being "
                         f"relative: the log of the noisier values below it is biased, and so "
                         f"are the fitted values; the default floor is at least {crossover:.3g}")
    return lines
