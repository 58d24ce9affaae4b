"""Ctrl-C at any instant (mitsuba_pbrdf.interrupts, mitsuba_pbrdf.outputs.together).

In process (fast): a SIGINT that comes while held is recorded and delivered
as KeyboardInterrupt when released; an output is never replaced while one is
pending; outputs written together are all replaced or none; a KeyboardInterrupt
that Dr.Jit wraps (``dr.while_loop``) is reported as an interruption (exit
130), not as an error (exit 2).

For real (slow): ``pbrdf render``, ``render --bands``, ``fit``, ``batch`` and
``recover-normals`` get SIGINT at random delays from 0 to 2 s after they
start, with earlier outputs in place. Each run must end in one of: exit 130
with ``pbrdf COMMAND: interrupted`` as the last line of stderr and no
traceback, every earlier output unchanged and no temporary file; exit 0 (the
signal came after the work was done), every output complete; or, in the
first tens of milliseconds, Python's own start-up (the signal killed the
interpreter before its handler was installed, or interrupted site.py: no line
of this package ran, nothing was written). The delays are printed (``-s``)
with the seed that drew them.
"""

import os
import random
import signal
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from mitsuba_pbrdf import interrupts
from mitsuba_pbrdf.cli import main
from mitsuba_pbrdf.outputs import together, write_text

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), os.pardir))

#: every test here starts from Python's own SIGINT handler, whatever pytest inherited
pytestmark = pytest.mark.usefixtures("python_sigint_handler")


def _sigint_now():
    os.kill(os.getpid(), signal.SIGINT)


def test_a_held_sigint_is_delivered_on_release():
    with pytest.raises(KeyboardInterrupt):
        with interrupts.held():
            _sigint_now()
            assert interrupts.pending()       # recorded, not raised
    assert not interrupts.pending() and not interrupts.is_held()
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_no_output_is_replaced_while_a_sigint_is_pending(tmp_path):
    target = write_text(tmp_path / "a.txt", "old\n")
    with pytest.raises(KeyboardInterrupt):
        with interrupts.held():
            _sigint_now()
            write_text(target, "new\n")
    assert open(target).read() == "old\n" and os.listdir(tmp_path) == ["a.txt"]


def test_outputs_written_together_are_replaced_together_or_not_at_all(tmp_path):
    a, b = write_text(tmp_path / "a.txt", "old a\n"), write_text(tmp_path / "b.txt", "old b\n")
    with pytest.raises(KeyboardInterrupt):
        with together():
            write_text(a, "new a\n")
            _sigint_now()                     # Ctrl-C between the two writes
            write_text(b, "new b\n")
    assert [open(p).read() for p in (a, b)] == ["old a\n", "old b\n"]
    with pytest.raises(ValueError):
        with together():
            write_text(a, "new a\n")
            raise ValueError("the second output failed")
    assert open(a).read() == "old a\n"
    with together():
        write_text(a, "new a\n")
        write_text(b, "new b\n")
        assert open(a).read() == "old a\n"   # replaced at the end only
    assert [open(p).read() for p in (a, b)] == ["new a\n", "new b\n"]
    assert sorted(os.listdir(tmp_path)) == ["a.txt", "b.txt"]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_a_sigint_before_a_command_ends_is_delivered_by_run_command(capfd):
    from mitsuba_pbrdf.cli.errors import run_command

    def command(args):
        _sigint_now()      # recorded: the command line holds SIGINT until released
        raise ValueError("an error after Ctrl-C")

    interrupts.hold()
    assert run_command(command, None, "render") == 130
    assert capfd.readouterr().err.strip() == "pbrdf render: interrupted"
    assert not interrupts.is_held()


def test_a_keyboard_interrupt_wrapped_by_drjit_is_an_interruption(capfd):
    """dr.while_loop wraps a KeyboardInterrupt raised in its body in a
    RuntimeError ('encountered an exception (see above)'), as recover-normals
    met it; the command line says interrupted and exits 130, not 2."""
    import drjit as dr
    import mitsuba as mi

    from mitsuba_pbrdf.cli.errors import run_command

    def body(i):
        raise KeyboardInterrupt

    def command(args):
        dr.while_loop((mi.UInt32(0),), lambda i: i < 3, body)

    assert run_command(command, None, "recover-normals") == 130
    out, err = capfd.readouterr()
    assert err.strip().splitlines()[-1] == "pbrdf recover-normals: interrupted"


def test_a_keyboard_interrupt_in_an_extensions_import_is_an_interruption(capfd):
    """A Ctrl-C inside a pybind11 extension's module init during a command's
    long work comes back as ``ImportError: initialization failed`` raised from
    the KeyboardInterrupt (a fit's lazy SciPy import met it): interrupted,
    exit 130, not an internal error."""
    from mitsuba_pbrdf.cli.errors import run_command

    def command(args):
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as e:
            raise ImportError("initialization failed") from e

    assert run_command(command, None, "fit") == 130
    assert capfd.readouterr().err.strip() == "pbrdf fit: interrupted"

    def bug(args):
        raise ImportError("initialization failed")

    assert run_command(bug, None, "fit") == 1
    assert "internal error: ImportError" in capfd.readouterr().err


def test_on_the_command_line_a_sigint_after_the_outputs_changes_nothing(tmp_path, capfd, monkeypatch):
    """Once together() has replaced the outputs the command has finished: on
    the command line SIGINT stays held to the end, then is ignored (SIG_IGN
    survives the interpreter's shutdown, a Python handler does not), so a
    late Ctrl-C neither reports an interruption nor kills the process."""
    from mitsuba_pbrdf.cli.errors import run_command

    monkeypatch.setitem(interrupts._state, "command_line", True)
    target = write_text(tmp_path / "a.txt", "old\n")

    def command(args):
        with together():
            write_text(target, "new\n")
        assert interrupts.is_held()     # still held after the commit
        _sigint_now()                   # recorded, not raised
        print("wrote a.txt")
        return 0

    assert run_command(command, None, "render") == 0
    assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
    _sigint_now()                       # ignored to the end of the process
    assert open(target).read() == "new\n"
    out, err = capfd.readouterr()
    assert out == "wrote a.txt\n" and err == ""


def test_on_the_command_line_an_error_or_interruption_ends_with_sigint_ignored(capfd, monkeypatch):
    from mitsuba_pbrdf.cli.errors import CliError, run_command

    monkeypatch.setitem(interrupts._state, "command_line", True)

    def failing(args):
        raise CliError("--spp: must be positive")

    def interrupted_while_failing(args):
        interrupts.hold()
        _sigint_now()
        raise CliError("--spp: must be positive")

    assert run_command(failing, None, "render") == 2
    assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
    signal.signal(signal.SIGINT, signal.default_int_handler)
    assert run_command(interrupted_while_failing, None, "render") == 130
    assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
    err = capfd.readouterr().err.splitlines()
    assert err == ["pbrdf render: error: --spp: must be positive", "pbrdf render: interrupted"]


def test_a_ctrl_c_through_an_exec_still_exits_130_under_python_m(tmp_path):
    """A KeyboardInterrupt that passed through ``exec`` of a string (as SciPy's
    array-API shim imports NumPy: a Ctrl-C while ``pbrdf fit`` imported
    scipy.optimize) left CPython's unhandled-Ctrl-C flag set although
    run_command caught it, and under ``python -m`` the interpreter killed
    itself with SIGINT after its shutdown: a parent saw -2 (5 runs of 30 of
    ``pbrdf fit`` interrupted at 0.2-0.8 s), not the 130 it reported."""
    (tmp_path / "probe.py").write_text(textwrap.dedent("""
        import sys
        from mitsuba_pbrdf.cli.errors import run_command

        def command(args):
            exec("raise KeyboardInterrupt")

        sys.exit(run_command(command, None, "fit"))
    """))
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    done = subprocess.run([sys.executable, "-m", "probe"], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 130, (done.returncode, done.stderr)
    assert done.stderr.strip().splitlines()[-1] == "pbrdf fit: interrupted"


@pytest.mark.parametrize("orig_argv, argv0, holds", [
    (["python", "-m", "mitsuba_pbrdf", "render"], "-m", True),
    (["/venv/bin/python", "/venv/bin/pbrdf", "fit"], "/venv/bin/pbrdf", True),
    (["python", "-m", "pytest"], "/x/pytest/__main__.py", False),
    (["python", "-m", "mitsuba_pbrdf.schema"], "-m", False),
    (["python", "script.py"], "script.py", False),
])
def test_the_command_line_holds_from_the_package_import(monkeypatch, orig_argv, argv0, holds):
    monkeypatch.setattr(sys, "orig_argv", orig_argv, raising=False)
    monkeypatch.setattr(sys, "argv", [argv0])
    monkeypatch.setitem(interrupts._state, "command_line", False)   # put back after
    try:
        assert interrupts.hold_for_command_line() is holds
    finally:
        interrupts.release()


# ------------------------------------------------------------- SIGINT for real

SCENE = os.path.join(ROOT, "scenes", "default.xml")
SMALL = ["-D", "width=48", "-D", "height=36", "--variant", "llvm_ad_spectral_polarized"]


def _render(out):
    return ["render", SCENE, "--spp", "64", "--out", f"{out}/r", *SMALL], ["r.exr", "r.png"]


def _bands(out):
    return (["render", SCENE, "--bands", "450:650:20", "--spp", "20", "--out", f"{out}/c",
             *SMALL], ["c.exr", "c.png"])


def _fit(out):
    return (["fit", os.path.join(ROOT, "tests", "data", "fit_example.csv"), "--json",
             f"{out}/fit.json", "--plot", f"{out}/fit.png"], ["fit.json", "fit.png"])


def _batch(out):
    """Earlier files where the sweep's jobs write theirs (no manifest yet: the
    jobs render and replace them, each atomically, one job at a time)."""
    sweep = os.path.join(out, "sweep.toml")
    with open(sweep, "w") as f:
        f.write(f'scene = "{SCENE}"\nout = "{out}/batch"\nspp = 4\n'
                '[params]\nwidth = 16\nheight = 12\nsigma = [0.1, 0.2]\n')
    return ["batch", sweep, "--workers", "1"], ["batch/sigma-0.1.exr", "batch/sigma-0.2.exr"]


def _recover(out):
    from mitsuba_pbrdf.inverse.normals.scenes import write_plate_files
    from mitsuba_pbrdf.stokes.exr import write_stokes_exr
    from mitsuba_pbrdf.stokes.image import StokesImage

    flat = np.zeros((4, 4, 3), np.float32)
    flat[..., 2] = 1.0
    plate = write_plate_files(out, flat, size=8, spp=1)
    stokes = np.zeros((8, 8, 4, 3), np.float32)
    stokes[:, :, 0], stokes[:, :, 1] = 1.0, 0.2
    target = write_stokes_exr(os.path.join(out, "t.exr"), StokesImage(stokes, ["R", "G", "B"]))
    return (["recover-normals", plate, "--targets", str(target), "--out", f"{out}/rn",
             "--iterations", "30", "--spp", "2", "--no-progress"],
            ["rn/normals.exr", "rn/normals.png", "rn/recovery.json"])


COMMANDS = {"render": _render, "render --bands": _bands, "fit": _fit, "batch": _batch,
            "recover-normals": _recover}


@pytest.mark.slow
def test_a_sigint_once_the_outputs_are_written_lets_the_command_finish(tmp_path):
    """SIGINT the moment ``pbrdf render``'s PNG appears (the EXR and PNG are
    replaced together, last): the command has finished, so it exits 0 with
    both outputs complete. (Before, Python's shutdown, which takes a second
    on this machine, restored SIGINT's default action and the process died
    of the signal: the shell's status 130 for a finished render.)"""
    from mitsuba_pbrdf.stokes.exr import read_stokes_exr
    from proof.interrupt import interrupt_once_output_exists

    args, _ = _render(str(tmp_path))
    result = interrupt_once_output_exists(args, tmp_path, "r.png")
    assert result.returncode == 0, (result.returncode, result.stderr)
    assert "r.png" in result.stdout and read_stokes_exr(str(tmp_path / "r.exr")).width == 48


@pytest.mark.slow
@pytest.mark.parametrize("name", list(COMMANDS))
def test_sigint_at_random_delays_never_replaces_an_output(name, tmp_path):
    from proof.interrupt import interrupt_after, sigint_outcome

    seed = random.randrange(2 ** 32)
    rng = random.Random(seed)
    delays = sorted(rng.uniform(0.0, 2.0) for _ in range(3))
    print(f"{name}: seed {seed}, delays {', '.join(f'{d:.3f}' for d in delays)} s")
    for i, delay in enumerate(delays):
        out = tmp_path / f"{i}-{delay:.3f}"  # two delays may print alike (CI: 0.567, 0.567)
        out.mkdir()
        args, outputs = COMMANDS[name](str(out))
        for rel in outputs:
            os.makedirs(os.path.dirname(out / rel), exist_ok=True)
            (out / rel).write_bytes(b"an earlier output")
        result = interrupt_after(args, delay)
        outcome = sigint_outcome(result, args[0])
        print(f"  {delay:.3f} s: {outcome}")
        earlier = [(out / rel).read_bytes() == b"an earlier output" for rel in outputs]
        leftovers = [str(p) for p in out.rglob("*") if ".tmp" in p.name]
        assert not leftovers, (delay, leftovers)
        if outcome in ("interrupted", "before python", "python startup"):
            if name == "batch":   # jobs are separate: each file earlier or a finished job's
                from mitsuba_pbrdf.stokes.exr import read_stokes_exr

                for rel, kept in zip(outputs, earlier):
                    assert kept or read_stokes_exr(str(out / rel)).width == 16, (delay, rel)
            else:
                assert all(earlier), (delay, outcome, result.stderr)
        else:
            assert outcome == "finished", (delay, outcome)
            assert not any(earlier), (delay, "finished without replacing its outputs")


def test_a_sigint_before_the_package_can_hold_it_counts_as_python_startup():
    """A KeyboardInterrupt in the package's import of ``interrupts`` (before it
    can hold SIGINT) is start-up, as in site.py; one raised after it, in the
    package's other lines, is a failure of the promise."""
    import subprocess

    from proof.interrupt import sigint_outcome

    def outcome(code):
        err = ('Traceback (most recent call last):\n'
               '  File "<frozen runpy>", line 112, in _get_module_details\n'
               '  File "/x/mitsuba_pbrdf/__init__.py", line 43, in <module>\n'
               f'    {code}\n'
               '  File "/x/mitsuba_pbrdf/interrupts.py", line 42, in <module>\n'
               '    import threading\n'
               '  File "<frozen importlib._bootstrap>", line 1176, in _find_and_load\n'
               'KeyboardInterrupt\n')
        return sigint_outcome(subprocess.CompletedProcess([], -2, "", err), "render")

    assert outcome("from . import interrupts as _interrupts") == "python startup"
    assert outcome("from .registry import install_hook").startswith("exit -2 with: Traceback")
