"""Emitters nested in emitters compose with their polarization (the BSDFs:
tests/bsdfs/test_perturbed.py).

**Emitter in emitter.** ``polarized_emitter`` is a linear diattenuator in
front of its lamp: principal transmittances T (1 + p) and T (1 - p) (module
docstring), so two of them at theta1 (inner) and theta2 (outer) pass, on the
polarizers' axis (light along local z, where the tilted-polarizer
approximation is exact), ``2 T1 T2 L cos²(theta1 - theta2)`` for p = 1
(Malus's law), polarized along the outer axis. Off axis each filter acts
with its axis projected across the ray; the expected Stokes vector is the
product of the two diattenuators' Mueller matrices, written here in their
trigonometric form from the projected axes' angles (the plugin uses an
algebraic form without angles), applied to the bare lamp's value from the
same call. Both sides are float32 products of a few terms: ``TOL = 1e-5`` of
the bare lamp's S0.
"""

import math

import drjit as dr
import mitsuba as mi
import numpy as np
import pytest

from proof.covering import pairwise, uncovered

TOL = 1e-5


# ------------------------------------------------------------ reference (NumPy)

def diattenuator(chi, degree, transmittance):
    """(..., 4, 4) Mueller matrix of a linear diattenuator whose axis is at
    ``chi`` (radians) in the Stokes basis: principal transmittances
    T (1 + p), T (1 - p)."""
    q, r = transmittance * (1 + degree), transmittance * (1 - degree)
    c, s = np.cos(2 * chi), np.sin(2 * chi)
    g = np.sqrt(q * r)
    m = np.zeros(np.shape(chi) + (4, 4))
    m[..., 0, 0] = (q + r) / 2
    m[..., 0, 1] = m[..., 1, 0] = (q - r) / 2 * c
    m[..., 0, 2] = m[..., 2, 0] = (q - r) / 2 * s
    m[..., 1, 1] = ((q + r) * c ** 2 + 2 * g * s ** 2) / 2
    m[..., 2, 2] = ((q + r) * s ** 2 + 2 * g * c ** 2) / 2
    m[..., 1, 2] = m[..., 2, 1] = (q + r - 2 * g) * c * s / 2
    m[..., 3, 3] = g
    return m


def axis_angle(angle_deg, w):
    """The angle (radians) of the axis (cos a, sin a, 0) projected across
    rays propagating along ``w`` (N x 3), in Mitsuba's Stokes basis of w."""
    a = np.array([math.cos(math.radians(angle_deg)), math.sin(math.radians(angle_deg)), 0.0])
    e = a - (w @ a)[:, None] * w
    x = vectors(mi.mueller.stokes_basis(mi.Vector3f(*w.T)))
    y = np.cross(w, x)
    return np.arctan2(np.sum(e * y, -1), np.sum(e * x, -1))


def vectors(v):
    """A Dr.Jit 3-vector as an N x 3 float64 array."""
    return np.stack([np.array(c, np.float64) for c in v], -1)


def first_column(value):
    """The Stokes vectors (N x 4, first wavelength) of emitters' Mueller values."""
    rows = [np.atleast_1d(np.array(value[i, 0], np.float64)[0]) for i in range(4)]
    return np.stack(np.broadcast_arrays(*rows), -1)     # a literal 0 has width 1


def filters(*layers, lamp):
    """``polarized_emitter``s nested around ``lamp``: ``layers`` (angle,
    degree, transmittance) from the innermost out."""
    emitter = lamp
    for angle, degree, transmittance in layers:
        emitter = {"type": "polarized_emitter", "angle": angle, "degree": degree,
                   "transmittance": transmittance, "inner": emitter}
    return emitter


def expected(bare, w, layers):
    """The bare lamp's Stokes vectors (N x 4) through ``layers``."""
    s = bare.copy()
    for angle, degree, transmittance in layers:
        s = np.einsum("nij,nj->ni", diattenuator(axis_angle(angle, w), degree, transmittance), s)
    return s


def directions(n, seed):
    rng = np.random.default_rng(seed)
    w = rng.normal(size=(n, 3))
    w = w / np.linalg.norm(w, axis=1, keepdims=True)
    return np.concatenate([[[0, 0, 1.0], [0, 0, -1.0]], w])


# ------------------------------------------------------------ emitter in emitter

@pytest.mark.parametrize("theta1,theta2", [(0, 90), (0, 0), (30, 75), (-20, 115)])
def test_emitter_in_emitter_follows_malus_law(theta1, theta2):
    """Crossed ideal polarizers pass nothing: the outer filter acts on the
    inner one's polarized light, not on its intensity."""
    layers = [(theta1, 1.0, 0.5), (theta2, 1.0, 0.5)]
    lamp = {"type": "constant", "radiance": 2.0}
    w = directions(30, 1)
    si = dr.zeros(mi.SurfaceInteraction3f, len(w))
    si.wi = mi.Vector3f(*w.T)      # an infinite emitter's light propagates along si.wi
    si.wavelengths = mi.UnpolarizedSpectrum(450.0, 520.0, 600.0, 690.0)
    bare = first_column(mi.load_dict(lamp).eval(si))
    seen = first_column(mi.load_dict(filters(*layers, lamp=lamp)).eval(si))
    L = bare[0, 0]
    # on the axis, +z: Malus, polarized along the outer axis
    delta = math.radians(theta1 - theta2)
    assert abs(seen[0, 0] - 2 * 0.25 * L * math.cos(delta) ** 2) < TOL * L
    if abs(math.cos(delta)) > 0.1:
        aolp = 0.5 * math.degrees(math.atan2(seen[0, 2], seen[0, 1]))
        assert abs((aolp - theta2 + 90) % 180 - 90) < 1e-3
    assert np.abs(seen - expected(bare, w, layers)).max() < TOL * L


@pytest.mark.parametrize("method", ["sample_direction", "eval_direction", "sample_ray"])
def test_emitter_in_emitter_composes_in_every_method(method):
    """An area lamp in a rectangle behind a leaky filter behind another one:
    what each method returns is the bare lamp's value through both filters."""
    layers = [(20.0, 0.7, 0.6), (65.0, 0.9, 0.8)]
    lamp = {"type": "area", "radiance": 3.0}

    scenes = [mi.load_dict({"type": "scene", "lamp": {"type": "rectangle", "emitter": wrapped}})
              for wrapped in (lamp, filters(*layers, lamp=lamp))]    # kept alive

    rng = np.random.default_rng(5)
    n = 64
    it = dr.zeros(mi.Interaction3f, n)
    it.p = mi.Point3f(*np.stack([rng.uniform(-2, 2, n), rng.uniform(-2, 2, n),
                                 rng.uniform(0.5, 3, n)]))
    it.wavelengths = mi.UnpolarizedSpectrum(450.0, 520.0, 600.0, 690.0)
    sample = mi.Point2f(*rng.uniform(size=(2, n)))
    ray_sample = mi.Point2f(*rng.uniform(size=(2, n)))
    out = []
    for scene in scenes:
        e = scene.emitters()[0]
        if method == "sample_ray":
            ray, value = e.sample_ray(0.0, 0.3, sample, ray_sample)
            w = vectors(ray.d)
        else:
            ds, value = e.sample_direction(it, sample)
            if method == "eval_direction":
                value = e.eval_direction(it, ds)
            w = -vectors(ds.d)
        out.append((first_column(value), w))
    (bare, w_bare), (seen, w) = out
    assert np.abs(w - w_bare).max() < 1e-6
    assert np.all(bare[:, 0] > 0)
    assert np.abs(seen - expected(bare, w, layers)).max() < TOL * bare[:, 0].max()


# ------------------------------------------------------------ to_world of the emitters

def singular():
    """A transform whose third column is the sum of the first two."""
    m = np.eye(4)
    m[:3, 2] = [1.0, 1.0, 0.0]
    return mi.ScalarTransform4f(m)


def stokes_map(path):
    """A 16 x 9 Stokes EXR at ``path`` (S0 = 1, S1 = 0.5, S2 = 0.2 everywhere)."""
    from mitsuba_pbrdf.stokes import write_stokes_exr

    s = np.zeros((9, 16, 4, 3), np.float32)
    s[:, :, 0], s[:, :, 1], s[:, :, 2] = 1.0, 0.5, 0.2
    write_stokes_exr(path, s, bands=list("RGB"))
    return str(path)


def emitter_dict(kind, tmp_path, **extra):
    base = {"polarized_sky": {"type": "polarized_sky", "sun_direction": [0.0, 0.5, 1.0],
                              "radiance": 1.0},
            "sunsky": {"type": "polarized_sky", "sun_direction": [0.0, 0.5, 1.0]},
            "stokes_envmap": {"type": "stokes_envmap",
                              "filename": stokes_map(tmp_path / "map.exr")},
            "polarized_emitter": {"type": "polarized_emitter",
                                  "lamp": {"type": "constant"}}}[kind]
    return dict(base, **extra)


@pytest.mark.parametrize("kind", ["polarized_sky", "sunsky", "stokes_envmap",
                                  "polarized_emitter"])
@pytest.mark.parametrize("to_world,error,text", [
    (singular, ValueError, "parameter 'to_world' is singular (its 3 x 3 part has determinant 0)"),
    (lambda: mi.ScalarTransform4f(np.diag([1.0, 1.0, np.nan, 1.0])), ValueError,
     "parameter 'to_world' contains NaN or infinite values"),
    (lambda: 3.0, TypeError, "parameter 'to_world' must be a transform, got float"),
], ids=["singular", "nan", "float"])
def test_a_bad_to_world_is_named_at_load_time(kind, to_world, error, text, tmp_path):
    """Was: ZeroDivisionError (polarized_sky), LinAlgError: Singular matrix
    (stokes_envmap), a silent load (polarized_emitter's singular or
    stokes_envmap's NaN transform), AttributeError (a float)."""
    with pytest.raises(Exception) as raised:
        mi.load_dict(emitter_dict(kind, tmp_path, to_world=to_world()))
    last = str(raised.value).strip().splitlines()[-1]
    plugin = "polarized_sky" if kind == "sunsky" else kind
    assert last.startswith(f"{error.__name__}: {plugin}: {text}"), last


# ------------------------------------------------------------ polarized_sky's nested emitter

@pytest.mark.parametrize("inner", ["polarized_emitter", "stokes_envmap"])
def test_a_polarized_emitter_nested_in_the_sky_is_refused(inner, tmp_path):
    """The sky replaces its intensity's polarization: a polarized intensity
    was silently unpolarized (a 0-degree filter's S1 = S0 became 0)."""
    with pytest.raises(Exception) as raised:
        mi.load_dict({"type": "polarized_sky", "sun_direction": [0.0, 0.5, 1.0],
                      "inner": emitter_dict(inner, tmp_path)})
    last = str(raised.value).strip().splitlines()[-1]
    assert last.startswith("ValueError: polarized_sky: the nested emitter is polarized"), last
    # unpolarized ones, a transparent filter included, are the sky's intensity
    for unpolarized in ({"type": "constant"},
                        {"type": "polarized_emitter", "degree": 0.0, "lamp": {"type": "constant"}}):
        mi.load_dict({"type": "polarized_sky", "sun_direction": [0.0, 0.5, 1.0],
                      "inner": unpolarized})


# ------------------------------------------------------------ the emitters' covering array

SUN = [0.0, 0.5, 1.0]
OUTER_FILTERS = {"filter": [(65.0, 0.9, 0.7)], "filter2": [(65.0, 0.9, 0.7), (-10.0, 1.0, 0.5)]}
EMITTER_FACTORS = {
    "inner": ["constant", "area", "spot", "filter", "stokes_envmap", "sky"],
    "outer": ["filter", "filter2", "sky"],
    "variant": ["llvm_ad_spectral_polarized", "llvm_ad_mono_polarized", "llvm_ad_spectral"],
    "to_world": ["identity", "rotation", "scaled", "singular"],
    "method": ["eval", "eval_direction", "sample_direction", "sample_ray"],
}


def transform(name):
    """The outer plugin's ``to_world`` level as (Mitsuba transform or None, 3 x 3)."""
    rotation = mi.ScalarTransform4f().rotate((np.array([1.0, 2.0, 0.5]) / math.sqrt(5.25)).tolist(),
                                             70.0)        # Mitsuba wants a unit axis
    t = {"identity": None, "rotation": rotation, "scaled": rotation.scale(2.0),
         "singular": singular()}[name]
    m = np.eye(3) if t is None else np.array(t.matrix, np.float64).reshape(4, 4)[:3, :3]
    return t, m


def inner_dict(kind, tmp_path):
    return {"constant": {"type": "constant", "radiance": 1.5},
            "area": {"type": "area", "radiance": 1.5},
            "spot": {"type": "spot", "intensity": 4.0, "cutoff_angle": 60.0,
                     "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, -1],
                                                                target=[0, 0, 1], up=[0, 1, 0])},
            "filter": filters((20.0, 0.8, 0.9), lamp={"type": "constant", "radiance": 1.5}),
            "stokes_envmap": emitter_dict("stokes_envmap", tmp_path),
            "sky": {"type": "polarized_sky", "sun_direction": [0.3, -0.2, 1.0], "radiance": 1.5,
                    "dolp_max": 0.6}}[kind]


def outer_dict(row, inner):
    t, _ = transform(row["to_world"])
    extra = {} if t is None else {"to_world": t}
    if row["outer"] == "sky":
        return dict({"type": "polarized_sky", "sun_direction": SUN, "dolp_max": 0.7,
                     "inner": inner}, **extra)
    emitter = inner
    for angle, degree, transmittance in OUTER_FILTERS[row["outer"]]:
        emitter = dict({"type": "polarized_emitter", "angle": angle, "degree": degree,
                        "transmittance": transmittance, "inner": emitter}, **extra)
    return emitter


def load_emitter(d, kind):
    """``(keep-alive, emitter)``: an area lamp lives in a rectangle at z = 0
    facing +z."""
    if kind != "area":
        return None, mi.load_dict(d)
    scene = mi.load_dict({"type": "scene", "lamp": {"type": "rectangle", "emitter": d}})
    return scene, scene.emitters()[0]


def outer_mueller(row, w):
    """(N, 4, 4) NumPy Mueller matrix of the outer plugin for light along ``w``
    (None for the sky: its polarization replaces the intensity's)."""
    from proof import polarized_light as pl

    _, m = transform(row["to_world"])
    out = np.broadcast_to(np.eye(4), (len(w), 4, 4))
    if row["outer"] == "sky":
        return None
    for angle, degree, transmittance in OUTER_FILTERS[row["outer"]]:
        a = m @ np.array([math.cos(math.radians(angle)), math.sin(math.radians(angle)), 0.0])
        e = a - (w @ a)[:, None] * w
        x = vectors(mi.mueller.stokes_basis(mi.Vector3f(*w.T)))
        chi = np.arctan2(np.sum(e * np.cross(w, x), -1), np.sum(e * x, -1))
        out = diattenuator(chi, degree, transmittance) @ out
    del pl
    return out


def call(emitter, row, rng_seed, n=48):
    """``(value, w)``: the row's method on ``n`` fixed inputs; w the
    propagation direction of the light (N x 3)."""
    rng = np.random.default_rng(rng_seed)
    wavelengths = (450.0, 520.0, 600.0, 690.0)
    method = row["method"]
    if method == "sample_ray":
        ray, value = emitter.sample_ray(0.0, mi.Float(rng.uniform(size=n)),
                                        mi.Point2f(*rng.uniform(size=(2, n))),
                                        mi.Point2f(*rng.uniform(size=(2, n))))
        return value, vectors(ray.d)
    it = dr.zeros(mi.Interaction3f, n)
    it.p = mi.Point3f(rng.uniform(-0.5, 0.5, n), rng.uniform(-0.5, 0.5, n), rng.uniform(1, 2, n))
    if mi.is_spectral:
        it.wavelengths = mi.UnpolarizedSpectrum(*wavelengths)
    if method == "eval":
        if row["inner"] == "area":     # points on the lamp seen from it.p
            target = np.stack([rng.uniform(-1, 1, n), rng.uniform(-1, 1, n), np.zeros(n)])
            d = target - np.array([np.array(c) for c in it.p])
            ray = mi.Ray3f(it.p, mi.Vector3f(*(d / np.linalg.norm(d, axis=0))))
            ray.wavelengths = it.wavelengths
            si = row["_scene"].ray_intersect(ray)
            return emitter.eval(si), -vectors(ray.d)
        w = directions(n - 2, rng_seed)
        si = dr.zeros(mi.SurfaceInteraction3f, n)
        si.wi = mi.Vector3f(*w.T)
        si.wavelengths = it.wavelengths
        return emitter.eval(si), w
    ds, value = emitter.sample_direction(it, mi.Point2f(*rng.uniform(size=(2, n))))
    if method == "eval_direction":
        value = emitter.eval_direction(it, ds)
    return value, -vectors(ds.d)


def refusal(row):
    """The one line a row must be refused with, or None."""
    if row["to_world"] == "singular":
        plugin = "polarized_sky" if row["outer"] == "sky" else "polarized_emitter"
        return f"ValueError: {plugin}: parameter 'to_world' is singular"
    if row["outer"] == "sky" and row["inner"] in ("area", "spot"):
        return "ValueError: polarized_sky: the nested emitter must be an infinite emitter"
    if row["outer"] == "sky" and row["inner"] in ("filter", "stokes_envmap", "sky") \
            and "polarized" in row["variant"]:
        return "ValueError: polarized_sky: the nested emitter is polarized"
    return None


EMITTER_ROWS = sorted(pairwise(EMITTER_FACTORS), key=lambda r: r["variant"])


def test_the_emitter_array_covers_every_pair():
    assert not uncovered(EMITTER_FACTORS, EMITTER_ROWS)
    assert len(EMITTER_ROWS) <= 30


@pytest.mark.parametrize("row", EMITTER_ROWS, ids=["-".join(r.values()) for r in EMITTER_ROWS])
def test_nested_emitters_compose(row, tmp_path):
    """Each row: the outer plugin's value is its Mueller matrix (NumPy) times
    the bare inner emitter's value from the same call on the same inputs, or
    the sky's pattern on the inner's intensity, or a named refusal. Rows
    where the bare lamp returns nothing (a spot's ``eval``) still check that
    nothing NaN comes out."""
    from mitsuba_pbrdf import use_variant
    from proof import polarized_light as pl

    use_variant(row["variant"])
    inner = inner_dict(row["inner"], tmp_path)
    expected_error = refusal(row)
    if expected_error:
        with pytest.raises(Exception) as raised:
            load_emitter(outer_dict(row, inner), row["inner"])
        assert str(raised.value).strip().splitlines()[-1].startswith(expected_error)
        return
    keep, outer = load_emitter(outer_dict(row, inner), row["inner"])
    keep_bare, bare = load_emitter(inner, row["inner"])
    row = dict(row, _scene=keep)
    value, w = call(outer, row, 11)
    row["_scene"] = keep_bare
    bare_value, w_bare = call(bare, row, 11)
    assert np.abs(w - w_bare).max() < 1e-6
    if not mi.is_polarized:
        got, ref = np.array(value, np.float64), np.array(bare_value, np.float64)
        scale = 1.0 if row["outer"] == "sky" else \
            np.prod([t for _, _, t in OUTER_FILTERS[row["outer"]]])
        assert np.all(np.isfinite(got)) and np.allclose(got, scale * ref, rtol=1e-6, atol=0)
        return
    got, ref = first_column(value), first_column(bare_value)
    assert np.all(np.isfinite(got))
    peak = max(ref[:, 0].max(), 1e-30)
    m = outer_mueller(row, w)
    if m is not None:
        want = np.einsum("nij,nj->ni", m, ref)
    else:       # the sky: Rayleigh's pattern (proof's form) on the inner's intensity
        sun = pl.unit(np.array(SUN))
        degree, e = pl.rayleigh(-w, sun, 0.7)
        x = vectors(mi.mueller.stokes_basis(mi.Vector3f(*w.T)))
        q, u = pl.linear_stokes(degree, e, x, np.cross(w, x))
        want = ref[:, :1] * np.stack([np.ones_like(q), q, u, np.zeros_like(q)], -1)
    assert np.abs(got - want).max() < TOL * peak, np.abs(got - want).max() / peak


def rotator(forward, a, b):
    """(N, 4, 4) Stokes rotator from basis vector ``a`` to ``b`` (both
    across ``forward``), Mitsuba's sign (rotate_stokes_basis), by angles."""
    theta = np.arctan2(np.sum(forward * np.cross(a, b), -1), np.sum(a * b, -1))
    r = np.zeros((len(forward), 4, 4))
    r[:, 0, 0] = r[:, 3, 3] = 1
    r[:, 1, 1] = r[:, 2, 2] = np.cos(2 * theta)
    r[:, 1, 2], r[:, 2, 1] = np.sin(2 * theta), -np.sin(2 * theta)
    return r


# ------------------------------------------------------------ to_world turns the polarization

def varied_map(path):
    """A 32 x 17 Stokes EXR whose S0 and linear polarization vary smoothly
    over the sphere (DoLP <= 0.6)."""
    from mitsuba_pbrdf.stokes import write_stokes_exr

    j, i = np.meshgrid(np.arange(17), np.arange(32), indexing="ij")
    phi, theta = 2 * np.pi * (i + 0.5) / 32, np.pi * j / 16
    s = np.zeros((17, 32, 4, 3), np.float32)
    s[:, :, 0] = (1.5 + np.cos(phi) * np.sin(theta))[..., None]
    dolp, chi = 0.6 * np.sin(theta) ** 2, phi + theta
    s[:, :, 1] = (s[:, :, 0, 0] * dolp * np.cos(2 * chi))[..., None]
    s[:, :, 2] = (s[:, :, 0, 0] * dolp * np.sin(2 * chi))[..., None]
    write_stokes_exr(path, s, bands=list("RGB"))
    return str(path)


@pytest.mark.parametrize("kind", ["stokes_envmap", "sky-berry", "sky-texture", "sky-sunsky",
                                  "filter"])
@pytest.mark.parametrize("level", ["rotation", "scaled"])
def test_to_world_turns_the_light_and_its_polarization(kind, level, tmp_path):
    """An emitter turned by R, seen along R w, is the unturned one seen along
    w, its Stokes vector rotated from Mitsuba's basis of R w to R times the
    basis of w (AoLP follows the rotation); a uniform scale changes nothing.
    Float32 lookups at rotated coordinates: 1e-4 of S0."""
    t, m = transform(level)
    rotation = m / np.cbrt(np.linalg.det(m))
    sun = np.array([0.3, -0.2, 1.0])
    texture = {"type": "bitmap", "raw": True, "filter_type": "bilinear",
               "bitmap": mi.Bitmap(np.random.default_rng(1).uniform(
                   0.5, 2.0, (8, 16, 1)).astype(np.float32))}

    def make(to_world, turn):
        extra = {} if to_world is None else {"to_world": to_world}
        if kind == "stokes_envmap":
            return dict({"type": "stokes_envmap", "filename": varied_map(tmp_path / "m.exr")},
                        **extra)
        if kind == "sky-sunsky":
            return dict({"type": "polarized_sky", "sun_direction": (turn @ sun).tolist()},
                        **extra)
        if kind.startswith("sky"):
            radiance = texture if kind == "sky-texture" else 1.0
            return dict({"type": "polarized_sky", "sun_direction": (turn @ sun).tolist(),
                         "model": "berry" if kind == "sky-berry" else "rayleigh",
                         "radiance": radiance}, **extra)
        return dict({"type": "polarized_emitter", "angle": 35.0, "degree": 0.8,
                     "lamp": {"type": "constant"}}, **extra)

    plain, turned = mi.load_dict(make(None, np.eye(3))), mi.load_dict(make(t, rotation))
    # not the poles of the lat-long maps (local ±z, ±y), where the azimuth,
    # hence the texel, is undefined
    w = directions(80, 2)[2:]
    w = w[np.abs(w[:, 2]) < 0.99][:62]
    out = []
    for emitter, dirs in ((plain, w), (turned, w @ rotation.T)):
        si = dr.zeros(mi.SurfaceInteraction3f, len(dirs))
        si.wi = mi.Vector3f(*dirs.T)
        si.wavelengths = mi.UnpolarizedSpectrum(450.0, 520.0, 600.0, 690.0)
        out.append(first_column(emitter.eval(si)))
    (s, s_turned), w_turned = out, w @ rotation.T
    x_turned = vectors(mi.mueller.stokes_basis(mi.Vector3f(*w_turned.T)))
    target = vectors(mi.mueller.stokes_basis(mi.Vector3f(*w.T))) @ rotation.T
    back = np.einsum("nij,nj->ni", rotator(w_turned, x_turned, target), s_turned)
    assert np.abs(s[:, 1:3]).max() > 0.1 * s[:, 0].max()          # polarized
    assert np.abs(back - s).max() < 1e-4 * s[:, 0].max(), np.abs(back - s).max() / s[:, 0].max()


@pytest.mark.parametrize("matrix", [np.diag([1.0, 1.0, -1.0, 1.0]), np.diag([1.0, 2.0, 1.0, 1.0]),
                                    np.array([[1, 0.5, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0],
                                              [0, 0, 0, 1.0]])],
                         ids=["mirror", "uneven-scale", "shear"])
@pytest.mark.parametrize("kind", ["stokes_envmap", "polarized_sky", "sunsky"])
def test_a_sky_refuses_a_to_world_that_is_not_a_rotation(kind, matrix, tmp_path):
    """Mitsuba's envmap and sunsky look texels up at the un-normalized
    to_world⁻¹ w (a scale of 2 moved S0 by up to 21 % for stokes_envmap,
    8 % for polarized_sky's sunsky: now normalized); a mirror, shear or
    uneven scale is refused."""
    with pytest.raises(Exception) as raised:
        mi.load_dict(emitter_dict(kind, tmp_path, to_world=mi.ScalarTransform4f(matrix)))
    last = str(raised.value).strip().splitlines()[-1]
    plugin = "polarized_sky" if kind == "sunsky" else kind
    assert last.startswith(f"ValueError: {plugin}: parameter 'to_world' must be a "
                           "rotation"), last
