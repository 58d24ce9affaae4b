"""The mutation-study tool (proof/mutation.py) itself: it must
produce each operator's mutants, change exactly the node it names, leave
strings, error messages and annotations alone, and give sources that compile,
or the study's score (validation/mutation.md) would measure nothing."""

import ast
import textwrap

import pytest

from proof import mutation

MODULE = textwrap.dedent('''
    """Docstring 1 + 2."""
    import numpy as np


    def f(a: int, b) -> float:
        if a + b < 3 and not b:
            raise ValueError(f"bad {a - 1}")
        return -np.minimum(a * b, 2.5), max(a, True)
''')


@pytest.fixture
def module(tmp_path, monkeypatch):
    monkeypatch.setattr(mutation, "ROOT", str(tmp_path))
    (tmp_path / "m.py").write_text(MODULE)
    return "m.py"


def test_every_operator_is_found_once_and_nothing_in_strings(module):
    found = mutation.mutants_of(module)
    summary = sorted((m.kind, m.before, m.after) for m in found)
    assert summary == sorted([
        ("operator", "a + b", "a - b"),
        ("comparison", "a + b < 3", "a + b <= 3"),
        ("number", "3", "4"),
        ("boolean", "a + b < 3 and (not b)", "a + b < 3 or not b"),
        ("unary", "not b", "b"),
        ("unary", "-np.minimum(a * b, 2.5)", "np.minimum(a * b, 2.5)"),
        ("name", "np.minimum", "np.maximum"),
        ("operator", "a * b", "a / b"),
        ("number", "2.5", "3.5"),
        ("name", "max", "min"),
        ("bool", "True", "False"),
    ]), summary
    # nothing from the docstring, the f-string of the raise, or the annotations
    assert all(m.function == "f" for m in found)
    assert len({m.key for m in found}) == len(found)


def test_each_mutant_changes_exactly_its_node_and_compiles(module):
    original = ast.dump(ast.parse(MODULE))
    for m in mutation.mutants_of(module):
        source = mutation.mutated_source(m)
        compile(source, "m.py", "exec")
        assert ast.dump(ast.parse(source)) != original, m.key
        assert m.after in source and '"""Docstring 1 + 2."""' in source, m.key
        # one change only: applying the mutation's inverse text restores the original line set
        changed = [line for line in source.splitlines()
                   if line not in ast.unparse(ast.parse(MODULE)).splitlines()]
        assert len(changed) == 1, (m.key, changed)


def test_the_study_population_is_the_plugin_and_the_reference():
    mutants = mutation.all_mutants()
    studies = {mutation.study_of(m.path) for m in mutants}
    assert studies == {"plugin", "reference"}
    assert {m.path for m in mutants} >= {"mitsuba_pbrdf/bsdfs/pbrdf.py", "mitsuba_pbrdf/mueller.py",
                                         "mitsuba_pbrdf/reference/model.py"}
    assert len(mutants) > 700
    sample = mutation.sample_mutants(mutants, 20, seed=0)
    assert sample == mutation.sample_mutants(mutants, 20, seed=0) and len(sample) == 20
