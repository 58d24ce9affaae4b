"""Bad input: every invalid parameter value and type is rejected when the scene
is loaded, with a message that names the parameter, so that no bad input can
render silently.

Tables: Python dictionaries (``mi.load_dict``), XML (``mi.load_string``, also
inside a whole scene), parameter updates through ``mi.traverse``, and a subset
in other variants. Cases Mitsuba's own parser rejects before the plugin sees
them (a spectrum with negative entries, an unreferenced parameter, a Python
list) are listed with Mitsuba's message, which names the parameter too. The
table of load_dict cases lives in ``proof/bad_input.py``.
"""

import numpy as np
import pytest

import mitsuba as mi

from mitsuba_pbrdf import use_variant
from proof.bad_input import INF, NAN, bitmap, cases, load_error

#: proof.bad_input.BadInput rows (parameters, the plugin's error or None for
#: Mitsuba's parser, text of the message's last line): the table shared with
#: validation/bad_input.py, built for the suite's variant (tests/conftest.py).
BAD_INPUT = cases()


def check_message(last_line, error, message):
    assert last_line is not None, "loaded without error"
    if error is not None:
        assert last_line.startswith(f"{error.__name__}: pbrdf:"), last_line
    assert message in last_line, last_line


@pytest.mark.parametrize("extra,error,message", BAD_INPUT, ids=[repr(b.params)[:60] for b in BAD_INPUT])
def test_bad_input_is_rejected_at_load_time_naming_the_parameter(extra, error, message):
    """Mitsuba's loader wraps a plugin's exception in a RuntimeError whose last
    line is ours: '<ErrorType>: pbrdf: ... <parameter> ...'."""
    check_message(load_error(extra), error, message)


# ---------------------------------------------------------------- XML

BAD_XML = [
    ('<float name="sigma" value="-2"/>', "'sigma'"),
    ('<float name="sigma" value="nan"/>', "'sigma'"),
    ('<float name="sigma" value="inf"/>', "'sigma'"),
    ('<integer name="sigma_dd" value="0"/><float name="kdd" value="0.2"/>', "'sigma_dd'"),
    ('<integer name="sigma_u" value="0"/>', "'sigma_u' is 0"),   # sigma = 0 is a mirror
    ('<string name="sigma" value="rough"/>', "'sigma'"),
    ('<float name="sigma_dd" value="-1"/><float name="kdd" value="0.2"/>', "'sigma_dd'"),
    ('<rgb name="kid" value="-0.1, 0.2, 0.3"/>', "'kid'"),
    ('<spectrum name="kdd" value="-0.2"/>', "'kdd'"),
    ('<boolean name="kdd" value="true"/>', "'kdd'"),
    ('<vector name="ks" value="1, 2, 3"/>', "'ks'"),
    ('<spectrum name="eta" value="1.2"/>', "'eta' and 'k'"),
    ('<string name="material" value="Unobtainium"/>', "'material'"),
    ('<string name="material" value="Cu"/><spectrum name="eta" value="1.2"/>'
     '<spectrum name="k" value="3"/>', "'material'"),
    ('<string name="shadowing" value="none"/>', "'shadowing'"),
    ('<string name="dd_distribution" value="cauchy"/>', "'dd_distribution'"),
    ('<string name="sampling" value="uniform"/>', "'sampling'"),
    ('<float name="sigmaa" value="0.1"/>', '"sigmaa"'),
    ('<texture type="bitmap" name="kid"><string name="filename" value="$NEGATIVE"/>'
     '<string name="filter_type" value="nearest"/><boolean name="raw" value="true"/></texture>',
     "'kid'"),
]


@pytest.fixture(scope="module")
def negative_exr(tmp_path_factory):
    """A one-channel EXR with one negative texel."""
    use_variant("llvm_ad_spectral_polarized")
    texels = np.full((8, 8, 1), 0.3, dtype=np.float32)
    texels[2, 6, 0] = -0.4
    path = tmp_path_factory.mktemp("bad_input") / "negative.exr"
    mi.Bitmap(texels).write(str(path))
    return str(path)


@pytest.mark.parametrize("body,message", BAD_XML, ids=[b[0][:50] for b in BAD_XML])
def test_bad_xml_is_rejected_naming_the_parameter(body, message, negative_exr):
    body = body.replace("$NEGATIVE", negative_exr)
    bsdf = f'<bsdf version="3.0.0" type="pbrdf">{body}</bsdf>'
    with pytest.raises(Exception) as info:
        mi.load_string(bsdf)
    assert message in str(info.value).strip().splitlines()[-1], str(info.value)
    # ... and the scene holding it does not load either: nothing renders silently
    scene = f"""<scene version="3.0.0">
        <integrator type="stokes"><integrator type="direct"/></integrator>
        <sensor type="perspective"><film type="hdrfilm"><integer name="width" value="8"/>
            <integer name="height" value="8"/></film></sensor>
        <emitter type="constant"/>
        <shape type="sphere"><bsdf type="pbrdf">{body}</bsdf></shape>
    </scene>"""
    with pytest.raises(Exception) as info:
        mi.load_string(scene)
    assert message in str(info.value), str(info.value)


# ---------------------------------------------------------------- parameter updates

BAD_UPDATES = [
    ("sigma.value", -0.1, "'sigma'"), ("sigma.value", 0.0, "'sigma'"),
    ("sigma.value", NAN, "'sigma'"), ("sigma.value", INF, "'sigma'"),
    ("sigma.value", 1e-6, "'sigma' must be >= 7.07e-05"),  # below Mitsuba's alpha floor
    ("sigma_dd.value", 0.0, "'sigma_dd'"), ("sigma_dd.value", NAN, "'sigma_dd'"),
    ("sigma_dd.value", 5e-5, "'sigma_dd' must be >= 7.07e-05"),
    ("ks.value", -1.0, "'ks'"), ("ks.value", NAN, "'ks'"),
    ("kdd.value", INF, "'kdd'"), ("kid.value", -0.2, "'kid'"),
    ("eta.value", 0.0, "'eta'"), ("eta.value", NAN, "'eta'"), ("k.value", -1.0, "'k'"),
]


@pytest.mark.parametrize("key,value,message", BAD_UPDATES,
                         ids=[f"{k}={v}" for k, v, _ in BAD_UPDATES])
def test_bad_parameter_update_is_rejected_naming_the_parameter(key, value, message):
    bsdf = mi.load_dict({"type": "pbrdf", "eta": 1.2, "k": 7.0, "sigma": 0.1, "kdd": 0.2,
                         "sigma_dd": 0.5, "kid": 0.1})
    params = mi.traverse(bsdf)
    assert key in params.keys(), sorted(params.keys())
    params[key] = value
    with pytest.raises(ValueError, match=message):
        params.update()


def test_bad_tabulated_update_is_rejected():
    """A named conductor's tabulated n with one negative value is rejected.
    Mitsuba's own spectrum node refuses it first, with its message ("entries
    must be non-negative"), before the plugin's parameters_changed runs."""
    params = mi.traverse(mi.load_dict({"type": "pbrdf", "material": "Cu"}))
    values = np.array(params["eta.values"])
    values[len(values) // 2] = -0.1
    params["eta.values"] = mi.Float(values)
    with pytest.raises((RuntimeError, ValueError), match="'eta'|non-negative"):
        params.update()


# ---------------------------------------------------------------- other variants

@pytest.mark.parametrize("variant", ["llvm_ad_rgb", "llvm_ad_mono_polarized",
                                     "scalar_spectral_polarized"], indirect=True)
def test_bad_input_in_other_variants(variant):
    cases = [({"sigma": -0.1}, ValueError, "'sigma'"),
             ({"kid": mi.ScalarColor3f(0.2, -0.1, 0.3)}, ValueError, "'kid'"),
             ({"kdd": bitmap(NAN, at=(4, 4))}, ValueError, "'kdd'"),   # texel at the centre
             ({"eta": 1.2, "k": INF}, ValueError, "'k'"),
             ({"material": "Unobtainium"}, ValueError, "'material'"),
             ({"shadowing": "none"}, ValueError, "'shadowing'"),
             ({"ks": "shiny"}, TypeError, "'ks'")]
    for extra, error, message in cases:
        check_message(load_error(extra), error, message)


# ---------------------------------------------------------------- once accepted silently

def test_every_texel_of_a_bitmap_is_checked_256():
    """A bad texel anywhere in a bitmap (here off any 64 x 64 sampling grid)
    is caught; once only a grid of texel centres was evaluated."""
    for value in (NAN, -0.5, INF):
        texels = np.full((256, 256, 1), 0.3, dtype=np.float32)
        texels[1, 1, 0] = value
        tex = {"type": "bitmap", "bitmap": mi.Bitmap(texels), "filter_type": "nearest",
               "raw": True}
        check_message(load_error({"kdd": tex}), ValueError, "'kdd'")


@pytest.mark.parametrize("variant", ["scalar_spectral_polarized"], indirect=True)
def test_every_texel_of_a_bitmap_is_checked_in_scalar_variants(variant):
    """Scalar variants once checked the texture at its centre only."""
    check_message(load_error({"kdd": bitmap(NAN, at=(1, 1))}), ValueError, "'kdd'")


def test_negative_inline_spectrum_names_the_parameter():
    """An inline XML spectrum with a negative entry (Mitsuba's own
    ContinuousDistribution refuses it) gets a message naming the parameter."""
    xml = ('<bsdf version="3.0.0" type="pbrdf"><spectrum name="eta" value="400:1.2, 700:-0.3"/>'
           '<spectrum name="k" value="1"/></bsdf>')
    with pytest.raises(Exception) as info:
        mi.load_string(xml)
    assert "eta" in str(info.value).strip().splitlines()[-1], str(info.value)


@pytest.mark.parametrize("extra,name", [({"sigma": 1e-5}, "'sigma'"),
                                        ({"sigma_dd": 1e-6, "kdd": 0.3}, "'sigma_dd'")])
def test_roughness_below_mitsubas_floor_is_rejected(extra, name):
    """Mitsuba's MicrofacetDistribution clamps alpha to >= 1e-4 (sigma 7.07e-5):
    a smaller sigma would render a wider lobe than asked (sigma = 1e-5: a peak
    50x lower than the model's) and is rejected instead."""
    check_message(load_error(extra), ValueError, name)


@pytest.mark.parametrize("extra", [
    {"material": "Se"},
    {"eta": {"type": "irregular", "wavelengths": "400, 600, 700", "values": "1.2, 1.3, 1.4"},
     "k": 0.0}], ids=["material Se", "irregular eta 400-700 nm"])
def test_spectra_not_covering_the_spectral_range_do_not_render_unphysically(extra):
    """A tabulated n, k that does not cover 360-830 nm (27 of Mitsuba's 71
    conductors, e.g. Se: 310-689 nm, or a user's spectrum) must not evaluate to
    n = k = 0 outside its table, where r_p = 0/0 and the surface would polarize
    fully at normal incidence. Either loading fails naming the parameter, or at
    normal incidence and exit (where R_s = R_p for any surface) M01 vanishes at
    every wavelength, 1e-5 of M00 allowing float32 rounding."""
    from mitsuba_pbrdf import frames

    use_variant("llvm_ad_spectral_polarized")
    last_line = load_error(extra)
    if last_line is not None:
        assert any(n in last_line for n in ("'material'", "'eta'", "'k'")), last_line
        return
    bsdf = mi.load_dict(dict({"type": "pbrdf", "sigma": 0.1}, **extra))
    up = np.array([[0.0, 0.0, 1.0]])
    M = frames.eval_global(bsdf, up, up, (400.0, 650.0, 750.0, 830.0))[0]
    assert np.all(np.isfinite(M))
    assert np.all(np.abs(M[:, 0, 1]) <= 1e-5 * M[:, 0, 0]), M[:, 0, :2]


def test_negative_zero_k_is_the_same_as_zero():
    """Total internal reflection (n = 0.5, k = 0, facet angle 60 deg > 30 deg):
    k = -0.0 and k = +0.0 must give the same Mueller matrix (1e-6 of M00: the
    same float32 arithmetic), or -0.0 be rejected naming 'k'."""
    from mitsuba_pbrdf import frames

    use_variant("llvm_ad_spectral_polarized")
    t = np.radians(60.0)
    to_light = np.array([[np.sin(t), 0.0, np.cos(t)]])
    to_viewer = np.array([[-np.sin(t) + 0.01, 0.02, np.cos(t)]])
    to_viewer /= np.linalg.norm(to_viewer)
    last_line = load_error({"eta": 0.5, "k": -0.0})
    if last_line is not None:
        assert "'k'" in last_line
        return
    M = [frames.eval_global(mi.load_dict({"type": "pbrdf", "eta": 0.5, "k": k, "sigma": 0.1}),
                            to_viewer, to_light)[0, 0] for k in (0.0, -0.0)]
    assert np.all(np.abs(M[0] - M[1]) <= 1e-6 * M[0][0, 0]), (M[0][2:, 2:], M[1][2:, 2:])


def test_a_zero_texel_of_an_rgb_roughness_bitmap_is_caught_in_spectral_variants():
    """Spectral variants store an RGB bitmap as upsampling coefficients (and
    clamp it to [0, 1]: NaN, Inf and negative texels cannot get through), so
    the check evaluates the texture at every texel centre: a roughness texel
    of 0 off the centre (row 3, column 5 of 8 x 8) is refused."""
    for value in (0.0, -0.5):
        texels = np.full((8, 8, 3), 0.4, dtype=np.float32)
        texels[3, 5] = value
        tex = {"type": "bitmap", "bitmap": mi.Bitmap(texels), "filter_type": "nearest"}
        check_message(load_error({"kdd": 0.3, "sigma_dd": tex}), ValueError, "'sigma_dd'")


def test_an_8_bit_rgb_png_as_a_float_parameter_is_refused_at_load(tmp_path):
    """An ordinary 8-bit RGB PNG as sigma_u loaded and then failed in the render
    with 'drjit.custom(...): error ... (see above)', naming neither the
    parameter nor the file (issue 28); the load-time check now evaluates it
    with eval_1, as the kernel does."""
    from PIL import Image

    use_variant("llvm_ad_spectral_polarized")
    path = tmp_path / "rough.png"
    Image.fromarray(np.full((8, 8, 3), 80, np.uint8)).save(path)
    check_message(load_error({"sigma_u": {"type": "bitmap", "filename": str(path)}}),
                  ValueError, "'sigma_u' takes one value per point")
    grey = tmp_path / "grey.png"
    Image.fromarray(np.full((8, 8), 80, np.uint8)).save(grey)   # one channel: accepted
    assert load_error({"sigma_u": {"type": "bitmap", "filename": str(grey)}}) is None
