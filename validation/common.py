"""Shared pieces of the validation studies: the Mitsuba variant, Markdown
tables and figure output.

Each study (``validation/<study>.py``) is a driver with a ``main(argv)``: its
arguments and sizes, a run of the checks in ``mitsuba_pbrdf.diagnostics`` and ``proof/`` (or of the
package's own functions), and ``validation/<study>.md`` with its figures under
``validation/figures/``. ``python validation/run_all.py`` runs them all. The
tests in ``tests/`` call the same ``mitsuba_pbrdf.diagnostics`` and ``proof`` functions with
smaller sample counts and assert on them; neither folder imports the other.
"""

import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
FIGURES = os.path.join(HERE, "figures")
if ROOT not in sys.path:        # `python validation/<study>.py` from anywhere
    sys.path.insert(0, ROOT)

#: The main target variant (docs/conventions.md).
VARIANT = "llvm_ad_spectral_polarized"


def use_variant(name=VARIANT):
    """``mitsuba_pbrdf.use_variant(name)``; returns the ``mitsuba`` module."""
    import mitsuba as mi

    import mitsuba_pbrdf

    mitsuba_pbrdf.use_variant(name)
    return mi


# ---------------------------------------------------------------------------
# Output
# ---------------------------------------------------------------------------

def fmt(x, digits=3):
    """A number for a Markdown table."""
    if isinstance(x, str):
        return x
    if x is None or (isinstance(x, float) and np.isnan(x)):
        return "–"
    if isinstance(x, (bool, np.bool_)):
        return "yes" if x else "**no**"
    if isinstance(x, (int, np.integer)):
        return f"{x:,}"
    x = float(x)
    if x == 0:
        return "0"
    if 1e-3 <= abs(x) < 1e4:
        return f"{x:.{digits}g}"
    return f"{x:.{max(digits - 1, 1)}e}"


def table(headers, rows, digits=3):
    """A Markdown table."""
    def cell(text):
        return text.replace("|", "\\|")          # a literal | inside a cell (|Δ|)

    lines = ["| " + " | ".join(cell(h) for h in headers) + " |", "|" + "---|" * len(headers)]
    for row in rows:
        lines.append("| " + " | ".join(cell(fmt(v, digits)) for v in row) + " |")
    return "\n".join(lines)


def write_markdown(name, text):
    """Write ``validation/<name>.md`` and echo it to stdout."""
    path = os.path.join(HERE, name + ".md")
    with open(path, "w", encoding="utf-8") as f:
        f.write(text.rstrip() + "\n")
    sys.stdout.write(text.rstrip() + "\n")
    return path


def figure_path(name):
    os.makedirs(FIGURES, exist_ok=True)
    return os.path.join(FIGURES, name + ".png")


def save_figure(fig, name, dpi=90):
    """Save a matplotlib figure as ``validation/figures/<name>.png``."""
    path = figure_path(name)
    fig.savefig(path, dpi=dpi, bbox_inches="tight")
    import matplotlib.pyplot as plt

    plt.close(fig)
    return os.path.relpath(path, HERE)


def pyplot():
    """matplotlib.pyplot with the non-interactive Agg backend."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plt.rcParams.update({"font.size": 9, "axes.titlesize": 9, "legend.fontsize": 7.5,
                         "axes.grid": True, "grid.alpha": 0.3})
    return plt
