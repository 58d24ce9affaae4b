"""The fitted parameters: names, defaults, bounds, and their layout as the
solver's vector (n and k per wavelength, the other parameters shared).

A refined parameter (``sigma``, refined by ``sigma_u`` and ``sigma_v``:
:data:`mitsuba_pbrdf.schema.REFINEMENTS`) is fitted alone, or, in an
anisotropic fit, replaced by its fitted refinements, which start from its
value; a value given for it (``--init sigma=0.2``, ``--fix sigma=0.2``) then
sets both, as in the plugin."""

from __future__ import annotations

import math

import numpy as np

from .. import schema
from ..choices import MODELS
from ..errors import ParameterError

__all__ = ["PER_WAVELENGTH", "SHARED", "ANISOTROPIC", "shared_names", "DEFAULTS", "BOUNDS",
           "SCALE_FLOORS", "PLUGIN_NAMES",
           "TWO_COMPONENT_FIXED", "LOBE_PARAMETERS", "absent_parameters", "parse_assignments",
           "ParameterVector"]

_FITTED = [p for p in schema.PARAMETERS if p.fit is not None]

#: Fitted per wavelength (n, k), by their names in fits.
PER_WAVELENGTH = tuple(p.fit.name or p.name for p in _FITTED if p.fit.per_wavelength)
#: Fitted once for all wavelengths.
SHARED = tuple(p.fit.name or p.name for p in _FITTED if not p.fit.per_wavelength)
#: Starting values, bounds (lower, upper) and uncertainty scale floors by fitted name.
DEFAULTS = {p.fit.name or p.name: p.fit.initial for p in _FITTED}
BOUNDS = {p.fit.name or p.name: (p.fit.lower, p.fit.upper) for p in _FITTED}
SCALE_FLOORS = {p.fit.name or p.name: p.fit.scale_floor for p in _FITTED if p.fit.scale_floor}
#: The plugin's (and the reference's) name of each fitted parameter: eta for n.
PLUGIN_NAMES = {p.fit.name or p.name: p.name for p in _FITTED}
#: Refined parameter -> its fitted refinements (``{"sigma": ("sigma_u", "sigma_v")}``).
ANISOTROPIC = {base: refs for base, refs in schema.REFINEMENTS.items()
               if base in SHARED and all(r in SHARED for r in refs)}


def shared_names(anisotropic=False):
    """The shared parameters of a fit: each refined parameter, or where
    *anisotropic* its refinements instead."""
    dropped = {r for refs in ANISOTROPIC.values() for r in refs}
    if anisotropic:
        dropped = set(ANISOTROPIC)
    return tuple(p for p in SHARED if p not in dropped)


#: What the two-component model fixes: the directional diffuse lobe's parameters (kdd = 0).
TWO_COMPONENT_FIXED = MODELS["two"].fixed
#: Each lobe's weight -> the fitted parameters that act through that lobe alone
#: (the index n, k through the specular lobe's Fresnel factor): with the
#: weight fixed at 0 the model has none of them.
LOBE_PARAMETERS = {
    weight: ((PER_WAVELENGTH if lobe == "specular" else ())
             + tuple(p.fit.name or p.name for p in _FITTED if p.lobe == lobe and p.role != "weight"))
    for lobe, (weight, _) in schema.LOBES.items() if weight in SHARED}


def absent_parameters(model, fix=None):
    """``{parameter: why the model lacks it}`` for *model* with the values
    *fix* holds: the two-component model's directional diffuse lobe (kdd = 0),
    and the parameters of a lobe whose weight is fixed at 0."""
    fix = fix or {}
    absent = {name: MODELS[model].why_fixed for name in MODELS[model].fixed}
    for weight, names in LOBE_PARAMETERS.items():
        if weight not in absent and fix.get(weight) == 0:
            absent.update({name: f"{weight} is fixed at 0, so its lobe is off" for name in names
                           if name not in absent})
    return absent


def parse_assignments(text, what):
    """'a=1,b=2' or a dict -> dict (values float), each value finite and within
    the parameter's bounds (:data:`BOUNDS`); errors name ``what`` (the option)."""
    if not text:
        return {}
    if isinstance(text, dict):
        items = [(str(k), v) for k, v in text.items()]
    else:
        items = []
        for item in str(text).split(","):
            key, sep, value = item.partition("=")
            if not sep or not key.strip():
                raise ValueError(f"{what}: expected name=value, got {item!r}")
            items.append((key.strip(), value))
    out = {}
    for key, value in items:
        try:
            v = float(value)
        except (TypeError, ValueError):
            raise ValueError(f"{what}: {key}={value!r} is not a number") from None
        lo, hi = BOUNDS.get(key.partition("@")[0], (-math.inf, math.inf))
        if not (math.isfinite(v) and lo <= v <= hi):
            raise ValueError(f"{what}: {key}={v:g} is outside the allowed range "
                             f"[{lo:g}, {hi:g}]")
        out[key] = v
    return out


class ParameterVector:
    """Maps the free parameters to a vector and back."""

    def __init__(self, wavelengths, model, init, fix, anisotropic=False):
        self.wavelengths = np.asarray(wavelengths, dtype=np.float64)
        self.anisotropic = bool(anisotropic)
        self.shared = shared_names(self.anisotropic)
        W = len(self.wavelengths)
        self.values = {p: np.full(W, DEFAULTS[p]) for p in PER_WAVELENGTH}
        self.values.update({p: float(DEFAULTS[p]) for p in self.shared})
        for base, refs in ANISOTROPIC.items():       # refinements start from their base
            if self.anisotropic:
                self.values.update({r: float(DEFAULTS[base]) for r in refs})
        init, fix = (self._refined(source) for source in (init, fix))
        self.fixed = set()
        #: parameters the model lacks (:func:`absent_parameters`): neither fitted nor reported
        self.absent = absent_parameters(model, fix)
        off = MODELS[model].fixed
        if off:
            self.values[off[0]] = 0.0       # the lobe's weight
            self.fixed |= set(off)
        for source, is_fix in ((init, False), (fix, True)):
            for key, v in source.items():
                name, _, at = key.partition("@")
                if name not in PER_WAVELENGTH + SHARED:
                    raise ParameterError("fix" if is_fix else "init",
                                         f"unknown parameter {name!r}; parameters: "
                                         f"{', '.join(PER_WAVELENGTH + SHARED)} "
                                         f"(n@<nm>, k@<nm> for one wavelength)")
                if name in self.absent:
                    raise ParameterError("fix" if is_fix else "init",
                                         f"{key}: the {model}-component model has no {name} "
                                         f"({self.absent[name]})")
                if name in PER_WAVELENGTH:
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
                    self.values[name] = float(v)
                    if is_fix:
                        self.fixed.add(name)
        self.fixed |= {f"{p}@{j}" for p in PER_WAVELENGTH if p in self.absent for j in range(W)}
        self.fixed |= set(self.absent) & set(self.shared)
        self.free = [f"{p}@{j}" for p in PER_WAVELENGTH for j in range(W)
                     if f"{p}@{j}" not in self.fixed]
        self.free += [p for p in self.shared if p not in self.fixed]
        if not self.free:
            raise ParameterError("fix", "every parameter of the model is fixed: nothing to fit")

    def _refined(self, assignments):
        """*assignments* with a refined parameter's value given to each of its
        refinements in an anisotropic fit; a refinement named in an isotropic
        fit is an error."""
        out = {}
        for key, v in assignments.items():
            if key in ANISOTROPIC and self.anisotropic:
                out.update({r: v for r in ANISOTROPIC[key]})
                continue
            base = next((b for b, refs in ANISOTROPIC.items() if key in refs), None)
            if base and not self.anisotropic:
                raise ValueError(f"{key} is fitted only in an anisotropic fit (anisotropic=True, "
                                 f"pbrdf fit --anisotropic); an isotropic fit has {base}")
            out[key] = v
        return out

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
        """The model's values, {name: value or per-wavelength array}, the free
        ones taken from *x* (in the order of ``free``)."""
        values = {p: self.values[p].copy() for p in PER_WAVELENGTH}
        values.update({p: self.values[p] for p in self.shared})
        return self.place(x, values)

    def place(self, x, into):
        """*into* ({name: value or per-wavelength array}) with each free
        parameter's entry set from *x* (in the order of ``free``)."""
        for name, v in zip(self.free, x):
            p, _, j = name.partition("@")
            if j:
                into[p][int(j)] = v
            else:
                into[p] = float(v)
        return into
