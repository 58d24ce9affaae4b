"""Saying when the model does not fit: the goodness of fit by region of the
reflection, and the warnings a fit's report gives.

**Regions** (by geometry, the same for every sample). They are exclusive and
counted in this order, each value in the first whose rule it meets:

1. ``grazing``: the light or the detector 75° or more from the normal;
2. ``specular peak``: the detector within 2° of the mirror direction;
3. ``near-specular``: 2° to 10° from it;
4. ``off-specular``: beyond 10°.

so a grazing value within 2° of the mirror direction counts as grazing, not
as specular peak; each later region also gives the number of values that meet
its own rule but were counted as grazing. Per region: the number of measured
values, the RMS and the mean of ``ln(model / data)`` of ``m00`` (where both
are positive; a mean above 0 is a model too high), and the objective's
chi-square per value there.

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
* data that are not reciprocal (:func:`reciprocity`): where the data hold
  light/detector-swapped pairs, their median ratio outside
  [1 / :data:`RECIPROCITY_LIMIT`, :data:`RECIPROCITY_LIMIT`].
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Optional

import numpy as np

from ..measured.pairs import TOL, matching_pairs

__all__ = ["REGIONS", "MODEL_LIMITED", "RECIPROCITY_LIMIT", "Region", "Reciprocity",
           "region_labels", "regional_fit", "reciprocity", "diagnose"]

#: Region name -> its rule, in the order they are tried (exclusive: the first that applies).
REGIONS = {"grazing": "light or detector >= 75 deg from the normal",
           "specular peak": "not grazing, detector within 2 deg of the mirror direction",
           "near-specular": "not grazing, 2-10 deg from the mirror direction",
           "off-specular": "not grazing, beyond 10 deg from the mirror direction"}
GRAZING_DEG, PEAK_DEG, NEAR_DEG = 75.0, 2.0, 10.0
#: Reduced chi-square above which a fit is limited by its model.
MODEL_LIMITED = 3.0
#: Light/detector-swapped pairs whose median M00 ratio lies outside [1/x, x] are
#: warned of. A pair's ratio scatters by sqrt(2) times the values' relative
#: noise (7 % at 5 %), so 1.25 (|ln| = 0.22) is over 3 of those even for one pair
#: and far more for a median of many; and a reciprocal model cannot follow it:
#: it fits the pairs' geometric mean, each side at least 11 % off.
RECIPROCITY_LIMIT = 1.25


@dataclass
class Region:
    """Goodness of fit of one region of the reflection."""
    name: str
    rule: str
    values: int            # measured values (all quantities) in the region
    rms_ln: float          # RMS of ln(model / data) of m00 (NaN without m00)
    mean_ln: float         # mean of ln(model / data) of m00 (> 0: model too high)
    chi2_per_value: float  # the objective's chi-square per value
    order: int = 0         # 1-based place in the counting order (:data:`REGIONS`)
    counted_earlier: int = 0  # values meeting this region's own rule, counted as grazing

    @property
    def label(self) -> str:
        """E.g. "2. specular peak (not grazing, ...; 5 more values within it counted as grazing)"."""
        more = (f"; {self.counted_earlier} more values within it counted as grazing"
                if self.counted_earlier else "")
        return f"{self.order}. {self.name} ({self.rule}{more})"

    def as_dict(self):
        out = {k: (None if isinstance(v, float) and not math.isfinite(v) else v)
               for k, v in asdict(self).items()}
        return dict(out, label=self.label)


def _direction(theta, phi):
    t, p = np.radians(theta), np.radians(phi)
    return np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1)


def _mirror_labels(data) -> np.ndarray:
    """The region of each measurement by its angle from the mirror direction alone."""
    wi, wr = _direction(data.theta_i, data.phi_i), _direction(data.theta_r, data.phi_r)
    mirror = wi * np.array([-1.0, -1.0, 1.0])
    off = np.degrees(np.arccos(np.clip(np.sum(mirror * wr, -1), -1.0, 1.0)))
    return np.where(off < PEAK_DEG, "specular peak",
                    np.where(off < NEAR_DEG, "near-specular", "off-specular")).astype(object)


def region_labels(data) -> np.ndarray:
    """The region of each measurement (see the module docstring)."""
    labels = _mirror_labels(data)
    labels[np.maximum(data.theta_i, data.theta_r) >= GRAZING_DEG] = "grazing"
    return labels


def regional_fit(data, model, terms):
    """:class:`Region` rows for the fitted *model* ({quantity: values}) under
    the objective's *terms*; regions without measurements are left out."""
    labels, own = region_labels(data), _mirror_labels(data)
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
    for order, (name, rule) in enumerate(REGIONS.items(), 1):
        inside = labels == name
        n = int(count[inside].sum())
        if not n:
            continue
        l = ln[inside & np.isfinite(ln)]
        earlier = int(count[(own == name) & (labels != name)].sum())
        rows.append(Region(name, rule, n,
                           float(np.sqrt(np.mean(l * l))) if l.size else math.nan,
                           float(np.mean(l)) if l.size else math.nan,
                           float(chi2[inside].sum() / n), order, earlier))
    return rows


@dataclass
class Reciprocity:
    """Helmholtz reciprocity of the data: its light/detector-swapped pairs
    (:func:`mitsuba_pbrdf.measured.pairs.matching_pairs`) and the median of
    their M00 ratios, the geometry with the light farther from the normal over
    its swap (1 for a reciprocal sample)."""
    pairs: int
    median_ratio: float
    warning: str = ""

    def line(self) -> str:
        return (f"reciprocity: {self.pairs} light/detector-swapped pairs, median m00 ratio "
                f"{self.median_ratio:.3g} (light farther from the normal over its swap; "
                f"1 if reciprocal)")

    def as_dict(self):
        return asdict(self)


def reciprocity(data) -> Optional[Reciprocity]:
    """:class:`Reciprocity` of *data*'s m00, or None where it holds no swapped
    pairs with both values > 0 (a pair with theta_i = theta_r has no light
    farther from the normal and is left out)."""
    if "m00" not in data.observed:
        return None
    pairs = matching_pairs(data, swap=True)
    a, b = pairs[:, 0], pairs[:, 1]
    y = data.observed["m00"]
    # each pair once, oriented: row a has the light farther from the normal
    keep = ((data.theta_i[a] > data.theta_r[a] + TOL) & np.isfinite(y[a]) & np.isfinite(y[b])
            & (y[a] > 0) & (y[b] > 0))
    if not keep.any():
        return None
    median = float(np.median(y[a[keep]] / y[b[keep]]))
    count = int(keep.sum())
    warning = ""
    if not 1 / RECIPROCITY_LIMIT <= median <= RECIPROCITY_LIMIT:
        warning = (f"warning: the data are not reciprocal: swapping light and detector changes "
                   f"m00 by a median factor {median:.3g} over {count} pairs (outside "
                   f"[{1 / RECIPROCITY_LIMIT:g}, {RECIPROCITY_LIMIT:g}]); the model is "
                   f"reciprocal and fits their geometric mean: check the instrument's "
                   f"calibration of the light and detector arms, or the angle columns' order")
    return Reciprocity(count, median, warning)


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


def diagnose(result, data, material=None, swapped=None):
    """The warnings of a fit (one line each; see the module docstring);
    *swapped*: the data's :func:`reciprocity`, if computed."""
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
    if swapped is not None and swapped.warning:
        lines.append(swapped.warning)
    return lines
