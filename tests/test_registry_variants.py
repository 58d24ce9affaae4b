"""Plugin classes per Mitsuba variant (:func:`mitsuba_pbrdf.registry.plugin_class`):
one class per plugin and variant, built by the module's ``build_class()``,
kept across variant switches and shared by threads, with the plugin module
itself imported once (never re-run, never swapped in ``sys.modules``)."""

import sys
import threading

import pytest

mi = pytest.importorskip("mitsuba")

import mitsuba_pbrdf  # noqa: E402
from mitsuba_pbrdf import registry  # noqa: E402
from mitsuba_pbrdf.registry import PLUGINS, plugin_class  # noqa: E402

VARIANTS = ("llvm_ad_spectral_polarized", "llvm_ad_rgb")


@pytest.fixture
def restore_variant():
    previous = mi.variant()
    yield
    if previous is not None:
        mitsuba_pbrdf.use_variant(previous)


def test_each_variant_keeps_its_classes_across_switches(restore_variant):
    seen, modules = {}, {}
    for variant in VARIANTS + VARIANTS:     # there and back again
        mitsuba_pbrdf.use_variant(variant)
        for kind, name, module, cls in PLUGINS:
            got = plugin_class(name)
            assert got.__name__ == cls
            # its base is this variant's Mitsuba class
            base = {"bsdf": mi.BSDF, "emitter": mi.Emitter,
                    "integrator": mi.CppADIntegrator}[kind]
            assert issubclass(got, base), (name, variant)
            assert seen.setdefault((name, variant), got) is got, (name, variant)
            # one module object for every variant
            assert modules.setdefault(module, sys.modules[module]) is sys.modules[module]
    for _, name, _, _ in PLUGINS:
        assert seen[(name, VARIANTS[0])] is not seen[(name, VARIANTS[1])]
    # the variant's own class is what scenes load
    bsdf = mi.load_dict({"type": "pbrdf", "kid": 0.2})
    assert type(bsdf) is seen[("pbrdf", mi.variant())]


def test_threads_share_one_class_per_variant(restore_variant, monkeypatch):
    mitsuba_pbrdf.use_variant("llvm_ad_spectral_polarized")
    monkeypatch.setattr(registry, "_classes", {})   # every thread builds at once
    names = [p[1] for p in PLUGINS]
    results, errors = [], []
    start = threading.Barrier(4)

    def look_up():
        try:
            start.wait()
            results.append([plugin_class(name) for name in names])
        except Exception as e:  # noqa: BLE001 (reported below)
            errors.append(e)

    threads = [threading.Thread(target=look_up) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors
    assert all(r == results[0] for r in results)
    assert results[0] == [plugin_class(name) for name in names]


def test_plugin_modules_import_without_a_variant_and_name_the_missing_one():
    import subprocess

    code = ("import mitsuba_pbrdf.bsdfs.pbrdf, mitsuba_pbrdf.emitters.polarized_sky\n"
            "import mitsuba_pbrdf.integrators.stokes_prb\n"
            "from mitsuba_pbrdf.registry import plugin_class\n"
            "plugin_class('polarized_sky')")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert result.returncode != 0
    assert "VariantNotSetError: no Mitsuba variant is set" in result.stderr
