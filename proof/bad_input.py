"""The table of invalid ``pbrdf`` parameters and the message each gets.

Every entry must be rejected when the BSDF is loaded (``mi.load_dict``), with a
one-line message naming the parameter: :func:`cases` lists them, :func:`load_error`
loads one and returns the last line of the error. Cases Mitsuba's own parser
rejects before the plugin sees them (a spectrum with negative entries, an
unreferenced parameter, a Python list) carry Mitsuba's message, which names the
parameter too. Shared by the tests (``tests/hostile/test_bad_input.py``, which asserts
on each) and the bad-input study (``validation/bad_input.py``, which lists the
messages).

The table holds Mitsuba objects (bitmaps, colours, transforms), so it is built
for the active variant: set one first (``mitsuba_pbrdf.use_variant``).
"""

from typing import List, NamedTuple, Optional

import numpy as np

NAN, INF = float("nan"), float("inf")


def bitmap(value, at=(3, 5), fill=0.5):
    """A 8 x 8 one-channel bitmap texture (nearest filter, raw values) with
    ``value`` at one texel off the centre."""
    import mitsuba as mi

    texels = np.full((8, 8, 1), fill, dtype=np.float32)
    texels[at[0], at[1], 0] = value
    return {"type": "bitmap", "bitmap": mi.Bitmap(texels), "filter_type": "nearest", "raw": True}


class BadInput(NamedTuple):
    """One bad set of pbrdf parameters and the error it must raise at load."""
    params: dict            #: parameters added to a valid pbrdf's
    error: Optional[type]   #: the exception the plugin raises; None: Mitsuba's parser refuses it
    text: str               #: text the message's last line must contain


def cases() -> List[BadInput]:
    """The table of bad parameters (:class:`BadInput` rows) for the active variant."""
    from mitsuba_pbrdf.variant import require_variant

    mi = require_variant()
    return [BadInput(*row) for row in [
        # negative, zero (where > 0 is required), NaN, infinite
        ({"sigma": -0.1}, ValueError, "'sigma'"),
        ({"sigma": 1e-9}, ValueError, "'sigma'"),              # 0 is the smooth limit
        ({"sigma_u": 0.0, "sigma_v": 0.1}, ValueError, "'sigma_u' is 0"),
        ({"sigma": 0.0, "sampling": "cosine"}, ValueError, "'sampling'"),
        ({"sigma": NAN}, ValueError, "'sigma'"),
        ({"sigma": INF}, ValueError, "'sigma'"),
        ({"sigma": -INF}, ValueError, "'sigma'"),
        ({"alpha": -0.1}, ValueError, "'alpha'"),              # Mitsuba's names, their bounds
        ({"alpha": NAN}, ValueError, "'alpha'"),
        ({"alpha_u": 5e-5}, ValueError, "'alpha_u'"),
        ({"alpha_v": bitmap(-1.0)}, ValueError, "'alpha_v'"),
        ({"sigma_dd": -1.0, "kdd": 0.1}, ValueError, "'sigma_dd'"),
        ({"sigma_dd": 0.0, "kdd": 0.1}, ValueError, "'sigma_dd'"),
        ({"sigma_dd": NAN, "kdd": 0.1}, ValueError, "'sigma_dd'"),
        ({"sigma_dd": INF}, ValueError, "'sigma_dd'"),
        ({"ks": -0.5}, ValueError, "'ks'"),
        ({"ks": NAN}, ValueError, "'ks'"),
        ({"ks": INF}, ValueError, "'ks'"),
        ({"kdd": -1.0}, ValueError, "'kdd'"),
        ({"kdd": NAN}, ValueError, "'kdd'"),
        ({"kdd": INF}, ValueError, "'kdd'"),
        ({"kid": -1e-3}, ValueError, "'kid'"),
        ({"kid": NAN}, ValueError, "'kid'"),
        ({"kid": INF}, ValueError, "'kid'"),
        ({"eta": -0.2, "k": 3.0}, ValueError, "'eta'"),
        ({"eta": 0.0, "k": 3.0}, ValueError, "'eta'"),
        ({"eta": NAN, "k": 3.0}, ValueError, "'eta'"),
        ({"eta": INF, "k": 3.0}, ValueError, "'eta'"),
        ({"eta": 1.2, "k": -3.0}, ValueError, "'k'"),
        ({"eta": 1.2, "k": NAN}, ValueError, "'k'"),
        ({"eta": 1.2, "k": INF}, ValueError, "'k'"),
        # textures holding a bad value somewhere
        ({"kid": mi.ScalarColor3f(0.2, -0.1, 0.3)}, ValueError, "'kid'"),
        ({"kid": {"type": "uniform", "value": -0.3}}, ValueError, "'kid'"),
        ({"kdd": {"type": "checkerboard", "color0": -0.5, "color1": 0.2}}, ValueError, "'kdd'"),
        ({"ks": {"type": "checkerboard", "color0": 0.2, "color1": -0.1}}, ValueError, "'ks'"),
        ({"kid": bitmap(-0.25)}, ValueError, "'kid'"),
        ({"kid": bitmap(NAN)}, ValueError, "'kid'"),
        ({"ks": bitmap(INF)}, ValueError, "'ks'"),
        ({"sigma": bitmap(0.0)}, ValueError, "'sigma'"),
        ({"sigma_dd": bitmap(-1.0), "kdd": 0.2}, ValueError, "'sigma_dd'"),
        ({"eta": bitmap(-1.0), "k": 1.0}, ValueError, "'eta'"),
        ({"eta": 1.0, "k": bitmap(INF)}, ValueError, "'k'"),
        # a float parameter evaluated as the kernel does (eval_1): an RGB bitmap in a
        # spectral variant has no one value per point (issue 28)
        ({"sigma_u": {"type": "bitmap", "bitmap": mi.Bitmap(np.full((8, 8, 3), 0.3, np.float32))}},
         ValueError, "'sigma_u' takes one value per point"),
        ({"sigma_dd_v": {"type": "bitmap", "bitmap": mi.Bitmap(np.full((8, 8, 3), 0.3,
                                                                     np.float32))}, "kdd": 0.2},
         ValueError, "'sigma_dd_v' takes one value per point"),
        ({"eta": {"type": "irregular", "wavelengths": "400, 700", "values": "1.2, -0.5"},
          "k": 1.0}, None, '"eta"'),
        ({"eta": {"type": "regular", "wavelength_min": 400, "wavelength_max": 700,
                  "values": "1.2, nan"}, "k": 1.0}, None, '"eta"'),
        # wrong types
        ({"ks": "shiny"}, TypeError, "'ks'"),
        ({"sigma": "0.1"}, TypeError, "'sigma'"),
        ({"sigma": True}, TypeError, "'sigma'"),
        ({"sigma_dd": True}, TypeError, "'sigma_dd'"),
        ({"alpha_v": "0.1"}, TypeError, "'alpha_v'"),
        ({"eta": "Cu", "k": 1.0}, TypeError, "'eta'"),
        ({"kdd": {"type": "diffuse"}}, TypeError, "'kdd'"),
        ({"kid": mi.ScalarTransform4f()}, TypeError, "'kid'"),
        ({"kid": [0.1, 0.2]}, None, "[kid]"),
        ({"material": 3.0}, TypeError, "'material'"),
        ({"shadowing": 1.0}, TypeError, "'shadowing'"),
        ({"dd_distribution": 1.0}, TypeError, "'dd_distribution'"),
        ({"sampling": 3}, TypeError, "'sampling'"),
        # unknown names and options
        ({"material": "Unobtainium"}, ValueError, "'material'"),
        ({"material": "al"}, ValueError, "'material'"),
        ({"material": "Al "}, ValueError, "'material'"),
        ({"material": ""}, ValueError, "'material'"),
        ({"shadowing": "cook"}, ValueError, "'shadowing'"),
        ({"shadowing": "none"}, ValueError, "'shadowing'"),   # the reference's, not the plugin's
        ({"dd_distribution": "phong"}, ValueError, "'dd_distribution'"),
        ({"sampling": "importance"}, ValueError, "'sampling'"),
        ({"sigmaa": 0.1}, None, '"sigmaa"'),                    # a misspelt parameter
        # conflicting parameters
        ({"material": "Cu", "eta": 0.2, "k": 3.0}, ValueError, "'material'"),
        ({"material": "Cu", "k": 3.0}, ValueError, "'material'"),
        ({"eta": 0.2}, ValueError, "'eta' and 'k'"),
        ({"k": 3.0}, ValueError, "'eta' and 'k'"),
        ({"sigma": 0.1, "alpha": 0.2}, ValueError, "'sigma' or 'alpha'"),
        ({"sigma_u": 0.1, "alpha_u": 0.2}, ValueError, "'sigma_u' or 'alpha_u'"),
        ({"alpha_v": 0.1, "sigma_v": bitmap(0.2)}, ValueError, "'sigma_v' or 'alpha_v'"),
    ]]


def load_error(params):
    """The last line of the error loading a pbrdf with ``params``, or None."""
    import mitsuba as mi

    try:
        mi.load_dict(dict({"type": "pbrdf"}, **params))
    except Exception as e:   # Mitsuba wraps the plugin's exception in a RuntimeError
        return str(e).strip().splitlines()[-1]
    return None


def describe(params):
    """Parameters as a short string (textures and Mitsuba objects abbreviated)."""
    out = []
    for key, value in params.items():
        if isinstance(value, dict):
            value = f"<{value.get('type')} texture>"
        elif not isinstance(value, (str, int, float, list)):
            value = type(value).__name__
        out.append(f"{key} = {value!r}")
    return ", ".join(out)
