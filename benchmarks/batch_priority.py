"""Does submitting a sweep as one graph in its order
(:mod:`mitsuba_pbrdf.batch.runner`: "ordered") slow a sweep without faults,
against the submission before it ("equal": one ``client.submit`` per job,
one priority for all)? Runs the same sweep both ways, interleaved, on one
local cluster of 2 workers kept for all runs (its start is not timed), after
a warm-up of each. Prints each run's seconds and the medians' ratio.

    python benchmarks/batch_priority.py                 # 60 jobs, 16 x 16 px, 16 spp, 5 runs each
    python benchmarks/batch_priority.py --jobs 12 --repeats 2
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from mitsuba_pbrdf.batch import runner  # noqa: E402
from mitsuba_pbrdf.batch.cluster import connect  # noqa: E402
from mitsuba_pbrdf.batch.runner import submit_in_order  # noqa: E402
from mitsuba_pbrdf.batch.sweep import load_sweep  # noqa: E402

SPHERE = ROOT / "scenes" / "gallery" / "sphere.xml"


def submit_equal(client, function, arguments, keys):
    """The submission before: one ``client.submit`` per job, Dask's default priority."""
    return [client.submit(function, *args, key=key, pure=False)
            for args, key in zip(arguments, keys)]


def one_run(folder: Path, name: str, jobs: int, spp: int, address: str, submit) -> float:
    """Seconds of ``run_sweep`` for a fresh sweep of *jobs* renders in *folder*."""
    sigmas = ", ".join(f"{0.05 + 0.002 * i:.3f}" for i in range(jobs))
    path = folder / f"{name}.toml"
    path.write_text(f'scene = "{SPHERE}"\nout = "{folder / name}"\nspp = {spp}\n'
                    f"[params]\nwidth = 16\nheight = 16\nsigma = [{sigmas}]\n")
    runner.submit_in_order = submit
    summary = runner.run_sweep(load_sweep(path), scheduler=address, progress=False)
    assert summary.done == jobs, summary.line()
    return summary.seconds


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--jobs", type=int, default=60)
    parser.add_argument("--spp", type=int, default=16)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    ways = {"ordered": submit_in_order, "equal": submit_equal}
    times = {way: [] for way in ways}
    with connect(workers=2, drjit_threads=2) as (client, _), \
            tempfile.TemporaryDirectory() as tmp:
        address = client.scheduler.address
        for repeat in range(args.repeats + 1):  # the first round warms up
            for way, submit in (ways.items() if repeat % 2 else reversed(ways.items())):
                seconds = one_run(Path(tmp), f"{way}-{repeat}", args.jobs, args.spp,
                                  address, submit)
                if repeat:
                    times[way].append(seconds)
                print(f"{'warm-up' if not repeat else f'run {repeat}'} {way}: {seconds:.2f} s",
                      flush=True)
    medians = {way: statistics.median(t) for way, t in times.items()}
    print(f"{args.jobs} jobs, 16x16 px, {args.spp} spp, 2 local workers, {args.repeats} "
          f"interleaved runs each: median ordered {medians['ordered']:.2f} s, equal "
          f"{medians['equal']:.2f} s, ratio ordered/equal "
          f"{medians['ordered'] / medians['equal']:.3f}")


if __name__ == "__main__":
    main()
