"""Tables of the mutation study (:mod:`mitsuba_pbrdf.checks.mutation`)."""

#: The fast test subset run on each mutant of each package, in order (the
#: quickest killers first: ``pytest -x`` stops at the first failure). A file
#: that an older tests/ lacks is left out of that run.
SUBSETS = {
    "plugin": ["tests/test_bsdf_vs_reference.py", "tests/test_mixture_sampling.py",
               "tests/test_bsdf.py", "tests/test_sampling.py", "tests/test_bad_input.py"],
    "reference": ["tests/test_reference.py", "tests/test_bsdf_vs_reference.py"],
}
EQUIVALENT = {}
DEFECTS = []
