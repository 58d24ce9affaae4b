"""Regenerate every validation table and figure.

    python validation/run_all.py [--quick] [--only physics,furnace,...] [--list]

Runs every study, each in its own process: every ``validation/<study>.py``
that defines a ``main(argv)`` (found by reading the files, see
:func:`studies`), except this script and ``common.py``, in alphabetical order,
with the arguments of :data:`ARGUMENTS` (none for a study not listed there).
A new study is therefore run without editing this file.

Each writes ``validation/<study>.md`` (and figures under ``validation/figures/``);
this script writes ``validation/summary.md`` with the run times (with
``--only``, it refreshes those studies' rows and keeps the others; ``--quick
--only`` leaves it alone). ``--quick``
uses fewer samples everywhere (a smoke test; the committed tables come from a
full run, and a quick run overwrites them: restore them with git). ``--only``
takes a comma-separated subset; an unknown name is a one-line error (exit 2).
``--list`` prints the command of each selected study, one a line, and runs
nothing. Exit status 1 if a study fails.
"""

import argparse
import ast
import os
import re
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
#: Scripts in validation/ that are not studies.
NOT_STUDIES = ("common", "run_all")
#: Command-line arguments per study: (full run, ``--quick`` run).
ARGUMENTS = {
    "accuracy": (["--pairs", "100000"], ["--pairs", "10000"]),
    "anisotropic": ([], ["--pairs", "2000", "--samples", "100000"]),
    "fit_pbsdf": ([], ["--quick"]),
    "fit_ptfe": ([], ["--quick"]),
    "fit_real": ([], ["--quick"]),
    "fit_synthetic": ([], ["--quick"]),
    "furnace": (["--samples", "1048576"], ["--samples", "65536"]),
    "inverse_memory": ([], ["--quick"]),
    "inverse_rendering": ([], ["--size", "32", "--iterations", "40"]),
    "measured_oracle": ([], ["--quick"]),
    "normal_maps": ([], ["--quick"]),
    # The mutation study's full run is long (a sample of 200 mutants: about
    # 30-60 min on 2 cores, validation/mutation.md); --quick runs 2 mutants.
    "mutation": (["--sample", "200", "--seed", "0", "--label", "after-sample200"],
                 ["--sample", "2", "--label", "smoke"]),
    "path_replay_gradients": ([], ["--quick"]),
    "physics": (["--pairs", "100000"], ["--pairs", "10000"]),
    "rendered_stokes": (["--spp", "256", "--passes", "8"], ["--spp", "64", "--passes", "8"]),
    "shape_from_polarization": (["--long", "200"], ["--quick"]),
    "sky_normals": ([], ["--quick"]),
    "polarized_sky_bias": ([], ["--quick"]),
    "published_scenes": ([], ["--quick"]),
    "stress": (["--samples", "1000000"], ["--samples", "100000"]),
    "svbrdf_recovery": ([], ["--quick"]),
}


def _defines_main(path):
    """Whether the script at ``path`` defines a top-level ``main`` taking an argument."""
    with open(path, encoding="utf-8") as f:
        tree = ast.parse(f.read(), path)
    return any(isinstance(node, ast.FunctionDef) and node.name == "main"
               and (node.args.args or node.args.vararg) for node in tree.body)


def studies(folder=HERE):
    """Names of the study scripts in ``folder``, sorted: every ``*.py`` with a
    ``main(argv)``, except :data:`NOT_STUDIES`."""
    names = []
    for name in sorted(os.listdir(folder)):
        stem, ext = os.path.splitext(name)
        if ext == ".py" and stem not in NOT_STUDIES and _defines_main(os.path.join(folder, name)):
            names.append(stem)
    return names


def title(study, folder=HERE):
    """The first sentence of the study's module docstring."""
    with open(os.path.join(folder, study + ".py"), encoding="utf-8") as f:
        doc = ast.get_docstring(ast.parse(f.read())) or study
    first = " ".join(doc.split("\n\n")[0].split())
    return first.split(". ")[0].rstrip(".").replace("``", "`")


def selected_studies(only, available):
    """The studies ``--only`` names (comma-separated; all if empty), in the
    order of ``available``; ValueError naming any unknown one."""
    wanted = [s for s in only.split(",") if s] if only else list(available)
    unknown = [s for s in wanted if s not in available]
    if unknown:
        raise ValueError(f"--only: unknown study {', '.join(map(repr, unknown))} "
                         f"(studies: {', '.join(available)})")
    return [s for s in available if s in wanted]


def _row_study(row):
    """The study a summary row links to (``[...](study.md)``), or None."""
    match = re.search(r"\]\(([A-Za-z0-9_]+)\.md\)", row)
    return match.group(1) if match else None


def _row_seconds(row):
    """The time column of a summary row, in seconds (0 if unreadable)."""
    match = re.search(r"\| (\d+) s \|", row)
    return int(match.group(1)) if match else 0


def merged_rows(summary, new_rows, available):
    """Rows of ``summary`` with those of ``new_rows`` ({study: row}) replaced or
    added, ordered as ``available``: ``--only`` refreshes part of the table."""
    old = {}
    if os.path.exists(summary):
        with open(summary, encoding="utf-8") as f:
            for line in f:
                study = _row_study(line)
                if line.startswith("| [") and study in available:
                    old[study] = line.rstrip("\n")
    old.update(new_rows)
    return [old[s] for s in available if s in old]


def write_summary(summary, rows, quick=False, partial=False):
    """Write ``validation/summary.md``: one row per study, total time = sum of rows."""
    total = sum(_row_seconds(row) for row in rows)
    how = ("rows refreshed one study at a time with `--only`; the total is the sum of the rows"
           if partial else "one run")
    with open(summary, "w", encoding="utf-8") as f:
        f.write("# Validation summary\n\n"
                f"`python validation/run_all.py{' --quick' if quick else ''}`: "
                f"{total / 60:.1f} min on this machine (2 cores; {how}).\n\n"
                "| study | command | time | status |\n|---|---|---|---|\n"
                + "\n".join(rows) + "\n")


def main(argv=None):
    available = studies()
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer samples (smoke test)")
    parser.add_argument("--only", default="", help="comma-separated subset of "
                        + ", ".join(available))
    parser.add_argument("--list", action="store_true",
                        help="print the selected studies' commands and run nothing")
    args = parser.parse_args(argv)
    stale = sorted(set(ARGUMENTS) - set(available))
    if stale:
        parser.exit(2, f"run_all.py: error: ARGUMENTS names {', '.join(stale)}, which "
                       "is not a study (validation/<study>.py with a main(argv))\n")
    try:
        selected = selected_studies(args.only, available)
    except ValueError as e:
        parser.exit(2, f"run_all.py: error: {e}\n")
    if args.list:
        for study in selected:
            extra = ARGUMENTS.get(study, ([], []))[1 if args.quick else 0]
            print(" ".join(["python", f"validation/{study}.py"] + extra))
        return 0
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [ROOT] + ([os.environ["PYTHONPATH"]] if os.environ.get("PYTHONPATH") else [])),
        MPLBACKEND="Agg")
    rows, failed = [], []
    start = time.perf_counter()
    for study in selected:
        full, quick = ARGUMENTS.get(study, ([], []))
        extra = quick if args.quick else full
        command = [sys.executable, os.path.join(HERE, study + ".py")] + extra
        print(f"== {study}: {' '.join(command[1:])}", flush=True)
        t0 = time.perf_counter()
        result = subprocess.run(command, cwd=ROOT, env=env, stdout=subprocess.DEVNULL)
        seconds = time.perf_counter() - t0
        status = "ok" if result.returncode == 0 else f"**failed ({result.returncode})**"
        if result.returncode:
            failed.append(study)
        print(f"   {status}, {seconds:.0f} s", flush=True)
        shown = " ".join(["python", f"validation/{study}.py"] + extra)
        rows.append(f"| [{title(study)}]({study}.md) | `{shown}` | {seconds:.0f} s | {status} |")
    total = time.perf_counter() - start
    summary = os.path.join(HERE, "summary.md")
    if args.only and not args.quick:
        write_summary(summary, merged_rows(summary, dict(zip(selected, rows)), available),
                      partial=True)
    elif not args.only:
        write_summary(summary, rows, quick=args.quick)
    print(f"total {total:.0f} s" + (f"; failed: {', '.join(failed)}" if failed else ""))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
