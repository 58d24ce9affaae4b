"""pbrdf render's files in one call (mitsuba_pbrdf.visualization.render_files):
docs/python.md's section runs, and the files are those the command writes."""

from mitsuba_pbrdf.stokes.exr import read_stokes_exr
from proof.doc_sections import run_section


def test_python_md_render_section_runs(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert run_section("python.md", "A render's files in one call")
    assert capsys.readouterr().out.strip() == "(24, 32, 4, 3) default.exr default.png"
    image = read_stokes_exr(tmp_path / "default.exr")
    assert image.metadata["title"] == "default: llvm_ad_spectral_polarized, 2 spp"
    assert image.s0.mean() > 0 and (tmp_path / "default.png").stat().st_size > 0
