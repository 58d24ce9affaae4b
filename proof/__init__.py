"""The proof outside the wheel: scaffolding that ``tests/`` and ``validation/``
share and users never need. Not packaged (the wheel holds ``mitsuba_pbrdf``
alone; tests/project/test_packaging.py checks it), and nothing in ``mitsuba_pbrdf``
imports it (tests/project/test_layout.py checks that).

* :mod:`.mutation`, :mod:`.mutation_tables`: the mutation-testing tool
  (validation/mutation.md);
* :mod:`.bad_input`: the table of invalid ``pbrdf`` parameters and their messages;
* :mod:`.fuzz_inputs`, :mod:`.conditioning`, :mod:`.stress`: the stability
  stress test (hostile parameters and directions, the float32 conditioning,
  the checks and their tallies);
* :mod:`.mirror_fresnel`: Fresnel reflectance, pseudo-Brewster angle and
  s-polarization of the model in the mirror direction;
* :mod:`.rendered`: rendered Stokes images against geometry and the reference;
* :mod:`.render_gradients`: gradients of a linear functional of a render, to
  compare integrators;
* :mod:`.plugin_snapshot`: bit-for-bit record and comparison of the plugin's
  outputs (``python proof/plugin_snapshot.py``);
* :mod:`.interrupt`: Ctrl-C for real (SIGINT to a ``pbrdf`` process group once
  an output exists), for the tests of ``pbrdf batch``;
* :mod:`.batch_report`: what the two ``pbrdf batch`` benchmarks share (options,
  seconds inside jobs from the manifest, batch.md's two parts).

It is importable from the repository root: pytest's ``pythonpath`` holds
``.``, and each ``validation/<study>.py`` puts the root on ``sys.path``.
The checks users can run on their own BSDFs are :mod:`mitsuba_pbrdf.diagnostics`.
"""
