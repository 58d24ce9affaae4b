"""Where the optimizer starts, and the order of the two microfacet lobes.

**Starts.** Real metals show a near-mirror spike, a glossy lobe or a broad
tail, and a least-squares fit finds the lobe nearest its start. The fit
therefore starts from the initial values (``--init``, the material's index)
and from a grid of roughness scales per lobe: the specular width at
:data:`SIGMA_STARTS` and, in the three-component model, the directional
diffuse width at :data:`WIDTH_RATIOS` times it. More starts than that add
random perturbations of the initial values (widths and indices by up to x2).

**Lobe order.** The specular lobe is the narrower one: the directional
diffuse width is fitted as its ratio to the specular width, bounded below by
1 (:class:`WidthOrder`), so that two starts cannot find the same optimum with
the lobes' labels traded. The ratio is internal to the optimizer: results and
uncertainties are given in ``sigma`` and ``sigma_dd``. Anisotropic fits and
fits that fix either width are not ordered.
"""

from __future__ import annotations

import math

import numpy as np

from .vector import SCALE_FLOORS

__all__ = ["SIGMA_STARTS", "WIDTH_RATIOS", "start_points", "default_starts", "WidthOrder"]

#: Specular widths of the default starts: a near-mirror spike, a glossy and a rough lobe.
SIGMA_STARTS = (0.01, 0.05, 0.2)
#: The directional diffuse width over the specular one at the default starts.
WIDTH_RATIOS = (3.0, 10.0)
SPECULAR_WIDTHS = ("sigma", "sigma_u", "sigma_v")


def _grid(layout, x0, lo, hi):
    free = layout.free
    widths = [free.index(w) for w in SPECULAR_WIDTHS if w in free]
    dd = free.index("sigma_dd") if "sigma_dd" in free else None
    if not widths and dd is None:
        return []
    points = []
    for sigma in SIGMA_STARTS:
        for ratio in (WIDTH_RATIOS if dd is not None else (None,)):
            x = x0.copy()
            for i in widths:
                x[i] = sigma
            if ratio is not None:
                x[dd] = (sigma if widths else layout.values.get("sigma", sigma)) * ratio
            x = np.clip(x, lo, hi)
            if not any(np.allclose(x, p) for p in points + [x0]):
                points.append(x)
    return points


def default_starts(layout, x0, lo, hi) -> int:
    """The number of starts when none is asked for: the initial values and the grid."""
    return 1 + len(_grid(layout, x0, lo, hi))


def start_points(layout, x0, lo, hi, count, rng):
    """*count* starting vectors: *x0*, the roughness grid, then random
    perturbations of *x0* (widths and indices by a factor up to 2)."""
    points = [x0.copy()] + _grid(layout, x0, lo, hi)
    while len(points) < count:
        x = x0.copy()
        for i, name in enumerate(layout.free):
            if name.partition("@")[0] in SCALE_FLOORS:            # indices and widths
                x[i] *= math.exp(rng.uniform(-math.log(2), math.log(2)))
        points.append(np.clip(x, lo + 1e-9, hi))
    return points[:count]


class WidthOrder:
    """``sigma_dd >= sigma``: the optimizer's vector holds ``sigma_dd / sigma``
    (bounded below by 1) where the natural one holds ``sigma_dd``."""

    def __init__(self, layout, lo, hi):
        free = layout.free
        self.active = ("sigma_dd" in free and "sigma" in free and not layout.anisotropic)
        if self.active:
            self.dd, self.sigma = free.index("sigma_dd"), free.index("sigma")
            self.dd_upper = float(hi[self.dd])
            self.lo, self.hi = lo.copy(), hi.copy()
            self.lo[self.dd] = 1.0
            self.hi[self.dd] = self.dd_upper / lo[self.sigma]
        else:
            self.lo, self.hi = lo, hi

    def to_internal(self, x):
        z = np.array(x, dtype=np.float64)
        if self.active:
            z[self.dd] = x[self.dd] / x[self.sigma]
        return np.clip(z, self.lo, self.hi)

    def to_natural(self, z):
        x = np.array(z, dtype=np.float64)
        if self.active:
            x[self.dd] = min(z[self.dd] * z[self.sigma], self.dd_upper)
        return x

    def jacobian(self, J, z):
        """The Jacobian in the optimizer's vector from *J* in the natural one."""
        if not self.active:
            return J
        J = J.copy()
        d_dd = J[:, self.dd].copy()
        J[:, self.dd] = d_dd * z[self.sigma]
        J[:, self.sigma] += d_dd * z[self.dd]
        return J

    def at_bound(self, z) -> bool:
        """Whether the fit ended with the two widths equal (the order's bound)."""
        return self.active and z[self.dd] <= 1.0 + 1e-6
