"""``polarized_sky``: the emitted Stokes vector, its frames and its sampling.

Every comparison is per pixel (one ray through each pixel centre: stratified
sampler without jitter, box filter) against an independent NumPy float64
statement of the physics (``proof/polarized_light.py``): the Rayleigh pattern
from the scattering plane's normal, Berry, Dennis and Lee's pattern in the
paper's stereographic form, the reference evaluator's Fresnel Mueller matrix,
and the ``stokes`` integrator's camera basis x = normalize(d x up).

Tolerance of the normalized Stokes parameters q, u, v (S1/S0, S2/S0, S3/S0):
``TOL = 1e-5``. The plugin computes them in float32 (unit roundoff 6e-8) from
O(1) quantities in about 20 operations, the integrator rotates them once into
the camera basis and sums bands, and the pixel ray's direction is itself
float32: a few 1e-7 in all (measured: <= 7e-7). 1e-5 is about 170 float32
ulps of 1, well above that, and still 50 times below what a Stokes basis off
by 0.02 degrees (2 * 0.02 * pi/180 * 0.8 = 5.6e-4) would give.
"""

import math

import drjit as dr
import mitsuba as mi
import numpy as np
import pytest

from mitsuba_pbrdf import use_variant
from mitsuba_pbrdf.reference import fresnel_mueller
from proof import polarized_light as pl

TOL = 1e-5
SUN_ELEVATION, SUN_AZIMUTH = 30.0, 40.0
SUN = pl.sun_vector(SUN_ELEVATION, SUN_AZIMUTH)
SEPARATION = 35.0          # the plugin's default neutral-point separation (degrees)
DOLP_MAX = 0.8
#: a view of the sky from 15 to 75 degrees elevation, 110 degrees from the sun
SKY_VIEW = dict(origin=[0, 0, 0], target=pl.sun_vector(45, 150), up=[0, 0, 1], fov=60)


def sky(**extra):
    return dict({"type": "polarized_sky", "sun_direction": SUN.tolist(), "dolp_max": DOLP_MAX},
                **extra)


def expected_sky(model, d):
    """(degree, E direction) of the reference sky seen along d."""
    if model == "rayleigh":
        return pl.rayleigh(d, SUN, DOLP_MAX)
    return pl.berry_stereographic(d, SUN_ELEVATION, SUN_AZIMUTH, SEPARATION, DOLP_MAX)


def render_sky_view(model="rayleigh", width=32, height=24, **view):
    cam = pl.camera(**dict(SKY_VIEW, **view), width=width, height=height)
    image, loaded = pl.render_stokes(pl.scene(sky(model=model), cam))
    _, d = pl.pixel_rays(loaded)
    q, u, v, s0 = pl.normalized(image)
    x, y = pl.camera_basis(d, pl.camera_up(loaded))
    degree, e = expected_sky(model, d)
    eq, eu = pl.linear_stokes(degree, e, x, y)
    return (q, u, v, s0), (eq, eu, degree)


def aolp_deg(q, u):
    return 0.5 * np.degrees(np.arctan2(u, q))


def angle_difference(a, b):
    """a - b in degrees, wrapped to [-90, 90) (AoLP is defined modulo 180)."""
    return (np.asarray(a) - b + 90.0) % 180.0 - 90.0


# ---------------------------------------------------------------- the sky seen directly

@pytest.mark.parametrize("model", ["rayleigh", "berry"])
def test_the_sky_seen_directly_matches_the_formula_per_pixel(model):
    (q, u, v, s0), (eq, eu, degree) = render_sky_view(model)
    assert np.all(s0 > 0) and np.all(np.isfinite(q))
    assert degree.min() < 0.35 and degree.max() > 0.75      # the view spans the pattern
    assert np.abs(q - eq).max() < TOL and np.abs(u - eu).max() < TOL
    assert np.abs(v).max() == 0.0                            # skylight is linearly polarized
    assert np.abs(np.hypot(q, u) - degree).max() < TOL
    # AoLP: an error dq in q, u turns the angle by at most dq / DoLP radians
    bound = np.degrees(TOL / degree)
    assert np.all(np.abs(angle_difference(aolp_deg(q, u), aolp_deg(eq, eu))) < bound)


def test_the_stereographic_form_at_zero_separation_is_the_rayleigh_sky():
    """Anchors the reference's reading of Berry et al.'s angle (arg(w)/2 from
    the sun's meridian) on the physics: with the neutral points merged into
    the sun, the field is perpendicular to the scattering plane."""
    rng = np.random.default_rng(1)
    d = pl.unit(rng.normal(size=(2000, 3)))
    d[:, 2] = np.abs(d[:, 2])
    degree_b, e_b = pl.berry_stereographic(d, SUN_ELEVATION, SUN_AZIMUTH, 0.0, DOLP_MAX)
    degree_r, e_r = pl.rayleigh(d, SUN, DOLP_MAX)
    assert np.abs(degree_b - degree_r).max() < 1e-9
    assert np.abs(np.abs(np.sum(e_b * e_r, -1)) - 1).max() < 1e-6


def eval_sky(emitter, d):
    """(q, u, S0) of what ``emitter.eval`` returns for directions d (N x 3),
    in the Stokes basis stokes_basis(-d), and that basis (x, y) as NumPy."""
    si = dr.zeros(mi.SurfaceInteraction3f, len(d))
    si.wi = mi.Vector3f(*(-d.T))
    si.wavelengths = mi.UnpolarizedSpectrum(450.0, 520.0, 600.0, 690.0)
    value = emitter.eval(si)
    s = [np.array(value[i, 0][0], np.float64) for i in range(4)]
    x = mi.mueller.stokes_basis(si.wi)
    x = np.stack([np.array(c, np.float64) for c in x], -1)
    return s[1] / s[0], s[2] / s[0], s[0], x, np.cross(-d, x)


def test_berry_pattern_vanishes_at_its_four_neutral_points():
    emitter = mi.load_dict(sky(model="berry", radiance=1.0))   # the whole sphere lit
    zenith = np.array([0.0, 0.0, 1.0])
    down = pl.unit(SUN * SUN[2] - zenith)
    half = math.radians(SEPARATION / 2)
    babinet = math.cos(half) * SUN - math.sin(half) * down
    brewster = math.cos(half) * SUN + math.sin(half) * down
    points = np.stack([babinet, brewster, -brewster, -babinet])   # Arago, fourth: antipodes
    q, u, _, _, _ = eval_sky(emitter, points)
    assert np.abs(np.hypot(q, u)).max() < 1e-6
    # and the stereographic form agrees that they are its zeros
    degree, _ = pl.berry_stereographic(points, SUN_ELEVATION, SUN_AZIMUTH, SEPARATION, 1.0)
    assert degree.max() < 1e-12


def test_berry_pattern_is_continuous_where_the_babinet_point_crosses_the_zenith():
    """Sun at 71-81 degrees: the Babinet point (17.5 degrees above the sun)
    passes over the zenith at 72.5; the pattern at fixed directions changes
    smoothly with the sun's elevation."""
    rng = np.random.default_rng(2)
    d = pl.unit(rng.normal(size=(500, 3)))
    d[:, 2] = np.abs(d[:, 2]) + 0.2
    d = pl.unit(d)
    previous, jumps = None, []
    for elevation in np.arange(71.0, 81.0, 0.25):
        emitter = mi.load_dict(dict(sky(model="berry"),
                                    sun_direction=pl.sun_vector(elevation, 40).tolist()))
        q, u, _, _, _ = eval_sky(emitter, d)
        if previous is not None:
            jumps.append(np.abs(np.stack([q, u]) - previous).max())
        previous = np.stack([q, u])
    assert max(jumps) < 0.05, max(jumps)    # a sign flip would jump by up to 2 * 0.8


def test_the_sun_disk_is_unpolarized_and_the_sky_beside_it_is_not():
    """Within the sun's radius (0.27 degrees) the light is unpolarized; one
    degree away it is the Berry sky's (DoLP 0.04 between the Babinet and
    Brewster points)."""
    emitter = mi.load_dict(sky(model="berry"))
    off = pl.unit(SUN + 0.02 * np.array([0.0, 0.0, 1.0]))          # ~1 degree away
    rim = pl.unit(SUN + 0.004 * np.array([0.0, 0.0, 1.0]))         # ~0.2 degree away
    q, u, s0, x, y = eval_sky(emitter, np.stack([SUN, rim, off]))
    assert q[0] == 0 and u[0] == 0 and q[1] == 0 and u[1] == 0
    assert s0[0] > 1e3 * s0[2]
    degree, e = pl.berry_stereographic(off[None], SUN_ELEVATION, SUN_AZIMUTH, SEPARATION,
                                       DOLP_MAX)
    eq, eu = pl.linear_stokes(degree, e, x[2:], y[2:])
    assert degree[0] > 0.03
    assert abs(q[2] - eq[0]) < TOL and abs(u[2] - eu[0]) < TOL


def test_the_emitted_basis_is_stokes_basis_of_the_propagation():
    """eval's Stokes vector read in stokes_basis(w), w = -d, is the physics."""
    emitter = mi.load_dict(sky())
    rng = np.random.default_rng(3)
    d = pl.unit(rng.normal(size=(1000, 3)))
    d[:, 2] = np.abs(d[:, 2]) + 0.05
    d = pl.unit(d)
    q, u, _, x, y = eval_sky(emitter, d)
    degree, e = pl.rayleigh(d, SUN, DOLP_MAX)
    eq, eu = pl.linear_stokes(degree, e, x, y)
    assert np.abs(q - eq).max() < TOL and np.abs(u - eu).max() < TOL


# ---------------------------------------------------------------- a rolled camera

@pytest.mark.parametrize("roll", [30.0, 90.0, -45.0])
def test_a_rolled_camera_turns_the_aolp_by_the_roll(roll):
    """Turning the camera's up vector by rho about its viewing direction d
    turns the basis x = d x up by -rho about the light's propagation -d, so
    the AoLP of the centre pixel (same sky direction) grows by rho; every
    pixel still matches the formula."""
    d = pl.unit(SKY_VIEW["target"])
    up0 = pl.unit(np.array([0.0, 0.0, 1.0]) - d[2] * d)
    side = np.cross(d, up0)
    r = math.radians(roll)
    up = math.cos(r) * up0 + math.sin(r) * side     # rotated by +rho about d
    assert np.allclose(np.cross(up0, up) @ d, math.sin(r))
    (q0, u0, _, _), _ = render_sky_view(width=33, height=25)
    (q, u, _, _), (eq, eu, _) = render_sky_view(width=33, height=25, up=up.tolist())
    turned = angle_difference(aolp_deg(q[12, 16], u[12, 16]), aolp_deg(q0[12, 16], u0[12, 16]))
    assert abs(angle_difference(turned, roll)) < 1e-3, turned
    assert np.abs(q - eq).max() < TOL and np.abs(u - eu).max() < TOL


# ---------------------------------------------------------------- reflection by a metal

ETA, K = 0.27, 2.8      # a copper-like index with strong retardance (S3 up to 0.5)
REFLECTION_VIEW = dict(origin=[0, -3, 1.2], target=[0, 0, 0], up=[0, 0, 1], fov=40)


def reflection_scene(**emitter):
    plane = {"plane": {"type": "rectangle", "to_world": mi.ScalarTransform4f().scale(100),
                       "bsdf": {"type": "conductor", "eta": ETA, "k": K}}}
    return pl.scene(dict(sky(), **emitter), pl.camera(**REFLECTION_VIEW), plane)


def expected_reflection(d, up):
    """(q, u, v, F, incident Stokes in the s/p frame) of the plane z = 0
    reflecting the Rayleigh sky (proof/polarized_light.py: the reference's
    Fresnel matrix in the s/p frames of reflection, rotated into the camera
    basis)."""
    return pl.reflected(d, up, pl.rayleigh_incident(SUN, DOLP_MAX), ETA, K)


def test_a_smooth_metal_reflects_the_sky_through_its_fresnel_matrix():
    image, loaded = pl.render_stokes(reflection_scene())
    _, d = pl.pixel_rays(loaded)
    q, u, v, _ = pl.normalized(image)
    eq, eu, ev, F, _ = expected_reflection(d, pl.camera_up(loaded))
    assert np.abs(ev).max() > 0.3                  # the metal turns linear into circular
    for got, want in ((q, eq), (u, eu), (v, ev)):
        assert np.abs(got - want).max() < TOL
    # an unpolarized sky would be 0.2-0.4 off: the test sees the sky's polarization
    assert np.abs(q - F[..., 1, 0] / F[..., 0, 0]).max() > 0.2


def test_the_unpolarized_variant_renders_the_intensity(variant_switch):
    """In llvm_ad_spectral the sky is sunsky's (bit for bit) and equals the
    polarized render's S0 where the sky is seen directly. Off the metal the
    polarized S0 differs by the Fresnel matrix's m01 q_in / m00 (the
    polarization of the sky changes how much of it a metal reflects)."""
    cam = pl.camera(**SKY_VIEW)
    polarized, _ = pl.render_stokes(pl.scene(sky(), cam))
    reflected, loaded = pl.render_stokes(reflection_scene())
    _, d = pl.pixel_rays(loaded)
    _, _, _, F, stokes_in = expected_reflection(d, pl.camera_up(loaded))
    q_in = stokes_in[..., 1]

    variant_switch("llvm_ad_spectral")
    plain, _ = pl.render_stokes(pl.scene(sky(), cam))
    sunsky, _ = pl.render_stokes(pl.scene({"type": "sunsky", "sun_direction": SUN.tolist()}, cam))
    plain_reflected, _ = pl.render_stokes(reflection_scene())
    assert np.array_equal(plain.stokes, sunsky.stokes)
    s0, s0_plain = polarized.stokes[:, :, 0], plain.stokes[:, :, 0]
    assert np.abs(s0 - s0_plain).max() <= TOL * np.abs(s0_plain).max()
    ratio = reflected.stokes[:, :, 0].sum(-1) / plain_reflected.stokes[:, :, 0].sum(-1)
    predicted = 1 + F[..., 0, 1] / F[..., 0, 0] * q_in
    assert np.abs(predicted - 1).max() > 0.01
    assert np.abs(ratio - predicted).max() < TOL


@pytest.fixture
def variant_switch():
    def switch(name):
        use_variant(name)
    yield switch
    use_variant("llvm_ad_spectral_polarized")


# ---------------------------------------------------------------- sampling, parameters

def test_sampling_is_the_intensitys_and_carries_the_polarization():
    scene = mi.load_dict({"type": "scene", "sky": sky(model="berry")})
    emitter = scene.emitters()[0]
    reference = mi.load_dict({"type": "sunsky", "sun_direction": SUN.tolist()})
    reference.set_scene(scene)
    n = 4096
    it = dr.zeros(mi.Interaction3f, n)
    it.wavelengths = mi.UnpolarizedSpectrum(450.0, 520.0, 600.0, 690.0)
    rng = np.random.default_rng(4)
    sample = mi.Point2f(*rng.random((2, n)).astype(np.float32))
    ds, weight = emitter.sample_direction(it, sample)
    ds_ref, weight_ref = reference.sample_direction(it, sample)
    assert np.array_equal(np.array(ds.d), np.array(ds_ref.d))
    assert np.array_equal(np.array(ds.pdf), np.array(ds_ref.pdf))
    assert np.array_equal(np.array(emitter.pdf_direction(it, ds)),
                          np.array(reference.pdf_direction(it, ds_ref)))
    w00, w_ref = np.array(weight[0, 0]), np.array(weight_ref[0, 0])
    assert np.array_equal(w00, w_ref)
    value = emitter.eval_direction(it, ds)
    assert np.array_equal(np.array(value[0, 0]),
                          np.array(reference.eval_direction(it, ds_ref)[0, 0]))
    # the same polarization in the sample's weight as in eval_direction (where
    # both are lit: sunsky's own eval_direction can miss a sun sample drawn at
    # the disk's rim)
    lit = (w00 > 0) & (np.array(value[0, 0]) > 0)
    assert lit.mean() > 0.9
    for i in (1, 2, 3):
        ratio_weight = np.array(weight[i, 0])[lit] / w00[lit]
        ratio_value = np.array(value[i, 0])[lit] / np.array(value[0, 0])[lit]
        assert np.abs(ratio_weight - ratio_value).max() < TOL
    assert np.abs(np.array(weight[1, 0])).max() > 0          # polarized
    # the sample names this emitter (an adjoint pass re-evaluates ds.emitter)
    assert dr.all(ds.emitter == mi.EmitterPtr(emitter))
    assert scene.environment() is emitter


@pytest.mark.parametrize("emitter", [
    {"type": "polarized_sky", "sun_direction": [0.0, 0.6, 0.8]},
    {"type": "polarized_sky", "sun_direction": [0.0, 0.6, 0.8], "radiance": 1.0},
    {"type": "polarized_emitter", "lamp": {"type": "constant"}},
], ids=["sunsky", "radiance", "polarized_emitter"])
def test_shadow_rays_reach_occluders_beyond_the_unit_sphere(emitter):
    """Mitsuba 3.9.1 never calls a Python emitter's set_scene, so the
    wrapped infinite emitter keeps a unit bounding sphere and put its
    sampled point 2 units away: a roof 5 units up did not shadow. Now the
    point is wrapped.FAR away and the roof shadows every sample."""
    from mitsuba_pbrdf.emitters.wrapped import FAR

    roof = {"type": "rectangle", "to_world": mi.ScalarTransform4f().translate([0, 0, 5])
            .scale(1000).rotate([1, 0, 0], 180)}
    n = 256
    it = dr.zeros(mi.SurfaceInteraction3f, n)
    it.wavelengths = mi.UnpolarizedSpectrum(450.0, 520.0, 600.0, 690.0)
    it.n = mi.Normal3f(0, 0, 1)
    rng = np.random.default_rng(2)
    sample = mi.Point2f(*rng.random((2, n)).astype(np.float32))
    open_sky = mi.load_dict({"type": "scene", "sky": emitter})
    roofed = mi.load_dict({"type": "scene", "sky": emitter, "roof": roof})
    ds, weight = open_sky.sample_emitter_direction(it, sample, True)
    up = np.array(ds.d.z) > 0.05
    assert np.allclose(np.array(ds.dist), FAR) and up.sum() > 20
    assert np.all(np.array(weight[0, 0])[:, up] > 0)
    _, shadowed = roofed.sample_emitter_direction(it, sample, True)
    assert np.all(np.array(shadowed[0, 0])[:, up] == 0)


def test_a_constant_radiance_replaces_the_sunsky_intensity():
    emitter = mi.load_dict(sky(radiance=2.5))
    d = pl.unit(np.array([[0.3, 0.2, 0.9], [0.0, 0.9, -0.2]]))
    q, u, s0, x, y = eval_sky(emitter, d)
    assert np.allclose(s0, 2.5)
    degree, e = pl.rayleigh(d, SUN, DOLP_MAX)
    eq, eu = pl.linear_stokes(degree, e, x, y)
    assert np.abs(q - eq).max() < TOL and np.abs(u - eu).max() < TOL


def test_dolp_max_is_exposed_and_differentiable():
    emitter = mi.load_dict(sky())
    params = mi.traverse(emitter)
    nondifferentiable = int(mi.ParamFlags.NonDifferentiable)
    assert "dolp_max" in params and not params.flags("dolp_max") & nondifferentiable
    # sun_direction too (the pattern's; test_polarized_sky_gradients.py)
    assert not params.flags("sun_direction") & nondifferentiable
    dr.enable_grad(params["dolp_max"])
    params.update()
    d = pl.unit(np.array([[0.3, -0.5, 0.6]]))
    si = dr.zeros(mi.SurfaceInteraction3f, 1)
    si.wi = mi.Vector3f(*(-d.T))
    si.wavelengths = mi.UnpolarizedSpectrum(550.0)
    value = emitter.eval(si)
    q = value[1, 0][0] / dr.detach(value[0, 0][0])
    dr.backward(q)
    grad = float(dr.grad(params["dolp_max"])[0])
    assert abs(grad - float(dr.detach(q)[0]) / DOLP_MAX) < 1e-6
    params["dolp_max"] = 0.4
    params.update()
    q2, _, _, _, _ = eval_sky(emitter, d)
    assert abs(q2[0] - float(dr.detach(q)[0]) / 2) < 1e-6


def test_changing_the_sun_direction_moves_pattern_and_intensity():
    emitter = mi.load_dict(sky())
    params = mi.traverse(emitter)
    other = pl.sun_vector(60, -30)
    params["sun_direction"] = mi.Vector3f(other)
    params.update()
    fresh = mi.load_dict(dict(sky(), sun_direction=other.tolist()))
    d = pl.unit(np.array([[0.3, 0.2, 0.9], [-0.5, 0.4, 0.3]]))
    for a, b in zip(eval_sky(emitter, d)[:3], eval_sky(fresh, d)[:3]):
        assert np.allclose(a, b, rtol=1e-6)


# ---------------------------------------------------------------- date, time and place

#: noon (UTC, longitude 0) of the June solstice at 48° N
SOLSTICE = dict(year=2024, month=6, day=21, hour=12.0, minute=0.0, second=0.0,
                latitude=48.0, longitude=0.0, timezone=0.0)


def sunsky_sun(**when):
    params = mi.traverse(mi.load_dict(dict({"type": "sunsky"}, **when)))
    return pl.unit(np.array(params["sun_direction"], np.float64).ravel())


def test_a_date_time_and_place_put_the_pattern_where_sunsky_puts_the_sun():
    """Mitsuba 3.9.1's sunsky takes year ... timezone instead of a sun
    direction; polarized_sky hands them on and polarizes around the sun
    sunsky computes. The astronomy, checked on its own: at noon of the June
    solstice the sun stands 90° - latitude + 23.44° high (65.44° at 48° N;
    the equation of time moves noon by 1.7 min, 0.01° of elevation). In
    sunsky's local frame the noon sun of the northern hemisphere is at +X and
    the morning sun at -Y (measured: +X south, +Y west)."""
    emitter = mi.load_dict(dict({"type": "polarized_sky", "dolp_max": DOLP_MAX}, **SOLSTICE))
    sun = sunsky_sun(**SOLSTICE)
    assert np.abs(np.array(emitter.sun) - sun).max() < 1e-6
    assert abs(np.degrees(np.arcsin(sun[2])) - (90.0 - 48.0 + 23.44)) < 0.05
    assert sun[0] > 0.4 and abs(sun[1]) < 0.01
    d = pl.unit(np.array([[0.3, 0.2, 0.9], [-0.5, 0.4, 0.3], [0.1, -0.9, 0.2]]))
    q, u, s0, x, y = eval_sky(emitter, d)
    degree, e = pl.rayleigh(d, sun, DOLP_MAX)
    eq, eu = pl.linear_stokes(degree, e, x, y)
    assert np.abs(q - eq).max() < TOL and np.abs(u - eu).max() < TOL
    # the same intensity as sunsky's at that date, time and place
    plain = mi.load_dict(dict({"type": "sunsky"}, **SOLSTICE))
    si = dr.zeros(mi.SurfaceInteraction3f, len(d))
    si.wi = mi.Vector3f(*(-d.T))
    si.wavelengths = mi.UnpolarizedSpectrum(450.0, 520.0, 600.0, 690.0)   # eval_sky's
    assert np.allclose(s0, np.array(plain.eval(si)[0, 0][0]), rtol=1e-6)


def test_a_new_hour_moves_the_sun_and_the_pattern_follows():
    emitter = mi.load_dict(dict({"type": "polarized_sky"}, **SOLSTICE))
    params = mi.traverse(emitter)
    assert params.flags("sun_direction") & int(mi.ParamFlags.ReadOnly)
    params["intensity.hour"] = mi.Float(9.0)
    params.update()
    morning = sunsky_sun(**dict(SOLSTICE, hour=9.0))
    assert morning[1] < -0.6                      # the morning sun, at -Y
    assert np.abs(np.array(emitter.sun) - morning).max() < 1e-6
    assert np.abs(np.array(params["sun_direction"]).ravel() - morning).max() < 1e-6
    fresh = mi.load_dict({"type": "polarized_sky", "sun_direction": morning.tolist()})
    d = pl.unit(np.array([[0.3, 0.2, 0.9], [-0.5, 0.4, 0.3]]))
    for a, b in zip(eval_sky(emitter, d)[:3], eval_sky(fresh, d)[:3]):
        assert np.allclose(a, b, rtol=1e-5, atol=1e-6)
    with pytest.raises(Exception, match="Read-Only"):
        params["sun_direction"] = mi.Vector3f(0.0, 0.0, 1.0)


# ---------------------------------------------------------------- hostile input

NAN, INF = float("nan"), float("inf")
S = [0.3, 0.2, 0.8]

#: (parameters, error type or None for Mitsuba's parser, text the last line holds)
HOSTILE = [
    ({"sun_direction": [0, 0, 0]}, ValueError, "'sun_direction' has zero length"),
    ({"sun_direction": [NAN, 0, 1]}, ValueError, "'sun_direction' must be 3 finite"),
    ({"sun_direction": [INF, 0, 1]}, ValueError, "'sun_direction' must be 3 finite"),
    ({}, ValueError, "'sun_direction' is required"),
    ({"sun_direction": [0.3, 0, -0.2]}, ValueError, "'sun_direction' puts the sun 33.7° below"),
    ({"sun_direction": "up"}, TypeError, "'sun_direction' must be a vector"),
    ({"sun_direction": S, "dolp_max": -0.1}, ValueError, "'dolp_max' must be in [0, 1]"),
    ({"sun_direction": S, "dolp_max": 1.5}, ValueError, "'dolp_max' must be in [0, 1]"),
    ({"sun_direction": S, "dolp_max": NAN}, ValueError, "'dolp_max' must be finite"),
    ({"sun_direction": S, "dolp_max": "high"}, TypeError, "'dolp_max' must be a number"),
    ({"sun_direction": S, "model": "mie"}, ValueError, "'model' is 'mie'; valid values: rayleigh, berry"),
    ({"sun_direction": S, "model": 3.0}, TypeError, "'model' must be a string"),
    ({"sun_direction": S, "model": "berry", "neutral_point_separation": 120.0}, ValueError,
     "'neutral_point_separation' must be in [0, 90]"),
    ({"sun_direction": S, "model": "berry", "neutral_point_separation": NAN}, ValueError,
     "'neutral_point_separation' must be finite"),
    ({"sun_direction": S, "neutral_point_separation": 20.0}, ValueError,
     "'neutral_point_separation' applies to model 'berry' only"),
    ({"sun_direction": S, "turbidity": 0.5}, ValueError, "'turbidity' must be in [1, 10]"),
    ({"sun_direction": S, "turbidity": 12.0}, ValueError, "'turbidity' must be in [1, 10]"),
    ({"sun_direction": S, "albedo": 1.5}, ValueError, "'albedo' must be in [0, 1]"),
    ({"sun_direction": S, "albedo": {"type": "spectrum", "value": 2.0}}, ValueError,
     "Albedo values must be in [0, 1]"),
    ({"sun_direction": S, "radiance": 1.0, "turbidity": 3.0}, ValueError,
     "'turbidity' belongs to the sunsky intensity, which 'radiance' replaces"),
    ({"sun_direction": S, "radiance": -1.0}, ValueError, "'radiance' must be >= 0"),
    ({"sun_direction": S, "radiance": NAN}, ValueError, "'radiance' contains NaN"),
    ({"sun_direction": S, "radiance": {"type": "rgb", "value": [1.0, -1.0, 0.5]}}, ValueError,
     "'radiance' must be >= 0"),
    ({"sun_direction": S, "light": {"type": "point"}}, ValueError,
     "nested emitter must be an infinite emitter"),
    ({"sun_direction": S, "a": {"type": "constant"}, "b": {"type": "constant"}}, ValueError,
     "at most one intensity"),
    ({"sun_direction": S, "radiance": 1.0, "env": {"type": "constant"}}, ValueError,
     "at most one intensity"),
    ({"sun_direction": S, "dolpmax": 0.5}, None, '"dolpmax"'),
    ({"sun_direction": S, "hour": 12.0}, ValueError,
     "give 'sun_direction' or a date, time and place (year, month, day, hour, minute"),
    ({"hour": 12.0, "month": 13}, ValueError, "'month' must be in [1, 12]"),
    ({"hour": 12.0, "year": 2024.5}, ValueError, "'year' must be a whole number, got 2024.5"),
    ({"hour": 12.0, "latitude": 95.0}, ValueError, "'latitude' must be in [-90, 90]"),
    ({"hour": NAN}, ValueError, "'hour' must be finite"),
    ({"hour": 12.0, "radiance": 1.0}, ValueError,
     "'hour' belongs to the sunsky intensity, which 'radiance' replaces"),
    ({"hour": 23.0, "month": 6, "day": 21, "latitude": 48.0, "longitude": 0.0,
      "timezone": 0.0}, ValueError, "put the sun 17.2° below the horizon"),
]


def load_error(params, plugin="polarized_sky"):
    """(last line, whole message) of the error loading the plugin, or None."""
    try:
        mi.load_dict(dict({"type": plugin}, **params))
    except Exception as e:      # Mitsuba wraps the plugin's exception in a RuntimeError
        return str(e).strip().splitlines()[-1], str(e)
    return None


def check_message(error, kind, text, plugin="polarized_sky"):
    assert error is not None, "loaded without error"
    last, whole = error
    if kind is not None:
        assert last.startswith(f"{kind.__name__}: {plugin}: "), last
    assert text in (last if kind is not None else whole), whole


@pytest.mark.parametrize("params,kind,text", HOSTILE, ids=[repr(h[0])[:50] for h in HOSTILE])
def test_hostile_input_is_refused_at_load_time_naming_the_parameter(params, kind, text):
    check_message(load_error(params), kind, text)


def test_the_wrong_variant_is_named(variant_switch):
    variant_switch("llvm_ad_mono_polarized")
    check_message(load_error({"sun_direction": S}), ValueError,
                  "the default sunsky intensity needs an RGB or spectral variant, not "
                  "'llvm_ad_mono_polarized'")
    emitter = mi.load_dict(sky(radiance=1.0))     # a given radiance works there
    assert emitter.model == "rayleigh"


@pytest.mark.parametrize("key,value,text", [
    ("dolp_max", 1.5, "'dolp_max' must be in [0, 1]"),
    ("sun_direction", [0.0, 0.0, 0.0], "'sun_direction' has zero length"),
])
def test_a_bad_parameter_update_is_refused(key, value, text):
    params = mi.traverse(mi.load_dict(sky()))
    params[key] = mi.Vector3f(value) if isinstance(value, list) else value
    with pytest.raises(Exception) as error:
        params.update()
    assert text in str(error.value).strip().splitlines()[-1]


SCENE_XML = """<scene version="3.0.0">
    <integrator type="stokes"><integrator type="path"/></integrator>
    <sensor type="perspective"><float name="fov" value="60"/>
        <transform name="to_world"><lookat origin="0,0,0" target="-0.6,0.35,0.7" up="0,0,1"/>
        </transform><film type="hdrfilm"><integer name="width" value="8"/>
        <integer name="height" value="6"/></film></sensor>
    <emitter type="polarized_sky">
        <vector name="sun_direction" x="0.3" y="0.2" z="0.8"/>
        <float name="dolp_max" value="DOLP"/>
    </emitter>
</scene>"""


def pbrdf_render(tmp_path, dolp):
    import subprocess
    import sys

    scene = tmp_path / "sky.xml"
    scene.write_text(SCENE_XML.replace("DOLP", dolp))
    return subprocess.run([sys.executable, "-m", "mitsuba_pbrdf", "render", str(scene),
                           "--spp", "4", "--out", str(tmp_path / "sky")],
                          capture_output=True, text=True, timeout=300)


def test_pbrdf_render_renders_a_scene_file_with_the_sky(tmp_path):
    from mitsuba_pbrdf.stokes import dolp, luminance_stokes, read_stokes_exr

    result = pbrdf_render(tmp_path, "0.8")
    assert result.returncode == 0, result.stderr
    degree = dolp(luminance_stokes(read_stokes_exr(tmp_path / "sky.exr")), axis=-1)
    assert degree.min() > 0.05 and 0.5 < degree.max() <= 0.8 + TOL


def test_a_scene_file_with_a_bad_sky_fails_in_one_line(tmp_path):
    """pbrdf render: one line naming the parameter, exit status 2, no traceback."""
    result = pbrdf_render(tmp_path, "1.4")
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.stderr, result.stderr
    assert "polarized_sky: parameter 'dolp_max' must be in [0, 1]" in lines[0]


def test_a_refused_sky_leaves_later_renders_working():
    """The checks run before the emitter registers with Dr.Jit: a refused
    emitter (kept alive here by the exception's traceback) is not traced
    into the next render's calls."""
    errors = []
    for params, _, _ in HOSTILE:
        with pytest.raises(Exception) as error:
            mi.load_dict(dict({"type": "polarized_sky"}, **params))
        errors.append(error)
    (q, u, _, s0), (eq, eu, _) = render_sky_view()
    assert len(errors) == len(HOSTILE) and np.all(s0 > 0)
    assert np.abs(q - eq).max() < TOL and np.abs(u - eu).max() < TOL
