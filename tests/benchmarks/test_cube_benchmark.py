"""Smoke test of benchmarks/cube.py (--quick): it runs end to end and reports
finite, positive figures. The full run is by hand (docs/spectral-cube.md)."""

import os
import re
import sys

ROOT = os.path.join(os.path.dirname(__file__), os.pardir, os.pardir)
sys.path.insert(0, os.path.join(ROOT, "benchmarks"))

import cube  # noqa: E402


def test_quick_cube_benchmark_reports_the_cost_table(tmp_path):
    report = tmp_path / "cube.md"
    assert cube.main(["--quick", "--rounds", "2", "--report", str(report)]) == 0
    text = report.read_text()
    row = [line for line in text.splitlines() if line.startswith("| analytic_plane")]
    assert len(row) == 1
    numbers = [float(x) for x in re.findall(r"\| ([0-9.]+(?:e-?\d+)?) (?=\|)", row[0])]
    # cube spp, cube s, narrow spp, narrow s, two noises, equal-noise s, speed-up
    # (seconds are printed to 0.01 s, so a tiny render may read 0.00)
    assert len(numbers) == 8 and all(n >= 0 for n in numbers), row
    cube_spp, _, narrow_spp, narrow_s, cube_noise, narrow_noise, _, _ = numbers
    assert cube_spp == narrow_spp * 10 / 4 and narrow_s > 0
    assert cube_noise > 0 and narrow_noise > 0
