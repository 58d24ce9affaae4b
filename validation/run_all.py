"""Regenerate every validation table and figure.

    python validation/run_all.py [--quick] [--only physics,furnace,...]

Runs each study in its own process (``validation/<study>.py``), in this order:

====================  =====================================================
``paper_claims``      study 1: P-G vs two- vs three-component, in-plane
``physics``           study 2: Fresnel, pseudo-Brewster, s-polarization,
                      reciprocity, realizability
``furnace``           study 2: white furnace, albedo of each lobe
``rendered_stokes``   study 3: rendered Stokes images vs physics
``stress``            study 4: 10^6-sample stability stress test
``bad_input``         study 5: the message of every invalid parameter
``accuracy``          plugin vs reference, element by element
====================  =====================================================

Each writes ``validation/<study>.md`` (and figures under ``validation/figures/``);
this script writes ``validation/summary.md`` with the run times. ``--quick``
uses fewer samples everywhere (a smoke test, minutes less; the committed
tables come from a full run). Exit status 1 if a study fails.
"""

import argparse
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)

STUDIES = {
    "paper_claims": ([], []),
    "physics": (["--pairs", "100000"], ["--pairs", "10000"]),
    "furnace": (["--samples", "1048576"], ["--samples", "65536"]),
    "rendered_stokes": (["--spp", "256", "--passes", "8"], ["--spp", "64", "--passes", "8"]),
    "stress": (["--samples", "1000000"], ["--samples", "100000"]),
    "bad_input": ([], []),
    "accuracy": (["--pairs", "100000"], ["--pairs", "10000"]),
}
TITLES = {
    "paper_claims": "Paper's claims: Priest-Germer vs two- vs three-component",
    "physics": "Physics checks (Fresnel, pseudo-Brewster, s-polarization, reciprocity, "
               "realizability)",
    "furnace": "White furnace: albedo of each lobe",
    "rendered_stokes": "Rendered Stokes images vs physics",
    "stress": "Stability stress test",
    "bad_input": "Bad input",
    "accuracy": "Plugin vs reference accuracy",
}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer samples (smoke test)")
    parser.add_argument("--only", default="", help="comma-separated subset of " + ", ".join(STUDIES))
    args = parser.parse_args(argv)
    selected = [s for s in STUDIES if not args.only or s in args.only.split(",")]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [ROOT] + ([os.environ["PYTHONPATH"]] if os.environ.get("PYTHONPATH") else [])),
        MPLBACKEND="Agg")
    rows, failed = [], []
    start = time.perf_counter()
    for study in selected:
        full, quick = STUDIES[study]
        command = [sys.executable, os.path.join(HERE, study + ".py")] + (quick if args.quick else full)
        print(f"== {study}: {' '.join(command[1:])}", flush=True)
        t0 = time.perf_counter()
        result = subprocess.run(command, cwd=ROOT, env=env, stdout=subprocess.DEVNULL)
        seconds = time.perf_counter() - t0
        status = "ok" if result.returncode == 0 else f"**failed ({result.returncode})**"
        if result.returncode:
            failed.append(study)
        print(f"   {status}, {seconds:.0f} s", flush=True)
        shown = " ".join(["python", f"validation/{study}.py"] + (quick if args.quick else full))
        rows.append(f"| [{TITLES[study]}]({study}.md) | `{shown}` | {seconds:.0f} s | {status} |")
    total = time.perf_counter() - start
    if not args.only:
        with open(os.path.join(HERE, "summary.md"), "w", encoding="utf-8") as f:
            f.write("# Validation summary\n\n"
                    f"`python validation/run_all.py{' --quick' if args.quick else ''}`: "
                    f"{total / 60:.1f} min on this machine.\n\n"
                    "| study | command | time | status |\n|---|---|---|---|\n"
                    + "\n".join(rows) + "\n")
    print(f"total {total:.0f} s" + (f"; failed: {', '.join(failed)}" if failed else ""))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
