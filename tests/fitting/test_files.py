"""The one-call reading and fitting of a file (mitsuba_pbrdf.measured.reading,
mitsuba_pbrdf.fitting.files): docs/python.md's section runs, the calls give
what the steps they stand for give, and ``pbrdf fit``'s choices are the
library's records."""

import json
import re
from pathlib import Path

import numpy as np
import pytest

from mitsuba_pbrdf import fitting, measured
from mitsuba_pbrdf.errors import ParameterError
from proof.doc_sections import run_section

ROOT = Path(__file__).resolve().parents[2]
NIST = ROOT / "tests" / "data" / "nist_ptfe_subset.csv"


def test_python_md_reading_and_fitting_runs(tmp_path, monkeypatch, capsys):
    (tmp_path / "tests").mkdir()
    (tmp_path / "tests" / "data").symlink_to(ROOT / "tests" / "data")
    monkeypatch.chdir(tmp_path)    # the block's outputs go here, its inputs are the repository's
    assert run_section("python.md", "Reading and fitting a file")
    assert capsys.readouterr().out.split()[1] == "None"   # a CSV file has no table
    assert json.loads((tmp_path / "fit.json").read_text())["two"]["model"] == "two"
    assert 'name="kdd" value="0"' in (tmp_path / "fit.xml").read_text()


def test_save_writes_what_pbrdf_fit_writes(tmp_path):
    """FileFit.save is the command's writer: the scene names the file fitted,
    and no file is left when one of them cannot be written."""
    fit = fitting.fit_file(ROOT / "tests" / "data" / "fit_example.csv", models=["two"],
                           material="Al", distribution="beckmann", starts=1,
                           observables=["m00", "dolp"])
    fit.save(scene=str(tmp_path / "fit.xml"))
    assert "pbrdf fit to fit_example.csv" in (tmp_path / "fit.xml").read_text()
    with pytest.raises(OSError):
        fit.save(json=str(tmp_path / "new.json"), scene=str(tmp_path / "fit.xml" / "x.xml"))
    assert not (tmp_path / "new.json").exists()


def test_read_is_the_reader_then_the_selection():
    from mitsuba_pbrdf.measured.selection import select_wavelengths

    whole = measured.read_measurements(NIST)
    picked = measured.read(NIST, wavelengths=[633])
    expected = select_wavelengths(whole, [633])
    assert len(picked) == len(expected) < len(whole)
    np.testing.assert_array_equal(picked.theta_r, expected.theta_r)


@pytest.mark.parametrize("kwargs, parameter", [({"layout": "csv"}, "layout"),
                                               ({"observables": ["m77"]}, "observables")])
def test_read_names_the_bad_parameter(kwargs, parameter):
    with pytest.raises(ParameterError) as e:
        measured.read(NIST, **kwargs)
    assert e.value.parameter == parameter


def test_a_table_takes_no_csv_layout(tmp_path):
    path = tmp_path / "t.pbsdf"
    path.write_bytes(b"tensor_file\0")
    with pytest.raises(ParameterError, match="layout: applies to CSV files"):
        measured.read(path, layout="nist")


def test_fit_commands_choices_are_the_libraries():
    """``pbrdf fit`` takes its choices from the records (mitsuba_pbrdf.choices)
    that the library reads its options through."""
    import argparse

    from mitsuba_pbrdf.cli import fit as cli_fit

    parser = argparse.ArgumentParser()
    cli_fit.add_parser(parser.add_subparsers())
    fit = parser._subparsers._group_actions[0].choices["fit"]
    choices = {a.dest: tuple(a.choices) for a in fit._actions if a.choices}
    assert choices["layout"] == measured.LAYOUTS == ("auto", "goniometer", "nist")
    assert choices["model"] == tuple(fitting.MODELS) + ("both",) == ("three", "two", "both")


def test_entry_points_examples_run():
    """The Example sections of the fit's entry points (numpydoc) run as written."""
    import doctest

    from mitsuba_pbrdf.fitting import files, solver
    from mitsuba_pbrdf.measured import reading

    for module in (solver, files, reading):
        failed, attempted = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
        assert attempted and not failed, module.__name__


@pytest.mark.parametrize("kwargs, message", [
    ({"plot": "fit.txt"}, "plot: cannot write a .txt file (fit.txt); it writes .png or .pdf"),
    ({"json": "data.csv"}, "json and path name the same file data.csv: an output never replaces"),
    ({"json": "a.xml", "scene": "a.xml"}, "scene and json name the same file a.xml"),
])
def test_save_checks_its_files_before_writing_any(kwargs, message, tmp_path, monkeypatch):
    from mitsuba_pbrdf.outputs import OutputPlanError

    monkeypatch.chdir(tmp_path)
    fit = fitting.FileFit(data=None, table=None, results={}, path="data.csv")
    with pytest.raises(OutputPlanError, match=re.escape(message)):
        fit.save(**kwargs)
    assert list(tmp_path.iterdir()) == []
