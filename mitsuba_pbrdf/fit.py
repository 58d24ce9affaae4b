"""Fit the pBRDF model to goniometer measurements (a CSV file).

::

    python -m mitsuba_pbrdf.fit measurements.csv [--material Al] [--model both]
        [--backend reference|drjit] [--fix name=value,...] [--init name=value,...]
        [--shadowing vgroove|smith] [--dd-distribution beckmann|ggx] [--starts N]
        [--rel-uncertainty 0.05] [--abs-uncertainty 0.005] [--plot fit.png] [--json out.json]

(also installed as the console script ``pbrdf-fit``). In Python::

    from mitsuba_pbrdf import fit
    data = fit.read_measurements("measurements.csv")
    results = fit.fit_models(data, material="Al")          # three- and two-component
    print(fit.report(data, results))
    fit.plot_fit(data, results, "fit.png")

**CSV format.** One header row, then one row per measurement; names are
case-insensitive, columns in any order:

* ``theta_i, phi_i, theta_r, phi_r``: directions towards the light and towards
  the detector, degrees (zenith in [0, 90), azimuth in [-360, 360]); the
  specular direction has ``phi_r = phi_i + 180``;
* ``wavelength``: nm, > 0;
* observed quantities, at least one: ``m00`` ... ``m33`` (Mueller BRDF
  elements, 1/sr, no cosine factor, in the global s/p frames of
  :mod:`mitsuba_pbrdf.reference`: S1 = I_s - I_p, Mitsuba's sign for the
  circular elements) and/or ``dolp`` (degree of linear polarization of the
  reflected light for unpolarized illumination, sqrt(m10^2 + m20^2) / m00, in
  [0, 1]). A row may leave some of them empty (not measured there);
* optional standard uncertainties ``<quantity>_err`` (e.g. ``m00_err``,
  ``dolp_err``), > 0. Without them each value is given
  ``rel * |value| + abs * max|column|`` (``--rel-uncertainty 0.05``,
  ``--abs-uncertainty 0.005``) and the parameters' uncertainties are scaled by
  the reduced chi-square.

Lines starting with ``#`` are comments. Other columns are ignored (and
listed). Malformed files (missing columns, no
observed quantity, non-numeric or NaN values where a value is required,
angles or wavelengths out of range, negative M00, DoLP outside [0, 1],
non-positive uncertainties) raise :class:`MeasurementError` naming the file,
row and column.

**Parameters.** The complex index n + ik per distinct wavelength, and
``sigma, ks, kdd, sigma_dd, kid`` shared by all wavelengths (see README's
model). ``--material`` starts n, k from Mitsuba's tabulated spectra (else
n = 1.5, k = 5); ``--fix`` holds parameters (``n``/``k`` for all
wavelengths, or ``n@633=1.2`` for one). The *two-component* model is the
specular lobe plus the ideal diffuse one (``kdd = 0``: the model the paper
modifies); ``--model both`` (default) fits both and reports each error, as the
paper compares them.

**Backends.** ``reference`` (default): ``scipy.optimize.least_squares``
(trust-region reflective, bounds) on the float64 NumPy reference evaluator,
Jacobian by finite differences. ``drjit``: the same solver on the Dr.Jit
plugin (float32), Jacobian by Dr.Jit forward-mode derivatives (one pass per
parameter). Both give the same parameters; ``reference`` is faster on the
data sizes of goniometer measurements (validation/fit_timing.py).

Parameter uncertainties are the square roots of the diagonal of
(J^T J)^-1 of the weighted residuals at the optimum (times the reduced
chi-square without given uncertainties): they are meaningful only where the
fit is good and the parameter is not at a bound (reported).
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import sys
import time
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Sequence

import numpy as np

from . import reference as ref

__all__ = [
    "MeasurementError",
    "Measurements",
    "read_measurements",
    "write_measurements",
    "synthetic_measurements",
    "model_observables",
    "FitResult",
    "fit_model",
    "fit_models",
    "report",
    "plot_fit",
    "main",
]

ANGLES = ("theta_i", "phi_i", "theta_r", "phi_r")
ELEMENTS = tuple(f"m{i}{j}" for i in range(4) for j in range(4))
OBSERVABLES = ELEMENTS + ("dolp",)
SHARED = ("sigma", "ks", "kdd", "sigma_dd", "kid")
DEFAULTS = dict(n=1.5, k=5.0, sigma=0.15, ks=1.0, kdd=0.1, sigma_dd=0.5, kid=0.01)
BOUNDS = dict(n=(0.01, 20.0), k=(0.0, 40.0), sigma=(1e-3, 2.0), ks=(0.0, 20.0),
              kdd=(0.0, 20.0), sigma_dd=(1e-3, 5.0), kid=(0.0, 10.0))
MODELS = {"three": "three-component (specular + directional diffuse + ideal diffuse)",
          "two": "two-component (specular + ideal diffuse, kdd = 0)"}


class MeasurementError(ValueError):
    """A measurement file that cannot be used, with the reason."""


# ---------------------------------------------------------------------------
# Measurements
# ---------------------------------------------------------------------------

@dataclass
class Measurements:
    """Measured pBRDF data. Angles in degrees as in the file; ``observed`` and
    ``uncertainty`` map a quantity (``m00`` ... ``m33``, ``dolp``) to an array
    with NaN where a row does not measure it (``uncertainty`` holds only the
    given ``<quantity>_err`` columns)."""
    theta_i: np.ndarray
    phi_i: np.ndarray
    theta_r: np.ndarray
    phi_r: np.ndarray
    wavelength: np.ndarray
    observed: Dict[str, np.ndarray]
    uncertainty: Dict[str, np.ndarray] = field(default_factory=dict)
    source: str = "<memory>"
    ignored_columns: List[str] = field(default_factory=list)

    def __len__(self):
        return len(self.theta_i)

    @property
    def wavelengths(self) -> np.ndarray:
        """Distinct wavelengths, sorted."""
        return np.unique(self.wavelength)

    def radians(self):
        return tuple(np.radians(a) for a in (self.theta_i, self.phi_i, self.theta_r, self.phi_r))

    def count(self) -> int:
        """Number of measured values."""
        return int(sum(np.isfinite(v).sum() for v in self.observed.values()))


def _number(text, path, row, column, required):
    text = (text or "").strip()
    if text == "":
        if required:
            raise MeasurementError(f"{path}: row {row}: column {column!r} is empty")
        return math.nan
    try:
        value = float(text)
    except ValueError:
        raise MeasurementError(f"{path}: row {row}: column {column!r} is not a number: "
                               f"{text!r}") from None
    if math.isnan(value):
        raise MeasurementError(f"{path}: row {row}: column {column!r} is NaN")
    if math.isinf(value):
        raise MeasurementError(f"{path}: row {row}: column {column!r} is infinite")
    return value


def read_measurements(path) -> Measurements:
    """Read and check a measurement CSV (format in the module docstring)."""
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise MeasurementError(f"{path}: no such file")
    with open(path, newline="", encoding="utf-8-sig") as f:
        lines = [line for line in f if line.strip() and not line.lstrip().startswith("#")]
    if not lines:
        raise MeasurementError(f"{path}: empty file (expected a header row: "
                               f"{', '.join(ANGLES)}, wavelength, m00 ...)")
    reader = csv.reader(lines)
    header = [h.strip().lower() for h in next(reader)]
    duplicates = sorted({h for h in header if header.count(h) > 1})
    if duplicates:
        raise MeasurementError(f"{path}: duplicate column(s) {', '.join(duplicates)}")
    required = list(ANGLES) + ["wavelength"]
    missing = [c for c in required if c not in header]
    if missing:
        raise MeasurementError(
            f"{path}: missing column(s) {', '.join(missing)}; a measurement file needs "
            f"{', '.join(required)} and at least one of m00 ... m33, dolp")
    quantities = [c for c in OBSERVABLES if c in header]
    if not quantities:
        raise MeasurementError(f"{path}: no measured quantity: add a column m00 ... m33 "
                               f"or dolp (found {', '.join(header)})")
    errors = [c for c in header if c.endswith("_err")]
    for c in errors:
        if c[:-4] not in quantities:
            raise MeasurementError(f"{path}: uncertainty column {c!r} has no column "
                                   f"{c[:-4]!r} to go with")
    known = set(required) | set(quantities) | set(errors)
    ignored = [c for c in header if c not in known]

    columns = {c: [] for c in required + quantities + errors}
    for row_number, row in enumerate(reader, start=2):
        if len(row) != len(header):
            raise MeasurementError(f"{path}: row {row_number}: {len(row)} fields, "
                                   f"the header has {len(header)}")
        cells = dict(zip(header, row))
        for c in required:
            columns[c].append(_number(cells[c], path, row_number, c, True))
        values = {c: _number(cells[c], path, row_number, c, False) for c in quantities}
        if all(math.isnan(v) for v in values.values()):
            raise MeasurementError(f"{path}: row {row_number}: no measured value "
                                   f"({', '.join(quantities)} all empty)")
        for c in quantities:
            columns[c].append(values[c])
        for c in errors:
            v = _number(cells[c], path, row_number, c, False)
            if math.isnan(v) and not math.isnan(values[c[:-4]]):
                raise MeasurementError(f"{path}: row {row_number}: {c!r} is empty but "
                                       f"{c[:-4]!r} is given")
            columns[c].append(v)
    if not columns["theta_i"]:
        raise MeasurementError(f"{path}: no data rows after the header")
    arrays = {c: np.array(v, dtype=np.float64) for c, v in columns.items()}
    data = Measurements(*(arrays[c] for c in ANGLES), arrays["wavelength"],
                        {c: arrays[c] for c in quantities},
                        {c[:-4]: arrays[c] for c in errors}, path, ignored)
    check_measurements(data)
    return data


def check_measurements(data: Measurements):
    """Range checks (raise :class:`MeasurementError` naming the first bad row;
    rows are numbered as in the file, the header being row 1)."""
    def fail(mask, message):
        rows = np.flatnonzero(mask)
        if rows.size:
            more = f" (and {rows.size - 1} more rows)" if rows.size > 1 else ""
            raise MeasurementError(f"{data.source}: row {rows[0] + 2}: {message}{more}")

    for name in ("theta_i", "theta_r"):
        a = getattr(data, name)
        fail(~np.isfinite(a), f"{name} is not finite")
        fail((a < 0) | (a >= 90), f"{name} = {a[(a < 0) | (a >= 90)][:1]} deg is out of "
             "range [0, 90) (zenith angle from the surface normal)")
    for name in ("phi_i", "phi_r"):
        a = getattr(data, name)
        fail(~np.isfinite(a) | (np.abs(a) > 360), f"{name} is out of range [-360, 360] deg")
    w = data.wavelength
    fail(~np.isfinite(w) | (w <= 0), "wavelength must be > 0 (nm)")
    if "m00" in data.observed:
        fail(data.observed["m00"] < 0, "m00 is negative")
    if "dolp" in data.observed:
        d = data.observed["dolp"]
        fail((d < 0) | (d > 1), "dolp is outside [0, 1]")
    for name, u in data.uncertainty.items():
        fail(np.isfinite(data.observed[name]) & ~(u > 0), f"{name}_err must be > 0")


def write_measurements(data: Measurements, path, uncertainties=True):
    """Write ``data`` as a CSV in the format :func:`read_measurements` reads."""
    cols = list(ANGLES) + ["wavelength"] + list(data.observed)
    if uncertainties:
        cols += [f"{c}_err" for c in data.uncertainty]
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(cols)
        for i in range(len(data)):
            row = [getattr(data, c)[i] for c in ANGLES] + [data.wavelength[i]]
            row += [data.observed[c][i] for c in data.observed]
            if uncertainties:
                row += [data.uncertainty[c][i] for c in data.uncertainty]
            w.writerow(["" if not np.isfinite(v) else f"{v:.9g}" for v in row])
    return path


# ---------------------------------------------------------------------------
# The model on the measurements' geometry (float64 reference)
# ---------------------------------------------------------------------------

def _per_point(data, per_wavelength):
    """Per-measurement values of a per-wavelength array."""
    index = np.searchsorted(data.wavelengths, data.wavelength)
    return np.asarray(per_wavelength, dtype=np.float64)[index]


def _observables_from_mueller(M, names):
    out = {}
    for name in names:
        if name == "dolp":
            with np.errstate(divide="ignore", invalid="ignore"):
                out[name] = np.where(M[:, 0, 0] > 0, np.hypot(M[:, 1, 0], M[:, 2, 0])
                                     / M[:, 0, 0], 0.0)
        else:
            out[name] = M[:, int(name[1]), int(name[2])]
    return out


def model_observables(data: Measurements, values: Dict, shadowing="vgroove",
                      dd_distribution="beckmann", names=None):
    """The model's value of each observed quantity (or ``names``) at every
    measurement, with the float64 reference. ``values``: ``n``, ``k`` (one per
    distinct wavelength, or scalars) and the shared parameters."""
    names = list(data.observed) if names is None else list(names)
    n = np.broadcast_to(values["n"], data.wavelengths.shape)
    k = np.broadcast_to(values["k"], data.wavelengths.shape)
    M = ref.pbrdf(*data.radians(), _per_point(data, n), _per_point(data, k),
                  values["sigma"], values["ks"], values["kdd"], values["sigma_dd"],
                  values["kid"], shadowing, dd_distribution)
    return _observables_from_mueller(M, names)


def synthetic_measurements(values, theta_i=(20.0, 45.0, 70.0), theta_r=None, wavelengths=(633.0,),
                           quantities=("m00", "dolp"), noise=0.02, noise_floor=1e-4, seed=0,
                           shadowing="vgroove", dd_distribution="beckmann", out_of_plane=True):
    """Measurements of the model with parameters ``values`` (see
    :func:`model_observables`) on a goniometer grid (in plane, detector from
    -80 to 80 deg in 2-deg steps, plus an out-of-plane ring at 30 and 90 deg
    azimuth), with Gaussian noise of standard deviation ``noise * |value| +
    noise_floor * max|column|`` (given as the uncertainty)."""
    rng = np.random.default_rng(seed)
    theta_r = np.arange(-80.0, 80.1, 2.0) if theta_r is None else np.asarray(theta_r, float)
    rows = []
    for wl in wavelengths:
        for ti in theta_i:
            for tr in theta_r:
                rows.append((ti, 0.0, abs(tr), 180.0 if tr >= 0 else 0.0, wl))
            if out_of_plane:
                for tr in (20.0, 40.0, 60.0):
                    for dphi in (150.0, 120.0, 90.0):
                        rows.append((ti, 0.0, tr, dphi, wl))
    a = np.array(rows)
    data = Measurements(a[:, 0], a[:, 1], a[:, 2], a[:, 3], a[:, 4], {}, {}, "<synthetic>")
    wl = data.wavelengths
    vals = dict(values)
    if "material" in vals:
        vals["n"], vals["k"] = ref.conductor_ior(vals.pop("material"), wl)
    clean = model_observables(data, vals, shadowing, dd_distribution, quantities)
    for q, y in clean.items():
        u = noise * np.abs(y) + noise_floor * np.abs(y).max()
        obs = y + rng.normal(size=y.shape) * u
        if q == "dolp":
            obs = np.clip(obs, 0.0, 1.0)
        elif q == "m00":
            obs = np.abs(obs)
        data.observed[q] = obs
        data.uncertainty[q] = u
    return data


# ---------------------------------------------------------------------------
# Fitting
# ---------------------------------------------------------------------------

@dataclass
class FitResult:
    """Outcome of :func:`fit_model`. ``values`` / ``errors``: ``n``, ``k``
    (arrays over ``wavelengths``) and the shared parameters; ``errors`` is NaN
    for fixed parameters; ``at_bound`` lists parameters stopped at a bound."""
    model: str
    backend: str
    wavelengths: np.ndarray
    values: Dict
    errors: Dict
    chi2: float
    dof: int
    residuals: Dict[str, np.ndarray]      # model - data, NaN where not measured
    rms: Dict[str, float]                 # RMS of model - data per quantity
    relative_rms: Dict[str, float]        # RMS of (model - data) / data where |data| >= 1 % of max
    seconds: float
    evaluations: int
    success: bool
    message: str
    free: List[str] = field(default_factory=list)
    at_bound: List[str] = field(default_factory=list)
    shadowing: str = "vgroove"
    dd_distribution: str = "beckmann"

    @property
    def reduced_chi2(self):
        return self.chi2 / max(self.dof, 1)

    def as_dict(self):
        conv = lambda v: v.tolist() if isinstance(v, np.ndarray) else v
        return {"model": self.model, "backend": self.backend,
                "wavelengths": self.wavelengths.tolist(),
                "values": {k: conv(v) for k, v in self.values.items()},
                "errors": {k: conv(v) for k, v in self.errors.items()},
                "chi2": self.chi2, "dof": self.dof, "reduced_chi2": self.reduced_chi2,
                "rms": self.rms, "relative_rms": self.relative_rms, "seconds": self.seconds,
                "evaluations": self.evaluations, "success": self.success,
                "message": self.message, "at_bound": self.at_bound,
                "shadowing": self.shadowing, "dd_distribution": self.dd_distribution}


def _parse_assignments(text, what):
    """'a=1,b=2' or a dict -> dict (values float)."""
    if not text:
        return {}
    if isinstance(text, dict):
        return {str(k): float(v) for k, v in text.items()}
    out = {}
    for item in str(text).split(","):
        key, sep, value = item.partition("=")
        if not sep:
            raise ValueError(f"{what}: expected name=value, got {item!r}")
        try:
            out[key.strip()] = float(value)
        except ValueError:
            raise ValueError(f"{what}: {key.strip()}={value!r} is not a number") from None
    return out


class _Layout:
    """Maps the free parameters to a vector and back."""

    def __init__(self, wavelengths, model, init, fix):
        self.wavelengths = np.asarray(wavelengths, dtype=np.float64)
        W = len(self.wavelengths)
        self.values = {"n": np.full(W, DEFAULTS["n"]), "k": np.full(W, DEFAULTS["k"])}
        self.values.update({p: float(DEFAULTS[p]) for p in SHARED})
        self.fixed = set()
        if model == "two":
            self.values["kdd"] = 0.0
            self.fixed |= {"kdd", "sigma_dd"}
        for source, is_fix in ((init, False), (fix, True)):
            for key, v in source.items():
                name, _, at = key.partition("@")
                if name not in ("n", "k") + SHARED:
                    raise ValueError(f"unknown parameter {name!r}; parameters: n, k, "
                                     f"{', '.join(SHARED)} (n@<nm>, k@<nm> for one wavelength)")
                if name in ("n", "k"):
                    if at:
                        j = np.flatnonzero(np.isclose(self.wavelengths, float(at)))
                        if not j.size:
                            raise ValueError(f"{key}: no measurement at {at} nm "
                                             f"(wavelengths: {self.wavelengths.tolist()})")
                        self.values[name][j[0]] = v
                        if is_fix:
                            self.fixed.add(f"{name}@{j[0]}")
                    else:
                        self.values[name][:] = v
                        if is_fix:
                            self.fixed |= {f"{name}@{j}" for j in range(W)}
                else:
                    if model == "two" and name in ("kdd", "sigma_dd") and not is_fix:
                        continue
                    self.values[name] = float(v)
                    if is_fix:
                        self.fixed.add(name)
        self.free = [f"{p}@{j}" for p in ("n", "k") for j in range(W)
                     if f"{p}@{j}" not in self.fixed]
        self.free += [p for p in SHARED if p not in self.fixed]

    def label(self, name):
        p, _, j = name.partition("@")
        return f"{p}({self.wavelengths[int(j)]:g} nm)" if j else p

    def get(self, name, values=None):
        values = self.values if values is None else values
        p, _, j = name.partition("@")
        return float(values[p][int(j)]) if j else float(values[p])

    def vector(self):
        return np.array([self.get(n) for n in self.free])

    def bounds(self):
        lo = np.array([BOUNDS[n.partition("@")[0]][0] for n in self.free])
        hi = np.array([BOUNDS[n.partition("@")[0]][1] for n in self.free])
        return lo, hi

    def unpack(self, x):
        values = {"n": self.values["n"].copy(), "k": self.values["k"].copy()}
        values.update({p: self.values[p] for p in SHARED})
        for name, v in zip(self.free, x):
            p, _, j = name.partition("@")
            if j:
                values[p][int(j)] = v
            else:
                values[p] = float(v)
        return values


def _weights(data, rel, abs_):
    """(quantity names, observed vector, uncertainty vector, index arrays)."""
    names, obs, unc, index = [], [], [], []
    for q, y in data.observed.items():
        rows = np.flatnonzero(np.isfinite(y))
        if q in data.uncertainty:
            u = data.uncertainty[q][rows]
        else:
            u = rel * np.abs(y[rows]) + abs_ * np.abs(y[rows]).max()
            u = np.where(u > 0, u, 1.0)
        names.append(q)
        obs.append(y[rows])
        unc.append(u)
        index.append(rows)
    return names, obs, unc, index


class _ReferenceResiduals:
    def __init__(self, data, layout, shadowing, dd):
        self.data, self.layout, self.shadowing, self.dd = data, layout, shadowing, dd
        self.count = 0

    def observables(self, x):
        self.count += 1
        return model_observables(self.data, self.layout.unpack(x), self.shadowing, self.dd)

    jacobian = None  # finite differences by scipy


class _DrJitResiduals:
    """The plugin evaluated on all measurements in one call. n and k are 1 x W
    bitmaps looked up with nearest filtering at each measurement's texel, so
    one BSDF serves every wavelength; derivatives by forward mode."""

    def __init__(self, data, layout, shadowing, dd):
        import drjit as dr
        import mitsuba as mi
        if mi.variant() is None or not mi.is_polarized or mi.variant().startswith("scalar"):
            mi.set_variant("llvm_ad_spectral_polarized")
        import mitsuba_pbrdf
        mitsuba_pbrdf.register()
        self.dr, self.mi = dr, mi
        self.data, self.layout, self.names = data, layout, list(data.observed)
        v = layout.values
        # Mitsuba's bitmaps are at least 2 x 2: two equal rows, >= 2 columns
        self.columns = max(len(layout.wavelengths), 2)
        bitmap = lambda a: {"type": "bitmap", "raw": True, "filter_type": "nearest",
                            "data": self._texels(a)}
        # weights load as non-zero so that every lobe of the model exists
        self.bsdf = mi.load_dict({
            "type": "pbrdf", "eta": bitmap(v["n"]), "k": bitmap(np.maximum(v["k"], 1e-3)),
            "sigma": 0.1, "ks": 1.0, "kdd": 0.0 if v["kdd"] == 0 and "kdd" in layout.fixed else 0.1,
            "sigma_dd": 0.5, "kid": 0.1, "shadowing": shadowing, "dd_distribution": dd})
        self.params = mi.traverse(self.bsdf)
        ti, pi_, tr, pr = data.radians()
        d = lambda t, p: np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1)
        self.wo_hat, self.wi_hat = d(ti, pi_), d(tr, pr)
        texel = np.searchsorted(layout.wavelengths, data.wavelength)
        self.uv = mi.Point2f(((texel + 0.5) / self.columns).astype(np.float32),
                             np.full(len(data), 0.25, np.float32))
        w = mi.Float(data.wavelength.astype(np.float32))
        self.wavelengths = mi.UnpolarizedSpectrum(w, w, w, w)
        self.count = 0

    def _texels(self, per_wavelength):
        t = np.zeros((2, self.columns, 1), np.float32)
        t[:, :len(per_wavelength), 0] = np.asarray(per_wavelength, np.float32)[None, :]
        t[:, len(per_wavelength):, 0] = t[:, :1, 0]
        return self.mi.TensorXf(t)

    def _set(self, x):
        values = self.layout.unpack(x)
        p = self.params
        p["eta.data"] = self._texels(values["n"])
        p["k.data"] = self._texels(values["k"])
        for name in SHARED:
            key = name + ".value"
            if key in p:
                p[key] = float(values[name])
        return values

    def _evaluate(self):
        from .inverse import mueller_brdf
        M = mueller_brdf(self.bsdf, self.wi_hat, self.wo_hat, self.wavelengths, uv=self.uv)
        out = []
        for name in self.names:
            if name == "dolp":
                dr = self.dr
                m00 = M[0, 0][0]
                r2 = dr.square(M[1, 0][0]) + dr.square(M[2, 0][0])
                ok = (m00 > 0) & (r2 > 0)  # guard both branches: no NaN derivatives
                out.append(dr.select(ok, dr.sqrt(dr.select(ok, r2, 1.0))
                                     / dr.select(ok, m00, 1.0), 0.0))
            else:
                out.append(M[int(name[1]), int(name[2])][0])
        return out

    def observables(self, x):
        self.count += 1
        self._set(x)
        self.params.update()
        with self.dr.suspend_grad():
            out = self._evaluate()
        return {n: np.asarray(o, dtype=np.float64) for n, o in zip(self.names, out)}

    def jacobian_columns(self, x):
        """{free parameter: {quantity: derivative at every measurement}}."""
        dr, mi = self.dr, self.mi
        self._set(x)
        keys = {"n": "eta.data", "k": "k.data"}
        cols = {}
        for name in self.layout.free:
            p, _, j = name.partition("@")
            key = keys.get(p, p + ".value")
            dr.enable_grad(self.params[key])
            self.params.update()
            out = self._evaluate()
            if j:
                t = np.zeros((2, self.columns, 1), np.float32)
                t[:, int(j), 0] = 1.0
                dr.set_grad(self.params[key], mi.TensorXf(t))
            else:
                dr.set_grad(self.params[key], 1.0)
            # keep interior gradients: an output (m00) may feed another (dolp)
            dr.forward_to(*out, flags=dr.ADFlag.ClearEdges | dr.ADFlag.ClearInput)
            cols[name] = {n: np.asarray(dr.grad(o), dtype=np.float64) for n, o in zip(self.names, out)}
            dr.disable_grad(self.params[key])
            self.params.update()
        self.count += 1
        return cols


def fit_model(data: Measurements, model="three", backend="reference", shadowing="vgroove",
              dd_distribution="beckmann", material=None, init=None, fix=None, starts=3,
              rel_uncertainty=0.05, abs_uncertainty=0.005, seed=0) -> FitResult:
    """Least-squares fit of one model (``"three"`` or ``"two"``) to ``data``.

    ``init`` / ``fix``: {name: value} (``n``, ``k``, ``n@<nm>``, ``k@<nm>``,
    ``sigma``, ``ks``, ``kdd``, ``sigma_dd``, ``kid``) or ``"name=value,..."``.
    ``material``: starting n, k from Mitsuba's tabulated spectra. ``starts``:
    the fit runs from the initial values and from ``starts - 1`` random
    perturbations of them (sigma and n, k by up to x2), keeping the lowest
    chi-square.
    """
    from scipy.optimize import least_squares

    if model not in MODELS:
        raise ValueError(f"model must be one of {', '.join(MODELS)}, not {model!r}")
    if backend not in ("reference", "drjit"):
        raise ValueError(f"backend must be 'reference' or 'drjit', not {backend!r}")
    init = _parse_assignments(init, "init")
    fix = _parse_assignments(fix, "fix")
    wavelengths = data.wavelengths
    if material is not None:
        try:
            n0, k0 = ref.conductor_ior(material, wavelengths)
        except ValueError as e:
            raise ValueError(f"material {material!r}: {e}") from None
        init = dict({f"n@{w:g}": v for w, v in zip(wavelengths, n0)},
                    **{f"k@{w:g}": v for w, v in zip(wavelengths, k0)}, **init)
    layout = _Layout(wavelengths, model, init, fix)
    names, obs, unc, index = _weights(data, rel_uncertainty, abs_uncertainty)
    n_obs = sum(len(o) for o in obs)
    if n_obs <= len(layout.free):
        raise ValueError(f"{n_obs} measured values cannot determine {len(layout.free)} "
                         f"free parameters")
    evaluator = (_ReferenceResiduals if backend == "reference" else _DrJitResiduals)(
        data, layout, shadowing, dd_distribution)

    def residuals(x):
        model_values = evaluator.observables(x)
        return np.concatenate([(model_values[q][i] - o) / u
                               for q, o, u, i in zip(names, obs, unc, index)])

    jac = "2-point"
    if backend == "drjit":
        def jac(x):
            cols = evaluator.jacobian_columns(x)
            return np.stack([np.concatenate([cols[p][q][i] / u for q, u, i in
                                             zip(names, unc, index)]) for p in layout.free], 1)

    lo, hi = layout.bounds()
    x0 = np.clip(layout.vector(), lo, hi)
    rng = np.random.default_rng(seed)
    t0 = time.perf_counter()
    best = None
    tol = 1e-10 if backend == "reference" else 1e-7   # float32 residuals: looser tolerances
    for start in range(max(int(starts), 1)):
        x_start = x0.copy()
        if start:
            for i, name in enumerate(layout.free):
                if name.partition("@")[0] in ("sigma", "n", "k", "sigma_dd"):
                    x_start[i] *= math.exp(rng.uniform(-math.log(2), math.log(2)))
            x_start = np.clip(x_start, lo + 1e-9, hi)
        sol = least_squares(residuals, x_start, jac=jac, bounds=(lo, hi), method="trf",
                            x_scale="jac", ftol=tol, xtol=tol, gtol=tol, max_nfev=400)
        if best is None or sol.cost < best.cost:
            best = sol
    seconds = time.perf_counter() - t0

    values = layout.unpack(best.x)
    chi2 = float(2 * best.cost)
    dof = n_obs - len(layout.free)
    J = best.jac
    try:
        cov = np.linalg.pinv(J.T @ J)
    except np.linalg.LinAlgError:
        cov = np.full((len(layout.free),) * 2, np.nan)
    if any(q not in data.uncertainty for q in names):
        cov = cov * chi2 / max(dof, 1)
    sd = np.sqrt(np.clip(np.diag(cov), 0, None))
    errors = {"n": np.full(len(wavelengths), np.nan), "k": np.full(len(wavelengths), np.nan)}
    errors.update({p: math.nan for p in SHARED})
    for name, s in zip(layout.free, sd):
        p, _, j = name.partition("@")
        if j:
            errors[p][int(j)] = s
        else:
            errors[p] = float(s)
    at_bound = [layout.label(n) for n, x, a, b in zip(layout.free, best.x, lo, hi)
                if x <= a * (1 + 1e-6) + 1e-12 or x >= b * (1 - 1e-6)]

    final = model_observables(data, values, shadowing, dd_distribution)
    resid, rms, rel = {}, {}, {}
    for q, y in data.observed.items():
        r = final[q] - y
        resid[q] = r
        ok = np.isfinite(y)
        rms[q] = float(np.sqrt(np.mean(r[ok] ** 2)))
        # relative error where the value is >= 1 % of the column's largest
        # (a goniometer's useful dynamic range; tiny values make ratios meaningless)
        pos = ok & (np.abs(y) >= 0.01 * np.nanmax(np.abs(y)))
        rel[q] = float(np.sqrt(np.mean((r[pos] / y[pos]) ** 2))) if pos.any() else math.nan
    return FitResult(model, backend, wavelengths, values, errors, chi2, dof, resid, rms, rel,
                     seconds, evaluator.count, bool(best.success), str(best.message),
                     [layout.label(n) for n in layout.free], at_bound, shadowing, dd_distribution)


def fit_models(data: Measurements, models=("three", "two"), **options) -> Dict[str, FitResult]:
    """:func:`fit_model` for each of ``models`` with the same options."""
    return {m: fit_model(data, model=m, **options) for m in models}


# ---------------------------------------------------------------------------
# Report and plot
# ---------------------------------------------------------------------------

def _fmt(v, e):
    if not np.isfinite(e):
        return f"{v:.5g} (fixed)"
    return f"{v:.5g} +/- {e:.2g}"


def report(data: Measurements, results: Dict[str, FitResult], truth: Optional[Dict] = None) -> str:
    """Text report: the data, then per model the parameters with standard
    uncertainties, chi-square and the RMS residual of each quantity, then the
    comparison of the models' errors."""
    lines = [f"# pBRDF fit of {data.source}",
             f"{len(data)} measurements, {data.count()} values "
             f"({', '.join(f'{q}: {np.isfinite(y).sum()}' for q, y in data.observed.items())}); "
             f"wavelengths {', '.join(f'{w:g}' for w in data.wavelengths)} nm; "
             f"uncertainties {'given' if data.uncertainty else 'assumed'}"]
    if data.ignored_columns:
        lines.append(f"ignored columns: {', '.join(data.ignored_columns)}")
    for name, r in results.items():
        lines += ["", f"## {MODELS[r.model]}",
                  f"backend {r.backend}, shadowing {r.shadowing}, directional diffuse "
                  f"{r.dd_distribution}; {r.evaluations} model evaluations, {r.seconds:.2f} s; "
                  f"{'converged' if r.success else 'NOT converged'} ({r.message})"]
        header = "| parameter | fitted | " + ("true |" if truth else "")
        lines += ["", header, "|---|---|" + ("---|" if truth else "")]
        for p in ("n", "k"):
            for j, w in enumerate(r.wavelengths):
                t = ""
                if truth:
                    tv = np.broadcast_to(truth[p], r.wavelengths.shape)[j]
                    t = f" {tv:.5g} |"
                lines.append(f"| {p} ({w:g} nm) | {_fmt(r.values[p][j], r.errors[p][j])} |{t}")
        for p in SHARED:
            if r.model == "two" and p in ("kdd", "sigma_dd"):
                continue
            t = f" {truth[p]:.5g} |" if truth else ""
            lines.append(f"| {p} | {_fmt(r.values[p], r.errors[p])} |{t}")
        if r.at_bound:
            lines.append(f"\nat a bound (uncertainty not meaningful): {', '.join(r.at_bound)}")
        lines += ["", f"chi2 = {r.chi2:.4g} for {r.dof} degrees of freedom "
                      f"(reduced {r.reduced_chi2:.3g})"]
        for q in data.observed:
            rel = (f", relative RMS {100 * r.relative_rms[q]:.2f} %"
                   if q == "m00" and np.isfinite(r.relative_rms[q]) else "")
            lines.append(f"* {q}: RMS residual {r.rms[q]:.4g}{rel}")
    if len(results) > 1:
        lines += ["", "## Model comparison", "",
                  "| model | reduced chi2 | " + " | ".join(
                      f"RMS {q}" + (" (relative)" if q == "m00" else "") for q in data.observed)
                  + " |", "|---|---|" + "---|" * len(data.observed)]
        for r in results.values():
            cells = [(f"{100 * r.relative_rms[q]:.2f} %" if q == "m00" else f"{r.rms[q]:.4g}")
                     for q in data.observed]
            lines.append(f"| {r.model}-component | {r.reduced_chi2:.3g} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def _series(data):
    """Groups of rows to draw as curves: (label, rows, x, in-plane?)."""
    ti, pi_, tr, pr = data.theta_i, data.phi_i, data.theta_r, data.phi_r
    dphi = np.radians(pr - pi_)
    in_plane = np.abs(np.sin(dphi)) < 1e-6
    signed = np.where(np.cos(dphi) < 0, tr, -tr)     # + on the specular side
    groups = []
    for w in data.wavelengths:
        for t in np.unique(ti):
            rows = np.flatnonzero((data.wavelength == w) & (ti == t) & in_plane)
            if rows.size:
                rows = rows[np.argsort(signed[rows])]
                groups.append((f"{t:g} deg, {w:g} nm", rows, signed[rows], True))
    rest = np.flatnonzero(~in_plane)
    if rest.size:
        groups.append(("out of plane", rest, None, False))
    return groups


def plot_fit(data: Measurements, results: Dict[str, FitResult], path, title=None):
    """Data (with error bars) and each model's fit, one panel per quantity:
    in-plane measurements against the signed detector angle (positive on the
    specular side), one curve per incidence angle and wavelength;
    out-of-plane ones in a panel of model against data."""
    import matplotlib
    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    quantities = list(data.observed)
    groups = _series(data)
    has_oop = any(not g[3] for g in groups)
    ncols = len(quantities) + (1 if has_oop else 0)
    fig = Figure(figsize=(5.0 * ncols, 4.2))
    axes = fig.subplots(1, ncols, squeeze=False)[0]
    names, _, unc, index = _weights(data, 0.05, 0.005)
    unc_full = {}
    for q, u, i in zip(names, unc, index):
        full = np.full(len(data), np.nan)
        full[i] = u
        unc_full[q] = full
    styles = {"three": "-", "two": "--"}
    colors = matplotlib.colormaps["tab10"]
    for ax, q in zip(axes, quantities):
        for g, (label, rows, x, in_plane) in enumerate(g for g in groups if g[3]):
            y = data.observed[q][rows]
            ok = np.isfinite(y)
            ax.errorbar(x[ok], y[ok], yerr=unc_full[q][rows][ok], fmt="o", ms=3,
                        color=colors(g % 10), label=f"data {label}", alpha=0.8)
            for m, r in results.items():
                fit = model_observables(data, r.values, r.shadowing, r.dd_distribution, [q])[q][rows]
                ax.plot(x, fit, styles.get(r.model, "-"), color=colors(g % 10), lw=1.2,
                        label=f"{r.model}-component" if g == 0 else None)
        ax.set_xlabel("detector angle theta_r (deg, + = specular side)")
        ax.set_ylabel(q + (" (1/sr)" if q != "dolp" else ""))
        if q == "m00":
            ax.set_yscale("log")
        ax.set_title(q)
        ax.legend(fontsize=6)
    if has_oop:
        ax = axes[-1]
        rows = next(g[1] for g in groups if not g[3])
        for m, r in results.items():
            for q in quantities:
                fit = model_observables(data, r.values, r.shadowing, r.dd_distribution, [q])[q][rows]
                y = data.observed[q][rows]
                scale = np.nanmax(np.abs(y)) or 1.0
                ax.plot(y / scale, fit / scale, "o" if r.model == "three" else "x", ms=3,
                        label=f"{q}, {r.model}-component")
        ax.plot([0, 1], [0, 1], "k:", lw=0.8)
        ax.set_xlabel("data / max")
        ax.set_ylabel("model / max")
        ax.set_title("out-of-plane measurements")
        ax.legend(fontsize=6)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    return path


# ---------------------------------------------------------------------------
# Command line
# ---------------------------------------------------------------------------

def _parser():
    p = argparse.ArgumentParser(
        prog="pbrdf-fit",
        description="Fit the three-component pBRDF (and the two-component one) to "
                    "measurements in a CSV file; see the module docstring for the format.")
    p.add_argument("csv", help="measurements: theta_i, phi_i, theta_r, phi_r (deg), "
                               "wavelength (nm), m00..m33 and/or dolp, optional <q>_err")
    p.add_argument("--model", choices=("three", "two", "both"), default="both")
    p.add_argument("--backend", choices=("reference", "drjit"), default="reference")
    p.add_argument("--material", help="start n, k from this tabulated conductor (e.g. Al, Cu)")
    p.add_argument("--init", default="", help="starting values, e.g. sigma=0.1,n=1.2")
    p.add_argument("--fix", default="", help="fixed values, e.g. n=1.2,k=7 or kid=0")
    p.add_argument("--shadowing", choices=("vgroove", "smith"), default="vgroove")
    p.add_argument("--dd-distribution", choices=("beckmann", "ggx"), default="beckmann")
    p.add_argument("--starts", type=int, default=3, help="number of starting points (default 3)")
    p.add_argument("--rel-uncertainty", type=float, default=0.05)
    p.add_argument("--abs-uncertainty", type=float, default=0.005)
    p.add_argument("--plot", help="write a PNG of fit versus data")
    p.add_argument("--json", help="write the results as JSON")
    return p


def main(argv: Optional[Sequence[str]] = None) -> int:
    args = _parser().parse_args(argv)
    try:
        data = read_measurements(args.csv)
        models = ("three", "two") if args.model == "both" else (args.model,)
        results = fit_models(data, models, backend=args.backend, shadowing=args.shadowing,
                             dd_distribution=args.dd_distribution, material=args.material,
                             init=args.init, fix=args.fix, starts=args.starts,
                             rel_uncertainty=args.rel_uncertainty,
                             abs_uncertainty=args.abs_uncertainty)
    except (MeasurementError, ValueError) as e:
        print(f"pbrdf-fit: error: {' '.join(str(e).split())}", file=sys.stderr)
        return 2
    print(report(data, results), end="")
    if args.plot:
        plot_fit(data, results, args.plot, title=os.path.basename(args.csv))
        print(f"\nplot: {args.plot}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({m: r.as_dict() for m, r in results.items()}, f, indent=1)
        print(f"results: {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
