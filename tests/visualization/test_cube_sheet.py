"""What the tools do with a Stokes cube (``pbrdf render --bands``): ``pbrdf
view --cube / --spectrum``, ``pbrdf polcam`` (one mosaic per band) and ``pbrdf
batch`` (``bands = ...`` in the sweep file). The cubes here are written from
known arrays where the property checked does not need a render."""

import os
from pathlib import Path

import numpy as np
import pytest

from mitsuba_pbrdf.camera.polcam import SensorModel, mono_mosaic, polcam_outputs
from mitsuba_pbrdf.cli import main
from mitsuba_pbrdf.errors import ParameterError
from mitsuba_pbrdf.visualization.cube_sheet import parse_region, stokes_spectrum
from mitsuba_pbrdf.rendering.bands import parse_bands
from mitsuba_pbrdf.rendering.cube import cube_image
from mitsuba_pbrdf.stokes.exr import read_exr_channels, read_stokes_exr, write_stokes_exr

pytestmark = pytest.mark.usefixtures("restore_variant")
SCENES = Path(__file__).resolve().parents[2] / "scenes"
BANDS = parse_bands("450:530:20")


def known_cube(h=12, w=16):
    """A cube whose band b has S0 = 1 + b, DoLP 0.1 (b + 1), AoLP 10 b degrees,
    and S0 doubled in a 2 x 2 block at x 3-4, y 2-3."""
    stokes = np.zeros((h, w, 4, len(BANDS.edges)), np.float32)
    for b in range(len(BANDS.edges)):
        s0, p, angle = 1.0 + b, 0.1 * (b + 1), np.radians(10 * b)
        stokes[:, :, :, b] = [s0, s0 * p * np.cos(2 * angle), s0 * p * np.sin(2 * angle), 0]
    stokes[2:4, 3:5, 0, :] *= 2  # a brighter 2 x 2 block
    return cube_image(stokes, BANDS, {"title": "known"})


def test_region_spectrum_is_the_region_mean():
    image = known_cube()
    spectrum = stokes_spectrum(image, parse_region("3,2,2,2"))
    assert spectrum.shape == (4, 4)
    np.testing.assert_allclose(spectrum[:, 0], 2 * (1.0 + np.arange(4)), rtol=1e-6)
    one = stokes_spectrum(image, parse_region("10,8"))
    np.testing.assert_allclose(one[:, 0], 1.0 + np.arange(4), rtol=1e-6)
    for bad, text in [("3", "expects X,Y"), ("1,2,0,1", "W, H >= 1"), ("-1,2", "X, Y >= 0")]:
        with pytest.raises(ParameterError, match=text):
            parse_region(bad)
    with pytest.raises(ParameterError, match="outside the 16x12 image"):
        parse_region("15,11,2,1", image)


def test_cli_view_cube_sheet_and_spectrum_csv(tmp_path, capsys):
    exr = write_stokes_exr(tmp_path / "cube.exr", known_cube())
    out = tmp_path / "sheet.png"
    assert main(["view", exr, "--spectrum", "3,2,2,2", "--out", str(out)]) == 0
    assert "(4 bands)" in capsys.readouterr().out
    assert out.stat().st_size > 0
    lines = (tmp_path / "sheet.csv").read_text().splitlines()
    assert lines[1] == "band,centre_nm,S0,S1,S2,S3,DoLP"
    rows = [line.split(",") for line in lines[2:]]
    assert [r[0] for r in rows] == ["460nm", "480nm", "500nm", "520nm"]
    np.testing.assert_allclose([float(r[2]) for r in rows], [2, 4, 6, 8], rtol=1e-6)
    # the block's S0 is doubled, S1 and S2 are not: half the DoLP
    np.testing.assert_allclose([float(r[6]) for r in rows], [0.05, 0.1, 0.15, 0.2], rtol=1e-5)
    assert main(["view", exr, "--cube", "--out", str(tmp_path / "c.png")]) == 0
    assert main(["view", exr, "--band", "480nm", "--out", str(tmp_path / "b.png")]) == 0
    # the command line names its option; nothing is written
    assert main(["view", exr, "--spectrum", "20,2", "--out", str(tmp_path / "x.png")]) == 2
    assert "--spectrum: pixel (20, 2) is outside" in capsys.readouterr().err
    assert not (tmp_path / "x.png").exists()


def test_the_sheet_and_its_spectrum_are_written_together(tmp_path):
    """save_cube_sheet with a CSV writes both files (the command's test above),
    or neither when one cannot be written."""
    from mitsuba_pbrdf.visualization.cube_sheet import save_cube_sheet

    image, region = known_cube(), parse_region("3,2,2,2")
    (tmp_path / "dir.csv").mkdir()
    with pytest.raises(OSError):
        save_cube_sheet(tmp_path / "t.png", image, region=region, csv=tmp_path / "dir.csv")
    assert not (tmp_path / "t.png").exists()
    with pytest.raises(ParameterError, match="csv"):
        save_cube_sheet(tmp_path / "u.png", image, csv=tmp_path / "u.csv")


def test_polcam_of_a_cube_gives_one_mosaic_per_band(tmp_path):
    image = known_cube()
    outputs = polcam_outputs(image)
    assert list(outputs["mosaic"]) == image.bands
    for name in image.bands:
        np.testing.assert_array_equal(outputs["mosaic"][name], mono_mosaic(image, name))
        assert set(outputs["I0"]) == set(image.bands)
    noisy = polcam_outputs(image, model=SensorModel(full_well=1000, bits=8, seed=3))
    assert [k for k in noisy if k.endswith(".png")] == [f"mosaic_{b}.png" for b in image.bands]
    # each band has its own noise (seed + band index), not one pattern repeated
    a, b = (noisy["mosaic"][n] / noisy["mosaic"][n].mean() for n in image.bands[:2])
    assert not np.allclose(a, b)
    exr = write_stokes_exr(tmp_path / "cube.exr", image)
    assert main(["polcam", exr, "--out", str(tmp_path / "cam")]) == 0
    mosaic = read_exr_channels(tmp_path / "cam" / "cube_mosaic.exr")
    assert sorted(mosaic) == sorted(image.bands)


def test_colour_sensor_refuses_a_cube_saying_why_and_what_to_do(tmp_path, capfd):
    """R, G, B of the colour sensor are integrals over the whole visible
    spectrum; a cube's band averages cannot give them: the library names its
    parameter, the command line the option, in one line, and nothing is written."""
    image = known_cube()
    with pytest.raises(ParameterError) as e:
        polcam_outputs(image, sensor="colour")
    assert e.value.parameter == "sensor"
    exr = write_stokes_exr(tmp_path / "cube.exr", image)
    assert main(["polcam", exr, "--sensor", "colour", "--out", str(tmp_path / "cam")]) == 2
    err = capfd.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(
        "pbrdf polcam: error: --sensor: 'colour' cannot see a Stokes cube: the colour sensor's "
        "R, G, B filters each integrate the whole visible spectrum"), err
    assert "render the scene without bands" in err[0] and "mono sensor" in err[0]
    assert not (tmp_path / "cam").exists()


@pytest.mark.parametrize("body, words", [
    ('bands = "500:450"\n', ["bands: the band '500:450' is reversed or empty"]),
    ('bands = "450:650:20"\nvariant = "llvm_ad_mono_polarized"\n',
     ["bands: needs a spectral variant"]),
    ('bands = 5\n', ["bands must be a non-empty string"]),
    ('bands = "450:650:20"\noutputs = ["stokes", "polcam"]\n[polcam]\nsensor = "colour"\n',
     ["polcam.sensor 'colour' cannot see the cube that bands renders",
      "render the scene without bands"]),
])
def test_bad_bands_in_a_sweep_are_refused_at_load_time(tmp_path, body, words):
    from mitsuba_pbrdf.batch.sweep import SweepError, load_sweep

    path = tmp_path / "s.toml"
    path.write_text(f'scene = "{SCENES / "analytic_plane.xml"}"\nout = "o"\n' + body)
    with pytest.raises(SweepError) as e:
        load_sweep(path)
    for word in words:
        assert word in str(e.value)


def test_batch_job_renders_a_cube(tmp_path):
    """A sweep's ``bands`` reaches the job's render: the job's EXR is the cube,
    and its polcam files have one mosaic per band (run_job in this process: the
    Dask side is tested in tests/batch/test_runner.py)."""
    from mitsuba_pbrdf.batch.job import run_job
    from mitsuba_pbrdf.batch.runner import _task
    from mitsuba_pbrdf.batch.sweep import load_sweep

    path = tmp_path / "s.toml"
    path.write_text(f'scene = "{SCENES / "analytic_plane.xml"}"\nout = "o"\nspp = 4\n'
                    'bands = "600:680:20"\nvariant = "llvm_ad_spectral_polarized"\n'
                    'outputs = ["stokes", "polcam"]\n[params]\nwidth = 16\nheight = 12\n')
    sweep = load_sweep(path)
    assert sweep.bands == "600:680:20"
    result = run_job(_task(sweep, sweep.jobs[0]))
    assert result.status == "done", result.error
    image = read_stokes_exr(os.path.join(sweep.out, result.file))
    assert image.bands == ["610nm", "630nm", "650nm", "670nm"]
    assert image.metadata["band_edges_nm"] == "600-620,620-640,640-660,660-680"
    mosaic = read_exr_channels(os.path.join(sweep.out, f"{sweep.jobs[0].name}_mosaic.exr"))
    assert sorted(mosaic) == sorted(image.bands)


def test_view_cube_warns_about_picture_options_the_contact_sheet_ignores(tmp_path, capfd):
    """``view --cube`` draws S0 (each band at its own exposure), DoLP and AoLP:
    --panels, --exposure and --stokes-scale are named in one warning line each,
    the options the sheet uses (--dolp-limit, --min-dolp, --dolp-cmap) in none,
    and the sheet is still drawn."""
    exr = write_stokes_exr(tmp_path / "cube.exr", known_cube())
    out = tmp_path / "c.png"
    assert main(["view", exr, "--cube", "--panels", "intensity", "--exposure", "1",
                 "--stokes-scale", "separate", "--dolp-limit", "0.5", "--min-dolp", "0.1",
                 "--dolp-cmap", "gray", "--out", str(out)]) == 0
    err = [line for line in capfd.readouterr().err.splitlines() if "warning" in line]
    why = ("has no effect on the contact sheet of a cube (it draws S0, DoLP and AoLP of "
           "every band; it uses --dolp-limit, --min-dolp, --dolp-cmap)")
    assert err == [f"pbrdf view: warning: {option} {why}"
                   for option in ("--panels", "--exposure", "--stokes-scale")]
    assert out.stat().st_size > 0
    assert main(["view", exr, "--spectrum", "3,2", "--dolp-limit", "0.5", "--out",
                 str(out)]) == 0
    assert "warning" not in capfd.readouterr().err


def dolp_bar_labels(fig):
    return [ax.get_ylabel() for ax in fig.axes if ax.get_ylabel().startswith("DoLP")]


def test_cube_sheet_shares_one_dolp_scale_and_its_titles_do_not_collide():
    """known_cube's DoLP is 0.1, 0.2, 0.3, 0.4 in its four bands: by default
    every band is drawn on one scale (0-0.5), so the least polarized band looks
    the least polarized; per band, the first spans a scale 2.5 x narrower. The
    three titles of a row do not overlap when drawn."""
    from mitsuba_pbrdf.visualization.cube_sheet import cube_sheet_figure, shared_dolp_limit

    image = known_cube()
    assert shared_dolp_limit(image) == 0.5
    fig = cube_sheet_figure(image, title="known")
    assert dolp_bar_labels(fig) == ["DoLP (0–0.5)"] * 4
    assert "DoLP 0–0.5 in every band (auto)" in fig._suptitle.get_text()
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    rows = {}
    for ax in fig.axes:
        if ax.get_title():
            rows.setdefault(round(ax.get_position().y0, 3), []).append(
                ax.title.get_window_extent(renderer))
    assert len(rows) == 4 and all(len(r) == 3 for r in rows.values())
    for boxes in rows.values():
        boxes = sorted(boxes, key=lambda b: b.x0)
        assert all(a.x1 < b.x0 for a, b in zip(boxes, boxes[1:]))
    per_band = dolp_bar_labels(cube_sheet_figure(image, dolp_scale="per-band"))
    # (the first band's 0.1 is 0.1000001 in float32: rounded up to the next nice step)
    assert per_band == ["DoLP (0–0.2, auto)", "DoLP (0–0.25, auto)", "DoLP (0–0.5, auto)",
                        "DoLP (0–0.5, auto)"]
    fixed = dolp_bar_labels(cube_sheet_figure(image, dolp_limit=0.3))
    assert fixed == ["DoLP (0–0.3)"] * 4


def test_view_dolp_scale_option(tmp_path, capfd):
    exr = write_stokes_exr(tmp_path / "cube.exr", known_cube())
    assert main(["view", exr, "--cube", "--dolp-scale", "per-band", "--out",
                 str(tmp_path / "c.png")]) == 0
    assert (tmp_path / "c.png").stat().st_size > 0
    assert main(["view", exr, "--band", "460nm", "--dolp-scale", "per-band", "--out",
                 str(tmp_path / "b.png")]) == 0
    assert "--dolp-scale has no effect without --cube" in capfd.readouterr().err
