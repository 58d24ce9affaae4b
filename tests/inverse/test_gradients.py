"""Derivatives of the plugin against central finite differences of the float64
reference, and derivatives of rendered Stokes losses against finite
differences of renders.

BSDF (``eval``): for every continuous parameter (``sigma``, ``sigma_dd``,
``ks``, ``kdd``, ``kid``, ``eta``, ``k`` as uniform spectra, the ``values`` of
the tabulated ``material`` spectra, and the texels of bitmap textures),
Dr.Jit's forward-mode derivative of all 16 Mueller elements (rotated into the
reference's global s/p frames) and its reverse-mode gradient of a random linear
functional of them are compared with central differences of
``reference.pbrdf`` (float64, step 1e-5 relative: truncation ~1e-10, rounding
~1e-11), at generic directions and at near-grazing ones (cos theta down to
1e-3), both transport modes.

Tolerances. The plugin runs in float32 (6e-8 per operation). Per pair and
wavelength, |dM_ij - FD_ij| <= rtol * max_ij |FD_ij| + 1e-6 * max over all pairs
(the absolute floor covers the far tails where float32 D underflows):

* generic directions (cos theta >= 0.05): rtol = 1e-3. Measured worst per
  parameter: sigma 7.7e-4 (in the far tail of the lobe, where the derivative
  changes sign and is ~1e-6 of its maximum), sigma_dd 1.1e-4, ks, eta, k
  3.2e-5, kdd 2.5e-6, kid 1.7e-7;
* near grazing (one direction at cos theta in [1e-3, 0.03]): rtol = 1e-2.
  cos theta (and cos beta for nearly opposite grazing directions) are float32
  quantities with ~1e-4 relative error there, which the Fresnel derivatives
  (proportional to cos beta at grazing facet incidence) and D's exponent
  amplify, and some derivatives are small differences of large terms (d/d
  sigma_dd = kdd (D' G + D G') / (4 cos cos) with D' G = -D G' to 1e-3).
  Measured worst: sigma_dd 4.8e-3 (that cancellation), eta and k 1.0e-3,
  kdd 3.0e-4, sigma and ks 6.6e-5, kid 7.4e-6.

Reverse mode sums the weighted derivatives of all pairs: relative 1e-4.

With ``shadowing="smith"`` the plugin uses Mitsuba's rational approximation of
the Beckmann Smith G1: the reference is multiplied by the ratio of the
approximate to the exact G1 (a function of sigma, so it is differentiated too).

Rendered losses: ``mitsuba_pbrdf.inverse.loss_and_gradient`` (forward- and
reverse-mode) against central differences of renders with common random
numbers (the same seed): see the docstrings of the two render tests.
"""

import math
import zlib

import drjit as dr
import mitsuba as mi
import numpy as np
import pytest
from scipy import stats

from bsdf_harness import WAVELENGTHS
from mitsuba_pbrdf import frames as mf
from mitsuba_pbrdf import reference as ref
from proof.mitsuba_g1 import mitsuba_beckmann_G1

N_PAIRS = 1500
PARAMS = ("sigma", "ks", "kdd", "sigma_dd", "kid", "eta", "k")

CONFIGS = {
    # explicit uniform eta and k, the paper's V-groove shadowing
    "uniform-vgroove-beckmann": dict(eta=1.2, k=7.0, sigma=0.15, ks=0.8, kdd=0.2, sigma_dd=0.5,
                                     kid=0.05),
    # tabulated Cu spectra (irregular spectra: `eta.values`, `k.values`), Smith, GGX
    "Cu-smith-ggx": dict(material="Cu", sigma=0.25, ks=0.9, kdd=0.3, sigma_dd=0.4, kid=0.1,
                         shadowing="smith", dd_distribution="ggx"),
}


# ------------------------------------------------------------------ helpers

def plugin_key(config, name):
    if name in ("eta", "k") and "material" in config:
        return name + ".values"
    return name + ".value"


def spectrum_tables(bsdf):
    """(wavelengths, eta values, k values) of a `material` BSDF's irregular spectra."""
    p = mi.traverse(bsdf)
    return tuple(np.array(p[key], dtype=np.float64) for key in
                 ("eta.wavelengths", "eta.values", "k.values"))


def reference_brdf(config, wi_hat, wo_hat, n, k, **override):
    """Reference Mueller BRDF (pairs, wavelengths, 4, 4) at Mitsuba's directions,
    with Mitsuba's approximate Beckmann Smith G1 where the plugin uses it."""
    c = dict(dict(ks=1.0, kdd=0.0, sigma_dd=0.5, kid=0.0, shadowing="vgroove",
                  dd_distribution="beckmann"), **config)
    c.update(override)
    ti, pi_ = mf.to_angles(wo_hat)
    tr, pr = mf.to_angles(wi_hat)
    angles = (ti[:, None], pi_[:, None], tr[:, None], pr[:, None])
    F = c["ks"] * ref.specular(*angles, n, k, c["sigma"], c["shadowing"])
    if c["shadowing"] == "smith":
        alpha = math.sqrt(2) * c["sigma"]
        cos_i, cos_r = np.cos(ti), np.cos(tr)
        ratio = (mitsuba_beckmann_G1(cos_i, alpha) * mitsuba_beckmann_G1(cos_r, alpha)
                 / (ref.smith_G1(cos_i, alpha) * ref.smith_G1(cos_r, alpha)))
        F = F * ratio[:, None, None, None]
        assert c["dd_distribution"] == "ggx"  # GGX's Smith G1 is exact in both
    fdd = ref.directional_diffuse(*angles, c["sigma_dd"], c["shadowing"], c["dd_distribution"])
    F[..., 0, 0] += c["kdd"] * fdd + c["kid"] * ref.ideal_diffuse(*angles[0::2])
    return F


def uniform_nk(config):
    m = len(WAVELENGTHS)
    return np.full(m, float(config["eta"])), np.full(m, float(config["k"]))


def directions(kind, seed):
    """(wi_hat, wo_hat) float32-exact pairs: `generic` (cos >= 0.05, half near
    the specular direction) or `grazing` (one direction at cos theta in
    [1e-3, 0.03], the other near its mirror direction or anywhere)."""
    rng = np.random.default_rng(seed)
    if kind == "generic":
        return mf.random_directions(N_PAIRS, rng, min_cos=0.05)
    wi, wo = mf.random_directions(N_PAIRS, rng, min_cos=1e-3)
    cos = rng.uniform(1e-3, 0.03, N_PAIRS)
    phi = rng.uniform(0, 2 * np.pi, N_PAIRS)
    graze = np.stack([np.sqrt(1 - cos**2) * np.cos(phi), np.sqrt(1 - cos**2) * np.sin(phi), cos], -1)
    half = N_PAIRS // 2
    wo[:half] = graze[:half]                                  # light at grazing
    mirror = graze[half:] * [-1, -1, 1]                       # viewer at grazing, light near
    tilt = rng.normal(scale=0.1, size=mirror.shape) * [1, 1, 0]  # its mirror direction
    wo[half:] = mirror + tilt
    wo[half:, 2] = np.abs(wo[half:, 2]) + 1e-3
    wi[half:] = graze[half:]
    norm = lambda v: (v / np.linalg.norm(v, axis=-1, keepdims=True)).astype(np.float32).astype(np.float64)
    return norm(wi), norm(wo)


def plugin_matrix(bsdf, wi_hat, wo_hat, mode):
    from mitsuba_pbrdf.frames import mueller_brdf
    return mueller_brdf(bsdf, wi_hat, wo_hat, WAVELENGTHS, mode)


def to_numpy(value, n):
    a = np.asarray(value, dtype=np.float64).reshape(4, 4, len(WAVELENGTHS), n)
    return np.transpose(a, (3, 2, 0, 1))


def reference_derivative(config, name, wi_hat, wo_hat, n, k, tangent_nk=None):
    """Central difference (float64) of the reference along parameter `name`;
    for `eta`/`k` along `tangent_nk` (per wavelength; default 1)."""
    if name in ("eta", "k"):
        t = np.ones(len(WAVELENGTHS)) if tangent_nk is None else tangent_nk
        h = 1e-5 * (n if name == "eta" else k).max()
        plus = dict(n=n + h * t, k=k) if name == "eta" else dict(n=n, k=k + h * t)
        minus = dict(n=n - h * t, k=k) if name == "eta" else dict(n=n, k=k - h * t)
        return (reference_brdf(config, wi_hat, wo_hat, **plus)
                - reference_brdf(config, wi_hat, wo_hat, **minus)) / (2 * h)
    x = float(np.float32(config[name]))
    h = 1e-5 * x
    return (reference_brdf(config, wi_hat, wo_hat, n, k, **{name: x + h})
            - reference_brdf(config, wi_hat, wo_hat, n, k, **{name: x - h})) / (2 * h)


def config_nk(bsdf, config):
    if "material" not in config:
        return uniform_nk(config)
    wl, eta_v, k_v = spectrum_tables(bsdf)
    return np.interp(WAVELENGTHS, wl, eta_v), np.interp(WAVELENGTHS, wl, k_v)


def elementwise_sum(M, W):
    """sum over lanes, bands and elements of M_ij * W_ij (``M * W`` on
    ``mi.Spectrum`` would be a matrix product)."""
    total = mi.Float(0.0)
    for i in range(4):
        for j in range(4):
            total += dr.sum(dr.sum(M[i, j] * W[i, j]), axis=None)
    return total


def check_close(name, got, expected, rtol):
    scale = np.abs(expected).max(axis=(-1, -2), keepdims=True)
    err = np.abs(got - expected)
    bound = rtol * scale + 1e-6 * np.abs(expected).max()
    rel = err / (scale + 1e-6 * np.abs(expected).max())
    if np.any(err > bound):
        i = np.unravel_index(np.argmax(err / bound), err.shape)
        raise AssertionError(f"d/d{name}: {np.sum(err > bound)} elements off; worst at pair {i[0]}, "
                             f"band {i[1]}, m{i[2]}{i[3]}: plugin {got[i]:.6g}, FD {expected[i]:.6g}, "
                             f"scale {scale[i[:2]].item():.3g}")
    return rel.max()


# ------------------------------------------------------------------ eval: forward mode

@pytest.mark.parametrize("kind", ["generic", "grazing"])
@pytest.mark.parametrize("name", sorted(CONFIGS))
def test_eval_forward_derivatives_match_reference(name, kind):
    """Forward mode, all 16 elements, every parameter, both modes."""
    config = CONFIGS[name]
    rtol = 1e-3 if kind == "generic" else 1e-2
    wi_hat, wo_hat = directions(kind, seed=zlib.crc32(f"{name}/{kind}".encode()))
    worst = {}
    for mode in ("radiance", "importance"):
        for param in PARAMS:
            bsdf = mi.load_dict(dict({"type": "pbrdf"}, **config))
            n, k = config_nk(bsdf, config)
            params = mi.traverse(bsdf)
            key = plugin_key(config, param)
            tangent_nk = None
            dr.enable_grad(params[key])
            params.update()
            value = plugin_matrix(bsdf, wi_hat, wo_hat, mode)
            if key.endswith(".values"):
                # a random direction in the table's values: its effect at the
                # test wavelengths is the linear interpolation of the tangent
                wl = np.array(params[param + ".wavelengths"], dtype=np.float64)
                t = np.random.default_rng(1).uniform(0.5, 1.5, wl.size)
                dr.set_grad(params[key], mi.Float(t.astype(np.float32)))
                tangent_nk = np.interp(WAVELENGTHS, wl, t.astype(np.float32))
            else:
                dr.set_grad(params[key], 1.0)
            dr.forward_to(value)
            got = to_numpy(dr.grad(value), len(wi_hat))
            expected = reference_derivative(config, param, wi_hat, wo_hat, n, k, tangent_nk)
            assert np.abs(expected).max() > 0
            worst[(mode, param)] = check_close(param, got, expected, rtol)
    print(f"\n{name} {kind}: worst relative error per parameter "
          + ", ".join(f"{m[0]}/{p} {e:.1e}" for (m, p), e in worst.items()))


# ------------------------------------------------------------------ eval: reverse mode

@pytest.mark.parametrize("name", sorted(CONFIGS))
def test_eval_reverse_gradients_match_reference(name):
    """Reverse mode: the gradient of sum(W * M) for random weights W, with
    respect to each parameter (for tabulated spectra: each table entry)."""
    config = CONFIGS[name]
    wi_hat, wo_hat = directions("generic", seed=7)
    W = np.random.default_rng(3).normal(size=(len(wi_hat), len(WAVELENGTHS), 4, 4))
    W_dr = mi.Spectrum(np.transpose(W, (2, 3, 1, 0)).astype(np.float32))
    bsdf = mi.load_dict(dict({"type": "pbrdf"}, **config))
    n, k = config_nk(bsdf, config)
    params = mi.traverse(bsdf)
    keys = {p: plugin_key(config, p) for p in PARAMS}
    for key in keys.values():
        dr.enable_grad(params[key])
    params.update()
    value = plugin_matrix(bsdf, wi_hat, wo_hat, "radiance")
    dr.backward(elementwise_sum(value, W_dr))
    for param, key in keys.items():
        got = np.array(dr.grad(params[key]), dtype=np.float64)
        if key.endswith(".values"):
            # d loss / d table entry j = sum_lambda (d loss / d n(lambda)) w_j(lambda)
            wl = np.array(params[param + ".wavelengths"], dtype=np.float64)
            per_band = np.array([np.sum(W[:, b] * reference_derivative(
                config, param, wi_hat, wo_hat, n, k, np.eye(len(WAVELENGTHS))[b])[:, b])
                for b in range(len(WAVELENGTHS))])
            weights = np.array([np.interp(WAVELENGTHS, wl, np.eye(wl.size)[j]) for j in range(wl.size)])
            expected = weights @ per_band
            assert np.count_nonzero(expected) <= 2 * len(WAVELENGTHS)
            np.testing.assert_allclose(got, expected, rtol=1e-4, atol=1e-4 * np.abs(expected).max(),
                                       err_msg=param)
        else:
            expected = np.sum(W * reference_derivative(config, param, wi_hat, wo_hat, n, k))
            np.testing.assert_allclose(got, [expected], rtol=1e-4, err_msg=param)


# ------------------------------------------------------------------ textures

def test_texture_texel_gradients_match_reference():
    """sigma and kid as 2x2 bitmaps (nearest filtering): the gradient of a
    linear functional of the BRDF with respect to each texel."""
    sigma = np.array([[0.1, 0.2], [0.3, 0.15]], dtype=np.float32)
    kid = np.array([[0.1, 0.2], [0.3, 0.05]], dtype=np.float32)
    bitmap = lambda a: {"type": "bitmap", "data": mi.TensorXf(a[..., None]), "raw": True,
                        "filter_type": "nearest"}
    config = dict(eta=1.2, k=7.0, ks=1.0)
    bsdf = mi.load_dict({"type": "pbrdf", "eta": 1.2, "k": 7.0, "sigma": bitmap(sigma),
                         "kid": bitmap(kid)})
    wi_hat, wo_hat = directions("generic", seed=11)
    m = len(wi_hat)
    texel = np.arange(m) % 4                               # lane -> texel (row-major)
    u, v = (texel % 2 + 0.5) / 2, (texel // 2 + 0.5) / 2
    W = np.random.default_rng(4).normal(size=(m, len(WAVELENGTHS), 4, 4))

    params = mi.traverse(bsdf)
    for key in ("sigma.data", "kid.data"):
        dr.enable_grad(params[key])
    params.update()
    from mitsuba_pbrdf.frames import _vector
    si = dr.zeros(mi.SurfaceInteraction3f, m)
    si.n, si.sh_frame = mi.Normal3f(0, 0, 1), mi.Frame3f(mi.Vector3f(0, 0, 1))
    si.uv = mi.Point2f(u.astype(np.float32), v.astype(np.float32))
    si.wi, wo = _vector(wi_hat), _vector(wo_hat)
    si.wavelengths = mi.UnpolarizedSpectrum(*WAVELENGTHS)
    value = bsdf.eval(mi.BSDFContext(), si, wo)
    value = mi.mueller.rotate_mueller_basis(
        value, -wo, mi.mueller.stokes_basis(-wo), _global(-wo),
        si.wi, mi.mueller.stokes_basis(si.wi), _global(si.wi)) / mi.Frame3f.cos_theta(wo)
    W_dr = mi.Spectrum(np.transpose(W, (2, 3, 1, 0)).astype(np.float32))
    dr.backward(elementwise_sum(value, W_dr))

    n, k = uniform_nk(config)
    s_lane = sigma.ravel()[texel].astype(np.float64)[:, None]
    kid_lane = kid.ravel()[texel].astype(np.float64)[:, None]

    def functional(s, kd):
        F = ref.pbrdf(*(a[:, None] for a in (*mf.to_angles(wo_hat), *mf.to_angles(wi_hat))),
                      n, k, s, 1.0, 0.0, 0.5, kd)
        return np.array([np.sum((W * F)[texel == t]) for t in range(4)])

    h = 1e-6
    d_sigma = (functional(s_lane + h, kid_lane) - functional(s_lane - h, kid_lane)) / (2 * h)
    d_kid = (functional(s_lane, kid_lane + h) - functional(s_lane, kid_lane - h)) / (2 * h)
    np.testing.assert_allclose(np.array(dr.grad(params["sigma.data"])).ravel(), d_sigma, rtol=1e-4)
    np.testing.assert_allclose(np.array(dr.grad(params["kid.data"])).ravel(), d_kid, rtol=1e-4)


def _global(d):
    from mitsuba_pbrdf.frames import _global_basis
    return _global_basis(d)


# ------------------------------------------------------------------ updates

@pytest.mark.parametrize("name", sorted(CONFIGS))
def test_updates_through_traverse_change_eval_as_the_reference(name):
    """Every parameter changed through `mi.traverse` + `update()` (so through
    `parameters_changed`) gives the reference at the new values."""
    config = CONFIGS[name]
    bsdf = mi.load_dict(dict({"type": "pbrdf"}, **config))
    params = mi.traverse(bsdf)
    new = dict(sigma=0.21, ks=0.6, kdd=0.35, sigma_dd=0.7, kid=0.12)
    for p, v in new.items():
        params[p + ".value"] = v
    if "material" in config:
        for p, scale in (("eta", 1.3), ("k", 0.8)):
            params[p + ".values"] = params[p + ".values"] * scale
    else:
        params["eta.value"], params["k.value"] = 2.0, 3.5
    params.update()
    n, k = config_nk(bsdf, config)
    if "material" not in config:
        n, k = uniform_nk(dict(eta=2.0, k=3.5))
    wi_hat, wo_hat = directions("generic", seed=5)
    got = to_numpy(plugin_matrix(bsdf, wi_hat, wo_hat, "radiance"), len(wi_hat))
    expected = reference_brdf(dict(config, **new), wi_hat, wo_hat, n, k)
    m00 = expected[..., :1, :1]
    assert np.all(np.abs(got - expected) <= 1e-4 * m00 + 1e-7 * m00.max())


# ------------------------------------------------------------------ rendered losses

def _plane_scene(integrator, spp, width=24, height=16):
    """The analytic plate of scenes/analytic_plane.xml as a dict, lit by a
    directional light (+ a constant sky for `path`)."""
    T = mi.ScalarTransform4f
    scene = {
        "type": "scene",
        "integrator": {"type": "stokes", "integrator": integrator},
        "sensor": {"type": "perspective", "fov": 40,
                   "to_world": T().look_at(origin=[2.4, 0, 1.2], target=[0.2, 0, 0], up=[0, 0, 1]),
                   "sampler": {"type": "independent", "sample_count": spp},
                   "film": {"type": "hdrfilm", "width": width, "height": height,
                            "pixel_format": "rgb", "rfilter": {"type": "box"}}},
        "sun": {"type": "directional", "direction": [0.85, 0.1, -0.45], "irradiance": 3.0},
        "plate": {"type": "rectangle", "to_world": T().scale(10),
                  "bsdf": {"type": "pbrdf", "eta": 1.2, "k": 7.0, "sigma": 0.15, "ks": 1.0,
                           "kdd": 0.2, "sigma_dd": 0.5, "kid": 0.05}},
    }
    if integrator["type"] == "path":
        scene["sky"] = {"type": "constant", "radiance": 0.5}
    return mi.load_dict(scene)


def _linear_loss(scene, seed=0):
    """A fixed random linear functional of the S0 (positive weights), S1 and
    S2 channels: (loss(image) -> mi.Float, weights as NumPy (H, W, C))."""
    from mitsuba_pbrdf.inverse import stokes_indices
    size = scene.sensors()[0].film().crop_size()
    (s0, s1, s2) = stokes_indices(scene, (0, 1, 2))
    rng = np.random.default_rng(seed)
    w = np.zeros((size[1], size[0], 15), dtype=np.float32)
    w[..., s0] = rng.uniform(0.5, 1.5, size=(size[1], size[0], len(s0)))
    w[..., s1 + s2] = rng.normal(size=(size[1], size[0], len(s1 + s2)))
    weights = mi.TensorXf(w)
    return (lambda image: dr.sum(image * weights, axis=None).array), w


def _render_functional(scene, key, value, weights, seed, spp):
    params = mi.traverse(scene)
    old = float(np.array(params[key])[0])  # a copy: assignment updates in place
    params[key] = value
    params.update()
    img = np.array(mi.render(scene, spp=spp, seed=seed), dtype=np.float64)
    params[key] = old
    params.update()
    return float(np.sum(img * weights))


def _fd_image(scene, key, seed, spp):
    """Per-pixel d image / d key: Richardson extrapolation of central
    differences of renders with `seed`, steps 1 % and 2 % (as _fd_of_renders)."""
    params = mi.traverse(scene)
    x = float(np.array(params[key])[0])

    def image(v):
        params[key] = v
        params.update()
        img = np.array(mi.render(scene, spp=spp, seed=seed), dtype=np.float64)
        params[key] = x
        params.update()
        return img

    d1 = (image(1.01 * x) - image(0.99 * x)) / (0.02 * x)
    d2 = (image(1.02 * x) - image(0.98 * x)) / (0.04 * x)
    return (4 * d1 - d2) / 3


def _fd_of_renders(scene, key, weights, seed, spp, linear=False):
    """Central difference of sum(weights * image) along `key`, renders with
    `seed`. `linear`: the image is linear in the parameter (ks, kdd, kid
    under a delta light, where no MIS weight depends on them): a step of
    0.5 x is then exact and keeps float32 rounding of the images (~1e-7 of a
    pixel) far below the difference. Otherwise Richardson extrapolation of
    steps 1 % and 2 % (truncation error O(h^4) ~ 1e-8)."""
    x = float(np.array(mi.traverse(scene)[key])[0])
    f = lambda v: _render_functional(scene, key, v, weights, seed, spp)
    if linear:
        return (f(1.5 * x) - f(0.5 * x)) / x
    d1 = (f(1.01 * x) - f(0.99 * x)) / (0.02 * x)
    d2 = (f(1.02 * x) - f(0.98 * x)) / (0.04 * x)
    return (4 * d1 - d2) / 3


RENDER_KEYS = ["plate.bsdf." + p + ".value" for p in PARAMS]


@pytest.mark.parametrize("method", ["forward", "reverse"])
@pytest.mark.slow
def test_rendered_loss_gradient_matches_finite_differences_direct(method):
    """Plate under a directional light, `direct` integrator: the light is
    sampled deterministically and BSDF-sampled rays hit nothing, so for a
    fixed seed the image is a smooth function of the BSDF parameters and a
    central difference of two renders with the seed of the derivative render
    (common random numbers) is the derivative of the same estimator. The
    loss is linear in the image, so the two agree up to float32 rounding of
    the images and the finite-difference truncation (see `_fd_of_renders`):
    relative 2e-3."""
    from mitsuba_pbrdf.rendering.passes import derivative_seed
    from mitsuba_pbrdf.inverse import loss_and_gradient
    scene = _plane_scene({"type": "direct"}, spp=8)
    loss, weights = _linear_loss(scene)
    params = mi.traverse(scene)
    _, grads, _ = loss_and_gradient(scene, params, RENDER_KEYS, loss, spp=8, seed=3,
                                    method=method)
    grad_seed = derivative_seed(3)
    errors = {}
    for key in RENDER_KEYS:
        fd = _fd_of_renders(scene, key, weights, grad_seed, spp=8,
                            linear=key.split(".")[-2] in ("ks", "kdd", "kid"))
        errors[key.split(".")[-2]] = abs(grads[key][0] - fd) / abs(fd)
        assert abs(grads[key][0] - fd) <= 2e-3 * abs(fd), (key, grads[key][0], fd)
    print(f"\n{method}: relative error per parameter "
          + ", ".join(f"{k} {e:.1e}" for k, e in errors.items()))


@pytest.mark.slow
def test_rendered_stokes_loss_gradient_matches_finite_differences_path():
    """`path` (depth 3) with a sky, so BSDF sampling contributes. Quadratic
    Stokes loss (S0, S1, S2) against a target rendered with other parameters.

    The gradient is sum_pixels dL/dI (primal image, seed s) x dI/dtheta
    (derivative render, seed g != s, as `mi.render` does, so that it is
    unbiased). The finite difference uses the same dL/dI and central
    differences of renders with seed g. Mitsuba's path tracer differentiates
    with *detached* sampling (sampled directions do not move with the
    parameters) while the renders' directions move with them, so the two are
    different estimators of the same derivative and agree within Monte Carlo
    noise, which each component gets its own bound for. The gradient is
    linear in w = dL/dI, so the pixels are split into 16 interleaved blocks:
    each block's AD gradient (reverse mode with the block's w and the same
    derivative seed; the blocks add up to the full gradient) minus its FD
    contribution is a difference d_b with mean 0 (both estimate the same
    derivative), independent between blocks (pixels sample independently).
    A t-test of mean(d_b) = 0 per component (15 degrees of freedom) at a
    family-wise 1e-3 for the 7 components (Sidak: 1.4e-4 each). 64 spp."""
    from mitsuba_pbrdf.rendering.passes import derivative_seed
    from mitsuba_pbrdf.inverse import loss_and_gradient, render, stokes_loss
    scene = _plane_scene({"type": "path", "max_depth": 3}, spp=64)
    params = mi.traverse(scene)
    target = np.array(render(scene, spp=256, seed=100))
    for key, v in zip(RENDER_KEYS, (0.2, 0.9, 0.25, 0.6, 0.08, 1.4, 6.0)):
        params[key] = v
    params.update()
    loss = stokes_loss(scene, target, (0, 1, 2))
    _, grads, _, image = loss_and_gradient(scene, params, RENDER_KEYS, loss, spp=64, seed=9,
                                           method="reverse", return_image=True)
    image = mi.TensorXf(image)
    dr.enable_grad(image)
    dr.backward(loss(image))
    weights = np.array(dr.grad(image), dtype=np.float64)
    grad_seed = derivative_seed(9)
    x = np.array([float(np.array(params[k])[0]) for k in RENDER_KEYS])
    got = np.array([grads[k][0] for k in RENDER_KEYS]) * x       # d loss / d log(x)
    fd_images = [_fd_image(scene, k, grad_seed, spp=64) for k in RENDER_KEYS]
    want = np.array([np.sum(weights * img) for img in fd_images]) * x
    blocks = 16
    rows, cols = np.indices(weights.shape[:2])
    block = (rows * 5 + cols) % blocks                           # interleaved pixel sets
    d = []
    for b in range(blocks):
        w_b = np.where((block == b)[..., None], weights, 0.0)
        w_tensor = mi.TensorXf(w_b.astype(np.float32))
        g_b = loss_and_gradient(scene, params, RENDER_KEYS,
                                lambda img: dr.sum((img * w_tensor).array), spp=64, seed=9,
                                method="reverse")[1]
        ad_b = np.array([g_b[k][0] for k in RENDER_KEYS]) * x
        d.append(ad_b - np.array([np.sum(w_b * img) for img in fd_images]) * x)
    d = np.array(d)
    np.testing.assert_allclose(d.sum(axis=0) + want, got, rtol=1e-3, atol=1e-5 * np.abs(got).max())
    t = d.mean(axis=0) / (d.std(axis=0, ddof=1) / np.sqrt(blocks))
    critical = stats.t.ppf(1 - 0.5 * (1 - (1 - 1e-3) ** (1 / len(RENDER_KEYS))), df=blocks - 1)
    print("\npath: d loss / d log x, AD vs FD (t): " + ", ".join(
        f"{k.split('.')[-2]} {g:.4g}/{w:.4g} ({ti:+.1f})"
        for k, g, w, ti in zip(RENDER_KEYS, got, want, t)) + f"; critical |t| {critical:.2f}")
    assert np.all(np.abs(t) <= critical), (got, want, t)
