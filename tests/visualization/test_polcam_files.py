"""pbrdf polcam's files in one call (mitsuba_pbrdf.visualization.polcam_files):
docs/python.md's section runs, and the files are the command's, written all
or none."""

from pathlib import Path

import numpy as np
import pytest

from mitsuba_pbrdf.camera.polcam import SensorModel
from mitsuba_pbrdf.cli import main
from mitsuba_pbrdf.stokes.exr import write_stokes_exr
from mitsuba_pbrdf.stokes.image import StokesImage
from mitsuba_pbrdf.visualization.polcam_files import polcam_files
from proof.doc_sections import run_section


def stokes_image(h=4, w=6, seed=8):
    """Physical Stokes vectors in R, G, B: S0 in [1, 2], DoLP below 1."""
    rng = np.random.default_rng(seed)
    s0 = rng.uniform(1, 2, (h, w, 3))
    p, a = rng.uniform(0, 0.9, s0.shape), rng.uniform(-np.pi / 2, np.pi / 2, s0.shape)
    stokes = np.stack([s0, s0 * p * np.cos(2 * a), s0 * p * np.sin(2 * a), 0 * s0], axis=2)
    return StokesImage(stokes.astype(np.float32), ["R", "G", "B"])


def test_python_md_camera_section_runs(tmp_path, monkeypatch, capsys):
    (tmp_path / "out").mkdir()
    write_stokes_exr(tmp_path / "out" / "default.exr", stokes_image())
    monkeypatch.chdir(tmp_path)
    assert run_section("python.md", "A polarization camera's files")
    assert capsys.readouterr().out.strip() == "['Y'] True"
    assert (tmp_path / "out" / "cam" / "default_mosaic_preview.png").is_file()


def test_the_files_are_the_commands_and_come_all_or_none(tmp_path):
    src = write_stokes_exr(tmp_path / "scene.exr", stokes_image())
    assert main(["polcam", src, "--out", str(tmp_path / "cli"), "--bits", "12"]) == 0
    files = polcam_files(src, tmp_path / "lib", model=SensorModel(bits=12))
    names = sorted(Path(p).name for p in files.paths)
    assert names == sorted(p.name for p in (tmp_path / "cli").iterdir())
    (tmp_path / "lib").mkdir()
    (tmp_path / "lib" / "scene_mosaic_preview.png").mkdir()   # the last file cannot be written
    with pytest.raises(OSError):
        files.write()
    assert [p.name for p in (tmp_path / "lib").iterdir()] == ["scene_mosaic_preview.png"]
