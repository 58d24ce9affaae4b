"""The fitted parameters: names, defaults, bounds, and their layout as the
solver's vector (n and k per wavelength, the other parameters shared)."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["SHARED", "DEFAULTS", "BOUNDS", "MODELS", "parse_assignments", "ParameterLayout"]

SHARED = ("sigma", "ks", "kdd", "sigma_dd", "kid")
DEFAULTS = dict(n=1.5, k=5.0, sigma=0.15, ks=1.0, kdd=0.1, sigma_dd=0.5, kid=0.01)
BOUNDS = dict(n=(0.01, 20.0), k=(0.0, 40.0), sigma=(1e-3, 2.0), ks=(0.0, 20.0),
              kdd=(0.0, 20.0), sigma_dd=(1e-3, 5.0), kid=(0.0, 10.0))
MODELS = {"three": "three-component (specular + directional diffuse + ideal diffuse)",
          "two": "two-component (specular + ideal diffuse, kdd = 0)"}


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


class ParameterLayout:
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
