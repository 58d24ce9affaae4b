"""Physical checks of a polarized BSDF that users can run on their own BSDFs
(``pbrdf``, Mitsuba's ``roughconductor``, ``measured_polarized``, a plugin of
their own); docs/diagnostics.md shows how.

One module per concern; each states its units and frames:

* :mod:`~mitsuba_pbrdf.diagnostics.realizability`: Cloude's coherency matrix
  and the output degree of polarization of any Mueller matrices (NumPy only);
* :mod:`~mitsuba_pbrdf.diagnostics.physics`: any Mitsuba BSDF as Mueller
  matrices in the reference's global s/p frames, and its reciprocity and
  realizability over random direction pairs (also of the reference);
* :mod:`~mitsuba_pbrdf.diagnostics.furnace`: directional-hemispherical albedo
  by a BSDF's own sampling (white furnace), and by quadrature of the reference;
* :mod:`~mitsuba_pbrdf.diagnostics.bsdf_outputs`: everything a BSDF's
  ``eval``, ``pdf``, ``eval_pdf`` and ``sample`` return, as NumPy.

Example, on any Mitsuba BSDF of a polarized variant::

    import numpy as np
    import mitsuba as mi
    import mitsuba_pbrdf
    from mitsuba_pbrdf import frames
    from mitsuba_pbrdf.diagnostics import physics, realizability

    mitsuba_pbrdf.use_variant("llvm_ad_spectral_polarized")
    bsdf = mi.load_dict({"type": "roughconductor", "alpha": 0.2})
    to_viewer, to_light = frames.random_directions(10_000, np.random.default_rng(0))
    M = physics.mueller_global(bsdf, to_viewer, to_light, (450.0, 550.0, 650.0))
    print(realizability.realizability(M, floor=1e-30))
    print(physics.reciprocity_errors(
        lambda v, l: physics.mueller_global(bsdf, v, l, (550.0,)), to_viewer, to_light))

Importing a module here needs no variant; the functions that load or
evaluate a Mitsuba BSDF need one. The test and study scaffolding built on
these (the stress test, the table of invalid inputs, the mutation tool) is in
the repository's ``proof/`` folder, outside the package.
"""
