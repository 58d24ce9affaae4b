"""Study 5: bad input, the message each invalid parameter gets.

    python validation/bad_input.py   (-> bad_input.md)

Loads a ``pbrdf`` with every entry of the table in
``proof/bad_input.py`` (``llvm_ad_spectral_polarized``) and
writes the error message it gets. ``tests/hostile/test_bad_input.py`` asserts on the
same table that each is rejected at load time and that the message names the
parameter; this page shows the messages a user sees.
"""

import argparse
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from validation import common  # noqa: E402
from proof import bad_input  # noqa: E402


def main(argv=None):
    argparse.ArgumentParser(description=__doc__.splitlines()[0]).parse_args(argv)
    common.use_variant()
    start = time.perf_counter()
    rows = []
    for params, error, fragment in bad_input.cases():
        message = bad_input.load_error(params) or "**loaded without error**"
        named = fragment in message
        rows.append((bad_input.describe(params), message[:160], named))
    text = (f"# Study 5: bad input\n\n`python validation/bad_input.py` "
            f"({time.perf_counter() - start:.1f} s): every invalid parameter of the table in "
            f"`proof/bad_input.py` ({len(rows)} cases; `tests/hostile/test_bad_input.py` "
            "also covers XML, scenes, `mi.traverse` updates and other variants) and the last "
            "line of the error Mitsuba reports when loading it. Found by that test and fixed "
            "since (regression tests there): bitmap textures were checked on a 64×64 grid of "
            "texels only (the centre in scalar variants), roughness below Mitsuba's floor "
            "(α = 1e-4) was clamped silently, tabulated spectra not covering 360–830 nm "
            "evaluated to n = k = 0 outside their table, and a negative inline XML spectrum "
            "got Mitsuba's message without the parameter's name.\n\n"
            + common.table(["parameters", "message (last line)", "names the parameter"], rows))
    common.write_markdown("bad_input", text)
    if not all(r[2] for r in rows):
        raise SystemExit("some bad input was not rejected with a message naming the parameter")


if __name__ == "__main__":
    main()
