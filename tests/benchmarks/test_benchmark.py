"""Smoke test of benchmarks/benchmark.py (--quick): it runs end to end and
reports finite figures. The full run is by hand (``docs/performance.md``)."""

import os
import re
import sys

import pytest

ROOT = os.path.join(os.path.dirname(__file__), os.pardir, os.pardir)
sys.path.insert(0, os.path.join(ROOT, "benchmarks"))

import benchmark  # noqa: E402

from mitsuba_pbrdf import use_variant  # noqa: E402


@pytest.mark.slow
def test_quick_benchmark_reports_every_section(tmp_path):
    try:
        assert benchmark.main(["--quick", "--out", str(tmp_path)]) == 0
    finally:
        use_variant("llvm_ad_spectral_polarized")
    text = (tmp_path / "results.md").read_text()
    for heading in ("Render time at equal spp", "JIT compile", "BSDF evaluation throughput",
                    "Error versus time", "Peak memory"):
        assert heading in text
    section = text.split("## Render time at equal spp")[1].split("## JIT compile")[0]
    ratios = [float(r) for r in re.findall(r"\| (\d+\.\d+) \|\n", section)]
    assert len(ratios) == 7 and all(0 < r < 100 for r in ratios)
    assert (tmp_path / "figures" / "error_vs_time_plane_small_light.png").stat().st_size > 10_000
