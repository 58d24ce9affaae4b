"""Stokes-basis rotations without trigonometry (mitsuba_pbrdf/mueller.py)
against Mitsuba's own ``mueller.rotate_mueller_basis`` and
``SurfaceInteraction3f.to_world_mueller``.

Oracle: Mitsuba 3.9.1's functions, same convention (rotation angle measured
counter-clockwise about the propagation direction). Both compute in float32;
Mitsuba goes through ``asin`` and ``sincos(2θ)``, these through dot and cross
products, so the rotator entries (in [-1, 1]) differ by rounding: a few ulps
of 1 (6e-8) per operation, about ten operations deep. With Mueller entries in
[-1, 1], a product entry sums 4 such terms: asserted 2e-6 absolute (about 30
ulps of 1). Measured largest differences: 9.5e-7 (rotate_mueller_basis) and
8.3e-7 (to_world_mueller), in both variants.
"""

import math

import drjit as dr
import mitsuba as mi
import numpy as np
import pytest

from mitsuba_pbrdf import use_variant


@pytest.fixture(params=["llvm_ad_spectral_polarized", "llvm_ad_mono_polarized"])
def polarized(request):
    use_variant(request.param)
    yield
    use_variant("llvm_ad_spectral_polarized")


def _unit(rng, n):
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _vectors(a):
    return mi.Vector3f(*[mi.Float(a[:, i]) for i in range(3)])


def _basis_pairs(forward, angles, rng):
    """Unit vectors ``current`` orthogonal to ``forward``, and ``target`` that
    one turned by ``angles`` (radians) counter-clockwise about ``forward``."""
    seed = _unit(rng, len(forward))
    current = seed - np.sum(seed * forward, axis=1, keepdims=True) * forward
    current /= np.linalg.norm(current, axis=1, keepdims=True)
    other = np.cross(forward, current)
    target = np.cos(angles)[:, None] * current + np.sin(angles)[:, None] * other
    return current, target


def _random_mueller(rng, n):
    m = dr.zeros(mi.Spectrum, n)
    for i in range(4):
        for j in range(4):
            m[i, j] = mi.UnpolarizedSpectrum(mi.Float(rng.uniform(-1, 1, n)))
    return m


def _entries(m):
    return np.array([[np.array(m[i, j], dtype=np.float64) for j in range(4)]
                     for i in range(4)])


# angles that matter: none, tiny, right angles, half turn, either sign, random
SPECIAL = np.array([0.0, 1e-6, -1e-6, 1e-3, math.pi / 2, -math.pi / 2, math.pi, -math.pi,
                    math.pi / 4, 3 * math.pi / 4, math.pi - 1e-4])


def test_rotate_mueller_basis_matches_mitsubas(polarized):
    from mitsuba_pbrdf import mueller

    rng = np.random.default_rng(3)
    n = 4096
    angles_in = np.concatenate([SPECIAL, rng.uniform(-math.pi, math.pi, n - len(SPECIAL))])
    angles_out = rng.permutation(angles_in)
    f_in, f_out = _unit(rng, n), _unit(rng, n)
    cur_in, tgt_in = _basis_pairs(f_in, angles_in, rng)
    cur_out, tgt_out = _basis_pairs(f_out, angles_out, rng)
    m = _random_mueller(rng, n)
    args = (m, _vectors(f_in), _vectors(cur_in), _vectors(tgt_in),
            _vectors(f_out), _vectors(cur_out), _vectors(tgt_out))
    ours = _entries(mueller.rotate_mueller_basis(*args))
    theirs = _entries(mi.mueller.rotate_mueller_basis(*args))
    worst = np.max(np.abs(ours - theirs))
    assert worst < 2e-6, f"largest difference {worst:.3g}"


def test_to_world_mueller_matches_mitsubas(polarized):
    from mitsuba_pbrdf import mueller

    rng = np.random.default_rng(5)
    n = 4096
    si = dr.zeros(mi.SurfaceInteraction3f, n)
    normals = _unit(rng, n)
    si.sh_frame = mi.Frame3f(_vectors(normals))
    # directions everywhere on the sphere, and along the frame's axes and poles
    wo, wi = _unit(rng, n), _unit(rng, n)
    axes = np.array([[0, 0, 1], [0, 0, -1], [1, 0, 0], [0, 1, 0], [0, -1, 0]], float)
    wo[:len(axes)], wi[:len(axes)] = axes, axes[::-1]
    m = _random_mueller(rng, n)
    ours = _entries(mueller.to_world_mueller(si, m, _vectors(wo), _vectors(wi)))
    theirs = _entries(si.to_world_mueller(m, _vectors(wo), _vectors(wi)))
    worst = np.max(np.abs(ours - theirs))
    assert worst < 2e-6, f"largest difference {worst:.3g}"


def test_rotator_entries_are_the_double_angle():
    """cos 2θ, sin 2θ for known angles θ, and a finite derivative at θ = 0
    (where the angle Mitsuba measures, 2 asin(|a - b| / 2), has none)."""
    from mitsuba_pbrdf import mueller

    rng = np.random.default_rng(7)
    angles = np.concatenate([SPECIAL, rng.uniform(-math.pi, math.pi, 1000)])
    forward = _unit(rng, len(angles))
    current, target = _basis_pairs(forward, angles, rng)
    c2, s2 = mueller.rotator_entries(_vectors(forward), _vectors(current), _vectors(target))
    assert np.allclose(np.array(c2), np.cos(2 * angles), atol=1e-6)
    assert np.allclose(np.array(s2), np.sin(2 * angles), atol=1e-6)

    # d(sin 2θ)/dθ = 2 at θ = 0: turn the target by a differentiated angle t
    t = mi.Float(0.0)
    dr.enable_grad(t)
    f = mi.Vector3f(0.0, 0.0, 1.0)
    a = mi.Vector3f(1.0, 0.0, 0.0)
    b = mi.Vector3f(dr.cos(t), dr.sin(t), 0.0)
    _, s = mueller.rotator_entries(f, a, b)
    dr.forward(t)
    assert dr.allclose(dr.grad(s), 2.0)
