"""The records of the fit's and the readers' choices (mitsuba_pbrdf.choices):
what each model fixes and each layout detects is what the library does, and
the command line's parser, which takes its choices from them, loads no NumPy."""

import subprocess
import sys

import pytest

from mitsuba_pbrdf import choices, schema
from mitsuba_pbrdf.fitting import vector
from mitsuba_pbrdf.measured.measurements import ANGLES


def test_the_two_component_model_fixes_the_directional_diffuse_lobe():
    assert choices.MODELS["two"].fixed == schema.LOBES["directional_diffuse"] == ("kdd",
                                                                                   "sigma_dd")
    assert choices.MODELS["three"].fixed == ()
    assert vector.absent_parameters("two") == {
        "kdd": "it is the three-component model with kdd = 0",
        "sigma_dd": "it is the three-component model with kdd = 0"}
    assert vector.absent_parameters("three") == {}


def test_a_model_without_a_lobe_fits_its_weight_at_zero():
    two = vector.ParameterVector([633.0], "two", {}, {})
    assert two.values["kdd"] == 0.0 and {"kdd", "sigma_dd"} <= two.fixed
    assert not {"kdd", "sigma_dd"} & set(two.free)
    assert {"kdd", "sigma_dd"} <= set(vector.ParameterVector([633.0], "three", {}, {}).free)


@pytest.mark.parametrize("given, kept", [({"three": 3, "two": 2}, 3), ({"two": 2, "three": 3}, 3),
                                         ({"two": 2}, 2)])
def test_the_preferred_fit_is_the_richest_models(given, kept):
    assert choices.preferred(given) == kept


def test_both_is_every_model():
    assert choices.model_names("both") == tuple(choices.MODELS)
    assert choices.model_names("two") == ("two",)


@pytest.mark.parametrize("header, layout, expected", [
    (["theta_i", "phi_i", "theta_r", "phi_r", "wavelength", "m00"], "auto", "goniometer"),
    (["lambda", "thetai", "phi", "thetar", "phir", "f_r11"], "auto", "nist"),
    (["lambda", "f_r11"], "auto", "nist"),
    (["lambda", "thetai", "phi", "thetar", "phir", "f_r11"], "goniometer", "goniometer"),
])
def test_the_layout_is_told_by_the_header_unless_named(header, layout, expected):
    assert choices.layout_of(header, layout).name == expected


def test_every_layout_has_a_reader():
    from mitsuba_pbrdf.measured.formats import READERS

    assert set(READERS) == set(choices.LAYOUTS)
    assert choices.LAYOUTS["goniometer"].columns.startswith(", ".join(ANGLES) + ", wavelength")


def test_the_parser_loads_no_numpy():
    """Building ``pbrdf``'s parser (every ``--help``) imports the records, not the readers."""
    code = ("import sys; from mitsuba_pbrdf.cli import build_parser; build_parser()\n"
            "assert 'numpy' not in sys.modules, 'numpy'\n"
            "assert 'mitsuba_pbrdf.measured' not in sys.modules, 'measured'\n"
            "assert 'mitsuba_pbrdf.fitting' not in sys.modules, 'fitting'\n")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            timeout=120)
    assert result.returncode == 0, result.stderr
