"""``pbrdf fit``'s progress: a bar on a terminal, one line per finished start
in a log (standard error either way), from the fit's
:class:`~mitsuba_pbrdf.fitting.result.FitProgress` reports."""

from __future__ import annotations

import sys

__all__ = ["FitProgressDisplay"]


class FitProgressDisplay:
    """A context manager and ``progress`` callback for *fits* consecutive fits
    (models x distributions)."""

    def __init__(self, fits: int, stream=None):
        self.fits, self.stream = fits, stream or sys.stderr
        self.bar = None
        self.fit = 0                     # fits begun
        self.current = None              # (model, distribution) of the fit going on

    def __enter__(self):
        if self.stream.isatty():
            from tqdm import tqdm
            self.bar = tqdm(total=self.fits, unit="fit", file=self.stream, leave=False,
                            dynamic_ncols=True)
        return self

    def __exit__(self, *exc):
        if self.bar is not None:
            self.bar.close()
        return False

    def __call__(self, p):
        key = (p.model, p.distribution)
        if key != self.current:
            self.current = key
            self.fit += 1
        step = ("the best start's polish on all rows" if p.polish
                else f"start {p.start} of {p.starts}")
        label = f"fit {self.fit}/{self.fits}: {p.model}-component, {p.distribution}: {step}"
        if self.bar is not None:
            self.bar.set_description(label, refresh=False)
            self.bar.set_postfix_str(f"{p.evaluations} evaluations, cost {p.cost:.4g}")
            if p.finished and p.start == p.starts:
                self.bar.update(1)
        elif p.finished:
            print(f"pbrdf fit: {label}: {p.evaluations} evaluations, cost {p.cost:.4g} "
                  f"(best {p.best:.4g})", file=self.stream, flush=True)
