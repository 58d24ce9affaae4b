"""Options do what ``--help`` says, or say why not: ``pbrdf polcam --exposure``
takes effect whenever it is accepted (with ``--bits`` or ``--full-well``), and
is refused where it would be ignored (the refusals are rows of
tests/hostile/test_cli_hostile.py and tests/batch/test_runner.py)."""

import numpy as np

from mitsuba_pbrdf.cli import main
from mitsuba_pbrdf.stokes.exr import read_exr_channels, write_stokes_exr
from mitsuba_pbrdf.stokes.image import StokesImage


def ramp_exr(path):
    """An unpolarized Stokes EXR whose S0 ramps from 0 to 1 across the image."""
    h, w = 8, 16
    stokes = np.zeros((h, w, 4, 3), np.float32)
    stokes[:, :, 0] = np.linspace(0.0, 1.0, w, dtype=np.float32)[None, :, None]
    write_stokes_exr(path, StokesImage(stokes, ["R", "G", "B"]))
    return str(path)


def test_exposure_with_bits_saturates_at_the_exposure(tmp_path, capsys):
    exr = ramp_exr(tmp_path / "ramp.exr")
    assert main(["polcam", exr, "--out", str(tmp_path / "auto"), "--bits", "8"]) == 0
    assert main(["polcam", exr, "--out", str(tmp_path / "half"), "--bits", "8",
                 "--exposure", "0.25"]) == 0
    auto = read_exr_channels(tmp_path / "auto" / "ramp_mosaic.exr")["Y"]
    half = read_exr_channels(tmp_path / "half" / "ramp_mosaic.exr")["Y"]
    # behind an ideal polarizer an unpolarized pixel keeps half its S0, so the
    # frame's maximum is 0.5; with --exposure 0.25 every pixel brighter than
    # 0.25 records 0.25 (full well), the others are quantized to 1/255 of it
    raw = auto.max()
    assert abs(raw - 0.5) < 0.5 / 255
    assert abs(half.max() - 0.25) < 1e-6
    saturated = auto > 0.25 + 0.5 / 255
    assert saturated.any() and np.allclose(half[saturated], 0.25, atol=1e-6)
    dim = auto < 0.25 - 0.5 / 255
    # quantization steps: 0.5/255 without the exposure, 0.25/255 with it
    assert np.all(np.abs(half[dim] - auto[dim]) <= 0.5 / 255 + 1e-6)


def test_picture_options_the_panels_do_not_use_are_warned_about(tmp_path, capfd):
    """``pbrdf view`` with a picture option none of the chosen panels uses
    prints one warning line naming it (and still draws); an option a chosen
    panel uses prints none."""
    exr = ramp_exr(tmp_path / "ramp.exr")
    out = str(tmp_path / "v.png")
    assert main(["view", exr, "--panels", "intensity", "--dolp-limit", "0.5", "--min-dolp",
                 "0.1", "--out", out]) == 0
    err = [line for line in capfd.readouterr().err.splitlines() if "warning" in line]
    assert err == [
        "pbrdf view: warning: --dolp-limit has no effect on the panels intensity "
        "(it is used by dolp, hsv)",
        "pbrdf view: warning: --min-dolp has no effect on the panels intensity "
        "(it is used by aolp)"]
    assert main(["view", exr, "--panels", "intensity,dolp", "--dolp-limit", "0.5",
                 "--stokes-scale", "separate", "--out", out]) == 0
    err = [line for line in capfd.readouterr().err.splitlines() if "warning" in line]
    assert err == ["pbrdf view: warning: --stokes-scale has no effect on the panels "
                   "intensity,dolp (it is used by s1, s2, s3)"]
