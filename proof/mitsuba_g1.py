"""Mitsuba's own Beckmann Smith G1, the rational approximation ``roughconductor``
uses: the oracles that compare with roughconductor divide it out (its pdf is
off the exact visible-normal density by -0.29 % to +0.31 %)."""

import numpy as np


def mitsuba_beckmann_G1(cos_theta, alpha):
    """The rational approximation of the Beckmann Smith G1 that Mitsuba 3.9 uses
    (microfacet.h: "< 0.35% rel. error")."""
    tan = np.sqrt(1 - cos_theta**2) / cos_theta
    with np.errstate(divide="ignore", invalid="ignore"):
        a = 1 / (alpha * tan)
        G1 = np.where(a >= 1.6, 1.0, (3.535 * a + 2.181 * a * a) / (1 + 2.276 * a + 2.577 * a * a))
    return np.where(tan == 0, 1.0, G1)
