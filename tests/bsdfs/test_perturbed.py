"""BSDFs nested in BSDFs compose with their polarization (the emitters:
tests/emitters/test_nesting.py): a pairwise covering array of wrappers around pbrdf
and roughconductor against the inner BSDF's value rotated into the outer's
Stokes bases in NumPy, Mitsuba's twosided against polarized_twosided, a
perturbation of a perturbation against the single equivalent one, and
stokes_prb around them (slow tier).
"""

import drjit as dr
import mitsuba as mi
import numpy as np
import pytest

from proof.covering import pairwise, uncovered
from tests.emitters.test_nesting import emitter_dict, filters, rotator, vectors


# ------------------------------------------------------------ the BSDFs' covering array

PBRDF = {"type": "pbrdf", "material": "Au", "sigma": 0.2, "kdd": 0.2, "kid": 0.05}
ROUGH = {"type": "roughconductor", "alpha": 0.3}
#: (tilt, azimuth) in degrees of each perturbation's normal
OUTER_NORMAL, OUTER_BUMP, INNER_NORMAL, INNER_BUMP = (25, 30), (20, 200), (15, -60), (18, 100)
#: A square 20 units wide whose uv runs along +x and +y (proof.tilted_plane's plane)
EXTENT = 20.0
BSDF_FACTORS = {
    "inner": ["pbrdf", "roughconductor", "normalmap", "bumpmap"],
    "outer": ["normalmap", "bumpmap", "twosided", "blendbsdf", "mask"],
    "variant": ["llvm_ad_spectral_polarized", "llvm_ad_mono_polarized", "llvm_ad_spectral"],
    "side": ["front", "back"],
    "mode": ["radiance", "importance"],
}
MODES = {"radiance": mi.TransportMode.Radiance, "importance": mi.TransportMode.Importance}


def perturbation(kind, normal, nested, flip=True):
    from proof import tilted_plane as tp

    n = tp.tilted_normal(*normal)
    texture = tp.normalmap_bitmap(n) if kind == "normalmap" else \
        tp.height_ramp_bitmap(n, extent=EXTENT)
    return {"type": f"polarized_{kind}", kind if kind == "normalmap" else "height": texture,
            "use_shadowing_function": False, "flip_invalid_normals": flip, "nested": nested}


def bsdf_dicts(row):
    """(outer, inner) dicts of a row."""
    inner = {"pbrdf": PBRDF, "roughconductor": ROUGH,
             "normalmap": perturbation("normalmap", INNER_NORMAL, PBRDF),
             "bumpmap": perturbation("bumpmap", INNER_BUMP, PBRDF)}[row["inner"]]
    outer = {"normalmap": lambda: perturbation("normalmap", OUTER_NORMAL, inner),
             "bumpmap": lambda: perturbation("bumpmap", OUTER_BUMP, inner),
             "twosided": lambda: {"type": "polarized_twosided", "nested": inner},
             "blendbsdf": lambda: {"type": "blendbsdf", "weight": 0.3, "a": inner, "b": ROUGH},
             "mask": lambda: {"type": "mask", "opacity": 0.6, "nested": inner}}[row["outer"]]()
    return outer, inner


def plane_si(wi):
    """Surface interactions at uv (0.5, 0.5) of the flat square: shading frame
    the world axes, ``wi`` local (N x 3)."""
    from bsdf_harness import make_si

    si = make_si(wi)
    n = len(wi)
    frame = dr.zeros(mi.Frame3f, n)
    frame.s, frame.t, frame.n = (mi.Vector3f(*np.repeat([e], n, 0).T) for e in np.eye(3))
    si.sh_frame = frame
    si.n = frame.n
    si.dp_du = mi.Vector3f(*np.repeat([[EXTENT, 0, 0]], n, 0).T)
    si.dp_dv = mi.Vector3f(*np.repeat([[0, EXTENT, 0]], n, 0).T)
    si.uv = mi.Point2f(0.5, 0.5)
    return si


def frame_of(row, bsdf, si):
    """The outer perturbation's frame P in S (N x 3 x 3, columns s, t, n),
    from the plugin's own frame function (what is checked here is the
    Mueller matrix's composition, not the frame)."""
    f = bsdf.frame(si)[0]
    return np.stack([vectors(f.s), vectors(f.t), vectors(f.n)], -1)


def basis_np(w):
    return vectors(mi.mueller.stokes_basis(mi.Vector3f(*w.T)))


def in_frame(value_p, frame, wi, wo):
    """A Mueller matrix (N, nw, 4, 4) evaluated for the P-local directions of
    ``wi``, ``wo`` (S-local, Radiance mode: light arrives along -wo, leaves
    along wi), re-expressed in the Stokes bases of the S-local directions."""
    to_s = lambda v: np.einsum("nij,nj->ni", frame, v)      # noqa: E731
    to_p = lambda v: np.einsum("nji,nj->ni", frame, v)      # noqa: E731
    wi_p, wo_p = to_p(wi), to_p(wo)
    r_in = rotator(-wo, to_s(basis_np(-wo_p)), basis_np(-wo))
    r_out = rotator(wi, to_s(basis_np(wi_p)), basis_np(wi))
    return np.einsum("nij,nwjk,nlk->nwil", r_out, value_p, r_in)


def evaluate(bsdf, wi, wo, frame=None, mode="radiance"):
    """``bsdf.eval`` at S-local ``wi``, ``wo``, as NumPy; with ``frame``
    (N x 3 x 3), at the P-local directions with the interaction's shading
    frame P (as a perturbation hands it on)."""
    from bsdf_harness import as_numpy, to_vector

    si = plane_si(wi)
    if frame is not None:
        wi = np.einsum("nji,nj->ni", frame, wi)
        wo = np.einsum("nji,nj->ni", frame, wo)
        si = plane_si(wi)
        f = dr.zeros(mi.Frame3f, len(wi))
        f.s, f.t, f.n = (mi.Vector3f(*frame[:, :, k].T) for k in range(3))
        si.sh_frame = f
    return as_numpy(bsdf.eval(mi.BSDFContext(MODES[mode]), si, to_vector(wo)))


def rebased(value, frame, wi, wo, mode):
    """:func:`in_frame` in either transport mode: in Importance mode the
    matrix maps light arriving along -wi to light leaving along wo."""
    return in_frame(value, frame, wi, wo) if mode == "radiance" else \
        in_frame(value, frame, wo, wi)


BSDF_ROWS = sorted(pairwise(BSDF_FACTORS), key=lambda r: r["variant"])


def test_the_bsdf_array_covers_every_pair():
    assert not uncovered(BSDF_FACTORS, BSDF_ROWS)
    assert len(BSDF_ROWS) <= 24


@pytest.mark.parametrize("row", BSDF_ROWS, ids=["-".join(r.values()) for r in BSDF_ROWS])
def test_nested_bsdfs_compose(row):
    """Each row: the outer plugin's ``eval`` against the inner one's: a
    perturbation's is the inner's at the perturbed directions, rotated into
    the unperturbed Stokes bases (NumPy, by angles); ``twosided``'s is the
    inner's on the front and, on the back, the inner's at the directions
    turned 180 degrees about x (a proper rotation: the back side is the
    front seen from below), rotated likewise; ``blendbsdf``'s and
    ``mask``'s are the weighted inner's. Both sides are float32
    evaluations of the same BSDF: 1e-5 of the largest element, 1e-4
    for the rotation of a pbrdf (its Mueller matrix spans 1e-3..10)."""
    from bsdf_harness import hemisphere_pairs
    from mitsuba_pbrdf import use_variant

    use_variant(row["variant"])
    outer_d, inner_d = bsdf_dicts(row)
    outer, inner = mi.load_dict(outer_d), mi.load_dict(inner_d)
    wi, wo = hemisphere_pairs(64, seed=3)
    sign = np.array([1, 1, 1.0]) if row["side"] == "front" else np.array([1, 1, -1.0])
    wi, wo = wi * sign, wo * sign
    mode = row["mode"]
    got = evaluate(outer, wi, wo, mode=mode)
    assert np.all(np.isfinite(got))
    if row["outer"] in ("normalmap", "bumpmap"):
        frame = frame_of(row, outer, plane_si(wi))
        wi_p = np.einsum("nji,nj->ni", frame, wi)
        wo_p = np.einsum("nji,nj->ni", frame, wo)
        keep = (wi_p[:, 2] > 0.05) & (wo_p[:, 2] > 0.05) & (wi[:, 2] * sign[2] > 0.05) \
            & (wo[:, 2] * sign[2] > 0.05)
        if row["side"] == "back":
            keep = np.ones(len(wi), bool)
            want = np.zeros_like(got)        # a one-sided BSDF's back
        else:
            want = evaluate(inner, wi, wo, frame, mode)
            if mi.is_polarized:
                want = rebased(want, frame, wi, wo, mode)
        got, want = got[keep], want[keep]
    elif row["outer"] == "twosided":
        if row["side"] == "front":
            want = evaluate(inner, wi, wo, mode=mode)
        else:
            turn = np.diag([1.0, -1.0, -1.0])
            frame = np.broadcast_to(turn, (len(wi), 3, 3))
            want = evaluate(inner, wi @ turn, wo @ turn, mode=mode)
            if mi.is_polarized:
                want = rebased(want, frame, wi, wo, mode)
    else:
        weight = {"blendbsdf": 0.7, "mask": 0.6}[row["outer"]]
        want = weight * evaluate(inner, wi, wo, mode=mode)
        if row["outer"] == "blendbsdf":
            want = want + 0.3 * evaluate(mi.load_dict(ROUGH), wi, wo, mode=mode)
    assert len(got) >= 8
    peak = max(np.abs(want).max(), 1e-30)
    tol = 1e-4 if mi.is_polarized and row["outer"] in ("normalmap", "bumpmap") else 1e-5
    err = np.abs(got - want).max() / peak
    assert err < tol, err


# ------------------------------------------------------------ polarized_twosided

def back_truth(inner, wi, wo, mode=None):
    """The inner BRDF's front turned 180 degrees about x, in the bases of the
    back-side directions ``wi``, ``wo`` (z < 0): (N, nw, 4, 4)."""
    from bsdf_harness import as_numpy, make_si, to_vector

    turn = np.diag([1.0, -1.0, -1.0])
    ctx = mi.BSDFContext(mode) if mode is not None else mi.BSDFContext()
    value = as_numpy(inner.eval(ctx, make_si(wi @ turn), to_vector(wo @ turn)))
    frame = np.broadcast_to(turn, (len(wi), 3, 3))
    if mode == mi.TransportMode.Importance:     # the matrix maps -wi's basis to wo's
        return in_frame(value, frame, wo, wi)
    return in_frame(value, frame, wi, wo)


@pytest.mark.parametrize("inner", [pytest.param(PBRDF, marks=pytest.mark.slow), ROUGH],
                         ids=["pbrdf", "roughconductor"])
def test_the_back_side_is_the_front_seen_from_below(inner):
    """Mitsuba's twosided gets the back side's S1-S2/S3 couplings' signs
    wrong (a mirrored AoLP); polarized_twosided matches the turned front, in
    eval, eval_pdf and sample, in both transport modes, and has
    twosided's S0, pdf and sampled directions."""
    from bsdf_harness import as_numpy, hemisphere_pairs, make_si, to_vector

    mine = mi.load_dict({"type": "polarized_twosided", "a": inner})
    theirs = mi.load_dict({"type": "twosided", "a": inner})
    bare = mi.load_dict(inner)
    wi, wo = hemisphere_pairs(64, seed=4)
    wi, wo = wi * [1, 1, -1.0], wo * [1, 1, -1.0]
    for mode in (mi.TransportMode.Radiance, mi.TransportMode.Importance):
        ctx = mi.BSDFContext(mode)
        want = back_truth(bare, wi, wo, mode)
        got = as_numpy(mine.eval(ctx, make_si(wi), to_vector(wo)))
        peak = np.abs(want).max()
        assert np.abs(got - want).max() < 1e-5 * peak
        value, pdf = mine.eval_pdf(ctx, make_si(wi), to_vector(wo))
        assert np.abs(as_numpy(value) - want).max() < 1e-5 * peak
        mitsuba = as_numpy(theirs.eval(ctx, make_si(wi), to_vector(wo)))
        assert np.abs(mitsuba - want).max() > 0.1 * peak          # Mitsuba's mirror
        assert np.allclose(mitsuba[..., 0, 0], got[..., 0, 0], rtol=1e-6, atol=0)
        assert np.array_equal(np.array(pdf), np.array(theirs.pdf(ctx, make_si(wi),
                                                                  to_vector(wo))))
    rng = np.random.default_rng(2)
    s1 = mi.Float(rng.uniform(size=len(wi)))
    s2 = mi.Point2f(*rng.uniform(size=(2, len(wi))))
    bs, weight = mine.sample(mi.BSDFContext(), make_si(wi), s1, s2)
    bs_m, weight_m = theirs.sample(mi.BSDFContext(), make_si(wi), s1, s2)
    assert np.array_equal(vectors(bs.wo), vectors(bs_m.wo))
    ok = np.array(bs.pdf) > 0
    w_dir = vectors(bs.wo)
    want = back_truth(bare, wi, w_dir) / np.array(bs.pdf)[:, None, None, None]
    got = as_numpy(weight)
    assert ok.mean() > 0.5
    assert np.abs(got[ok] - want[ok]).max() < 1e-4 * np.abs(want[ok]).max()


def test_two_sides_two_brdfs_and_the_unpolarized_variant_is_twosided(variant_switch):
    """The front is the first BRDF, unchanged; in unpolarized variants the
    plugin is Mitsuba's twosided to the bit."""
    from bsdf_harness import as_numpy, hemisphere_pairs, make_si, to_vector

    wi, wo = hemisphere_pairs(32, seed=6)
    pairs = {"a": PBRDF, "b": ROUGH}
    for variant in ("llvm_ad_spectral_polarized", "llvm_ad_spectral"):
        variant_switch(variant)
        mine = mi.load_dict(dict({"type": "polarized_twosided"}, **pairs))
        theirs = mi.load_dict(dict({"type": "twosided"}, **pairs))
        for sign in (1.0, -1.0):
            w_i, w_o = wi * [1, 1, sign], wo * [1, 1, sign]
            got = as_numpy(mine.eval(mi.BSDFContext(), make_si(w_i), to_vector(w_o)))
            ref = as_numpy(theirs.eval(mi.BSDFContext(), make_si(w_i), to_vector(w_o)))
            if sign > 0 or not mi.is_polarized:
                assert np.array_equal(got, ref)
            else:
                assert np.allclose(got[..., 0, 0], ref[..., 0, 0], rtol=1e-6, atol=0)
                want = back_truth(mi.load_dict(ROUGH), w_i, w_o)
                assert np.abs(got - want).max() < 1e-5 * np.abs(want).max()


@pytest.fixture
def variant_switch():
    from mitsuba_pbrdf import use_variant

    yield use_variant
    use_variant("llvm_ad_spectral_polarized")


# ------------------------------------------------------------ a perturbation of a perturbation

def single_normal(normal):
    """A polarized_normalmap of the constant ``normal`` (S-local) around pbrdf."""
    from proof import tilted_plane as tp

    return {"type": "polarized_normalmap", "normalmap": tp.normalmap_bitmap(normal),
            "use_shadowing_function": False, "nested": PBRDF}


@pytest.mark.parametrize("outer,inner", [("normalmap", "normalmap"), ("bumpmap", "normalmap"),
                                         ("normalmap", "bumpmap")])
def test_a_nested_perturbation_is_the_single_equivalent_one(outer, inner):
    """Two constant perturbations, P1 (outer) around P2 (inner), are one
    normal map whose normal is P2's normal carried into S by P1: the same
    Mueller matrix (isotropic pbrdf: the frames' tangents differ, the
    Stokes rotations take care of it), float32 products, 1e-4 of the
    largest element."""
    from bsdf_harness import hemisphere_pairs
    from mitsuba_pbrdf.bsdfs.bumpmap import bumpmap_frame

    inner_normal = INNER_NORMAL if inner == "normalmap" else INNER_BUMP
    nested = mi.load_dict(perturbation(
        outer, OUTER_NORMAL if outer == "normalmap" else OUTER_BUMP,
        perturbation(inner, inner_normal, PBRDF, flip=False), flip=False))
    wi, wo = hemisphere_pairs(64, seed=8)
    si = plane_si(wi)
    p1 = frame_of({}, nested, si)
    if inner == "normalmap":
        from proof import tilted_plane as tp
        n_eff = np.einsum("nij,j->ni", p1, tp.tilted_normal(*inner_normal))
    else:       # the bump map's own frame, from the interaction the outer hands on
        from mitsuba_pbrdf.bsdfs.perturbed import perturbed_interaction

        f1_si, f1_world = nested.frame(si)
        psi = perturbed_interaction(si, f1_si, f1_world)
        texture = nested.nested_bsdf.nested_texture
        f2 = bumpmap_frame(texture, nested.nested_bsdf.scale, psi, False, True)[0]
        n_eff = np.einsum("nij,nj->ni", p1, vectors(f2.n))
    # constant perturbations: every pair has the same effective normal
    assert np.abs(n_eff - n_eff[0]).max() < 1e-5
    single = mi.load_dict(dict(single_normal(n_eff[0]), flip_invalid_normals=False))
    frame = frame_of({}, single, si)
    keep = np.ones(len(wi), bool)          # every frame's horizon well below both
    for f in (frame, p1):
        for w in (wi, wo):
            keep &= np.einsum("nji,nj->ni", f, w)[:, 2] > 0.05
    got, want = evaluate(nested, wi, wo)[keep], evaluate(single, wi, wo)[keep]
    assert keep.sum() >= 8 and np.abs(want).max() > 0
    assert np.abs(got - want).max() < 1e-4 * np.abs(want).max()


# ------------------------------------------------------------ stokes_prb around them

@pytest.mark.slow
@pytest.mark.parametrize("case", ["twosided-normalmap-filters", "bumpmap-envmap"])
def test_stokes_prb_renders_and_differentiates_the_nestings(case, tmp_path):
    """``stokes_prb`` around nested plugins renders what ``stokes(path)``
    renders with the same random numbers (1e-5 of the image's largest value,
    tests/integrators/test_stokes_prb.py's bound) and differentiates it as ``path`` AD
    does where that is exact (cosine sampling: 1e-4), through the wrappers'
    parameters: the nested pbrdf's kdd and eta, the nested lamp's radiance."""
    from tests.integrators import test_stokes_prb as prb

    from mitsuba_pbrdf.integrators import from_path

    inner = prb.pbrdf()
    if case == "twosided-normalmap-filters":
        bsdf = {"type": "polarized_twosided",
                "nested": perturbation("normalmap", OUTER_NORMAL, inner)}
        extra = {}
    else:
        bsdf = perturbation("bumpmap", OUTER_BUMP, inner)
        extra = {"sky": emitter_dict("stokes_envmap", tmp_path)}
    d = prb.scene_dict("path", max_depth=3, bsdf=bsdf, extra=extra)
    if case == "twosided-normalmap-filters":
        d["key"]["emitter"] = filters((10.0, 0.9, 0.8), (55.0, 0.7, 0.9),
                                      lamp=d["key"]["emitter"])
    scene = mi.load_dict(d)
    replay = from_path(scene)
    a = np.array(mi.render(scene, spp=prb.SPP, seed=7))
    b = np.array(mi.render(scene, integrator=replay, spp=prb.SPP, seed=7))
    assert np.abs(a[..., 6:12]).max() > 1e-3 * np.abs(a).max()      # S1, S2 not empty
    np.testing.assert_allclose(b, a, atol=1e-5 * np.abs(a).max(), rtol=0)
    keys = [k for k in mi.traverse(scene).keys()
            if k.startswith("object.") and k.endswith((".kdd.value", ".eta.value"))
            or k.startswith("key.") and k.endswith("radiance.value")]
    assert len(keys) == 3, keys
    weights = prb.random_weights(4)
    want = prb.reverse_gradient(scene, keys, weights)
    got = prb.reverse_gradient(scene, keys, weights, integrator=replay)
    assert np.all(np.isfinite(got)) and np.all(np.abs(want) > 0)
    prb.assert_close(got, want)
