"""Hostile rows that cannot be forgotten: every option of every subcommand,
found by walking ``pbrdf``'s argparse parser, gets a standard set of bad
values, so a new option gets its rows without anyone writing them.

Each row runs the command in process (``main(argv)``) on a valid minimal
command line (:data:`BASE`, itself a row: it must reach the work) with one
option replaced by a bad value. The command's long work (the render, the
fit, the sweep, the recovery, the pictures and tables) is replaced by a stub
that raises :class:`Reached`, so a row ends in one of two ways:

* **rejected**: exit status 2, the last line of stderr ``pbrdf COMMAND:
  error: ...`` naming the option (its flag, its parameter name or its
  metavar; argparse's own usage errors included), one line apart from
  argparse's usage line, no traceback, no temporary file left;
* **reached the work**: the value passed every check. Allowed for values
  an option can mean (a band named ``nan``, a negative exposure in stops),
  never for the values each option's type forbids: a float option never
  takes NaN or an infinity, an integer option never 2^63 - 1.

Values by option type: integers ``"" abc 1.5 nan -1 2^63-1``; floats
``"" abc nan inf -inf 1e309 -1 -1e-320``; strings ``"" nan /sys/x
/nonexistent/missing``; choices ``bogus``; flags take none. Positional
arguments (files) get the string values.
"""

import argparse
import os

import numpy as np
import pytest

from mitsuba_pbrdf import cli
from mitsuba_pbrdf import variant as variant_module
from mitsuba_pbrdf.cli import main

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), os.pardir, os.pardir))
CSV = os.path.join(ROOT, "tests", "data", "fit_example.csv")
HUGE = str(2 ** 63 - 1)

VALUES = {
    "int": ["", "abc", "1.5", "nan", "-1", HUGE],
    "float": ["", "abc", "nan", "inf", "-inf", "1e309", "-1", "-1e-320"],
    "str": ["", "nan", "/sys/x", "/nonexistent/missing"],
    "choice": ["bogus"],
}
#: Values each type never accepts (the rest may be meaningful to some option).
FORBIDDEN = {"int": {"", "abc", "1.5", "nan", HUGE}, "float": {"", "abc", "nan", "inf", "-inf",
                                                               "1e309"},
             "str": set(), "choice": {"bogus"}}

#: A valid minimal command line per subcommand ({tmp}, {scene} ... from the fixture).
BASE = {
    "render": ["{scene}", "--out", "{tmp}/r", "--spp", "1"],
    "view": ["{exr}", "--out", "{tmp}/v.png"],
    "polcam": ["{exr}", "--out", "{tmp}/cam"],
    "plot": ["--out", "{tmp}/p.png"],
    "gallery": ["--out", "{tmp}/g", "--only", "plot"],
    "fit": [CSV],
    "export": ["--out", "{tmp}/h.pbsdf"],
    "batch": ["{sweep}"],
    "recover-normals": ["{plate}", "--targets", "{target}", "--out", "{tmp}/rn"],
    "params": ["{scene}"],
    "convert": ["{metal}", "--out", "{tmp}/c.xml"],
}

#: Where each command's long work starts: (module, function) replaced by the stub.
WORK = [("mitsuba_pbrdf.rendering.render", "render_request"),
        ("mitsuba_pbrdf.visualization.panels", "save_overview_png"),
        ("mitsuba_pbrdf.visualization.cube_sheet", "save_cube_sheet"),
        ("mitsuba_pbrdf.camera.polcam", "write_polcam_files"),
        ("mitsuba_pbrdf.visualization.pbrdf_plots", "save_pbrdf_plot"),
        ("mitsuba_pbrdf.visualization.gallery", "run_gallery"),
        ("mitsuba_pbrdf.fitting.files", "fit_models"),   # after fit_file has read the file
        ("mitsuba_pbrdf.measured.export", "export_pbsdf"),
        ("mitsuba_pbrdf.batch.runner", "run_sweep"),
        ("mitsuba_pbrdf.inverse.normals.recover", "recover_normals"),
        ("mitsuba_pbrdf.rendering.scene_params", "scene_parameters"),
        ("mitsuba_pbrdf.rendering.scene_convert", "write_text")]


class Reached(BaseException):
    """The command passed its checks and started its work."""


def _kind(action) -> str:
    if action.choices:
        return "choice"
    if action.type is int or getattr(action.type, "__name__", "") == "int":
        return "int"
    if action.type is float:
        return "float"
    return "str"


def options():
    """``[(command, action)]``: every option and positional argument that takes
    a value, of every subcommand (help, version and flags excluded)."""
    parser = cli.build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    out = []
    for name, command in sub.choices.items():
        for action in command._actions:
            if isinstance(action, (argparse._HelpAction, argparse._VersionAction)) \
                    or action.nargs == 0:
                continue
            out.append((name, action))
    return out


def flags():
    parser = cli.build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return [(name, a) for name, command in sub.choices.items() for a in command._actions
            if a.nargs == 0 and not isinstance(a, (argparse._HelpAction,
                                                   argparse._VersionAction))]


def rows():
    out = [(command, None, None, None) for command in BASE]   # the valid minimal runs
    for command, action in options():
        kind = _kind(action)
        for value in VALUES[kind]:
            out.append((command, action, kind, value))
    return out


ROWS = rows()


def _row_id(row):
    command, action, kind, value = row
    if action is None:
        return f"{command} (valid)"
    name = action.option_strings[0] if action.option_strings else action.dest
    return f"{command} {name} {value!r}"


def _argv(command, action, value, files):
    base = [a.format(**files) for a in BASE[command]]
    if action is None:
        return [command] + base
    if not action.option_strings:   # a positional argument: the first of the base
        return [command, value] + base[1:]
    flag = action.option_strings[-1] if action.option_strings[-1].startswith("--") \
        else action.option_strings[0]
    argv = list(base)
    for opt in action.option_strings:   # an option the base already has: replaced
        if opt in argv:
            i = argv.index(opt)
            del argv[i:i + 2]
    return [command] + argv + [flag, value]


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    from tests.cli.test_cli import TINY_SCENE
    from tests.hostile.test_cli_hostile import stokes_exr

    from mitsuba_pbrdf.inverse.normals.scenes import write_plate_files

    tmp = tmp_path_factory.mktemp("generated")
    scene = tmp / "tiny.xml"
    scene.write_text(TINY_SCENE)
    flat = np.zeros((4, 4, 3), np.float32)
    flat[..., 2] = 1.0
    plate = write_plate_files(tmp, flat, size=8, spp=1)
    sweep = tmp / "sweep.toml"
    sweep.write_text(f'scene = "{scene}"\nout = "out"\nspp = 1\n')
    metal = tmp / "metal.xml"
    metal.write_text('<scene version="3.0.0"><bsdf type="conductor"/></scene>')
    return dict(tmp=str(tmp), scene=str(scene), exr=stokes_exr(tmp / "good.exr"),
                metal=str(metal),
                target=stokes_exr(tmp / "target.exr", h=8, w=8), plate=plate,
                sweep=str(sweep))


@pytest.fixture
def stubbed(monkeypatch):
    import importlib

    monkeypatch.setattr(variant_module, "cuda_available", lambda: False)

    def reached(*args, **kwargs):
        raise Reached

    # modules that import a stubbed function by name at their own import: import
    # them first, so that they keep the real one after this test
    for module in ("mitsuba_pbrdf.visualization.gallery", "mitsuba_pbrdf.inverse",
                   "mitsuba_pbrdf.batch", "mitsuba_pbrdf.fitting"):
        importlib.import_module(module)
    for module, name in WORK:
        monkeypatch.setattr(importlib.import_module(module), name, reached)


def test_the_rows_cover_every_option():
    """Counts, for the report: options, values, rows (and the flags, which
    take no value)."""
    opts = options()
    assert len(ROWS) == len(BASE) + sum(len(VALUES[_kind(a)]) for _, a in opts)
    commands = {c for c, _ in opts}
    assert commands == set(BASE), commands ^ set(BASE)
    print(f"{len(opts)} options and arguments with values ({len(flags())} flags), "
          f"{sum(len(v) for v in VALUES.values())} values in 4 types, {len(ROWS)} rows")


@pytest.mark.usefixtures("restore_variant", "stubbed")
@pytest.mark.parametrize("row", ROWS, ids=[_row_id(r) for r in ROWS])
def test_generated_hostile_row(row, files, capfd, monkeypatch):
    command, action, kind, value = row
    monkeypatch.chdir(files["tmp"])
    argv = _argv(command, action, value, files)
    try:
        status = main(argv)
    except Reached:
        status = "reached"
    except SystemExit as e:         # argparse's usage errors
        status = e.code
    out, err = capfd.readouterr()
    assert "Traceback" not in err and "internal error" not in err, err
    leftovers = [n for _, _, names in os.walk(files["tmp"]) for n in names if ".tmp" in n]
    assert not leftovers
    if action is None:
        assert status == "reached", err
        return
    if status == "reached":
        assert value not in FORBIDDEN[kind], f"{argv} was accepted"
        return
    assert status == 2, (status, err)
    lines = [line for line in err.strip().splitlines() if line.strip()]
    last = lines[-1]
    assert last.startswith(f"pbrdf {command}: error: "), err
    usage = [line for line in lines[:-1] if not line.startswith(("usage:", " "))]
    assert not usage or all(line.startswith("pbrdf ") and "warning" in line for line in usage), \
        err
    names = set(action.option_strings) | {action.dest, action.dest.replace("_", "-")}
    if action.metavar:
        names |= {m for m in str(action.metavar).split("|")}
    if not action.option_strings:   # a file argument: the message names the file
        names |= {value, repr(value)} - {""}
    assert any(n and n in last for n in names), (names, last)
