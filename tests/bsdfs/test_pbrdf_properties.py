"""Mitsuba's roughness names (issue 36): ``alpha``, ``alpha_u``, ``alpha_v`` are
taken beside the paper's ``sigma``, ``sigma_u``, ``sigma_v`` with Mitsuba's
meaning, alpha = sqrt(2) sigma (Beckmann's width; the plugin's GGX takes the
same alpha as roughconductor's GGX). A width given as alpha is exposed by
``traverse`` under that name, with alpha's values. Bad values and giving both
names are in proof/bad_input.py's table (tests/hostile/test_bad_input.py)."""

import math

import mitsuba as mi
import numpy as np
import pytest

from bsdf_harness import as_numpy, hemisphere_pairs, make_si, to_vector
from mitsuba_pbrdf import schema, schema_tables
from tests.bsdfs.test_pbrdf_textured import MATCHED, checker, s0, tiles

SQRT2 = math.sqrt(2.0)
#: pbrdf against roughconductor, per element of M00 (tests/bsdfs/test_pbrdf_roughconductor.py).
TOL = 1e-5


def test_aliases_are_mitsubas_names_with_mitsubas_units():
    assert {name: (p.stands_for, p.scale) for name, p in schema.ALIASES.items()} == {
        "alpha": ("sigma", SQRT2), "alpha_u": ("sigma_u", SQRT2), "alpha_v": ("sigma_v", SQRT2)}
    assert schema.parameter("alpha").floor == pytest.approx(1e-4, rel=1e-12)  # Mitsuba's clamp


@pytest.mark.parametrize("name", sorted(schema.ALIASES))
def test_each_alias_is_read_and_exposed_under_its_name(name):
    bsdf = mi.load_dict({"type": "pbrdf", name: 0.3})
    params = mi.traverse(bsdf)
    assert float(params[f"{name}.value"][0]) == pytest.approx(0.3)
    assert schema.ALIASES[name].stands_for not in {k.split(".")[0] for k in params.keys()}
    mi.load_dict({"type": "pbrdf", name: 1e-4})        # Mitsuba's smallest alpha, as float32


@pytest.mark.parametrize("distribution", ["beckmann", "ggx"])
def test_alpha_gives_roughconductors_lobe(distribution):
    """Given as alpha (isotropic; anisotropic from alpha with alpha_v), pbrdf
    with Smith shadowing evaluates roughconductor's matrix; the pdfs differ
    only by the exact Beckmann G1 (tests/bsdfs/test_pbrdf_roughconductor.py), so they are
    compared for GGX alone."""
    wi, wo = hemisphere_pairs(3000, seed=36)
    si, w, ctx = make_si(wi), to_vector(wo), mi.BSDFContext()
    for given, mitsuba in (({"alpha": 0.3}, {"alpha": 0.3}),
                           ({"alpha": 0.3, "alpha_v": 0.08}, {"alpha_u": 0.3, "alpha_v": 0.08}),
                           ({"sigma": 0.3 / SQRT2, "alpha_v": 0.08},
                            {"alpha_u": 0.3, "alpha_v": 0.08})):
        pb = mi.load_dict({"type": "pbrdf", "material": "Cu", "shadowing": "smith",
                           "distribution": distribution, **given})
        rc = mi.load_dict({"type": "roughconductor", "material": "Cu",
                           "distribution": distribution, **mitsuba})
        expected, got = as_numpy(rc.eval(ctx, si, w)), as_numpy(pb.eval(ctx, si, w))
        assert np.all(np.abs(got - expected) <= TOL * expected[..., :1, :1] + 1e-30), given
        if distribution == "ggx":
            np.testing.assert_allclose(as_numpy(pb.pdf(ctx, si, w)),
                                       as_numpy(rc.pdf(ctx, si, w)), rtol=1e-5, atol=1e-30)


def test_textures_given_as_alpha_render_as_roughconductors():
    """A checkerboard alpha_u beside a constant alpha_v: matched-seed render
    against roughconductor with the same textures (point light: eval only,
    tests/bsdfs/test_pbrdf_textured.py); given as sigma_u = alpha_u / sqrt(2)
    rendered the same."""
    rc = {"type": "roughconductor", "material": "Cu", "alpha_u": checker(0.05, 0.3),
          "alpha_v": 0.2}
    pb = {"type": "pbrdf", "material": "Cu", "shadowing": "smith",
          "alpha_u": checker(0.05, 0.3), "alpha_v": 0.2}
    expected, got = tiles(rc), tiles(pb)
    assert np.abs(got - expected).max() <= MATCHED * s0(expected).mean()


def test_updating_alpha_changes_the_lobe_as_loading_it_does():
    wi, wo = hemisphere_pairs(500, seed=37)
    si, w, ctx = make_si(wi), to_vector(wo), mi.BSDFContext()
    bsdf = mi.load_dict({"type": "pbrdf", "alpha": 0.1})
    params = mi.traverse(bsdf)
    params["alpha.value"] = 0.4
    params.update()
    loaded = mi.load_dict({"type": "pbrdf", "alpha": 0.4})
    np.testing.assert_array_equal(as_numpy(bsdf.eval(ctx, si, w)),
                                  as_numpy(loaded.eval(ctx, si, w)))
    params["alpha.value"] = 5e-5
    with pytest.raises(ValueError, match="'alpha' must be >= 0.0001"):
        params.update()


def test_the_docs_tables_name_each_alias():
    table = schema_tables.markdown_table()
    for name, p in schema.ALIASES.items():
        assert f"| `{name}` |" in table and f"sqrt(2) {p.stands_for}" in p.doc
