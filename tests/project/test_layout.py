"""The package's layout and import behaviour: the plugin and the reference
evaluator never import each other, the reference needs NumPy alone, importing
the package needs no variant, the plugin is registered in every variant, tests/ and
validation/ never import each other (both use proof/ and mitsuba_pbrdf.diagnostics),
the package never imports proof/, no module imports itself in a circle, and
validation/run_all.py runs every study."""

import ast
import os
import re
import subprocess
import sys

import pytest

ROOT = os.path.join(os.path.dirname(__file__), os.pardir, os.pardir)
PACKAGE = os.path.join(ROOT, "mitsuba_pbrdf")


def run_python(code):
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=ROOT, timeout=120)


def imported_modules(folder):
    """{file: set of absolute module names it imports} for a sub-package,
    relative imports resolved against ``mitsuba_pbrdf.<folder>``."""
    out = {}
    base = ["mitsuba_pbrdf", folder]
    for name in sorted(os.listdir(os.path.join(PACKAGE, folder))):
        if not name.endswith(".py"):
            continue
        tree = ast.parse(open(os.path.join(PACKAGE, folder, name)).read())
        found = set()
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                found |= {a.name for a in node.names}
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    parent = base[: len(base) - node.level + 1]
                    module = ".".join(parent + ([node.module] if node.module else []))
                    found.add(module)
                    if not node.module:  # from . import x
                        found |= {f"{module}.{a.name}" for a in node.names}
                else:
                    found.add(node.module)
        out[name] = found
    return out


def test_plugin_never_imports_the_reference():
    for name, modules in imported_modules("bsdfs").items():
        bad = [m for m in modules if m.startswith("mitsuba_pbrdf.reference")]
        assert not bad, f"bsdfs/{name} imports {bad}"


def test_reference_imports_numpy_and_the_standard_library_only():
    allowed_own = {"mitsuba_pbrdf.reference", "mitsuba_pbrdf.schema"}
    for name, modules in imported_modules("reference").items():
        for m in modules:
            top = m.split(".")[0]
            if top == "mitsuba_pbrdf":
                assert any(m == a or m.startswith(a + ".") for a in allowed_own), \
                    f"reference/{name} imports {m}"
            else:
                assert top == "numpy" or top in sys.stdlib_module_names, \
                    f"reference/{name} imports {m}"


def test_the_import_scan_sees_a_forbidden_import(tmp_path, monkeypatch):
    """The scan above resolves relative imports: a plugin module importing the
    reference would be caught."""
    folder = tmp_path / "mitsuba_pbrdf" / "bsdfs"
    folder.mkdir(parents=True)
    (folder / "bad.py").write_text("from ..reference import pbrdf\nfrom . import lobes\n")
    monkeypatch.setattr(sys.modules[__name__], "PACKAGE", str(tmp_path / "mitsuba_pbrdf"))
    found = imported_modules("bsdfs")["bad.py"]
    assert "mitsuba_pbrdf.reference" in found and "mitsuba_pbrdf.bsdfs.lobes" in found


def test_reference_works_without_mitsuba():
    code = ("import sys; sys.modules['mitsuba'] = None; sys.modules['drjit'] = None\n"
            "import mitsuba_pbrdf.reference as r\n"
            "m = r.pbrdf(0.5, 0.0, 0.5, 3.14159, 1.2, 7.0, 0.1, kdd=0.1, kid=0.05)\n"
            "assert m.shape == (4, 4) and m[0, 0] > 0\n"
            "assert 'mitsuba' not in [k for k, v in sys.modules.items() if v is not None]\n"
            "print('ok')")
    result = run_python(code)
    assert result.returncode == 0 and "ok" in result.stdout, result.stderr


def test_import_needs_no_variant_and_first_use_says_what_to_type():
    result = run_python("import mitsuba_pbrdf, mitsuba as mi; assert mi.variant() is None\n"
                        "try:\n    mitsuba_pbrdf.register()\n"
                        "except mitsuba_pbrdf.VariantNotSetError as e:\n    print(e)")
    assert result.returncode == 0, result.stderr
    assert "mitsuba_pbrdf.use_variant('llvm_ad_spectral_polarized')" in result.stdout
    # the plugin module imports without a variant; its class needs one
    result = run_python("import mitsuba_pbrdf.bsdfs.pbrdf, mitsuba_pbrdf.registry as r\n"
                        "r.plugin_class('pbrdf')")
    assert result.returncode != 0
    assert "VariantNotSetError" in result.stderr
    assert "mitsuba_pbrdf.use_variant('llvm_ad_spectral_polarized')" in result.stderr


def test_mitsubas_own_call_before_a_variant_raises_what_python_md_says():
    """python.md promises VariantNotSetError for the package's calls and
    Mitsuba's bare RuntimeError for mi.load_dict before a variant is set."""
    result = run_python("import mitsuba_pbrdf, mitsuba as mi\n"
                        "try:\n    mi.load_dict({'type': 'pbrdf'})\n"
                        "except RuntimeError as e:\n    print(type(e).__name__, e)")
    assert result.returncode == 0, result.stderr
    assert "RuntimeError No variant was set!" in result.stdout
    with open(os.path.join(ROOT, "docs", "python.md"), encoding="utf-8") as f:
        page = " ".join(f.read().split())
    assert "`mi.load_dict({\"type\": \"pbrdf\"})` among them, raise Mitsuba's " \
           "`RuntimeError: No variant was set!`" in page


@pytest.mark.parametrize("code", [
    # the variant set first, then the package imported
    "import mitsuba as mi; mi.set_variant('llvm_ad_rgb'); import mitsuba_pbrdf",
    # the package first, then the variant set with Mitsuba's own call
    "import mitsuba_pbrdf; import mitsuba as mi; mi.set_variant('llvm_ad_rgb')",
    # switching variants after registering
    "import mitsuba_pbrdf; mitsuba_pbrdf.use_variant('llvm_ad_spectral_polarized');"
    "import mitsuba as mi; mi.set_variant('llvm_ad_rgb')",
])
def test_plugin_is_registered_in_every_variant(code):
    result = run_python(code + "\nb = mi.load_dict({'type': 'pbrdf', 'kid': 0.2})\n"
                               "print(type(b).__name__, mi.variant())")
    assert result.returncode == 0, result.stderr
    assert result.stdout.split() == ["PolarizedBRDF", "llvm_ad_rgb"]


def test_use_variant_names_the_available_variants():
    import mitsuba as mi

    import mitsuba_pbrdf

    before = mi.variant()
    with pytest.raises(mitsuba_pbrdf.UnknownVariantError, match="available: .*llvm_ad_rgb"):
        mitsuba_pbrdf.use_variant("llvm_ad_nonexistent")
    assert mi.variant() == before
    assert mitsuba_pbrdf.use_variant(before) is None


def test_no_project_file_cites_files_outside_the_repository():
    """Docstrings and docs cite only paths that exist in the repository."""
    cited = re.compile(r"\b((?:docs|validation|benchmarks|scenes|tests|examples|tools)/"
                       r"[\w./-]+\.(?:md|py|xml|csv|exr))")
    outside = ".." + "/shared"  # the developers' notes beside the repository
    missing = []
    for folder, _, files in os.walk(ROOT):
        if any(part.startswith(".") or part in ("out", "gallery") for part in
               os.path.relpath(folder, ROOT).split(os.sep)):
            continue
        for name in files:
            if not name.endswith((".py", ".md")):
                continue
            path = os.path.join(folder, name)
            text = open(path, encoding="utf-8").read()
            assert outside not in text, path
            if os.path.abspath(path) == os.path.abspath(__file__):
                continue  # this file's scans are tested on made-up paths
            for m in cited.findall(text):
                if not os.path.exists(os.path.join(ROOT, m)):
                    missing.append(f"{os.path.relpath(path, ROOT)}: {m}")
    assert not missing, missing


# ---------------------------------------------------------------- tests/, validation/, proof/

def import_references(path):
    """(module names a Python file imports, string constants it hands to
    ``sys.path``, ``site.addsitedir``, ``importlib.import_module`` or
    ``__import__``). Relative imports are given as ``.name`` (they never leave
    their package)."""
    tree = ast.parse(open(path, encoding="utf-8").read(), path)
    modules, strings = set(), set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            modules |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            modules.add("." * node.level + (node.module or ""))
        elif isinstance(node, ast.Call):
            f = node.func
            name = ast.unparse(f)
            if (name.startswith("sys.path.") or name in (
                    "site.addsitedir", "importlib.import_module", "import_module", "__import__")):
                strings |= {c.value for arg in node.args for c in ast.walk(arg)
                            if isinstance(c, ast.Constant) and isinstance(c.value, str)}
    return modules, strings


def _python_files(folder):
    folder = os.path.join(ROOT, folder)
    return sorted(os.path.join(folder, n) for n in os.listdir(folder) if n.endswith(".py"))


def _names(text):
    """The dotted or path components of a module name or a path string."""
    return [part for part in re.split(r"[./\\]", text) if part]


def layout_violations(folder, forbidden):
    """'file: what' for every import of, or sys.path entry towards, a folder in
    ``forbidden`` (top-level names; a test module ``test_*`` counts as tests/)."""
    out = []
    for path in _python_files(folder):
        modules, strings = import_references(path)
        for text in sorted(modules | strings):
            parts = _names(text)
            hits = [p for p in parts if p in forbidden
                    or ("tests" in forbidden and p.startswith("test_") and text in modules)]
            if hits and not (text in modules and text.startswith(".")):
                out.append(f"{os.path.relpath(path, ROOT)}: {text}")
    return out


def test_tests_never_import_validation():
    """tests/ runs proof/ and mitsuba_pbrdf.diagnostics, never the validation scripts."""
    assert layout_violations("tests", {"validation"}) == []


def test_validation_never_imports_tests():
    """validation/ reads shared scaffolding from proof/ (e.g. proof/bad_input.py)."""
    assert layout_violations("validation", {"tests"}) == []


def _package_folders():
    """Every folder of the package that holds Python files, relative to ROOT."""
    return sorted(os.path.relpath(d, ROOT) for d, _, files in os.walk(PACKAGE)
                  if "__pycache__" not in d and any(f.endswith(".py") for f in files))


def test_the_package_imports_neither_proof_nor_tests_nor_validation():
    """Nothing shipped imports the non-packaged folders: proof/ (test and study
    scaffolding, not in the wheel), tests/ or validation/."""
    folders = _package_folders()
    assert os.path.join("mitsuba_pbrdf", "diagnostics") in folders
    found = [v for folder in folders
             for v in layout_violations(folder, {"proof", "tests", "validation"})]
    assert found == [], found


def test_proof_imports_neither_tests_nor_validation():
    assert layout_violations("proof", {"tests", "validation"}) == []


def test_the_folder_scan_sees_forbidden_imports(tmp_path, monkeypatch):
    """The scan catches an import, a sys.path entry and a test module by name."""
    folder = tmp_path / "validation"
    folder.mkdir()
    (folder / "a.py").write_text("import sys, os\n"
                                 "sys.path.insert(0, os.path.join(ROOT, 'tests'))\n"
                                 "import test_bad_input\n")
    (folder / "b.py").write_text("from tests.conftest import make_si\n")
    (folder / "c.py").write_text("from . import common\nimport mitsuba_pbrdf.diagnostics\n")
    package = tmp_path / "mitsuba_pbrdf" / "rendering"
    package.mkdir(parents=True)
    (package / "d.py").write_text("from proof.stress import run\nfrom .proof import x\n")
    (tmp_path / "tests").mkdir()
    (tmp_path / "tests" / "t.py").write_text(
        "import importlib\nstress = importlib.import_module('validation.stress')\n"
        "from validation import common\n")
    monkeypatch.setattr(sys.modules[__name__], "ROOT", str(tmp_path))
    found = layout_violations("validation", {"tests"})
    assert found == ["validation/a.py: test_bad_input", "validation/a.py: tests",
                     "validation/b.py: tests.conftest"], found
    found = layout_violations("tests", {"validation"})
    assert found == ["tests/t.py: validation", "tests/t.py: validation.stress"], found
    found = layout_violations(os.path.join("mitsuba_pbrdf", "rendering"), {"proof"})
    assert found == ["mitsuba_pbrdf/rendering/d.py: proof.stress"], found


def run_all(*args):
    """``python validation/run_all.py ARGS`` in a subprocess (tests do not import
    validation/)."""
    return subprocess.run([sys.executable, os.path.join(ROOT, "validation", "run_all.py"),
                           *args], capture_output=True, text=True, cwd=ROOT, timeout=120)


def test_run_all_runs_every_study():
    """Every script in validation/ except common.py and run_all.py is a study
    with a report: run_all.py must run each of them, full and --quick."""
    scripts = {n[:-3] for n in os.listdir(os.path.join(ROOT, "validation"))
               if n.endswith(".py") and n not in ("common.py", "run_all.py")}
    assert len(scripts) >= 10
    for study in scripts:
        assert os.path.exists(os.path.join(ROOT, "validation", study + ".md")), study
    for flags in ((), ("--quick",)):
        result = run_all("--list", *flags)
        assert result.returncode == 0, result.stderr
        listed = [line.split()[1] for line in result.stdout.splitlines()]
        assert sorted(listed) == sorted(f"validation/{s}.py" for s in scripts), listed


def test_run_all_only_selects_and_rejects_unknown_names():
    result = run_all("--list", "--only", "stress,physics")
    assert result.returncode == 0, result.stderr
    assert result.stdout.splitlines() == ["python validation/physics.py --pairs 100000",
                                          "python validation/stress.py --samples 1000000"]
    result = run_all("--only", "physics,no_such_study")
    assert result.returncode == 2 and result.stdout == ""
    assert len(result.stderr.strip().splitlines()) == 1, result.stderr
    assert "'no_such_study'" in result.stderr and "Traceback" not in result.stderr


# ---------------------------------------------------------------- no circles

def package_import_graph(root=None):
    """{module: set of package modules it imports} over every module of the
    package (imports inside functions too), a package's ``__init__`` named by
    the package. An imported name resolves to the longest module prefix."""
    root = root or ROOT
    package = os.path.join(root, "mitsuba_pbrdf")
    files = {}
    for folder, _, names in os.walk(package):
        for n in names:
            if n.endswith(".py") and "__pycache__" not in folder:
                rel = os.path.relpath(os.path.join(folder, n), root)[:-3].replace(os.sep, ".")
                files[rel.removesuffix(".__init__")] = (os.path.join(folder, n),
                                                        rel.endswith("__init__"))

    def resolve(name):
        while name and name not in files:
            name = name.rpartition(".")[0]
        return name

    graph = {}
    for name, (path, is_package) in files.items():
        base = name.split(".") if is_package else name.split(".")[:-1]
        found = set()
        for node in ast.walk(ast.parse(open(path, encoding="utf-8").read(), path)):
            targets = []
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                module = (".".join(base[:len(base) - node.level + 1]
                                   + ([node.module] if node.module else []))
                          if node.level else node.module or "")
                targets = [module] + [f"{module}.{a.name}" for a in node.names]
            found |= {resolve(t) for t in targets if t.startswith("mitsuba_pbrdf")}
        graph[name] = found - {name, ""}
    return graph, {n for n, (_, is_package) in files.items() if is_package}


def circles(graph):
    """The strongly connected components (more than one node) of ``graph``."""
    order, low, stack, out = {}, {}, [], []

    def visit(v):
        order[v] = low[v] = len(order)
        stack.append(v)
        for w in graph.get(v, ()):
            if w not in order:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], order[w])
        if low[v] == order[v]:
            component = []
            while not component or component[-1] != v:
                component.append(stack.pop())
            if len(component) > 1:
                out.append(sorted(component))

    for v in sorted(graph):
        if v not in order:
            visit(v)
    return out


def test_no_module_imports_itself_in_a_circle():
    """No two modules of the package import each other, directly or through
    others (a package's ``__init__`` only hands its modules' names on, so it
    is left out)."""
    graph, faces = package_import_graph()
    modules = {n: {m for m in e if m not in faces} for n, e in graph.items() if n not in faces}
    assert circles(modules) == []


def test_no_subpackage_imports_itself_in_a_circle():
    """Between the sub-packages and top-level modules (``cli``, ``batch``,
    ``rendering``, ...) the arrows run one way: e.g. ``batch`` and ``cli`` share
    ``errors`` instead of ``batch`` importing ``cli``."""
    graph, _ = package_import_graph()
    top = lambda n: ".".join(n.split(".")[:2])
    arrows = {}
    for name, imported in graph.items():
        for m in imported:
            if "." in name and "." in m and top(name) != top(m):
                arrows.setdefault(top(name), set()).add(top(m))
    assert circles(arrows) == []


def test_the_circle_finder_sees_a_circle(tmp_path):
    """The graph reads relative and deferred imports, and a two-module loop is found."""
    folder = tmp_path / "mitsuba_pbrdf" / "rendering"
    folder.mkdir(parents=True)
    (tmp_path / "mitsuba_pbrdf" / "__init__.py").write_text("")
    (folder / "__init__.py").write_text("from .render import x\n")
    (folder / "render.py").write_text("from .narrowband import band\n")
    (folder / "narrowband.py").write_text("def f():\n    from .render import y\n")
    graph, faces = package_import_graph(str(tmp_path))
    assert graph["mitsuba_pbrdf.rendering.narrowband"] == {"mitsuba_pbrdf.rendering.render"}
    assert circles(graph) == [["mitsuba_pbrdf.rendering.narrowband",
                               "mitsuba_pbrdf.rendering.render"]]
    assert faces == {"mitsuba_pbrdf", "mitsuba_pbrdf.rendering"}


def _walk_python(folder):
    """Every .py file below *folder* (an absolute path), recursively."""
    return sorted(os.path.join(base, f) for base, _, files in os.walk(folder)
                  for f in files if f.endswith(".py"))


def _ast_uses(path):
    """Names a Python file uses: loaded names, attributes and imported names."""
    tree = ast.parse(open(path, encoding="utf-8").read())
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Name) and not isinstance(node.ctx, ast.Store):
            names.add(node.id)
        elif isinstance(node, ast.Attribute):
            names.add(node.attr)
        elif isinstance(node, ast.alias):
            names.add(node.name.rsplit(".", 1)[-1])
    return tree, names


def scaffolding_only_names(root=ROOT):
    """Public module-level functions and classes of the package that only
    tests/, validation/, proof/ or benchmarks/ use: not the package itself
    (another module, or the same module beyond the definition), not
    examples/, not README.md or docs/ (a documented name is public API)."""
    package = os.path.join(root, "mitsuba_pbrdf")
    defined, uses = [], {}
    for path in _walk_python(package):
        tree, names = _ast_uses(path)
        uses[path] = names
        defined += [(node.name, path) for node in tree.body
                    if isinstance(node, (ast.FunctionDef, ast.ClassDef))
                    and not node.name.startswith("_")]
    scaffolding = set()
    for folder in ("tests", "validation", "proof", "benchmarks"):
        for path in _walk_python(os.path.join(root, folder)):
            scaffolding |= _ast_uses(path)[1]
    public = ""
    for folder in ("docs", "examples"):
        for base, _, files in os.walk(os.path.join(root, folder)):
            public += "".join(open(os.path.join(base, f), encoding="utf-8").read()
                              for f in files if f.endswith((".md", ".py")))
    public += open(os.path.join(root, "README.md"), encoding="utf-8").read()
    found = []
    for name, path in defined:
        # a definition is no use: uses[] holds loaded names, attributes and imports
        used = any(name in names for names in uses.values())
        if not used and name in scaffolding and not re.search(rf"\b{re.escape(name)}\b", public):
            found.append(f"{os.path.relpath(path, root)}: {name}")
    return found


def test_the_wheel_ships_only_the_product():
    """No name defined in the package is there for the tests alone: test and
    study scaffolding lives in proof/ (docs/layout.md)."""
    names = scaffolding_only_names()
    assert not names, names


def test_the_test_only_scan_sees_a_test_only_name(tmp_path):
    for folder in ("mitsuba_pbrdf", "tests", "docs", "examples", "validation", "proof",
                   "benchmarks"):
        (tmp_path / folder).mkdir()
    (tmp_path / "README.md").write_text("# x\n")
    (tmp_path / "mitsuba_pbrdf" / "a.py").write_text(
        "def product():\n    return helper_for_tests\n\n\ndef helper_for_tests():\n    pass\n"
        "\n\ndef documented():\n    pass\n")
    (tmp_path / "tests" / "test_a.py").write_text(
        "from mitsuba_pbrdf.a import helper_for_tests, documented\nhelper_for_tests()\n")
    (tmp_path / "docs" / "a.md").write_text("`documented()` does this.\n")
    assert scaffolding_only_names(str(tmp_path)) == []        # helper_for_tests is used by product()
    (tmp_path / "mitsuba_pbrdf" / "a.py").write_text(
        "def product():\n    pass\n\n\ndef helper_for_tests():\n    pass\n"
        "\n\ndef documented():\n    pass\n")
    assert scaffolding_only_names(str(tmp_path)) == ["mitsuba_pbrdf/a.py: helper_for_tests"]
