"""Which fitted parameters the data determine, and honest uncertainties for
those that they do.

The weighted Jacobian ``J`` (residuals divided by their uncertainties, one
column per free parameter) is scaled column by column to each parameter's
*scale* (its value, with a floor: see :func:`parameter_scales`), giving
``Jn``. A singular value ``s`` of ``Jn`` with right singular vector ``v``
means that moving the parameters by ``v`` times their scales (a 100 % change)
changes chi-square by ``s^2``. Where ``s < 1`` (times the square root of the
reduced chi-square when the uncertainties are assumed) the data cannot pin
that combination to better than 100 % of the parameters' sizes: the
parameters with a component larger than :data:`GROUP_SHARE` in ``v`` are
**undetermined**. Their uncertainties are reported as undetermined (``None``
in JSON, never a small +/- from a pseudo-inverse, which silently drops the
direction) and the groups of parameters that move together are listed as
``correlated``. A DoLP-only fit, for instance, leaves the common scale of
ks, kdd and kid free (an exact null direction); an M00-only fit can trade n
against k and ks.

A parameter with a smaller share is undetermined too where that direction
alone moves it by 100 % of its scale or more (``|v_j| / s >= 1``). The other
parameters' standard uncertainties are the square roots of the diagonal of
``(Jn^T Jn)^-1`` over every direction that is not numerically null (weak
ones included: the marginal uncertainty, not the one conditional on the
undetermined parameters' fitted values), scaled back to the parameters'
units. A parameter of an M00-only fit that shares a weak direction with the
undetermined indices (ks, n at another wavelength) gets the wider +/- that
this trade allows.

The Jacobian must be that of residuals in units of the data's noise: for
the weighting objectives (``cosine``, ``log-cosine``, whose chi-square is not
one of noise) the fit passes that of the linear residuals ``(m - y) / u`` at
its optimum, and *chi2* (chi-square in those units at a parameter vector):
each direction is probed one standard uncertainty either way: if
chi-square there departs from the quadratic model by more than a factor
:data:`NONLINEAR` (a curved valley, as n against k of one incidence's M00),
the linear +/- does not hold and the direction's parameters are undetermined.
(The likelihood objectives are not probed yet: a linear fit of the same data
can still report a straight-line +/- along such a valley.)
"""

from __future__ import annotations

import numpy as np

from .. import schema
from .vector import SCALE_FLOORS

#: The lobe weights (ks, kdd, kid): measured against each other.
LOBE_WEIGHTS = tuple(weight for weight, _ in schema.LOBES.values())

__all__ = ["GROUP_SHARE", "parameter_scales", "analyze"]

#: Share of an undetermined direction (component of the unit singular vector)
#: above which a parameter belongs to its group.
GROUP_SHARE = 0.1
#: A direction whose chi-square one standard uncertainty away is off the
#: quadratic model's by more than this factor is nonlinear (undetermined).
NONLINEAR = 2.0


def parameter_scales(names, x):
    """A scale per free parameter: ``|x|`` with a floor of 0.1 for n and k,
    1e-3 for the roughnesses and 1 % of the largest lobe weight for ks, kdd
    and kid (a weight at 0 is still measured against the others)."""
    x = np.abs(np.asarray(x, dtype=np.float64))
    base = [n.partition("@")[0] for n in names]
    weights = [v for b, v in zip(base, x) if b in LOBE_WEIGHTS]
    weight_floor = 0.01 * max(weights) if weights and max(weights) > 0 else 1e-3
    return np.array([max(v, SCALE_FLOORS.get(b, weight_floor)) for b, v in zip(base, x)])


def analyze(J, names, x, chi2_scale=1.0, with_covariance=False, chi2=None):
    """``(sd, undetermined, groups)`` for a weighted Jacobian ``J`` (residuals x
    parameters) at ``x``: standard uncertainties (``inf`` for undetermined
    parameters), the undetermined parameters' names, and the groups (lists of
    names) of parameters that move together in undetermined directions.
    ``chi2_scale``: the reduced chi-square when the uncertainties are assumed
    (then scaled to the fit), else 1. ``with_covariance``: also return the
    marginal covariance matrix (parameters' units; see the module)."""
    names = list(names)
    J = np.asarray(J, dtype=np.float64)
    scales = parameter_scales(names, x)
    if not names:
        return (np.zeros(0), [], []) + ((np.zeros((0, 0)),) if with_covariance else ())
    if not np.all(np.isfinite(J)):
        return (np.full(len(names), np.inf), names, [names]) + (
            (np.full((len(names),) * 2, np.inf),) if with_covariance else ())
    Jn = J * scales[None, :]
    _, s, Vt = np.linalg.svd(Jn, full_matrices=False)
    s = np.concatenate([s, np.zeros(len(names) - s.size)])       # fewer residuals than parameters
    if Vt.shape[0] < len(names):
        Vt = np.linalg.svd(np.vstack([Jn, np.zeros((len(names) - Jn.shape[0], len(names)))]))[2]
    # below 1 (in units of the fit's noise) or numerically zero (finite-
    # difference Jacobians carry relative errors of ~1e-8)
    null = s <= 1e-6 * s.max()
    weak = (s < np.sqrt(chi2_scale)) | null
    if chi2 is not None:
        x = np.asarray(x, dtype=np.float64)
        c0 = chi2(x)
        for i in np.flatnonzero(~weak):
            d = Vt[i] * scales * np.sqrt(chi2_scale) / s[i]
            rise = (chi2(x + d) + chi2(x - d)) / 2 - c0     # quadratic model: chi2_scale
            weak[i] = not (chi2_scale / NONLINEAR <= rise <= chi2_scale * NONLINEAR)
    # a weak direction moves a parameter by |v_j| sqrt(chi2_scale) / s of its
    # scale per unit of chi-square: by 100 % or more, it is undetermined even
    # below GROUP_SHARE (a small share of a nearly flat direction)
    reach = np.abs(Vt) * np.sqrt(chi2_scale) / np.where(null, 1.0, s)[:, None]
    groups = []
    for v, r, n0 in zip(Vt[weak], reach[weak], null[weak]):
        members = {names[j] for j in np.flatnonzero((np.abs(v) > GROUP_SHARE)
                                                     | (~n0 & (r >= 1.0)))}
        merged = [g for g in groups if g & members]
        for g in merged:
            groups.remove(g)
            members |= g
        groups.append(members)
    undetermined = sorted(set().union(*groups), key=names.index) if groups else []
    # the marginal covariance: every direction but the numerically null ones.
    # Leaving out the weak ones too would give the uncertainty of each
    # parameter with the undetermined ones held at their fitted values, a +/-
    # far smaller than the data support wherever it shares a weak direction
    live = ~null
    cov = (Vt[live].T / s[live] ** 2) @ Vt[live] * chi2_scale
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None)) * scales
    sd[[names.index(n) for n in undetermined]] = np.inf
    groups = [sorted(g, key=names.index) for g in groups]
    if with_covariance:
        return sd, undetermined, groups, cov * scales[:, None] * scales[None, :]
    return sd, undetermined, groups
