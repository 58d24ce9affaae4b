"""Numerical robustness: extreme directions and parameters give finite,
physical values (a seeded stress test; validation/ may run a longer one).

Directions: cos(theta) log-uniform down to 1e-7, exact normal incidence, exact
retro-reflection and exact mirror pairs (the Mueller-rotation singularities),
nearly opposite grazing pairs (where float rounding makes cos(beta) <= 0), and
directions below the horizon. Parameters: sigma 1e-4..2, sigma_dd 1e-3..5,
k = 0 (dielectric), k = 100, n < 1, index-matched n = 1.
"""

import itertools

import mitsuba as mi
import numpy as np
import pytest

from bsdf_harness import as_numpy, make_si, to_vector

N = 20_000


def stress_directions(rng):
    def hemisphere(n):
        cos = np.exp(rng.uniform(np.log(1e-7), 0.0, n))
        sin = np.sqrt(1 - cos * cos)
        phi = rng.uniform(0, 2 * np.pi, n)
        return np.stack([sin * np.cos(phi), sin * np.sin(phi), cos], axis=1)

    wi, wo = hemisphere(N), hemisphere(N)
    wi[:500] = wo[:500] = [0.0, 0.0, 1.0]            # normal incidence and exit
    wo[500:1000] = wi[500:1000]                       # retro-reflection
    wo[1000:1500] = wi[1000:1500] * [-1, -1, 1]       # exact mirror direction
    wo[1500:2000] = -wi[1500:2000] * [1, 1, -1] + [1e-4, 0, 0]   # nearly opposite, grazing
    wo[1500:2000] /= np.linalg.norm(wo[1500:2000], axis=1, keepdims=True)
    below = np.zeros(N, dtype=bool)
    below[2000:2500] = True
    wo[2000:2500] *= [1, 1, -1]                       # light below the horizon
    below[2500:3000] = True
    wi[2500:3000] *= [1, 1, -1]                       # viewer below the horizon
    return wi, wo, below


IORS = [(1.2, 7.0), (1.5, 0.0), (0.3, 0.0), (0.5, 0.1), (2.0, 100.0), (1.0, 0.0)]
ROUGHNESS = [(1e-4, 1e-3), (0.3, 0.5), (2.0, 5.0)]


@pytest.mark.parametrize("eta,k", IORS)
@pytest.mark.slow
def test_extreme_inputs_give_finite_physical_values(eta, k):
    rng = np.random.default_rng(int(eta * 100 + k))
    wi, wo, below = stress_directions(rng)
    si, w = make_si(wi), to_vector(wo)
    for (sigma, sigma_dd), dd, shadowing in itertools.product(
            ROUGHNESS, ("beckmann", "ggx"), ("vgroove", "smith")):
        bsdf = mi.load_dict({"type": "pbrdf", "eta": eta, "k": k, "sigma": sigma, "kdd": 0.5,
                             "sigma_dd": sigma_dd, "kid": 0.2, "dd_distribution": dd,
                             "shadowing": shadowing})
        for mode in (mi.TransportMode.Radiance, mi.TransportMode.Importance):
            ctx = mi.BSDFContext(mode)
            label = f"sigma={sigma} sigma_dd={sigma_dd} {dd} {shadowing} {mode}"
            value, pdf = (as_numpy(x) for x in bsdf.eval_pdf(ctx, si, w))
            assert np.all(np.isfinite(value)) and np.all(np.isfinite(pdf)), label
            assert np.all(pdf >= 0), label
            m00 = value[..., :1, :1]
            assert np.all(m00 >= 0), label
            # A physical Mueller matrix never has |M_ij| > M00 (float32 slack).
            assert np.all(np.abs(value) <= m00 * (1 + 1e-4) + 1e-30), label
            assert np.all(value[below] == 0) and np.all(pdf[below] == 0), label

            bs, weight = bsdf.sample(ctx, si, mi.Float(rng.random(N).astype(np.float32)),
                                     mi.Point2f(*rng.random((2, N)).astype(np.float32)))
            weight, bs_pdf = as_numpy(weight), as_numpy(bs.pdf)
            assert np.all(np.isfinite(weight)) and np.all(np.isfinite(bs_pdf)), label
            assert np.all(weight[..., 0, 0] >= 0) and np.all(bs_pdf >= 0), label
            assert np.all(weight[wi[:, 2] <= 0] == 0), label


def test_normal_incidence_reflectance_is_fresnel():
    """Exact normal incidence and exit on a nearly flat surface: M00 / D(0)
    equals the Fresnel reflectance ((n-1)^2 + k^2)/((n+1)^2 + k^2) and the
    matrix is R diag(1, 1, -1, -1) up to the frame rotation of S1/S2: M33 =
    -R D0 / 4 with its sign (reflection reverses the handedness of circular
    polarization; r_p = -r_s at normal incidence), which no rotation of S1/S2
    changes."""
    eta, k, sigma = 1.2, 7.0, 0.05
    alpha = np.sqrt(2) * sigma
    bsdf = mi.load_dict({"type": "pbrdf", "eta": eta, "k": k, "sigma": sigma})
    up = [[0.0, 0.0, 1.0]]
    value = as_numpy(bsdf.eval(mi.BSDFContext(), make_si(up), to_vector(up)))[0, 0]
    D0 = 1.0 / (np.pi * alpha**2)   # Beckmann D at h = n; G = 1; f = D F / 4, times cos = 1
    R = ((eta - 1) ** 2 + k**2) / ((eta + 1) ** 2 + k**2)
    np.testing.assert_allclose(value[0, 0], D0 * R / 4, rtol=1e-5)
    np.testing.assert_allclose(value[3, 3], -D0 * R / 4, rtol=1e-5)
    np.testing.assert_allclose(value[1:3, 1:3] @ value[1:3, 1:3].T / (D0 * R / 4) ** 2,
                               np.eye(2), atol=1e-5)
