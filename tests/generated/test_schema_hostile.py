"""Hostile rows generated from the schema (mitsuba_pbrdf/schema.py): every
parameter of the ``pbrdf`` plugin gets the bad values its declaration forbids,
through ``mi.load_dict``, XML (``mi.load_string``) and ``mi.traverse``
updates, as a number, as a one-channel raw bitmap holding one bad texel, as a
``checkerboard`` (a procedural texture) and as a three-channel bitmap. A new
parameter gets its rows without anyone writing them.

Every row must be refused with a message whose last line names the
parameter (``'sigma'``; Mitsuba's own parser, where it refuses first, quotes
it as ``"sigma"``), except the three-channel bitmaps: spectral variants store
them as spectral-upsampling coefficients clamped to [0, 1] (a NaN or negative
texel cannot get through), so such a row is either refused or the BSDF it
loads evaluates to finite Mueller matrices (no NaN can render silently).

Bad values of a ``float``/``spectrum`` parameter: NaN, +inf, -1 (every one
is >= 0), 0 where it must be > 0 (as a texture only where a constant 0 is
the smooth limit: tests/bsdfs/test_pbrdf_smooth_limit.py), half its floor where it has one; of a
``choice`` or ``material``: an unknown name and a number.
"""

import math

import mitsuba as mi
import numpy as np
import pytest

from mitsuba_pbrdf import schema, use_variant

VARIANT = "llvm_ad_spectral_polarized"
PARAMETERS = [p for p in schema.PARAMETERS if p.plugin]


def bad_numbers(p):
    values = [math.nan, math.inf, -1.0]
    if p.positive:
        values.append(0.0)
    if p.floor:
        values.append(p.floor / 2)
    return values


def _base(p):
    """Valid companions of *p*: eta and k go together; a width is exposed
    where its lobe has a weight."""
    if p.name in ("eta", "k"):
        return {"eta": 1.2, "k": 3.0}
    weight = schema.LOBES.get(p.lobe, (None,))[0] if p.role and p.role != "weight" else None
    return {weight: 0.2} if weight else {}


def _bitmap(value, channels=1):
    texels = np.full((8, 8, channels), 0.4, np.float32)
    texels[3, 5] = value
    out = {"type": "bitmap", "bitmap": mi.Bitmap(texels), "filter_type": "nearest"}
    if channels == 1:
        out["raw"] = True
    return out


def rows():
    out = []
    for p in PARAMETERS:
        if p.kind in ("float", "spectrum"):
            for v in bad_numbers(p):
                constant = [] if p.smooth_at_zero and v == 0 else [(p, "number", v), (p, "xml", v)]
                out += constant + [(p, "bitmap1", v), (p, "checkerboard", v),
                                   (p, "bitmap3", v), (p, "traverse", v)]
        else:
            out += [(p, "number", "bogus"), (p, "number", 1.0), (p, "xml", "bogus")]
    return out


ROWS = rows()


def _value(p, form, v):
    if form == "number":
        return v
    if form == "bitmap1":
        return _bitmap(v, 1)
    if form == "bitmap3":
        return _bitmap(v, 3)
    if form == "checkerboard":
        return {"type": "checkerboard", "color0": 0.4, "color1": v}
    raise ValueError(form)


def _load_error(params):
    try:
        return None, mi.load_dict(dict({"type": "pbrdf"}, **params))
    except Exception as e:  # Mitsuba wraps the plugin's exception in a RuntimeError
        return str(e).strip().splitlines()[-1], None


def _xml_error(p, v):
    companions = "".join(f'<float name="{k}" value="{x}"/>' for k, x in _base(p).items()
                         if k != p.name)
    tag = "string" if isinstance(v, str) else "float"
    body = f'<{tag} name="{p.name}" value="{v}"/>'
    try:
        mi.load_string(f'<bsdf version="3.0.0" type="pbrdf">{companions}{body}</bsdf>')
    except Exception as e:
        return str(e).strip().splitlines()[-1]
    return None


def _traverse_error(p, v):
    good = 0.3 if p.name not in ("eta", "k") else None
    params = dict(_base(p))
    if good is not None:
        params[p.name] = good
    bsdf = mi.load_dict(dict({"type": "pbrdf"}, **params))
    exposed = mi.traverse(bsdf)
    key = f"{p.name}.value"
    if key not in exposed.keys():
        return "not exposed"
    exposed[key] = v
    try:
        exposed.update()
    except Exception as e:
        return str(e).strip().splitlines()[-1]
    return None


def _finite(bsdf) -> bool:
    from mitsuba_pbrdf import frames

    t = np.radians(30.0)
    wi = np.array([[np.sin(t), 0.0, np.cos(t)]])
    wo = np.array([[-np.sin(t), 0.01, np.cos(t)]])
    M = frames.eval_global(bsdf, wo / np.linalg.norm(wo), wi, (400.0, 500.0, 600.0, 700.0))
    return bool(np.all(np.isfinite(M)))


@pytest.mark.parametrize("p, form, v", ROWS,
                         ids=[f"{p.name} {form} {v!r}" for p, form, v in ROWS])
def test_generated_schema_row(p, form, v):
    use_variant(VARIANT)
    names = (f"'{p.name}'", f'"{p.name}"')
    if form == "xml":
        message = _xml_error(p, v)
    elif form == "traverse":
        message = _traverse_error(p, v)
        if message == "not exposed":
            pytest.skip(f"{p.name} is not exposed as {p.name}.value")
    else:
        message, bsdf = _load_error(dict(_base(p), **{p.name: _value(p, form, v)}))
        if message is None and form == "bitmap3":
            assert _finite(bsdf), (p.name, v)   # clamped to a valid colour: renders finite
            return
    assert message is not None, f"{p.name} = {v!r} ({form}) was accepted"
    assert any(n in message for n in names), message


def test_every_plugin_parameter_has_rows():
    covered = {p.name for p, _, _ in ROWS}
    assert covered == {p.name for p in PARAMETERS}
    print(f"{len(PARAMETERS)} parameters, {len(ROWS)} rows")
