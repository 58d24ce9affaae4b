"""Study 4: numerical stability stress test of the ``pbrdf`` plugin.

    python validation/stress.py [--samples 1000000] [--seed 0]   (-> stress.md)

A seeded generator draws random configurations and, for each, a batch of
direction pairs from several regions (generic, grazing, normal, retro, mirror,
near-mirror, nearly opposite, below the horizon); every ``eval``, ``pdf``,
``eval_pdf`` and ``sample`` result, in both transport modes, is checked to be
finite, non-negative where it must be, physically realizable, zero below the
horizon and self-consistent, and its value is compared with the float64
reference, also in units of the problem's own float32 conditioning.

The generator is ``proof.fuzz_inputs``, the checks and their
tallies ``proof.stress``, the conditioning
``proof.conditioning``; their docstrings give every range,
region and bound. This script runs them at the study's size and writes the
report; ``tests/bsdfs/test_fuzz.py`` runs the same code on 10^5 pairs.
"""

import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from validation import common  # noqa: E402
from proof import stress  # noqa: E402


def report(samples=1_000_000, seed=0):
    tally = stress.run(samples, seed, progress=True)
    checks = common.table(["check", "failures"],
                          sorted(tally.failures.items()))
    def percentile(name, q):
        return (float(np.percentile(np.concatenate(tally.errors[name]), q))
                if tally.errors[name] else np.nan)

    rows = [(name, tally.compared[name], percentile(name, 50), percentile(name, 99.9),
             tally.worst[name], tally.worst_units[name]) for name in tally.worst]
    accuracy = common.table(["region", "values compared", "median ΔM / M00",
                             "99.9th percentile", "worst", "worst in units of u (1 + κ)"], rows)
    cases = "\n".join(
        f"* {name}: error {c['error']:.2e}, κ {c['kappa']:.3g}, {c['mode']}, λ {c['wavelength']:.1f} "
        f"nm, wi {np.round(c['wi'], 8).tolist()}, wo {np.round(c['wo'], 8).tolist()}, "
        f"parameters {{{', '.join(f'{k}: {v:.4g}' for k, v in c['params'].items())}}}, "
        f"{c['config'].split('shadowing')[1].strip(' :')}"
        for name, c in tally.worst_case.items())
    cases_units = "\n".join(
        f"* {name}: {c['units']:.3g} u (1 + κ), error {c['error']:.2e}, κ {c['kappa']:.3g}, "
        f"{c['mode']}, wi {np.round(c['wi'], 8).tolist()}, wo {np.round(c['wo'], 8).tolist()}, "
        f"{c['config']}" for name, c in tally.worst_units_case.items())
    text = f"""# Study 4: stability stress test

`python validation/stress.py --samples {samples} --seed {seed}` ({tally.seconds:.0f} s):
{tally.samples:,} direction pairs over {tally.configs} random configurations, each evaluated
in both transport modes with `eval`, `pdf`, `eval_pdf` and `sample` ({tally.evaluations:,}
calls' lanes; × 4 wavelengths). The generator, the parameter ranges and the regions are
described in `proof/fuzz_inputs.py`, the checks in
`proof/stress.py`; `tests/bsdfs/test_fuzz.py` runs the same code on 10⁵ pairs.

**Checks** (number of failing lanes; every check must be 0):

{checks}

Smallest coherency eigenvalue seen: {tally.min_eigen:.2e} × M00 (tolerance
−{stress.REALIZABILITY_TOL:.1e}, i.e. 16 float32 roundings).

**Accuracy against the float64 reference** per region (both modes, 4 wavelengths per pair,
reference M00 > 1e-10 1/sr; reference evaluated at the plugin's float32 inputs, with Mitsuba's
approximate Beckmann G1 for Smith shadowing as the plugin uses). u = 2⁻²⁴; κ is the reference's
own sensitivity to perturbations the size of the float32 representation of the inputs
(`proof/conditioning.py`). Large relative errors occur only where κ is large, i.e. where the problem itself is
ill-conditioned: narrow lobes near grazing, and nearly opposite grazing directions, where the
half vector is the normalized sum of two almost cancelling float32 vectors. Bound asserted in
`tests/bsdfs/test_fuzz.py`: {stress.ACCURACY_UNITS} u (1 + κ).

{accuracy}

Largest error per region (ΔM / M00 = max_ij |M_ij − R_ij| / R00):

{cases}

Largest error in units of u (1 + κ) per region:

{cases_units}
"""
    if tally.examples:
        text += "\n**First failure per check:**\n\n" + "\n".join(
            f"* {k}: `{v}`" for k, v in tally.examples.items()) + "\n"
    common.write_markdown("stress", text)
    return tally


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=1_000_000)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    common.use_variant()
    report(args.samples, args.seed)


if __name__ == "__main__":
    main()
