"""The command line (mitsuba_pbrdf.cli), run in-process through main([...])."""

import os
import subprocess
import sys

import matplotlib.image
import mitsuba as mi
import numpy as np
import OpenEXR
import pytest

from mitsuba_pbrdf import variant as variant_module
from mitsuba_pbrdf.cli import main
from mitsuba_pbrdf.stokes.exr import read_stokes_exr

#: The real GPU probe (the autouse fixture below replaces it).
CUDA_AVAILABLE = variant_module.cuda_available
ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), os.pardir, os.pardir))
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
def cpu_default_variant(monkeypatch):
    """Commands without --variant use the LLVM variant here even on a machine
    with a GPU (the choice itself is tested with its probe below)."""
    monkeypatch.setattr(variant_module, "cuda_available", lambda: False)


# The code under test switches Mitsuba's variant (conftest.restore_variant).
pytestmark = pytest.mark.usefixtures("restore_variant")


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


# ---------------------------------------------------------------- passes, progress, variants


def test_plan_passes():
    from mitsuba_pbrdf.rendering.passes import (SAMPLES_PER_GPU_PASS, SAMPLES_PER_PASS,
                                                derivative_seed, pass_seeds, plan_passes,
                                                samples_per_pass)

    assert plan_passes(4, pixels=320 * 240) == [4]  # within the budget: one pass
    # scenes/default.xml (320 x 240, 64 spp): 4 passes of 16 spp, each 2^21 samples at most,
    # a power of two (the kernel of one-pass power-of-two renders), whatever the machine
    assert plan_passes(64, pixels=320 * 240) == [16] * 4
    assert 320 * 240 * 16 <= SAMPLES_PER_PASS == 1 << 21
    assert plan_passes(100, pixels=320 * 240) == [16] * 6 + [4]  # the rest in a last pass
    assert plan_passes(5, pixels=4000 * 4000) == [1] * 5          # cannot split below 1 spp
    assert plan_passes(10, passes=4) == [3, 3, 2, 2]               # a given count: equal passes
    assert plan_passes(3, passes=8) == [1, 1, 1]
    big = plan_passes(1024, pixels=640 * 480, budget=samples_per_pass("llvm"))
    assert big == [4] * 256 and 640 * 480 * 4 <= SAMPLES_PER_PASS
    assert samples_per_pass("cuda") == SAMPLES_PER_GPU_PASS
    assert plan_passes(64, pixels=320 * 240, budget=SAMPLES_PER_GPU_PASS) == [64]
    with pytest.raises(ValueError):
        plan_passes(0)
    seeds = pass_seeds(7, 50)
    assert seeds[0] == 7 and len(set(seeds)) == 50 and all(0 <= s < 2**32 for s in seeds)
    assert not set(pass_seeds(8, 50)) & set(seeds)
    # the derivative seed mi.render pairs with a primal seed (Mitsuba's TEA hash)
    for seed in (0, 5, 2**32 - 1):
        assert derivative_seed(seed) == int(mi.sample_tea_32(seed, 1)[0])


def test_passes_average_the_pass_images_weighted_by_their_samples():
    """A 3-pass render (3 + 3 + 2 spp) is the spp-weighted mean of single-pass
    renders with the pass seeds. analytic_plane.xml has one emitter, so renders
    with the same seed are identical (with several emitters Mitsuba 3.9 may
    list them in another order at each load, changing the sample realization)."""
    from mitsuba_pbrdf.rendering import render_scene
    from mitsuba_pbrdf.rendering.passes import pass_seeds

    scene = os.path.join(ROOT, "scenes", "analytic_plane.xml")
    small = {"width": 16, "height": 12}
    image = render_scene(scene, spp=8, passes=3, seed=5, params=small)
    assert image.metadata["passes"] == "3" and image.metadata["spp"] == "8"
    seeds = pass_seeds(5, 3)
    parts = [render_scene(scene, spp=n, passes=1, seed=s, params=small).stokes.astype(np.float64)
             for n, s in zip([3, 3, 2], seeds)]
    expected = (3 * parts[0] + 3 * parts[1] + 2 * parts[2]) / 8
    np.testing.assert_allclose(image.stokes, expected, rtol=1e-5, atol=1e-7)
    assert np.abs(parts[0] - parts[1]).max() > 1e-4  # the seeds differ


def test_render_passes_and_progress_bar(scene, tmp_path, capsys):
    out = tmp_path / "p"
    assert main(["render", str(scene), "--spp", "4", "--passes", "2", "--progress",
                 "--out", str(out)]) == 0
    captured = capsys.readouterr()
    assert "rendering tiny.xml (2 passes)" in captured.err and "spp" in captured.err
    assert read_stokes_exr(f"{out}.exr").metadata["passes"] == "2"
    assert main(["render", str(scene), "--passes", "0"]) == 2
    assert "--passes: must be at least 1" in error_of(capsys)


def test_default_variant_probe():
    assert variant_module.default_variant(lambda: False) == "llvm_ad_spectral_polarized"
    assert variant_module.default_variant(lambda: True) == "cuda_ad_spectral_polarized"

    def broken():
        raise RuntimeError("no driver")

    assert variant_module.default_variant(broken) == "llvm_ad_spectral_polarized"


def test_cuda_available_needs_the_variant_and_a_device(monkeypatch):
    import drjit as dr

    before = mi.variant()
    with monkeypatch.context() as m:
        m.setattr(mi, "variants", lambda: ["llvm_ad_spectral_polarized"])
        assert CUDA_AVAILABLE() is False

    # a backend that claims to exist but a variant that cannot be set: no GPU
    monkeypatch.setattr(dr, "has_backend", lambda backend: True)
    real_set_variant = mi.set_variant

    def set_variant(name, *args):
        if name.startswith("cuda"):
            raise ImportError("the CUDA backend hasn't been initialized")
        return real_set_variant(name, *args)

    monkeypatch.setattr(mi, "set_variant", set_variant)
    assert CUDA_AVAILABLE() is False
    assert mi.variant() == before

    # a variant that can be set: a GPU; the probe puts the previous variant back
    calls = []
    monkeypatch.setattr(mi, "set_variant", lambda name, *args: calls.append(name))
    assert CUDA_AVAILABLE() is True
    assert calls == ["cuda_ad_spectral_polarized", before]


def test_render_without_variant_uses_the_probe(scene, tmp_path, monkeypatch):
    monkeypatch.setattr(variant_module, "cuda_available", lambda: False)
    assert main(["render", str(scene), "--spp", "1", "--out", str(tmp_path / "v")]) == 0
    assert read_stokes_exr(tmp_path / "v.exr").metadata["variant"] == "llvm_ad_spectral_polarized"


def test_gpu_variant_that_cannot_start_is_a_clear_error(scene, tmp_path, capsys, monkeypatch):
    import drjit as dr

    if dr.has_backend(dr.JitBackend.CUDA):
        pytest.skip("a CUDA GPU is present")
    monkeypatch.setattr(variant_module, "cuda_available", lambda: True)  # a probe that is wrong
    assert main(["render", str(scene), "--spp", "1", "--out", str(tmp_path / "g")]) == 2
    err = error_of(capsys)
    assert "cuda_ad_spectral_polarized" in err and "cannot be used here" in err


# ---------------------------------------------------------------- view options


def test_view_sheet_band_and_greyscale(scene, tmp_path, capsys):
    main(["render", str(scene), "--spp", "2", "--out", str(tmp_path / "r")])
    capsys.readouterr()
    exr = str(tmp_path / "r.exr")
    assert main(["view", exr]) == 0  # default: the full sheet, next to the EXR
    check_png(tmp_path / "r.png")
    png = tmp_path / "g.png"
    assert main(["view", exr, "--out", str(png), "--panels", "dolp,aolp,hsv", "--band", "B",
                 "--dolp-cmap", "gray", "--dolp-limit", "0.5", "--min-dolp", "0.05",
                 "--exposure", "1.5"]) == 0
    check_png(png)
    capsys.readouterr()
    assert main(["view", exr, "--band", "Q"]) == 2
    assert "no band 'Q'" in error_of(capsys)
    assert main(["view", exr, "--panels", "dolp,nope"]) == 2
    err = error_of(capsys)
    assert "nope" in err and "choose from" in err
    assert main(["view", exr, "--dolp-limit", "0"]) == 2
    assert "--dolp-limit" in error_of(capsys)
    # the former spelling still works, says so in one line, and errors name it as typed
    assert main(["view", exr, "--dolp-max", "0"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert err[0] == "pbrdf view: warning: --dolp-max is deprecated, use --dolp-limit"
    assert err[1].startswith("pbrdf view: error: --dolp-max must be a finite number > 0")


# ---------------------------------------------------------------- plot


def test_plot_writes_the_pbrdf_sheet(tmp_path, capsys):
    png = tmp_path / "plot.png"
    argv = ["plot", "--material", "Cu", "--sigma", "0.1", "--kdd", "0.2", "--theta-i", "40",
            "--out", str(png)]
    assert main(argv) == 0
    assert "reference evaluator" in capsys.readouterr().out
    pixels = check_png(png)
    assert pixels.shape[0] > 500
    assert main(["plot", "--eta", "1.5", "--k", "3", "--shadowing", "smith",
                 "--dd-distribution", "ggx", "--kdd", "0.1", "--theta-i", "0",
                 "--wavelengths", "500", "--out", str(tmp_path / "n.png")]) == 0


@pytest.mark.parametrize("args, message", [
    (["--material", "Unobtainium"], "unknown material 'Unobtainium'"),
    (["--sigma", "0"], "sigma must be > 0"),
    (["--kid", "-1"], "kid must be >= 0"),
    (["--theta-i", "95"], "theta_i must be in [0, 90)"),
    (["--material", "Cu", "--eta", "1.5", "--k", "3"], "not both"),
    (["--eta", "1.5"], "both eta and k"),
    (["--wavelengths", "abc"], "comma-separated numbers"),
    (["--material", "Cu", "--wavelengths", "100"], "outside the 'Cu' table range"),
])
def test_plot_errors(tmp_path, capsys, args, message):
    assert main(["plot", *args, "--out", str(tmp_path / "x.png")]) == 2
    assert message in error_of(capsys)
    assert not (tmp_path / "x.png").exists()


# ---------------------------------------------------------------- gallery


def test_gallery_command(tmp_path, capsys):
    assert main(["gallery", "--only", "plot", "--out", str(tmp_path / "g")]) == 0
    assert "wrote" in capsys.readouterr().out
    check_png(tmp_path / "g" / "pbrdf_plot.png")
    assert main(["gallery", "--only", "plot,bogus"]) == 2
    assert "unknown gallery item(s) bogus" in error_of(capsys)
    assert main(["gallery", "--scenes", str(tmp_path / "nowhere"), "--only", "materials"]) == 2
    assert "gallery scenes" in error_of(capsys)
    assert main(["gallery", "--scale", "0"]) == 2
    assert "--scale" in error_of(capsys)


def test_gallery_leaves_the_repository_pictures_alone(tmp_path, capsys, monkeypatch):
    """By default the pictures go to out/gallery/ under the current folder;
    the repository's gallery/ is written only with --update-repo-pictures
    (here: its check and the folder it picks, without writing there)."""
    from mitsuba_pbrdf.cli import gallery as gallery_command

    picture = os.path.join(ROOT, "gallery", "pbrdf_plot.png")
    before = os.stat(picture).st_mtime_ns
    monkeypatch.chdir(tmp_path)
    assert main(["gallery", "--only", "plot"]) == 0
    check_png(tmp_path / "out" / "gallery" / "pbrdf_plot.png")
    assert os.stat(picture).st_mtime_ns == before
    assert gallery_command.repository_gallery() == os.path.join(ROOT, "gallery")
    assert main(["gallery", "--only", "plot", "--update-repo-pictures", "--out", "g"]) == 2
    assert "--update-repo-pictures writes README's pictures" in error_of(capsys)
    assert not (tmp_path / "g").exists()
    monkeypatch.setattr(gallery_command, "__file__", str(tmp_path / "site" / "cli" / "x.py"))
    assert main(["gallery", "--only", "plot", "--update-repo-pictures"]) == 2
    assert "does not run from a clone" in error_of(capsys)


def test_a_mistyped_option_shows_the_subcommands_usage(scene, capsys, tmp_path):
    with pytest.raises(SystemExit) as e:
        main(["render", str(scene), "--varient", "x", "--out", str(tmp_path / "x")])
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("usage: pbrdf render ")
    assert err.strip().splitlines()[-1] == ("pbrdf render: error: unrecognized arguments: "
                                            "--varient x (did you mean --variant?)")
    assert not list(tmp_path.glob("x.*"))


def test_help_lists_every_command(capsys):
    with pytest.raises(SystemExit) as e:
        main(["--help"])
    assert e.value.code == 0
    out = capsys.readouterr().out
    for command in ("render", "view", "plot", "gallery"):
        assert command in out


def test_render_mono_polarized_variant(scene, tmp_path):
    """Mono variants: Mitsuba names the Stokes bands R, G, B (all equal) and
    the preview Y; the EXR keeps them by name."""
    out = tmp_path / "mono"
    assert main(["render", str(scene), "--spp", "2", "--variant", "llvm_ad_mono_polarized",
                 "--out", str(out)]) == 0
    image = read_stokes_exr(f"{out}.exr")
    assert image.bands == ["R", "G", "B"] and image.metadata["variant"] == "llvm_ad_mono_polarized"
    np.testing.assert_array_equal(image.stokes[..., 0], image.stokes[..., 2])
    assert image.s0.max() > 0


def test_library_errors_name_the_option_the_command_has():
    """A library error names its parameter (``wavelength: ...``); the command
    line's error path names the option where the command has one, and leaves
    the parameter's name where it has none."""
    import argparse

    from mitsuba_pbrdf.cli.errors import option_message
    from mitsuba_pbrdf.errors import ParameterError

    error = ParameterError("sigma_dd", "must be positive,\n got 0")
    assert option_message(error, argparse.Namespace(sigma_dd=1.0)) == \
        "--sigma-dd: must be positive, got 0"
    assert option_message(error, argparse.Namespace()) == "sigma_dd: must be positive, got 0"
