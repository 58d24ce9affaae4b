"""Numbers, counts and ranges from user input: the one place where text and
values from options, sweep files and ``-D`` become numbers, with the float
extremes and the sizes that must be bounded.

* :func:`parse_float`: a finite float, or a
  :class:`~mitsuba_pbrdf.errors.ParameterError` naming the parameter;
* :func:`range_count`: how many STEPs fit between START and STOP, computed
  without overflow (a denormal step such as ``1e-320`` gives an infinite
  quotient, not an ``OverflowError``) and refused above a limit before any
  list is built;
* :func:`bounded_int`: an integer in a range, booleans refused (TOML's
  ``true`` is not 1), and a limit on sizes such as samples per pixel;
* :func:`product_count`: the size of a Cartesian product, refused above a
  limit before it is enumerated.

Standard library only; errors are ``ParameterError(parameter, detail)``.
"""

from __future__ import annotations

import math
from typing import Iterable, Optional

from .errors import ParameterError

__all__ = ["MAX_SPP", "INT_OPTION_LIMITS", "parse_float", "range_count", "bounded_int",
           "product_count", "int_limit", "check_int_option"]

#: Most samples per pixel of one render or sweep job (2^24, 16.7 million): a
#: render's pass plan is a list of passes, and Mitsuba's samplers count samples
#: in 32 bits; nothing near this is a render that ends.
MAX_SPP = 1 << 24


#: The largest magnitude an integer option takes, by its name (``dest``); the
#: others: 2^31 - 1. The commands check the lower bounds themselves, with
#: their own messages; this only keeps integers no command can use (2^63 - 1
#: samples, workers or starts) from reaching the work.
INT_OPTION_LIMITS = {"seed": (1 << 32) - 1, "spp": MAX_SPP, "passes": MAX_SPP,
                     "workers": 1024, "drjit_threads": 4096, "cores": 4096}
DEFAULT_INT_LIMIT = (1 << 31) - 1


def int_limit(dest: str) -> int:
    """The largest magnitude of the integer option *dest*
    (:data:`INT_OPTION_LIMITS`)."""
    return INT_OPTION_LIMITS.get(dest, DEFAULT_INT_LIMIT)


def check_int_option(option: str, dest: str, value) -> None:
    """:class:`~mitsuba_pbrdf.errors.ParameterError` naming *option* when the
    integer *value* is beyond :func:`int_limit`."""
    high = int_limit(dest)
    if value is not None and abs(int(value)) > high:
        raise ParameterError(option, f"must be an integer of at most {high}, got {value}")


def parse_float(text, parameter: str, what: str = "a number") -> float:
    """*text* as a finite float; ParameterError naming *parameter* otherwise."""
    try:
        value = float(text)
    except (TypeError, ValueError):
        raise ParameterError(parameter, f"expects {what}, got {text!r}") from None
    if not math.isfinite(value):
        raise ParameterError(parameter, f"must be finite, got {text!r}")
    return value


def range_count(start: float, stop: float, step: float, parameter: str, limit: int,
                item: Optional[str] = None, unit: str = "steps") -> float:
    """``(stop - start) / step`` (a float, not rounded), refused when the
    quotient is not finite or exceeds *limit*: the caller rounds and checks
    wholeness, and never builds a list longer than *limit*. Needs
    ``step > 0`` and ``stop > start`` checked by the caller."""
    with_item = f"{item!r}" if item is not None else f"{start:g}:{stop:g}:{step:g}"
    try:
        count = (stop - start) / step
    except (OverflowError, ZeroDivisionError):
        count = math.inf
    if not math.isfinite(count) or count > limit + 0.5:
        shown = "more than 1e308" if not math.isfinite(count) else f"{count:.4g}"
        raise ParameterError(parameter, f"{with_item} is {shown} {unit}; at most {limit}")
    return count


def bounded_int(value, parameter: str, low: int = 1, high: Optional[int] = None) -> int:
    """*value* as an int in ``[low, high]``: a Python int (or an integral float
    from a parser) but not a bool; ParameterError naming *parameter* otherwise."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) \
            or (isinstance(value, float) and not (math.isfinite(value) and value == int(value))):
        raise ParameterError(parameter, f"must be an integer, got {value!r}")
    value = int(value)
    if value < low or (high is not None and value > high):
        rng = f">= {low}" if high is None else f"in [{low}, {high}]"
        raise ParameterError(parameter, f"must be an integer {rng}, got {value}")
    return value


def product_count(sizes: Iterable[int], parameter: str, limit: int, what: str = "jobs") -> int:
    """The size of the Cartesian product of lists of these *sizes*, refused
    above *limit* (before anything is enumerated)."""
    sizes = list(sizes)
    total = math.prod(sizes)
    if total > limit:
        shape = " x ".join(str(n) for n in sizes)
        raise ParameterError(parameter, f"{shape} = {total} {what}; at most {limit}")
    return total
