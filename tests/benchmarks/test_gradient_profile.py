"""benchmarks/gradient_profile.py and benchmarks/device_check.sh: the IR
counts, the argument checks, and (slow) one tiny profile end to end, run as
a user runs it, in its own process."""

import io
import os
import re
import subprocess
import sys

import pytest

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), os.pardir, os.pardir))
sys.path.insert(0, os.path.join(ROOT, "benchmarks"))

import gradient_profile  # noqa: E402


def test_ir_counts_count_call_sites_in_llvm_ir():
    ir = io.StringIO(
        "define void @drjit_abc(i64 %start) {\n"
        "  %a = call <16 x float> @llvm.masked.gather.v16f32(<16 x ptr> %p)\n"
        "  %b = call fastcc [8 x <16 x float>] @gather_8xf32(<16 x ptr> %q)\n"
        "  call fastcc void @reduce_add_f32_noconflict(ptr %r, <16 x float> %a)\n"
        "  call void @llvm.masked.scatter.v16f32(<16 x float> %a, <16 x ptr> %p)\n"
        "  %c = alloca [4 x <16 x float>]\n"
        "}\n"
        "define fastcc %Ret_f @func_0123(ptr %x) {\n"
        "}\n"
        "define internal fastcc [8 x <16 x float>] @gather_8xf32(<16 x ptr> %q) {\n"
        "}\n")
    counts = gradient_profile.ir_counts({"ir": ir}, "llvm")
    assert counts == {"gathers": 2, "scatters": 1, "atomics": 1, "calls": 1, "local": 1,
                      "lines": 11}


def test_gradient_difference_is_relative_to_each_parameters_largest():
    a = {"eta": [2.0], "map": [4.0, -1.0, 0.0], "zero": [0.0]}
    assert gradient_profile.gradient_difference(a, a) == 0.0
    b = {"eta": [2.0], "map": [4.0, -1.5, 0.0], "zero": [1.0]}
    assert gradient_profile.gradient_difference(a, b) == 0.5 / 4.0


def test_baseline_is_another_checkouts_integrator():
    """--baseline DIR: DIR's stokes_prb module builds its class (in the suite's
    variant) and its methods run on this checkout's integrator."""
    import mitsuba as mi

    module = gradient_profile.load_baseline(ROOT)
    assert module.__file__ == os.path.join(ROOT, "mitsuba_pbrdf", "integrators", "stokes_prb.py")
    assert issubclass(module.StokesPRBIntegrator, mi.ad.integrators.common.ADIntegrator)
    assert callable(module.StokesPRBIntegrator.render_backward)


def run(args, **kw):
    return subprocess.run(args, cwd=ROOT, capture_output=True, text=True, timeout=600,
                          env=dict(os.environ, PYTHONPATH=ROOT), **kw)


@pytest.mark.parametrize("args, message", [
    (["--backend", "opencl"], "--backend must be cuda or llvm, got 'opencl'"),
    (["--sizes"], "unknown argument '--sizes'"),
])
def test_device_check_refuses_bad_arguments_in_one_line(args, message):
    proc = run(["bash", "benchmarks/device_check.sh"] + args)
    assert proc.returncode == 2
    assert proc.stdout == ""
    assert proc.stderr.strip().splitlines() == [f"device_check.sh: {message}" + (
        " (expected --backend cuda|llvm)" if "unknown" in message else "")]


def test_profile_refuses_bad_sizes_in_one_line():
    proc = run([sys.executable, "benchmarks/gradient_profile.py", "--cold", "--sizes", "16,x"])
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines()[-1].endswith(
        "--sizes: comma-separated integers expected, got '16,x'")


@pytest.mark.slow
def test_tiny_profile_prints_every_phase():
    proc = run([sys.executable, "benchmarks/gradient_profile.py", "--size", "16", "--spp", "2",
                "--reps", "1"])
    assert proc.returncode == 0, proc.stderr[-2000:]
    rows = {m.group(1): m.group(2) for m in re.finditer(r"^\| ([a-z ]+) \| (.*)\|$", proc.stdout,
                                                         re.MULTILINE)}
    assert set(rows) >= {"primal render", "primal pass", "adjoint pass"}
    # the adjoint pass is one large kernel that keeps its vertices in local arrays
    cells = [c.strip() for c in rows["adjoint pass"].split("|")]
    columns = [c[0] for c in gradient_profile.COLUMNS]
    assert int(cells[columns.index("local arrays")]) > 0
    assert int(cells[columns.index("largest: ops")]) > int(
        rows["primal pass"].split("|")[columns.index("largest: ops")])
    ratio = re.search(r"gradient \(this checkout\) / primal render: wall time, median "
                      r"(\d+\.\d+)", proc.stdout)
    assert ratio and 0.5 < float(ratio.group(1)) < 100
