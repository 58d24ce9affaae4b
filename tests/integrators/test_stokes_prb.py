"""``stokes_prb`` (polarized path replay, docs/path-replay.md) against
Mitsuba's ``stokes`` around ``path``.

Oracles and tolerances:

* Primal: the same random numbers in the same order as ``path``, so the
  images agree to float32 rounding. The two codes form the same sums of
  products in a different order (Mueller products vs Stokes vectors): a few
  ulps per vertex, ~1e-7 relative per pixel measured; asserted 1e-5 of the
  image's largest value.
* Gradients: equal to ``path`` differentiated by AD sample by sample where
  ``path`` AD is exact: where the sampled directions do not depend on the
  differentiated parameters (``pbrdf`` with ``sampling="cosine"``,
  ``diffuse``, ``polarizer``, a conductor's index). Mitsuba 3.9's ``path``
  leaves its re-evaluated BSDF weight in the local Stokes frame when the
  sampled direction carries a derivative, so elsewhere it is no oracle
  (docs/path-replay.md). Float32 rounding of the two summation orders over
  ~1e3 samples: relative 1e-4 of the largest component (measured <= 1.2e-5).
* Forward mode equals reverse mode (same estimator, same samples):
  relative 1e-4.

Images are 16 x 16 with 4 spp: every test compiles its own kernels (a few
seconds each), the rendering is negligible.
"""

import drjit as dr
import mitsuba as mi
import numpy as np
import pytest

from mitsuba_pbrdf import use_variant
from proof.render_gradients import functional_gradient, random_functional
from mitsuba_pbrdf.inverse.scenes import sphere_scene

T = mi.ScalarTransform4f
SIZE, SPP = 16, 4
PBRDF_KEYS = ["object.bsdf." + p + ".value" for p in ("eta", "k", "sigma", "ks", "kdd",
                                                       "sigma_dd", "kid")]


def pbrdf(sampling="cosine", **extra):
    bsdf = {"type": "pbrdf", "eta": 2.0, "k": 4.0, "sigma": 0.15, "ks": 1.0, "kdd": 0.2,
            "sigma_dd": 0.5, "kid": 0.05, "sampling": sampling}
    bsdf.update(extra)
    return bsdf


def scene_dict(integrator, max_depth=3, bsdf=None, floor=None, extra=None, env=True,
               rr_depth=5, hide_emitters=False):
    """A sphere (``object``) on a floor under an area light (+ a sky), seen by
    a 16 x 16 camera; ``integrator`` is ``"path"`` (inside ``stokes``) or
    ``"stokes_prb"``."""
    settings = {"max_depth": max_depth, "rr_depth": rr_depth, "hide_emitters": hide_emitters}
    if integrator == "path":
        inner = {"type": "stokes", "integrator": {"type": "path", **settings}}
    else:
        inner = {"type": "stokes_prb", **settings}
    d = sphere_scene(width=SIZE, height=SIZE, spp=SPP, fov=35, bsdf=bsdf or pbrdf())
    d["integrator"] = inner
    d["floor"]["bsdf"] = floor or {"type": "diffuse", "reflectance": 0.4}
    del d["sky"]
    if env:
        d["sky"] = {"type": "constant", "radiance": 0.3}
    d.update(extra or {})
    return d


def polarizer_filter(theta=30.0):
    """A linear polarizer in front of the camera, covering its view."""
    return {"filter": {"type": "rectangle",
                       "to_world": T().look_at(origin=[0, 1.55, 4.6], target=[0, 0.9, 0],
                                               up=[0, 1, 0]).scale(2.0),
                       "bsdf": {"type": "polarizer", "theta": theta}}}


def both(**kwargs):
    """The ``stokes``/``path`` scene and a ``stokes_prb`` integrator with its
    settings. One scene for both: Mitsuba may order a scene's emitters
    differently between loads, which changes which emitter a random number
    picks."""
    from mitsuba_pbrdf.integrators import from_path
    scene = mi.load_dict(scene_dict("path", **kwargs))
    return scene, from_path(scene)


def random_weights(seed=0):
    """A fixed random linear functional of all 15 channels (S1, S2 weighted
    as much as S0): its gradient checks every Stokes component."""
    return random_functional(SIZE, SIZE, seed=seed)


def reverse_gradient(scene, keys, weights, integrator=None, seed=3, seed_grad=11):
    return functional_gradient(scene, keys, weights, integrator=integrator, spp=SPP, seed=seed,
                               seed_grad=seed_grad)


def forward_gradient(scene, keys, weights, integrator=None, seed=3, seed_grad=11):
    """The same functional's derivative, one forward-mode render per entry."""
    return functional_gradient(scene, keys, weights, integrator=integrator, spp=SPP, seed=seed,
                               seed_grad=seed_grad, mode="forward")


def assert_close(got, want, rtol=1e-4):
    scale = np.abs(want).max()
    assert scale > 0
    np.testing.assert_allclose(got, want, atol=rtol * scale, rtol=0)


# ---------------------------------------------------------------- primal

def mitsuba_bsdfs():
    """Mitsuba's polarized BSDFs beside pbrdf: a roughconductor sphere, a
    pplastic plate and a linear polarizer in front of the camera."""
    return {"small": {"type": "sphere", "center": [-1.4, 0.5, 0.8], "radius": 0.5,
                      "bsdf": {"type": "roughconductor", "eta": 0.3, "k": 3.0, "alpha": 0.2}},
            "plate": {"type": "rectangle",
                      "to_world": T().translate([1.6, 0.6, 0.5]).scale(0.6),
                      "bsdf": {"type": "pplastic", "alpha": 0.3}},
            **polarizer_filter(theta=30.0)}


@pytest.mark.parametrize("case", ["depth1", "depth6-roulette", "mitsuba-bsdfs-hidden-emitters"])
@pytest.mark.slow
def test_primal_equals_stokes_path(case):
    kwargs = {
        "depth1": dict(max_depth=1),
        "depth6-roulette": dict(max_depth=6, rr_depth=2, bsdf=pbrdf("mixture")),
        "mitsuba-bsdfs-hidden-emitters": dict(max_depth=4, extra=mitsuba_bsdfs(),
                                              hide_emitters=True, env=False),
    }[case]
    scene, replay = both(**kwargs)
    a = np.array(mi.render(scene, spp=SPP, seed=7))
    b = np.array(mi.render(scene, integrator=replay, spp=SPP, seed=7))
    assert a.shape == b.shape == (SIZE, SIZE, 15)
    if case != "depth1":  # emitters seen directly are unpolarized
        assert np.abs(a[..., 6:9]).max() > 1e-3 * np.abs(a).max()  # S1 is not empty
    np.testing.assert_allclose(b, a, atol=1e-5 * np.abs(a).max(), rtol=0)


def test_channels_are_those_of_stokes():
    from mitsuba_pbrdf.stokes.image import channel_names
    names = []
    for integrator in ("path", "stokes_prb"):
        scene = mi.load_dict(scene_dict(integrator, max_depth=1))
        mi.render(scene, spp=1)
        names.append(channel_names(scene.sensors()[0].film()))
    assert names[0] == names[1] and names[1][3:6] == ["S0.R", "S0.G", "S0.B"]


# ---------------------------------------------------------------- gradients

def bitmap_sigma():
    data = np.linspace(0.1, 0.3, 16, dtype=np.float32).reshape(4, 4, 1)
    return {"type": "bitmap", "bitmap": mi.Bitmap(data), "raw": True, "filter_type": "nearest"}


@pytest.mark.parametrize("depth, rr_depth", [(2, 5), (5, 2)])
@pytest.mark.slow
def test_gradients_equal_path_ad_per_sample(depth, rr_depth):
    """pbrdf with cosine sampling on a diffuse floor: the BSDF parameters and
    the floor's reflectance; at depth 2 the roughness is a 4 x 4 bitmap (the
    gradient of each texel), at depth 5 roulette starts at depth 2 (depths 1
    to 6: validation/path_replay_gradients.py)."""
    texture = depth == 2
    scene, replay = both(max_depth=depth, rr_depth=rr_depth,
                         bsdf=pbrdf(sigma=bitmap_sigma()) if texture else pbrdf())
    keys = [k for k in PBRDF_KEYS if not (texture and ".sigma." in k)]
    keys += ["floor.bsdf.reflectance.value"] + (["object.bsdf.sigma.data"] if texture else [])
    weights = random_weights()
    want = reverse_gradient(scene, keys, weights)
    got = reverse_gradient(scene, keys, weights, integrator=replay)
    if texture:
        assert np.count_nonzero(want[-16:]) >= 8  # texels seen in the image
    assert_close(got, want)


@pytest.mark.slow
def test_singular_case_polarizer_depolarizing_floor_and_mitsuba_bsdfs():
    """A linear polarizer in front of the camera (rank-one Mueller matrix)
    and a depolarizing diffuse floor: the throughput cannot be inverted.
    With Mitsuba's roughconductor and pplastic beside pbrdf, gradients of
    parameters that do not move the sampled directions (where path AD is
    exact: not pplastic's diffuse reflectance, which sets its sampling
    weights) equal path AD's, in reverse and forward mode."""
    scene, replay = both(max_depth=4, extra=mitsuba_bsdfs())
    keys = ["object.bsdf.kdd.value", "object.bsdf.eta.value", "object.bsdf.ks.value",
            "floor.bsdf.reflectance.value", "filter.bsdf.theta.value", "small.bsdf.eta.value",
            "small.bsdf.k.value", "plate.bsdf.eta.value"]
    weights = random_weights(1)
    want = reverse_gradient(scene, keys, weights)
    got = reverse_gradient(scene, keys, weights, integrator=replay)
    assert np.all(np.abs(want) > 0)
    assert_close(got, want)
    some = [4]  # forward mode (one render per parameter): the polarizer's angle
    assert_close(forward_gradient(scene, [keys[i] for i in some], weights, integrator=replay),
                 got[some])


@pytest.mark.slow
def test_gradients_of_emitter_parameters_equal_path_ad():
    """The replay samples the emitters again, with derivatives, from the
    traced random numbers: the gradients of the two area lights', the sky's
    and two BSDF parameters equal path AD's (cosine sampling: path AD is
    exact)."""
    scene, replay = both(max_depth=3)
    keys = ["key.emitter.radiance.value", "back.emitter.radiance.value",
            "sky.radiance.value", "object.bsdf.kdd.value", "object.bsdf.eta.value"]
    weights = random_weights(2)
    want = reverse_gradient(scene, keys, weights)
    got = reverse_gradient(scene, keys, weights, integrator=replay)
    assert np.all(np.abs(want) > 0)
    assert_close(got, want)


@pytest.mark.slow
def test_forward_equals_reverse_with_mixture_sampling():
    """pbrdf's own lobe-mixture sampling (where path AD is no oracle): the
    two modes of stokes_prb compute the same estimator."""
    scene, replay = both(max_depth=3, bsdf=pbrdf("mixture"))
    keys = ["object.bsdf.sigma.value", "object.bsdf.eta.value", "object.bsdf.kdd.value"]
    weights = random_weights(4)
    assert_close(forward_gradient(scene, keys, weights, integrator=replay),
                 reverse_gradient(scene, keys, weights, integrator=replay))


def _largest_kernel_ir(history):
    kernels = [h for h in history if h.get("ir") is not None]
    ir = max(kernels, key=lambda h: h.get("operation_count", 0))["ir"]
    return ir.getvalue() if hasattr(ir, "getvalue") else ir


def test_the_adjoint_kernel_traces_each_path_once():
    """Dr.Jit records a loop body a second time when it finds loop-invariant
    state. Local-memory writes made outside the loop state kept the first
    recording's computation in the kernel: the adjoint kernel held the whole
    trace iteration twice. Its trace must hold the BSDF-sample call sites that
    the primal render's trace holds, no more (LLVM IR, which names each call)."""
    scene = mi.load_dict(scene_dict("stokes_prb", max_depth=3, bsdf=pbrdf("mixture")))
    params = mi.traverse(scene)
    dr.enable_grad(params[PBRDF_KEYS[0]])
    params.update()
    marker = "; Call: BSDF::eval_pdf_sample()"
    try:
        with dr.scoped_set_flag(dr.JitFlag.KernelHistory, True):
            dr.kernel_history()
            image = mi.render(scene, params, spp=SPP, seed=1)
            dr.eval(image)
            primal = _largest_kernel_ir(dr.kernel_history())
            dr.backward(dr.sum(image, axis=None))
            adjoint = _largest_kernel_ir(dr.kernel_history())
    finally:
        dr.disable_grad(params[PBRDF_KEYS[0]])
        params.update()
    assert primal.count(marker) > 0
    assert adjoint.count(marker) == primal.count(marker)


# ---------------------------------------------------------------- wiring

@pytest.mark.slow
def test_loss_and_gradient_uses_replay_by_default():
    from mitsuba_pbrdf.integrators import from_path
    from mitsuba_pbrdf.inverse import gradient_method, loss_and_gradient
    path = mi.load_dict(scene_dict("path", max_depth=3, bsdf=pbrdf("mixture")))
    params = mi.traverse(path)
    weights = random_weights(5)
    loss = lambda image: dr.sum(image * weights, axis=None).array  # noqa: E731
    value, grads, stats = loss_and_gradient(path, params, PBRDF_KEYS[:3], loss, spp=SPP, seed=2)
    assert stats.method == "prb" and gradient_method(path) == "prb"
    # the same as mi.render + dr.backward with the replay integrator
    replay = from_path(path)
    assert replay.max_depth == 3
    for k in PBRDF_KEYS[:3]:
        dr.enable_grad(params[k])
    params.update()
    from mitsuba_pbrdf.rendering.passes import derivative_seed
    image = mi.render(path, params, integrator=replay, spp=SPP, seed=2,
                      seed_grad=derivative_seed(2))
    dr.backward(loss(image))
    want = np.array([dr.grad(params[k])[0] for k in PBRDF_KEYS[:3]])
    for k in PBRDF_KEYS[:3]:
        dr.disable_grad(params[k])
    params.update()
    assert_close(np.array([grads[k][0] for k in PBRDF_KEYS[:3]]), want)


@pytest.mark.slow
def test_loss_image_of_the_replay_is_the_scenes_render():
    """With path replay, loss_and_gradient renders its primal image with
    stokes_prb: it must be the scene's own stokes + path image (same random
    numbers; tolerance of test_primal_equals_stokes_path) and give its loss."""
    from mitsuba_pbrdf.inverse import loss_and_gradient, render
    path = mi.load_dict(scene_dict("path", max_depth=3, bsdf=pbrdf("mixture")))
    params = mi.traverse(path)
    weights = random_weights(5)
    loss = lambda image: dr.sum(image * weights, axis=None).array  # noqa: E731
    value, _, stats, image = loss_and_gradient(path, params, PBRDF_KEYS[:1], loss, spp=SPP,
                                               seed=2, return_image=True)
    assert stats.method == "prb"
    want = render(path, spp=SPP, seed=2)
    assert type(path.integrator()).__name__ != "StokesPRBIntegrator"
    scale = np.max(np.abs(np.array(want)))
    assert np.max(np.abs(np.asarray(image) - np.array(want))) <= 1e-5 * scale
    assert value == pytest.approx(float(loss(want)[0]), rel=1e-5)


def test_scenes_it_cannot_replay():
    from mitsuba_pbrdf.inverse import gradient_method
    direct = scene_dict("path")
    direct["integrator"] = {"type": "stokes", "integrator": {"type": "direct"}}
    assert gradient_method(mi.load_dict(direct)) == "reverse"
    with pytest.raises(ValueError, match="stokes around path"):
        gradient_method(mi.load_dict(direct), "prb")
    with pytest.raises(ValueError, match="method must be one of"):
        gradient_method(mi.load_dict(direct), "backwards")
    unbounded = scene_dict("path", max_depth=-1)
    assert gradient_method(mi.load_dict(unbounded)) == "reverse"
    with pytest.raises(Exception, match="max_depth must be between 0 and 64"):
        mi.load_dict({"type": "stokes_prb", "max_depth": -1})


def test_unpolarized_variant_says_which_to_use(restore_variant):
    use_variant("llvm_ad_rgb")
    with pytest.raises(Exception, match="polarized JIT variant"):
        mi.load_dict({"type": "stokes_prb"})


def test_svbrdf_example_runs_and_moves_the_maps():
    """mitsuba_pbrdf.inverse.svbrdf.recover (examples/svbrdf_recovery.py) at toy size
    (the study is validation/svbrdf_recovery.py): two Adam steps on the 2 x 64 texels keep
    them inside their bounds, change the texels the cameras see, and leave
    the others."""
    from mitsuba_pbrdf.inverse.svbrdf import BOUNDS, START, recover
    result = recover(iterations=2, size=12, spp=2, target_spp=4, log=None)
    assert len(result["loss"]) == 2 and np.all(np.isfinite(result["loss"]))
    for name, recovered in result["recovered"].items():
        low, high = BOUNDS[name]
        seen = result["visible"][name]
        assert 0 < seen.sum() < seen.size
        assert np.all((recovered >= low) & (recovered <= high))
        assert np.all(recovered[~seen] == START[name])
        assert np.any(recovered[seen] != START[name])
