"""A scene's -D parameters are discoverable: ``pbrdf params SCENE`` lists each
``<default>`` with its value and what it sets (the schema's doc line for the
pbrdf BSDF's properties), and a key the scene does not take is refused with
the closest name and the scene's list, before Mitsuba parses anything."""

import os

import pytest

from mitsuba_pbrdf import schema
from mitsuba_pbrdf import variant as variant_module
from mitsuba_pbrdf.cli import main
from mitsuba_pbrdf.rendering.scene_params import (SceneParameterError, check_parameter_values,
                                                  scene_parameters)

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), os.pardir, os.pardir))
DEFAULT = os.path.join(ROOT, "scenes", "default.xml")
PLANE = os.path.join(ROOT, "scenes", "analytic_plane.xml")
NO_SPP = """<scene version="3.0.0">
    <integrator type="stokes"><integrator type="path"/></integrator>
    <sensor type="perspective"><film type="hdrfilm">
        <integer name="width" value="4"/><integer name="height" value="4"/>
    </film></sensor>
</scene>
"""


@pytest.fixture(autouse=True)
def cpu_default_variant(monkeypatch):
    monkeypatch.setattr(variant_module, "cuda_available", lambda: False)


def error_of(capsys):
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    return err


def test_scene_parameters_read_every_default_in_file_order():
    params = scene_parameters(DEFAULT)
    with open(DEFAULT) as f:
        text = f.read()
    assert [p.name for p in params][:3] == ["spp", "width", "height"]
    for p in params:  # each <default> of the file, with its value
        assert f'<default name="{p.name}" value="{p.default}"/>' in text
    sigma = next(p for p in params if p.name == "sigma")
    assert sigma.default == "0.08"
    assert sigma.doc() == f"pbrdf sigma: {schema.parameter('sigma').doc}"
    spp = next(p for p in params if p.name == "spp")
    assert spp.doc() == '<integer name="sample_count"> of the sampler (independent)'


def test_params_command_lists_values_and_schema_docs(capsys):
    assert main(["params", PLANE]) == 0
    out = capsys.readouterr().out
    lines = out.splitlines()
    assert lines[0].startswith(f"{PLANE}: 13 parameters")
    eta = next(line for line in lines if line.split()[:2] == ["eta", "1.2"])
    assert "pbrdf eta: Real part n" in eta
    assert "material" not in out.split("\n", 1)[1]  # the plane takes eta and k, not material
    assert main(["params", "gallery/plate"]) == 0  # a packaged scene, by name
    captured = capsys.readouterr()
    assert "wrapper" in captured.out and "the plugin type of a <bsdf>" in captured.out
    assert "listing the packaged scene" in captured.err


def test_params_command_says_where_the_samples_are_set(tmp_path, capsys):
    scene = tmp_path / "nospp.xml"
    scene.write_text(NO_SPP)
    assert main(["params", str(scene)]) == 0
    assert "no spp parameter: set the samples per pixel with pbrdf render --spp N" in \
        capsys.readouterr().out


def test_params_command_counts_one_parameter_in_the_singular(tmp_path, capsys):
    scene = tmp_path / "one.xml"
    scene.write_text(NO_SPP.replace('<integer name="width" value="4"/>',
                                    '<integer name="width" value="$width"/>')
                     .replace("<integrator type=\"stokes\">",
                              '<default name="width" value="4"/><integrator type="stokes">'))
    assert main(["params", str(scene)]) == 0
    assert capsys.readouterr().out.startswith(f"{scene}: 1 parameter (pbrdf render")


def test_unknown_key_gets_the_closest_name_and_the_list(capsys, tmp_path):
    assert main(["render", DEFAULT, "-D", "materal=Au", "--out", str(tmp_path / "x")]) == 2
    err = error_of(capsys)
    assert "unknown scene parameter 'materal' (did you mean 'material'?); this scene's " \
           "parameters: back_light, dd_distribution, height," in err
    assert "Found unused parameters" not in err  # refused before Mitsuba's parser
    assert main(["render", PLANE, "-D", "material=Ag", "--out", str(tmp_path / "x")]) == 2
    err = error_of(capsys)
    assert "unknown scene parameter 'material'" in err and "eta" in err and " k," in err
    assert not list(tmp_path.iterdir())
    with pytest.raises(SceneParameterError, match="did you mean 'sigma'"):
        check_parameter_values(DEFAULT, {"sgima": "0.1"})


def test_spp_on_a_scene_without_it_points_to_the_spp_option(tmp_path, capsys):
    scene = tmp_path / "nospp.xml"
    scene.write_text(NO_SPP)
    assert main(["render", str(scene), "-D", "spp=256", "--out", str(tmp_path / "x")]) == 2
    err = error_of(capsys)
    assert "unknown scene parameter 'spp'" in err and "--spp N" in err
