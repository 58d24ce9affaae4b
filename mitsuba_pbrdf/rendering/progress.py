"""Progress of long work (render passes, gallery items) on stderr.

:func:`progress_reporter` returns a context manager with ``update(n)``:

* ``"bar"`` (or True): a ``tqdm`` bar, cleared when done;
* ``"lines"``: plain lines for logs and CI (stderr not a terminal), at most one
  every :data:`LINE_INTERVAL_S` seconds and none for work that ends sooner;
* ``"auto"``: ``"bar"`` when stderr is a terminal, else ``"lines"``;
* ``"off"`` (or False, None): nothing.

The bar or lines are only shown for work split into at least two steps:
one-pass renders are short by construction (:mod:`mitsuba_pbrdf.rendering.passes`).
"""

from __future__ import annotations

import sys
import time
from typing import Union

__all__ = ["LINE_INTERVAL_S", "progress_mode", "progress_reporter"]

#: Seconds between two progress lines when stderr is not a terminal.
LINE_INTERVAL_S = 10.0


def progress_mode(progress: Union[bool, str, None]) -> str:
    """``"bar"``, ``"lines"`` or ``"off"`` for a ``progress`` argument."""
    if progress is True:
        return "bar"
    if progress in (False, None, "off"):
        return "off"
    if progress == "auto":
        return "bar" if sys.stderr.isatty() else "lines"
    if progress in ("bar", "lines"):
        return progress
    raise ValueError(f"progress must be True, False, 'auto', 'bar', 'lines' or 'off', "
                     f"got {progress!r}")


class _Off:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False

    def update(self, n):
        pass


class _Lines(_Off):
    """One line every LINE_INTERVAL_S seconds: done/total, elapsed, left."""

    def __init__(self, total, desc, unit, interval=None, stream=None):
        self.total, self.desc, self.unit = total, desc, unit
        self.interval = LINE_INTERVAL_S if interval is None else interval
        self.stream = stream or sys.stderr
        self.done = 0
        self.start = self.last = time.perf_counter()
        self.printed = False

    def update(self, n):
        self.done += n
        now = time.perf_counter()
        if now - self.last >= self.interval and self.done < self.total:
            elapsed = now - self.start
            left = elapsed * (self.total - self.done) / max(self.done, 1)
            print(f"{self.desc}: {self.done}/{self.total} {self.unit} "
                  f"({100 * self.done / self.total:.0f} %), {elapsed:.0f} s, "
                  f"about {left:.0f} s left", file=self.stream, flush=True)
            self.last, self.printed = now, True

    def __exit__(self, exc_type, *exc):
        if self.printed and exc_type is None:
            print(f"{self.desc}: done in {time.perf_counter() - self.start:.0f} s",
                  file=self.stream, flush=True)
        return False


def progress_reporter(total: int, desc: str, progress: Union[bool, str, None] = "auto",
                      steps: int = 2, unit: str = "spp"):
    """A context manager with ``update(n)`` reporting progress over *total*
    units in *steps* updates (see the module docstring; nothing when
    ``steps < 2``)."""
    mode = progress_mode(progress)
    if mode == "off" or steps < 2:
        return _Off()
    if mode == "lines":
        return _Lines(total, desc, unit)
    from tqdm import tqdm

    return tqdm(total=total, unit=unit, desc=desc, leave=False, dynamic_ncols=True,
                file=sys.stderr)
