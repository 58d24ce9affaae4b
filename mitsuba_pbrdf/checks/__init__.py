"""Physical and numerical checks of a pBRDF, shared by the tests and the
validation studies, and usable on their own.

One module per concern; each states its units and frames:

* :mod:`~mitsuba_pbrdf.checks.realizability`: Cloude's coherency matrix and the
  output degree of polarization of any Mueller matrices (NumPy only);
* :mod:`~mitsuba_pbrdf.checks.physics`: reciprocity and realizability of the
  reference and of a Mitsuba BSDF over random direction pairs;
* :mod:`~mitsuba_pbrdf.checks.fresnel`: normal-incidence reflectance,
  pseudo-Brewster angle and s-polarization in the mirror direction;
* :mod:`~mitsuba_pbrdf.checks.furnace`: directional-hemispherical albedo by
  quadrature of the reference and by a BSDF's own sampling;
* :mod:`~mitsuba_pbrdf.checks.fuzz_inputs`, :mod:`~mitsuba_pbrdf.checks.bsdf_outputs`,
  :mod:`~mitsuba_pbrdf.checks.conditioning`, :mod:`~mitsuba_pbrdf.checks.stress`:
  the stability stress test (hostile parameters and directions, everything a
  BSDF returns, the float32 conditioning, the checks and their tallies);
* :mod:`~mitsuba_pbrdf.checks.rendered`: rendered Stokes images against
  geometry and the reference;
* :mod:`~mitsuba_pbrdf.checks.bad_input`: the table of invalid plugin
  parameters and the message each gets.

Example, on any Mitsuba BSDF of a polarized variant::

    import numpy as np
    import mitsuba as mi
    import mitsuba_pbrdf
    from mitsuba_pbrdf import frames
    from mitsuba_pbrdf.checks import physics, realizability

    mitsuba_pbrdf.use_variant("llvm_ad_spectral_polarized")
    bsdf = mi.load_dict({"type": "roughconductor", "alpha": 0.2})
    to_viewer, to_light = frames.random_directions(10_000, np.random.default_rng(0))
    M = physics.mueller_global(bsdf, to_viewer, to_light, (450.0, 550.0, 650.0))
    print(realizability.realizability(M, floor=1e-30))
    print(physics.reciprocity_errors(
        lambda v, l: physics.mueller_global(bsdf, v, l, (550.0,)), to_viewer, to_light))

Importing a module here needs no variant; the functions that load or
evaluate a Mitsuba BSDF need one. Nothing here imports ``tests/`` or
``validation/``.
"""
