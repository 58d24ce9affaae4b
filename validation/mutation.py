"""Mutation testing: how many one-line mutants of the plugin and the reference the tests kill.

    python validation/mutation.py --full [--jobs 2] [--tests-rev REV]
    python validation/mutation.py --sample 160 [--seed 0] [--tests-rev REV]
    python validation/mutation.py --defects [--tests-rev REV]
    python validation/mutation.py --rerun LABEL --status "killed (timeout)" [--timeout-factor 10]
    python validation/mutation.py --rerun LABEL --status survived [--match TEXT]  # today's tests
    python validation/mutation.py --summary LABEL [LABEL ...]

Without arguments: a smoke run of 6 mutants. Each run is recorded as JSON in
``validation/mutation_runs/LABEL.json``; ``--summary`` prints a record's score
with its 95 % interval and its survivors, and compares two records of the same
mutants. A run that times out counts as a kill; on a machine shared with other
jobs the unmutated run's time is a poor yardstick, so ``--rerun`` runs a
record's timed-out mutants again with a longer limit and updates it (the
first status is kept as ``first_status``). ``--rerun LABEL --status
survived`` runs its survivors against today's tests/ (those of the working
tree, whatever the record's ``tests_rev``): after tests were added for them.
The analysis is ``validation/mutation.md``. The mutants, the test subsets
and the tables of equivalent mutants and of the review's defects are in
``proof/mutation.py`` and ``proof/mutation_tables.py``.
"""

import argparse
import json
import os
import shutil
import sys
import time

from common import HERE

from proof import mutation

RUNS = os.path.join(HERE, "mutation_runs")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--full", action="store_true", help="every mutant (hours on 2 cores)")
    parser.add_argument("--sample", type=int, default=6, help="a seeded random sample of N mutants")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--tests-rev", default=None, help="take tests/ from this git revision")
    parser.add_argument("--label", default=None, help="name of the run's JSON record")
    parser.add_argument("--defects", nargs="*", default=None, metavar="NAME",
                        help="run the review's one-line defects against new (and old) tests "
                             "(those whose name contains a NAME: rows of the record replaced)")
    parser.add_argument("--timeout-factor", type=float, default=3.0,
                        help="a mutant's run times out after this many unmutated runs")
    parser.add_argument("--rerun", metavar="LABEL", default=None,
                        help="run the mutants of record LABEL with --status again")
    parser.add_argument("--status", default="killed (timeout)")
    parser.add_argument("--match", default="", help="--rerun only mutants whose key contains this")
    parser.add_argument("--summary", nargs="+", metavar="LABEL", default=None)
    args = parser.parse_args(argv)
    if args.defects is not None:
        return defects(args.tests_rev, args.defects)
    if args.summary:
        return summary(args.summary)
    if args.rerun:
        return rerun(args.rerun, args.status, args.jobs, args.timeout_factor, args.match)
    mutants = mutation.all_mutants()
    chosen = mutants if args.full else mutation.sample_mutants(mutants, args.sample, args.seed)
    start = time.perf_counter()
    done, baseline = mutation.run_study(chosen, args.jobs, args.tests_rev,
                                        timeout_factor=args.timeout_factor)
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


def load(label):
    with open(os.path.join(RUNS, label + ".json"), encoding="utf-8") as f:
        return json.load(f)


def rerun(label, status, jobs, timeout_factor, match=""):
    """Run the mutants of record ``label`` whose status is ``status`` again
    with ``timeout_factor``: timeouts with the record's tests/, survivors with
    the working tree's; the record keeps the first status as ``first_status``."""
    record = load(label)
    keys = {m["key"] for m in record["mutants"] if m["status"] == status and match in m["key"]}
    chosen = [m for m in mutation.all_mutants() if m.key in keys]
    tests_rev = None if status == "survived" else record["tests_rev"]
    done, _ = mutation.run_study(chosen, jobs, tests_rev, timeout_factor=timeout_factor)
    again = {m.key: m for m in done}
    for m in record["mutants"]:
        if m["key"] in again:
            new = mutation.as_records([again[m["key"]]])[0]
            m.update(new, first_status=m.get("first_status", m["status"]),
                     rerun=f"tests/ from {tests_rev or 'the working tree'}, timeout "
                           f"{timeout_factor:g} x the unmutated run")
    with open(os.path.join(RUNS, label + ".json"), "w", encoding="utf-8") as f:
        json.dump(record, f, indent=1)
    print(f"{label}: {len(done)} mutants ({status}) run again: "
          + ", ".join(f"{m.status}" for m in done))
    return 0


def score(record):
    """(killed, run, 95 % Clopper-Pearson interval of the score over all the
    mutants, with the sample's finite-population correction)."""
    from scipy.stats import binomtest

    mutants = record["mutants"]
    killed, n, total = sum(m["status"].startswith("killed") for m in mutants), len(mutants), \
        record["total_mutants"]
    low, high = binomtest(killed, n).proportion_ci(0.95)
    shrink = ((total - n) / max(total - 1, 1)) ** 0.5      # sampling without replacement
    p = killed / n
    return killed, n, (p - (p - low) * shrink, p + (high - p) * shrink)


def summary(labels):
    """Print each record's score and survivors; for two records of the same
    mutants, the mutants whose status differs."""
    records = [load(label) for label in labels]
    for record in records:
        killed, n, (low, high) = score(record)
        timeouts = sum(m["status"] == "killed (timeout)" for m in record["mutants"])
        print(f"{record['label']}: tests from {record['tests_rev'] or 'the working tree'}; "
              f"{killed}/{n} killed ({killed / n:.1%}, 95 % interval {low:.1%}-{high:.1%} "
              f"of all {record['total_mutants']} mutants; {timeouts} by timeout), "
              f"{record['seconds'] / 60:.0f} min on {record['jobs']} jobs")
        rerun = [m for m in record["mutants"] if "first_status" in m]
        if rerun:
            first = sum(m.get("first_status", m["status"]).startswith("killed")
                        for m in record["mutants"])
            print(f"  first run {first}/{n} killed; {len(rerun)} run again "
                  f"({rerun[0]['rerun']}): " + ", ".join(
                      f"{m['first_status']} -> {m['status']}" for m in rerun))
        for package in sorted({m["path"].split("/")[1] for m in record["mutants"]}):
            ms = [m for m in record["mutants"] if m["path"].split("/")[1] == package]
            k = sum(m["status"].startswith("killed") for m in ms)
            print(f"  {package}: {k}/{len(ms)} killed")
        for m in record["mutants"]:
            if m["status"] == "survived":
                reason = mutation.EQUIVALENT.get(m["key"], "UNEXPLAINED: a gap or a new equivalent")
                print(f"  survived  {m['key']} (line {m['line']}): {reason}")
    if len(records) == 2:
        a, b = ({m["key"]: m["status"] for m in r["mutants"]} for r in records)
        for key in a:
            if key in b and a[key].startswith("killed") != b[key].startswith("killed"):
                print(f"  {a[key]} -> {b[key]}: {key}")
    return 0


def defects(tests_rev, names=()):
    """Each of mutation_tables.DEFECTS (those whose name contains one of
    ``names``, if given) against the tests that guard it now (they must fail)
    and, with ``tests_rev``, against the old suite's tests (JSON record
    validation/mutation_runs/defects.json; with ``names``, its rows of those
    defects replaced)."""
    new = mutation.make_copy()
    old = mutation.make_copy(tests_rev) if tests_rev else None
    chosen = [d for d in mutation.DEFECTS if not names or any(n in d["name"] for n in names)]
    rows = []
    for d in chosen:
        status, seconds, last = mutation.run_defect(d, new, d["new_tests"])
        row = dict(d, new_status=status, new_detail=last[:400], new_seconds=round(seconds, 1))
        if old:
            status, seconds, last = mutation.run_defect(d, old, d["old_tests"])
            row.update(old_status=status, old_detail=last[:400])
        print(f"{d['name']}: new tests {row['new_status']}; old tests {row.get('old_status')}",
              flush=True)
        rows.append(row)
    for folder in (new, old):
        if folder:
            shutil.rmtree(folder, ignore_errors=True)
    path = os.path.join(RUNS, "defects.json")
    if names and os.path.exists(path):
        with open(path, encoding="utf-8") as f:
            kept = {r["name"]: r for r in json.load(f)["defects"]}
        kept.update({r["name"]: r for r in rows})
        rows = [kept[d["name"]] for d in mutation.DEFECTS if d["name"] in kept]
    os.makedirs(RUNS, exist_ok=True)
    with open(path, "w", encoding="utf-8") as f:
        json.dump(dict(tests_rev=tests_rev, defects=rows), f, indent=1)
    caught = sum(r["new_status"].startswith("killed") for r in rows)
    print(f"{caught}/{len(rows)} defects fail the new tests")
    return 0 if caught == len(rows) else 1


if __name__ == "__main__":
    sys.exit(main())
