"""A record of the model's parameters as the plugin takes them, with its
checks, and quantities derived from a Mueller BRDF. NumPy only.
"""

from __future__ import annotations

import math
from dataclasses import field, make_dataclass
from typing import Any

import numpy as np

from ..schema import PARAMETERS
from .materials import available_materials, conductor_ior
from .model import pbrdf


class _ParamsMethods:
    """What a :class:`PBRDFParams` can do; its fields come from the schema."""

    def validate(self) -> "PBRDFParams":
        """Check every parameter against its declaration; returns self."""
        if (self.eta is None) != (self.k is None):
            raise ValueError("give both eta and k (the complex index n + ik), or neither")
        if self.eta is not None:
            self.material = None
        elif self.material is None:
            raise ValueError("give a material (e.g. Cu) or eta and k")
        elif self.material not in available_materials():
            raise ValueError(
                f"unknown material {self.material!r}; available: "
                f"{', '.join(available_materials())}"
            )
        for p in PARAMETERS:
            value = getattr(self, p.name, None) if p.reference else None
            if p.kind in ("float", "spectrum") and value is not None:
                _finite(p.name, value, positive=p.positive)
            elif p.kind == "choice" and p.reference and value not in p.choices:
                raise ValueError(f"{p.name} must be one of {', '.join(p.choices)}, "
                                 f"got {value!r}")
        return self

    def ior(self, wavelengths_nm):
        """``(n, k)`` arrays at the wavelengths (nm)."""
        wavelengths = np.asarray(wavelengths_nm, dtype=np.float64)
        if self.eta is not None:          # an explicit n + ik wins over the default material
            return (np.full(wavelengths.shape, float(self.eta)),
                    np.full(wavelengths.shape, float(self.k)))
        return conductor_ior(self.material, wavelengths)

    def label(self) -> str:
        """A one-line description for titles."""
        what = f"n={self.eta:g}, k={self.k:g}" if self.eta is not None else self.material
        sigma = f"σ={self.sigma:g}"
        if self.sigma_u is not None or self.sigma_v is not None:
            u = self.sigma if self.sigma_u is None else self.sigma_u
            v = self.sigma if self.sigma_v is None else self.sigma_v
            sigma = f"σu={u:g}, σv={v:g}"
        parts = [what, sigma + (", GGX" if self.distribution == "ggx" else ""), f"ks={self.ks:g}"]
        if self.kdd:
            width = f"σdd={self.sigma_dd:g}"
            if self.sigma_dd_u is not None or self.sigma_dd_v is not None:
                u = self.sigma_dd if self.sigma_dd_u is None else self.sigma_dd_u
                v = self.sigma_dd if self.sigma_dd_v is None else self.sigma_dd_v
                width = f"σdd_u={u:g}, σdd_v={v:g}"
            parts.append(f"kdd={self.kdd:g} ({width}, {self.dd_distribution})")
        if self.kid:
            parts.append(f"kid={self.kid:g}")
        parts.append(f"G={self.shadowing}")
        return ", ".join(parts)

    def evaluate(self, theta_i, phi_i, theta_r, phi_r, wavelengths_nm, lobe="all"):
        """Mueller BRDF (..., n_wavelengths, 4, 4) in 1/sr of one *lobe*
        (``all``, ``specular``, ``directional_diffuse``, ``ideal_diffuse``), with
        its weight; angles in radians, shaped (...,) (a wavelength axis is added)."""
        n, k = self.ior(wavelengths_nm)
        angles = [np.asarray(a, dtype=np.float64)[..., None]
                  for a in (theta_i, phi_i, theta_r, phi_r)]
        weights = dict(ks=self.ks, kdd=self.kdd, kid=self.kid)
        if lobe == "specular":
            weights.update(kdd=0.0, kid=0.0)
        elif lobe == "directional_diffuse":
            weights.update(ks=0.0, kid=0.0)
        elif lobe == "ideal_diffuse":
            weights.update(ks=0.0, kdd=0.0)
        elif lobe != "all":
            raise ValueError(f"unknown lobe {lobe!r}")
        # every other parameter the model function takes, by its schema name
        shape = {p.name: getattr(self, p.name) for p in PARAMETERS
                 if p.reference and p.name not in ("material", "eta", "k", "sigma", "ks", "kdd",
                                                    "kid")}
        with np.errstate(invalid="ignore", divide="ignore"):
            return pbrdf(*angles, n, k, self.sigma, **shape, **weights)


#: Parameters of the model, as the plugin takes them: one field per parameter
#: of :data:`mitsuba_pbrdf.PARAMETERS` that the reference takes, with
#: its default (``eta``, ``k``: None, meaning "from the material").
#: Either *material* (a Mitsuba conductor name: ``Al``, ``Cu``, ``Au``, ``Ag``,
#: ...) or both *eta* and *k* (a complex index n + ik, constant over
#: wavelength). :meth:`validate` checks them and raises ``ValueError`` naming
#: the parameter.
PBRDFParams = make_dataclass(
    "PBRDFParams",
    [(p.name, Any, field(default=p.default)) for p in PARAMETERS if p.reference],
    bases=(_ParamsMethods,), namespace={"__module__": __name__})
PBRDFParams.__doc__ = ("Parameters of the model, as the plugin takes them (table: "
                       "``docs/plugin.md``; declared in :mod:`mitsuba_pbrdf.schema`).")


def _finite(name, value, positive=False):
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(value) or value < 0 or (positive and value == 0):
        raise ValueError(f"{name} must be {'> 0' if positive else '>= 0'} and finite, "
                         f"got {value:g}")


def check_theta_i(theta_i):
    if not (0.0 <= float(theta_i) < 90.0):
        raise ValueError(f"theta_i must be in [0, 90) degrees, got {theta_i:g}")


def dop_unpolarized(M, eps: float = 1e-300) -> np.ndarray:
    """Degree of polarization of the light M (..., 4, 4) reflects when the
    incident light is unpolarized: |first column without M00| / M00 (0 where
    M00 = 0)."""
    M = np.asarray(M)
    m00 = M[..., 0, 0]
    polar = np.sqrt(M[..., 1, 0] ** 2 + M[..., 2, 0] ** 2 + M[..., 3, 0] ** 2)
    out = np.zeros_like(m00)
    np.divide(polar, m00, out=out, where=m00 > eps)
    return out
