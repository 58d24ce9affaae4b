"""The model on a set of measurements as the weighted sum of its lobes, with
each lobe kept until its own parameters change, and the Jacobian of the
observables column by column.

The pBRDF is linear in its lobe weights (paper Eq. 2)::

    F = ks Fs(n, k, sigma) + [kdd fdd(sigma_dd) + kid / pi] D0

so a weight's derivative is its lobe, exactly, and a width's or an index's
derivative needs its own lobe only (forward differences of the float64
reference, step ``sqrt(eps)`` times the parameter's scale). Fits of
unpolarized data (M00 alone) evaluate the specular lobe in the scalar form
(:func:`mitsuba_pbrdf.reference.specular_unpolarized`), a third of the work of
the Mueller form. The lobes are the reference's own functions; the sum is the
reference's :func:`~mitsuba_pbrdf.reference.pbrdf` written out
(``tests/fitting/test_fit_real.py`` checks that the two agree).
"""

from __future__ import annotations

from typing import Dict, Sequence

import numpy as np

from .. import reference as ref
from .vector import SCALE_FLOORS
from .observables import linear_ratios, observables_from_mueller

__all__ = ["LobeModel", "observable_derivatives"]

#: Forward-difference step, relative to a parameter's scale.
STEP = float(np.sqrt(np.finfo(np.float64).eps))

#: Lobes kept per kind (least recently used dropped): the current point and recent steps.
KEPT = 4

#: Which lobe each fitted parameter changes (weights: their lobe exactly).
SPECULAR = ("n", "k", "sigma", "sigma_u", "sigma_v")
DIRECTIONAL = ("sigma_dd",)
WEIGHTS = {"ks": "specular", "kdd": "directional", "kid": "ideal"}


def observable_derivatives(M, dM, names):
    """Derivatives of the observables along a change ``dM`` (N, 4, 4) of ``M``.
    DoLP ``= hypot(q, u)`` of the ratios ``q = M10 / M00``, ``u = M20 / M00``
    (:func:`.observables.linear_ratios`): ``dq = (dM10 - q dM00) / M00``, so
    nothing is squared that may underflow; 0 where DoLP or M00 is 0."""
    out = {}
    for name in names:
        if name == "dolp":
            q, u, ok = linear_ratios(M)
            dolp = np.hypot(q, u)
            ok &= dolp > 0
            m00, d = np.where(ok, M[:, 0, 0], 1.0), np.where(ok, dolp, 1.0)
            dq = (dM[:, 1, 0] - q * dM[:, 0, 0]) / m00
            du = (dM[:, 2, 0] - u * dM[:, 0, 0]) / m00
            out[name] = np.where(ok, (q * dq + u * du) / d, 0.0)
        else:
            out[name] = dM[:, int(name[1]), int(name[2])]
    return out


class LobeModel:
    """The model's observables ``names`` at the measurements of *data*.

    ``values``: ``n``, ``k`` (one per distinct wavelength) and the shared
    parameters (as :func:`mitsuba_pbrdf.fitting.model_observables`)."""

    def __init__(self, data, names: Sequence[str], shadowing="vgroove",
                 dd_distribution="beckmann", distribution="beckmann"):
        self.angles = data.radians()
        # the geometry is the same at every parameter vector: computed once
        self.geometry = ref.bistatic_geometry(*self.angles)
        self.row_wavelength = np.searchsorted(data.wavelengths, data.wavelength)
        self.names = list(names)
        self.polarized = any(q != "m00" for q in self.names)
        self.shadowing, self.dd, self.distribution = shadowing, dd_distribution, distribution
        self._kept: Dict[str, dict] = {}
        self.evaluations = 0             # lobe evaluations, the fit's unit of work

    # -- lobes, each kept until its parameters change --------------------------------
    def _lobe(self, name, key, compute, counted=True):
        kept = self._kept.setdefault(name, {})
        if key in kept:
            kept[key] = kept.pop(key)                      # the most recently used last
        else:
            self.evaluations += counted
            if len(kept) >= KEPT:
                del kept[next(iter(kept))]                 # the least recently used
            kept[key] = compute()
        return kept[key]

    def _specular(self, values):
        n = np.asarray(values["n"], dtype=np.float64)[self.row_wavelength]
        k = np.asarray(values["k"], dtype=np.float64)[self.row_wavelength]
        widths = {w: float(values[w]) for w in ("sigma", "sigma_u", "sigma_v") if w in values}
        nk = (tuple(np.asarray(values["n"], float)), tuple(np.asarray(values["k"], float)))
        shape = tuple(sorted(widths.items()))
        lobe = (widths.get("sigma"), self.shadowing, self.distribution, widths.get("sigma_u"),
                widths.get("sigma_v"))
        if self.polarized:
            return self._lobe("specular", nk + shape, lambda: ref.specular(
                *self.angles, n, k, *lobe, geometry=self.geometry))
        # the scalar form's factors apart: a width's step keeps the Fresnel
        # factor, an index's step the microfacet one
        return self._lobe("specular", nk + shape, lambda: (
            self._lobe("microfacet", shape, lambda: ref.microfacet_lobe(
                *self.angles, *lobe, geometry=self.geometry), counted=False)
            * self._lobe("fresnel", nk, lambda: ref.fresnel_unpolarized(
                self.geometry["cos_b"], n, k), counted=False)))

    def _directional(self, values):
        sigma_dd = float(values["sigma_dd"])
        return self._lobe("directional", (sigma_dd,), lambda: ref.directional_diffuse(
            *self.angles, sigma_dd, self.shadowing, self.dd, geometry=self.geometry))

    def _ideal(self):
        return self._lobe("ideal", (), lambda: ref.ideal_diffuse(self.angles[0], self.angles[2]))

    def _as_mueller(self, lobe, depolarized):
        """A lobe (scalar or Mueller) as Mueller matrices: (N, 4, 4), or for
        unpolarized fits (N, 1, 1), element 00 alone (a view, no copy)."""
        if not self.polarized:
            return (lobe if lobe.ndim == 1 else lobe[:, 0, 0])[:, None, None]
        if depolarized:
            M = np.zeros(lobe.shape[:1] + (4, 4))
            M[:, 0, 0] = lobe
            return M
        return lobe

    def mueller(self, values):
        """The model's Mueller matrices (N, 4, 4); for unpolarized fits (N, 1, 1), element 00."""
        spec = self._as_mueller(self._specular(values), False)
        M = float(values["ks"]) * spec
        M[:, 0, 0] += (float(values["kdd"]) * self._directional(values)
                       + float(values["kid"]) * self._ideal())
        return M

    def observables(self, values) -> Dict[str, np.ndarray]:
        return observables_from_mueller(self.mueller(values), self.names)

    # -- derivatives ------------------------------------------------------------------
    def _step(self, base, x, lower, upper):
        h = STEP * max(abs(x), SCALE_FLOORS.get(base, 1e-3))
        return h if x + h <= upper else -h

    def jacobian(self, values, free, bounds) -> Dict[str, Dict[str, np.ndarray]]:
        """{free parameter: {observable: derivative at every measurement}}.
        ``free``: names as :class:`~.vector.ParameterVector` gives them
        (``n@0``, ``sigma``, ...); ``bounds``: (lower, upper) arrays in that order."""
        M = self.mueller(values)
        columns = {}
        for name, lo, hi in zip(free, *bounds):
            base, _, j = name.partition("@")
            if base in WEIGHTS:
                lobe = {"specular": lambda: self._as_mueller(self._specular(values), False),
                        "directional": lambda: self._as_mueller(self._directional(values), True),
                        "ideal": lambda: self._as_mueller(self._ideal(), True)}[WEIGHTS[base]]
                dM = lobe()
            else:
                x = float(values[base][int(j)]) if j else float(values[base])
                h = self._step(base, x, lo, hi)
                moved = {p: (v.copy() if isinstance(v, np.ndarray) else v)
                         for p, v in values.items()}
                if j:
                    moved[base][int(j)] = x + h
                else:
                    moved[base] = x + h
                if base in SPECULAR:
                    weight, lobe = float(values["ks"]), self._specular
                    depolarized = False
                elif base in DIRECTIONAL:
                    weight, lobe = float(values["kdd"]), self._directional
                    depolarized = True
                else:
                    raise ValueError(f"no lobe for parameter {name!r}")
                before = self._as_mueller(lobe(values), depolarized)
                after = self._as_mueller(lobe(moved), depolarized)
                dM = weight * (after - before) / h
            columns[name] = observable_derivatives(M, dM, self.names)
        return columns
