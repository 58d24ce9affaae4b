"""Mutation testing: how many one-line mutants of the plugin and the reference the tests kill.

    python validation/mutation.py --full [--jobs 2] [--tests-rev REV]
    python validation/mutation.py --sample 160 [--seed 0] [--tests-rev REV]
    python validation/mutation.py --defects [--tests-rev REV]

Without arguments: a smoke run of 6 mutants. The mutants, the test subsets
and the tables of equivalent mutants and of the review's defects are in
``mitsuba_pbrdf/checks/mutation.py`` and ``mitsuba_pbrdf/checks/mutation_tables.py``.
"""

import argparse
import json
import os
import sys
import time

from common import HERE

from mitsuba_pbrdf.checks import mutation

RUNS = os.path.join(HERE, "mutation_runs")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--full", action="store_true", help="every mutant (hours on 2 cores)")
    parser.add_argument("--sample", type=int, default=6, help="a seeded random sample of N mutants")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--tests-rev", default=None, help="take tests/ from this git revision")
    parser.add_argument("--label", default=None, help="name of the run's JSON record")
    args = parser.parse_args(argv)
    mutants = mutation.all_mutants()
    chosen = mutants if args.full else mutation.sample_mutants(mutants, args.sample, args.seed)
    start = time.perf_counter()
    done, baseline = mutation.run_study(chosen, args.jobs, args.tests_rev)
    seconds = time.perf_counter() - start
    label = args.label or ("full" if args.full else f"sample{args.sample}-seed{args.seed}") \
        + (f"-tests-{args.tests_rev}" if args.tests_rev else "")
    os.makedirs(RUNS, exist_ok=True)
    with open(os.path.join(RUNS, label + ".json"), "w", encoding="utf-8") as f:
        json.dump(dict(label=label, tests_rev=args.tests_rev, total_mutants=len(mutants),
                       run=len(done), seconds=round(seconds), jobs=args.jobs,
                       baseline=baseline, subsets=mutation.SUBSETS,
                       mutants=mutation.as_records(done)), f, indent=1)
    killed = sum(m.status.startswith("killed") for m in done)
    print(f"{label}: {killed}/{len(done)} killed in {seconds:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
