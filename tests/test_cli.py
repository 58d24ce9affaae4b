"""The command line (mitsuba_pbrdf.cli), run in-process through main([...])."""

import os
import subprocess
import sys

import matplotlib.image
import mitsuba as mi
import numpy as np
import OpenEXR
import pytest

import mitsuba_pbrdf
from mitsuba_pbrdf.cli import main
from mitsuba_pbrdf.stokes_io import read_stokes_exr

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), os.pardir))
STOKES_CHANNELS = sorted(["R", "G", "B"] + [f"S{i}.{b}" for i in range(4) for b in "RGB"])

#: A tiny scene: a pbrdf sphere under a constant sky and an oblique area light.
TINY_SCENE = """<scene version="3.0.0">
    <default name="spp" value="4"/>
    <default name="sigma" value="0.1"/>
    <integrator type="stokes">
        <integrator type="path"><integer name="max_depth" value="3"/></integrator>
    </integrator>
    <sensor type="perspective">
        <transform name="to_world"><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
        <film type="hdrfilm">
            <integer name="width" value="32"/><integer name="height" value="24"/>
            <string name="pixel_format" value="rgb"/>
        </film>
    </sensor>
    <shape type="sphere">
        <bsdf type="pbrdf">
            <string name="material" value="Cu"/>
            <float name="sigma" value="$sigma"/>
            <spectrum name="kdd" value="0.1"/>
            <spectrum name="kid" value="0.05"/>
        </bsdf>
    </shape>
    <shape type="rectangle">
        <transform name="to_world"><lookat origin="-3, 1, -2" target="0, 0, 0" up="0, 1, 0"/></transform>
        <emitter type="area"><rgb name="radiance" value="5"/></emitter>
    </shape>
    <emitter type="constant"><rgb name="radiance" value="0.5"/></emitter>
</scene>
"""


@pytest.fixture(autouse=True)
def restore_variant():
    """The CLI switches Mitsuba's variant; put back the one the suite uses."""
    before = mi.variant()
    yield
    if mi.variant() != before:
        mi.set_variant(before)
        mitsuba_pbrdf.register()


@pytest.fixture
def scene(tmp_path):
    path = tmp_path / "tiny.xml"
    path.write_text(TINY_SCENE)
    return path


def exr_channels(path):
    with OpenEXR.File(str(path), separate_channels=True) as f:
        return sorted(f.channels())


def check_png(path):
    assert path.stat().st_size < 500_000
    pixels = matplotlib.image.imread(str(path))
    assert pixels.ndim == 3 and pixels.shape[0] > 100 and pixels.shape[1] > pixels.shape[0]
    return pixels


def error_of(capsys):
    """The one-line error message a failed command printed."""
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    return err


# ---------------------------------------------------------------- render / view


def test_render_writes_stokes_exr_and_png(scene, tmp_path, capsys):
    out = tmp_path / "result" / "tiny"
    assert main(["render", str(scene), "--spp", "4", "--out", str(out), "-D", "sigma=0.2"]) == 0
    stdout = capsys.readouterr().out
    assert f"wrote {out}.exr" in stdout and f"wrote {out}.png" in stdout
    assert "timings: load" in stdout and "render" in stdout

    assert exr_channels(f"{out}.exr") == STOKES_CHANNELS
    image = read_stokes_exr(f"{out}.exr")
    assert image.stokes.shape == (24, 32, 4, 3)
    assert np.all(np.isfinite(image.stokes))
    assert image.s0.max() > 0
    assert image.metadata["params"] == "sigma=0.2"
    assert image.metadata["variant"] == "llvm_ad_spectral_polarized"
    assert image.metadata["spp"] == "4"
    check_png(tmp_path / "result" / "tiny.png")


def test_render_default_out_is_out_slash_scene_stem(scene, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["render", str(scene), "--spp", "2"]) == 0
    assert (tmp_path / "out" / "tiny.exr").is_file()
    assert (tmp_path / "out" / "tiny.png").is_file()


def test_render_out_directory(scene, tmp_path):
    (tmp_path / "dir").mkdir()
    assert main(["render", str(scene), "--spp", "2", "--out", str(tmp_path / "dir")]) == 0
    assert (tmp_path / "dir" / "tiny.exr").is_file()


def test_view_redraws_the_png(scene, tmp_path, capsys):
    main(["render", str(scene), "--spp", "2", "--out", str(tmp_path / "r")])
    capsys.readouterr()
    png = tmp_path / "view.png"
    panels = "intensity,dolp,aolp,docp,s1,s2,s3"
    assert main(["view", str(tmp_path / "r.exr"), "--out", str(png), "--panels", panels]) == 0
    assert f"wrote {png}" in capsys.readouterr().out
    check_png(png)


def test_default_scene_renders_small(tmp_path, capsys):
    """scenes/default.xml loads and renders with the pbrdf plugin (tiny size)."""
    out = tmp_path / "default"
    argv = ["render", os.path.join(ROOT, "scenes", "default.xml"), "--spp", "2",
            "-D", "width=32", "-D", "height=24", "--out", str(out)]
    assert main(argv) == 0, capsys.readouterr().err
    image = read_stokes_exr(f"{out}.exr")
    assert image.stokes.shape == (24, 32, 4, 3)
    assert image.s0.mean() > 0


def test_python_dash_m_entry_point():
    """`python -m mitsuba_pbrdf` reaches the CLI (needs no variant set first)."""
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    result = subprocess.run([sys.executable, "-m", "mitsuba_pbrdf", "--help"],
                            capture_output=True, text=True, env=env, timeout=120)
    assert result.returncode == 0, result.stderr
    assert "render" in result.stdout and "view" in result.stdout


# ---------------------------------------------------------------- errors: exit 2, one line


def test_missing_scene_file(tmp_path, capsys):
    assert main(["render", str(tmp_path / "nope.xml")]) == 2
    err = error_of(capsys)
    assert "scene file not found" in err and "nope.xml" in err


def test_bad_xml_shows_mitsubas_parse_error(tmp_path, capsys):
    bad = tmp_path / "bad.xml"
    bad.write_text('<scene version="3.0.0">\n<shape type="sphere">\n<bsdf type="pbrdf">\n</shape>\n'
                   "</scene>\n")
    assert main(["render", str(bad)]) == 2
    err = error_of(capsys)
    assert "cannot load" in err and "bad.xml" in err and "mismatch" in err


def test_plugin_error_is_one_line_without_traceback(scene, capsys):
    assert main(["render", str(scene), "-D", "sigma=-1"]) == 2
    err = error_of(capsys)
    assert "sigma" in err and "Traceback" not in err


def test_unknown_scene_parameter_error(scene, capsys):
    assert main(["render", str(scene), "-D", "nosuch=1"]) == 2
    assert "nosuch" in error_of(capsys)


def test_bad_define(scene, capsys):
    assert main(["render", str(scene), "-D", "sigma"]) == 2
    assert "key=value" in error_of(capsys)


def test_unknown_variant_lists_the_available_ones(scene, capsys):
    assert main(["render", str(scene), "--variant", "llvm_ad_nonsense"]) == 2
    err = error_of(capsys)
    assert "llvm_ad_nonsense" in err and "llvm_ad_spectral_polarized" in err


def test_unpolarized_variant_is_refused_clearly(scene, capsys):
    assert main(["render", str(scene), "--variant", "llvm_ad_rgb"]) == 2
    assert "polarized" in error_of(capsys)


def test_view_missing_exr(tmp_path, capsys):
    assert main(["view", str(tmp_path / "nope.exr")]) == 2
    assert "nope.exr" in error_of(capsys)


def test_view_exr_without_stokes_channels(tmp_path, capsys):
    path = tmp_path / "plain.exr"
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, {c: np.zeros((2, 2), np.float32) for c in "RGB"}) as f:
        f.write(str(path))
    assert main(["view", str(path)]) == 2
    err = error_of(capsys)
    assert "plain.exr" in err and "no Stokes channels" in err and "B, G, R" in err


def test_usage_error_exits_2():
    with pytest.raises(SystemExit) as e:
        main(["render"])
    assert e.value.code == 2
