"""pbrdf render's files in one call (mitsuba_pbrdf.visualization.render_files):
docs/python.md's section runs, and the files are those the command writes."""

import re
from pathlib import Path

from mitsuba_pbrdf.stokes.exr import read_stokes_exr

ROOT = Path(__file__).resolve().parents[2]


def test_python_md_render_section_runs(tmp_path, monkeypatch, capsys):
    text = (ROOT / "docs" / "python.md").read_text("utf-8")
    body = text.split("## A render's files in one call\n", 1)[1].split("\n## ", 1)[0]
    blocks = re.findall(r"```python\n(.*?)```", body, re.S)
    assert blocks
    monkeypatch.chdir(tmp_path)
    for code in blocks:
        exec(compile(code, "docs/python.md", "exec"), {})
    assert capsys.readouterr().out.strip() == "(24, 32, 4, 3) default.exr default.png"
    image = read_stokes_exr(tmp_path / "default.exr")
    assert image.metadata["title"] == "default: llvm_ad_spectral_polarized, 2 spp"
    assert image.s0.mean() > 0 and (tmp_path / "default.png").stat().st_size > 0
