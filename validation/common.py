"""Shared pieces of the validation studies: the Mitsuba variant, physical
realizability of Mueller matrices (Cloude's coherency matrix), Markdown tables
and figure output.

Each study (``validation/<study>.py``) is a script with a ``main(argv)`` that
writes ``validation/<study>.md`` and its figures under ``validation/figures/``;
``python validation/run_all.py`` runs them all. The tests in ``tests/`` import
the same functions with smaller sample counts and assert on them.
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
# Realizability: Cloude's coherency matrix
# ---------------------------------------------------------------------------

# Stokes vector of a Jones vector E as S_i = E^H s_i E with the project's
# convention (reference.jones_to_mueller): S0 = |Ex|^2 + |Ey|^2,
# S1 = |Ex|^2 - |Ey|^2, S2 = 2 Re(Ex Ey*), S3 = 2 Im(Ex Ey*).
_S = np.array([
    [[1, 0], [0, 1]],
    [[1, 0], [0, -1]],
    [[0, 1], [1, 0]],
    [[0, 1j], [-1j, 0]],
], dtype=np.complex128)
# The Mueller matrix of a Jones matrix J is M_ij = tr(s_i J s_j J^H) / 2, and
# H = sum_ij M_ij (s_i kron conj(s_j)) / 4 equals vec(J) vec(J)^H / 2 (row-major
# vec): Hermitian, positive semi-definite, rank 1. A Mueller matrix is a convex
# sum of such (physically realizable) exactly when H >= 0 (Cloude 1986).
_BASIS = np.einsum("iab,jcd->ijacbd", _S, np.conj(_S)).reshape(4, 4, 4, 4) / 4.0


def coherency_matrix(M):
    """Cloude's coherency matrix (..., 4, 4) complex Hermitian, trace M00."""
    M = np.asarray(M, dtype=np.float64)
    return np.einsum("...ij,ijab->...ab", M, _BASIS)


def coherency_eigenvalues(M):
    """Eigenvalues (..., 4), ascending, of Cloude's coherency matrix of M.

    All are >= 0 for a physically realizable Mueller matrix and they sum to
    M00; a non-depolarizing (Jones) matrix has one non-zero eigenvalue."""
    return np.linalg.eigvalsh(coherency_matrix(M))


def output_dop(M, stokes_in):
    """Degree of polarization of M applied to each input Stokes vector.

    ``M`` (..., 4, 4), ``stokes_in`` (s, 4); returns (S0 (..., s), polarized
    part |S1..S3| (..., s))."""
    out = np.einsum("...ij,sj->...si", M, stokes_in)
    return out[..., 0], np.sqrt(np.sum(out[..., 1:] ** 2, axis=-1))


def poincare_inputs(n=62, seed=0):
    """Unpolarized light, the six pure states (+-S1, +-S2, +-S3) and ``n``
    random fully polarized states: (n + 7, 4) Stokes vectors with S0 = 1."""
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    pure = np.vstack([np.eye(3), -np.eye(3), v])
    return np.vstack([[1.0, 0, 0, 0], np.hstack([np.ones((len(pure), 1)), pure])])


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
