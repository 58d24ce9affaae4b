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
    parser.add_argument("--defects", action="store_true",
                        help="run the review's one-line defects against new (and old) tests")
    args = parser.parse_args(argv)
    if args.defects:
        return defects(args.tests_rev)
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


def defects(tests_rev):
    """Each of mutation_tables.DEFECTS against the tests that guard it now (they
    must fail) and, with ``tests_rev``, against the old suite's tests (JSON
    record validation/mutation_runs/defects.json)."""
    new = mutation.make_copy()
    old = mutation.make_copy(tests_rev) if tests_rev else None
    rows = []
    for d in mutation.DEFECTS:
        status, seconds, last = mutation.run_defect(d, new, d["new_tests"])
        row = dict(d, new_status=status, new_detail=last[:400], new_seconds=round(seconds, 1))
        if old:
            status, seconds, last = mutation.run_defect(d, old, d["old_tests"])
            row.update(old_status=status, old_detail=last[:400])
        print(f"{d['name']}: new tests {row['new_status']}; old tests {row.get('old_status')}",
              flush=True)
        rows.append(row)
    os.makedirs(RUNS, exist_ok=True)
    with open(os.path.join(RUNS, "defects.json"), "w", encoding="utf-8") as f:
        json.dump(dict(tests_rev=tests_rev, defects=rows), f, indent=1)
    caught = sum(r["new_status"].startswith("killed") for r in rows)
    print(f"{caught}/{len(rows)} defects fail the new tests")
    return 0 if caught == len(rows) else 1


if __name__ == "__main__":
    sys.exit(main())
