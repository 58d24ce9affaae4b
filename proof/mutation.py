"""Mutation testing of the plugin and the reference: one-line mutants against a fast test subset.

    python validation/mutation.py --full [--jobs 2] [--tests-rev REV]   # the whole study
    python validation/mutation.py [--sample 12]                         # smoke run (a few mutants)
    python validation/mutation.py --defects [--tests-rev REV]           # the issue's named defects
    python validation/mutation.py --summary LABEL [LABEL ...]           # score, survivors of runs

A mutant changes one thing in one module of ``mitsuba_pbrdf/bsdfs/`` or
``mitsuba_pbrdf/reference/`` (the operators of mutmut, applied with Python's
``ast``): ``+`` <-> ``-``, ``*`` <-> ``/``, ``**`` -> ``*``; ``<`` <-> ``<=``,
``>`` <-> ``>=``, ``==`` <-> ``!=``, ``is`` <-> ``is not``, ``in`` <-> ``not in``;
``and`` <-> ``or``; a unary ``-`` or ``not`` dropped; a number ``c`` -> ``c + 1``;
``True`` <-> ``False``; ``minimum`` <-> ``maximum``, ``min`` <-> ``max``. Not mutated:
docstrings and other strings, f-strings and the arguments of ``raise`` (error
messages: tests/hostile/test_bad_input.py checks those by content), and annotations.

Each mutant is written into a private copy of the package (``tests/`` and
``pyproject.toml`` beside it; byte-code off, so no stale ``.pyc``) and the test
subset of its package (:data:`SUBSETS`) runs on it with ``pytest -x``: the
mutant is *killed* when a test fails, errors or the run times out (3x the
unmutated run), and *survives* when every test passes. A survivor is either a
gap in the tests or an *equivalent* mutant (one that cannot change any result
the plugin or reference returns): :data:`EQUIVALENT` gives the reason for each
known one, and the report lists the rest as gaps.

``--tests-rev REV`` takes ``tests/`` from git revision ``REV`` instead of the
working tree: the score of an older suite against the same mutants.
``--defects`` runs :data:`DEFECTS`, the one-line mutants that stand for the
defects of the suite found in review, against the test that now guards each
(and, with ``--tests-rev``, against the old suite's version of that test):
each must fail the new test. Each run is recorded as JSON under
``validation/mutation_runs/``; ``--summary`` prints a record's score, its
uncertainty and its survivors (the analysis is ``validation/mutation.md``).
"""

import argparse
import ast
import copy
import os
import random
import shutil
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

from .mutation_tables import DEFECTS, EQUIVALENT, FORMER_NAMES, SUBSETS  # noqa: F401 (re-exported)

#: The repository: the folder that holds proof/ (this file's folder) and the package.
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

#: The study's population: the pbrdf plugin's modules (with the Stokes rotations
#: it calls) and the reference evaluator's, by the name of their test subset.
STUDIED = {
    "plugin": [f"mitsuba_pbrdf/bsdfs/{name}.py"
               for name in ("fresnel", "ior", "lobes", "microfacet", "pbrdf_properties", "pbrdf")]
              + ["mitsuba_pbrdf/mueller.py"],
    "reference": sorted(f"mitsuba_pbrdf/reference/{name}"
                        for name in os.listdir(os.path.join(ROOT, "mitsuba_pbrdf", "reference"))
                        if name.endswith(".py")),
}

BINOPS = {ast.Add: ast.Sub, ast.Sub: ast.Add, ast.Mult: ast.Div, ast.Div: ast.Mult,
          ast.Pow: ast.Mult, ast.FloorDiv: ast.Div, ast.Mod: ast.Div}
CMPOPS = {ast.Lt: ast.LtE, ast.LtE: ast.Lt, ast.Gt: ast.GtE, ast.GtE: ast.Gt,
          ast.Eq: ast.NotEq, ast.NotEq: ast.Eq, ast.Is: ast.IsNot, ast.IsNot: ast.Is,
          ast.In: ast.NotIn, ast.NotIn: ast.In}
NAMES = {"minimum": "maximum", "maximum": "minimum", "min": "max", "max": "min"}


@dataclass
class Mutant:
    """One mutation: ``path`` (relative to the repository), the ``index`` of the
    node in ``ast.walk`` order, what it does and where."""

    path: str
    index: int
    kind: str
    line: int
    function: str
    before: str
    after: str
    key: str = ""
    status: str = ""
    seconds: float = 0.0
    detail: str = field(default="", repr=False)


def _skipped_nodes(tree):
    """Ids of the nodes not to mutate: docstrings, strings, f-strings,
    ``raise`` arguments, annotations."""
    skip = set()

    def mark(node):
        for sub in ast.walk(node):
            skip.add(id(sub))

    for node in ast.walk(tree):
        if isinstance(node, (ast.Raise, ast.JoinedStr)):
            mark(node)
        elif isinstance(node, ast.Constant) and isinstance(node.value, (str, bytes)):
            mark(node)
        elif isinstance(node, ast.arg) and node.annotation is not None:
            mark(node.annotation)
        elif isinstance(node, ast.AnnAssign):
            mark(node.annotation)
        elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and node.returns:
            mark(node.returns)
    return skip


def _functions(tree):
    """Node id -> qualified name of the innermost function or class around it."""
    owner = {}

    def visit(node, name):
        for child in ast.iter_child_nodes(node):
            inner = name
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                inner = f"{name}.{child.name}" if name else child.name
            owner[id(child)] = inner
            visit(child, inner)

    visit(tree, "")
    return owner


def _mutations(node):
    """The mutations of one node: [(kind, apply(node) -> None)]."""
    out = []
    if isinstance(node, (ast.BinOp, ast.AugAssign)) and type(node.op) in BINOPS:
        out.append(("operator", lambda n: setattr(n, "op", BINOPS[type(n.op)]())))
    elif isinstance(node, ast.Compare):
        for i, op in enumerate(node.ops):
            if type(op) in CMPOPS:
                def swap(n, i=i):
                    n.ops[i] = CMPOPS[type(n.ops[i])]()
                out.append(("comparison", swap))
    elif isinstance(node, ast.BoolOp):
        out.append(("boolean", lambda n: setattr(
            n, "op", ast.Or() if isinstance(n.op, ast.And) else ast.And())))
    elif isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.Not)):
        out.append(("unary", None))
    elif isinstance(node, ast.Constant) and type(node.value) in (int, float):
        out.append(("number", lambda n: setattr(n, "value", n.value + 1)))
    elif isinstance(node, ast.Constant) and type(node.value) is bool:
        out.append(("bool", lambda n: setattr(n, "value", not n.value)))
    elif isinstance(node, ast.Attribute) and node.attr in NAMES:
        out.append(("name", lambda n: setattr(n, "attr", NAMES[n.attr])))
    elif isinstance(node, ast.Name) and node.id in NAMES and isinstance(node.ctx, ast.Load):
        out.append(("name", lambda n: setattr(n, "id", NAMES[n.id])))
    return out


class _DropUnary(ast.NodeTransformer):
    def __init__(self, target):
        self.target = target

    def visit_UnaryOp(self, node):
        self.generic_visit(node)
        return node.operand if node is self.target else node


def mutants_of(path):
    """Every :class:`Mutant` of the module at ``path`` (relative to ROOT)."""
    with open(os.path.join(ROOT, path), encoding="utf-8") as f:
        tree = ast.parse(f.read())
    skip, owner = _skipped_nodes(tree), _functions(tree)
    found, seen = [], {}
    for index, node in enumerate(ast.walk(tree)):
        if id(node) in skip:
            continue
        for kind, apply in _mutations(node):
            mutated = copy.deepcopy(node)
            if apply is None:
                mutated = mutated.operand
            else:
                apply(mutated)
            before, after = ast.unparse(node), ast.unparse(mutated)
            if len(before) > 70:
                before, after = _shorten(before, after)
            m = Mutant(path, index, kind, node.lineno, owner.get(id(node), ""), before, after)
            base = f"{path}::{m.function}: {before} -> {after}"
            seen[base] = seen.get(base, 0) + 1
            m.key = base if seen[base] == 1 else f"{base} #{seen[base]}"
            m.apply = apply
            found.append(m)
    return found


def _shorten(before, after):
    """Trim the common prefix and suffix of two long snippets."""
    i = 0
    while i < min(len(before), len(after)) and before[i] == after[i]:
        i += 1
    j = 0
    while j < min(len(before), len(after)) - i and before[-1 - j] == after[-1 - j]:
        j += 1
    lo, hi_b, hi_a = max(i - 25, 0), len(before) - max(j - 25, 0), len(after) - max(j - 25, 0)
    return ("..." * (lo > 0) + before[lo:hi_b] + "..." * (j > 25),
            "..." * (lo > 0) + after[lo:hi_a] + "..." * (j > 25))


def mutated_source(m):
    """The module's source with mutant ``m`` applied (unparsed from the AST)."""
    with open(os.path.join(ROOT, m.path), encoding="utf-8") as f:
        tree = ast.parse(f.read())
    node = list(ast.walk(tree))[m.index]
    if m.apply is None:
        tree = _DropUnary(node).visit(tree)
    else:
        m.apply(node)
    return ast.unparse(tree) + "\n"


def all_mutants():
    out = []
    for paths in STUDIED.values():
        for path in paths:
            out.extend(mutants_of(path))
    return out


def study_of(path: str) -> str:
    """The population (a key of :data:`STUDIED` and :data:`SUBSETS`) a file belongs to."""
    return next(key for key, paths in STUDIED.items() if path in paths)


# ---------------------------------------------------------------------------
# Running
# ---------------------------------------------------------------------------

def make_copy(tests_rev=None):
    """A private copy of the package, the test scaffolding (proof/), tests/ and
    pyproject.toml; returns its folder. With ``tests_rev``, tests/ and its
    scaffolding come from that git revision (proof/ there, or, before proof/
    existed, the package's old mitsuba_pbrdf/checks/, which the old tests import)."""
    folder = tempfile.mkdtemp(prefix="pbrdf-mutation-")
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc")
    shutil.copytree(os.path.join(ROOT, "mitsuba_pbrdf"), os.path.join(folder, "mitsuba_pbrdf"),
                    ignore=ignore)
    shutil.copy(os.path.join(ROOT, "pyproject.toml"), folder)
    if tests_rev:
        for path in ("tests", *_scaffolding_at(tests_rev)):
            archive = subprocess.run(["git", "archive", tests_rev, path], cwd=ROOT, check=True,
                                     capture_output=True).stdout
            subprocess.run(["tar", "-x", "-C", folder], input=archive, check=True)
    else:
        for path in ("tests", "proof"):
            shutil.copytree(os.path.join(ROOT, path), os.path.join(folder, path), ignore=ignore)
    return folder


def _scaffolding_at(rev):
    """The folders of test scaffolding that git revision ``rev`` has."""
    listed = subprocess.run(["git", "ls-tree", "--name-only", rev, "proof",
                             "mitsuba_pbrdf/checks"], cwd=ROOT, check=True,
                            capture_output=True, text=True).stdout.split()
    return [p for p in ("proof", "mitsuba_pbrdf/checks") if p in listed][:1]


def in_copy(folder, path):
    """``path`` (a file, or a test ``file::name``) as the copy in ``folder``
    has it: an older, flat tests/ has a file under its former name (FORMER_NAMES)."""
    file, sep, name = path.partition("::")
    if not os.path.exists(os.path.join(folder, file)) and file in FORMER_NAMES:
        file = "tests/" + FORMER_NAMES[file]
    return file + sep + name


def run_tests(folder, tests, timeout, stop_first=True):
    """``pytest -x`` of ``tests`` in ``folder`` (those of its files that exist
    there: an older tests/ may lack some): (status, seconds, last line)."""
    tests = [in_copy(folder, t) for t in tests]
    tests = [t for t in tests if os.path.exists(os.path.join(folder, t.split("::")[0]))]
    env = dict(os.environ, PYTHONPATH=folder, PYTHONDONTWRITEBYTECODE="1", MPLBACKEND="Agg")
    # "-n 0": one process per run; the study runs its copies side by side (--jobs)
    command = [sys.executable, "-m", "pytest", *(["-x"] if stop_first else []), "-q", "-rs", "-n", "0",
               "-p", "no:cacheprovider", *tests]
    start = time.perf_counter()
    try:
        r = subprocess.run(command, cwd=folder, env=env, capture_output=True, text=True,
                           timeout=timeout)
    except subprocess.TimeoutExpired:
        return "killed (timeout)", time.perf_counter() - start, ""
    seconds = time.perf_counter() - start
    lines = [x for x in r.stdout.splitlines() if x.strip()]
    failed = [x for x in lines if x.startswith(("FAILED", "ERROR"))]
    last = "; ".join(failed[:2]) if failed else (lines[-1] if lines else r.stderr[-200:])
    status = {0: "survived", 1: "killed"}.get(r.returncode, f"killed (exit {r.returncode})")
    return status, seconds, last


def subset_for(path):
    return SUBSETS[study_of(path)]


def run_mutant(m, folder, timeout):
    target = os.path.join(folder, m.path)
    with open(target, encoding="utf-8") as f:
        original = f.read()
    try:
        with open(target, "w", encoding="utf-8") as f:
            f.write(mutated_source(m))
        m.status, m.seconds, m.detail = run_tests(folder, subset_for(m.path), timeout)
    finally:
        with open(target, "w", encoding="utf-8") as f:
            f.write(original)
    return m


def run_study(mutants, jobs, tests_rev, progress=True, timeout_factor=3.0):
    """Run ``mutants`` on ``jobs`` private copies; returns (mutants, baseline
    seconds). A mutant's run times out after ``timeout_factor`` times the
    unmutated run (at least 60 s)."""
    folders = [make_copy(tests_rev) for _ in range(jobs)]
    baseline = {}
    for package in sorted({study_of(m.path) for m in mutants}):
        status, seconds, last = run_tests(folders[0], SUBSETS[package], timeout=3600)
        if status != "survived":
            raise SystemExit(f"mutation.py: the unmutated {package} subset fails: {last}")
        baseline[package] = seconds
    free = list(folders)
    done = []
    start = time.perf_counter()

    def work(m):
        folder = free.pop()
        try:
            limit = max(60.0, timeout_factor * baseline[study_of(m.path)])
            return run_mutant(m, folder, timeout=limit)
        finally:
            free.append(folder)

    with ThreadPoolExecutor(jobs) as pool:
        for m in pool.map(work, mutants):
            done.append(m)
            if progress:
                print(f"[{len(done)}/{len(mutants)} {time.perf_counter() - start:.0f} s] "
                      f"{m.status:>9}  {m.key}", flush=True)
    for folder in folders:
        shutil.rmtree(folder, ignore_errors=True)
    return done, baseline


def sample_mutants(mutants, count, seed=0):
    """A seeded random sample of ``count`` mutants, in their original order."""
    if count >= len(mutants):
        return list(mutants)
    chosen = set(random.Random(seed).sample(range(len(mutants)), count))
    return [m for i, m in enumerate(mutants) if i in chosen]


def as_records(mutants):
    """JSON-able records of run mutants."""
    return [dict(key=m.key, path=m.path, line=m.line, kind=m.kind, function=m.function,
                 before=m.before, after=m.after, status=m.status, seconds=round(m.seconds, 2),
                 detail=m.detail[:300]) for m in mutants]


def run_defect(defect, folder, tests, timeout=900):
    """Apply ``defect`` (a one-line text mutant, mutation_tables.DEFECTS) in
    ``folder`` and run ``tests`` there: (status, seconds, last line), the file
    restored afterwards. "missing" if the line is not in that copy."""
    target = os.path.join(folder, in_copy(folder, defect["path"]))
    with open(target, encoding="utf-8") as f:
        original = f.read()
    if original.count(defect["old"]) < 1:
        return "missing", 0.0, f"{defect['old']!r} not in {defect['path']}"
    try:
        with open(target, "w", encoding="utf-8") as f:
            f.write(original.replace(defect["old"], defect["new"]))
        status, seconds, last = run_tests(folder, tests, timeout, stop_first=False)
    finally:
        with open(target, "w", encoding="utf-8") as f:
            f.write(original)
    return status, seconds, last
