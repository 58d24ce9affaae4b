"""Shared test set-up: the suite's default variant (every test starts in it),
fixtures that switch variants (``mitsuba_pbrdf.use_variant`` sets one and
registers the plugin), and the fast tier's check. Helpers that tests import
are ``bsdf_harness.py``'s. Under pytest-xdist (README's command runs
``-n auto``) each test file goes to one worker whole, and the tests of
``SERIAL`` to one worker together (``pytest_xdist_make_scheduler``)."""

import os
import sys

import mitsuba as mi
import pytest

import mitsuba_pbrdf
from mitsuba_pbrdf import registry

#: PBRDF_TEST_BACKEND=cuda runs the suite on a GPU: every llvm_* variant a test
#: asks for through mitsuba_pbrdf.use_variant becomes its cuda_* twin
#: (benchmarks/device_check.sh).
BACKEND = os.environ.get("PBRDF_TEST_BACKEND", "llvm")
if BACKEND not in ("llvm", "cuda"):
    raise pytest.UsageError(f"PBRDF_TEST_BACKEND must be llvm or cuda, got {BACKEND!r}")
if BACKEND == "cuda":
    _use_variant = registry.use_variant

    def _on_backend(name):
        return _use_variant(name.replace("llvm_", "cuda_", 1))

    mitsuba_pbrdf.use_variant = registry.use_variant = _on_backend

use_variant = mitsuba_pbrdf.use_variant
#: The suite's variant: every test starts in it (the autouse fixture below).
DEFAULT_VARIANT = "llvm_ad_spectral_polarized"
use_variant(DEFAULT_VARIANT)
SUITE_VARIANT = mi.variant()      # its cuda_* twin under PBRDF_TEST_BACKEND=cuda

@pytest.fixture(autouse=True)
def default_variant():
    """Every test starts in the suite's variant, whatever the test before it
    left (a test that switches variants need not put it back)."""
    if mi.variant() != SUITE_VARIANT:
        use_variant(DEFAULT_VARIANT)
    yield


@pytest.fixture(autouse=True)
def sigint_left_as_found():
    """Every test leaves SIGINT's handler and the package's hold state
    (:mod:`mitsuba_pbrdf.interrupts`) as it found them: a test that left
    SIGINT ignored or held would make every later Ctrl-C test of the run
    fail, far from its cause. A leak is put right and reported as this
    test's error."""
    import signal

    from mitsuba_pbrdf import interrupts

    def state():
        return (signal.getsignal(signal.SIGINT),
                {k: interrupts._state[k] for k in ("held", "pending", "command_line")})

    before = state()
    yield
    after = state()
    if after != before:
        signal.signal(signal.SIGINT, before[0])
        interrupts._state.update(before[1])
        pytest.fail(f"the test left SIGINT's handler or hold state changed: {before} -> {after}")


@pytest.fixture
def python_sigint_handler():
    """Python's own SIGINT handler (``KeyboardInterrupt``) for a test that
    sends SIGINT to this process, the inherited one put back after: pytest
    started as a background job inherits SIGINT ignored, and Python then
    keeps ignoring it (so does :mod:`mitsuba_pbrdf.interrupts`, by design)."""
    import signal

    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)


@pytest.fixture
def variant(request):
    use_variant(request.param)
    yield request.param
    use_variant(DEFAULT_VARIANT)


@pytest.fixture
def restore_variant():
    """For modules whose code under test switches Mitsuba's variant: put back
    the one the suite was on (and its plugin registration) after each test."""
    before = mi.variant()
    yield
    if mi.variant() != before:
        use_variant(before)


# ---------------------------------------------------------------- the fast tier

#: The fast tier: README's `pytest -m "not slow"`, what to run between commits.
FAST_TIER = "not slow"


def package_modules():
    """Every module of the package (dotted names), ``__main__`` excepted."""
    root = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                        "mitsuba_pbrdf")
    names = []
    for folder, _, files in os.walk(root):
        for name in files:
            if name.endswith(".py") and name != "__main__.py":
                rel = os.path.relpath(os.path.join(folder, name), os.path.dirname(root))
                names.append(rel[:-3].replace(os.sep, ".").removesuffix(".__init__"))
    return sorted(names)


#: Files whose tests must not run beside one another on two workers: they start
#: Dask clusters and a single-node Slurm (processes, ports, the one slurmctld)
#: and wait for them under deadlines, or time a benchmark.
SERIAL = ("tests/batch/", "tests/benchmarks/")


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config, log):
    """xdist's scheduler for README's ``-n auto``: a test file goes to one
    worker whole (its module fixtures and compiled kernels built once), the
    files of ``SERIAL`` to one worker together. xdist's own ``loadgroup``
    cannot say this under pytest 9.2, which ignores the group suffix its
    workers write into the test ids."""
    from xdist.scheduler import LoadScopeScheduling

    class FileScheduling(LoadScopeScheduling):
        def _split_scope(self, nodeid):
            path = nodeid.split("::")[0]
            return "serial" if path.startswith(SERIAL) else path

    return FileScheduling(config, log)


def _package_modules_imported():
    return sorted(m for m in package_modules() if m in sys.modules)


def pytest_sessionfinish(session, exitstatus):
    """A whole fast-tier run (``pytest -m "not slow"``, no file or ``-k``
    chosen) must have touched (imported) every module of the package: a module
    whose only tests are marked ``slow`` fails the run, naming it. Under xdist
    each worker sends what it imported, and the controller checks the union."""
    config = session.config
    if hasattr(config, "workerinput"):      # an xdist worker: report, never judge
        config.workeroutput["pbrdf_imported"] = _package_modules_imported()
        return
    whole = (config.args_source == pytest.Config.ArgsSource.TESTPATHS
             and not config.option.keyword and not config.option.collectonly)
    if exitstatus != 0 or not whole or config.option.markexpr.strip() != FAST_TIER:
        return
    imported = getattr(config, "pbrdf_worker_imports", None)
    if imported is None:                    # no workers: this process ran the tests
        imported = set(_package_modules_imported())
    untouched = [m for m in package_modules() if m not in imported]
    if untouched:
        print(f"\nthe fast tier ({FAST_TIER}) imported no test of: {', '.join(untouched)}")
        session.exitstatus = 1


@pytest.hookimpl(optionalhook=True)
def pytest_testnodedown(node, error):
    """Collects each xdist worker's imported package modules on the controller."""
    found = getattr(node, "workeroutput", {}).get("pbrdf_imported", [])
    imported = getattr(node.config, "pbrdf_worker_imports", set())
    node.config.pbrdf_worker_imports = imported | set(found)
